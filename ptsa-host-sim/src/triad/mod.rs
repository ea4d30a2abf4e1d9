//! A triad: one calibration of three accelerometers on one block (`ptsa discover --data`
//! on a triad file; `docs/method/discovery.md`, "A triad"). A layer of its own beside
//! `discovery`: it uses only the model's file rules (`model::caseframe`), the instrument's
//! local gravity and `stats` (and, for its sheet, `discovery::sheet`'s SHA-256, date and
//! folder check).
//!
//! * [`frame`]: the triad file (`g_x`, `g_y`, `g_z`, `measured_x_cm_s2`, …), read with the
//!   case-frame's CSV rules and errors.
//! * [`fit`]: the model (bias, scale factor and `K_2` per axis, the non-orthogonality, one
//!   orientation per position, optionally each position's small rotation) fitted by
//!   Gauss–Newton; the |g| check.
//! * [`report`]: the `"triad"` JSON object, every key documented.
//! * [`apply`]: the calibration applied (`ptsa correct`), and its file
//!   (`--write-instrument`): one file for the three axes.
//! * [`sheet`]: the calibration sheet (`--sheet DIR`; the provenance helpers of
//!   `discovery::sheet`).
//! * this module: the text report and the per-position table.

pub mod apply;
pub mod correct_record;
pub mod fit;
pub mod frame;
pub mod report;
pub mod sheet;
pub mod stream;

use std::fmt::Write as _;

use fit::{AXES, SigmaSource, Triad};

/// The position counts [`design`] knows.
pub const DESIGNS: [usize; 5] = [6, 8, 12, 24, 37];

/// The nominal gravity directions of an `n`-position triad design (block frame, unit
/// vectors), or `None` for a count not in [`DESIGNS`]: 6, the faces; 8, the faces and two
/// opposite corners; 12, the edge directions `(±1, ±1, 0)/√2` and their permutations; 24,
/// the cube's 24 proper rotations applied to `(1, 2, 3)/√14` (every position tilted, every
/// axis at three levels: the design for approximate orientations); 37, those 24, the 12
/// edges and the `+z` face.
#[must_use]
pub fn design(n: usize) -> Option<Vec<[f64; 3]>> {
    let faces = || {
        let mut v = Vec::new();
        for j in 0..3 {
            for s in [1.0, -1.0] {
                let mut d = [0.0; 3];
                d[j] = s;
                v.push(d);
            }
        }
        v
    };
    let edges = || {
        let h = std::f64::consts::FRAC_1_SQRT_2;
        let mut v = Vec::new();
        for (j, k) in [(0, 1), (1, 2), (0, 2)] {
            for (a, b) in [(1.0, 1.0), (1.0, -1.0), (-1.0, 1.0), (-1.0, -1.0)] {
                let mut d = [0.0; 3];
                d[j] = a * h;
                d[k] = b * h;
                v.push(d);
            }
        }
        v
    };
    let turns = || {
        let s = 1.0 / 14f64.sqrt();
        let base = [1.0, 2.0, 3.0];
        // The even permutations with an even number of sign flips, the odd ones with an odd
        // number: the 24 signed permutation matrices of determinant +1.
        let perms: [([usize; 3], bool); 6] = [
            ([0, 1, 2], true),
            ([1, 2, 0], true),
            ([2, 0, 1], true),
            ([1, 0, 2], false),
            ([0, 2, 1], false),
            ([2, 1, 0], false),
        ];
        let mut v = Vec::new();
        for (p, even) in perms {
            for flips in 0..8u32 {
                if (flips.count_ones() % 2 == 0) == even {
                    v.push([0, 1, 2].map(|r| {
                        let sign = if flips >> r & 1 == 1 { -1.0 } else { 1.0 };
                        sign * base[p[r]] * s
                    }));
                }
            }
        }
        v
    };
    let c = 1.0 / 3f64.sqrt();
    match n {
        6 => Some(faces()),
        8 => {
            let mut v = faces();
            v.extend([[c, c, c], [-c, -c, -c]]);
            Some(v)
        }
        12 => Some(edges()),
        24 => Some(turns()),
        37 => {
            let mut v = turns();
            v.extend(edges());
            v.push([0.0, 0.0, 1.0]);
            Some(v)
        }
        _ => None,
    }
}

/// The text report of a fit: the three axes' coefficients with 1 σ, the misalignment
/// matrix, the |g| check, the χ² and the correction written out.
#[must_use]
pub fn text(t: &Triad, data: &str) -> String {
    let mut s = String::new();
    model(&mut s, t, data);
    axes(&mut s, t);
    misalignments(&mut s, t);
    checks(&mut s, t);
    correction(&mut s, t);
    s
}

/// What was calibrated, and the model.
fn model(s: &mut String, t: &Triad, data: &str) {
    let g = t.g_cm_s2;
    let _ = writeln!(
        s,
        "triad calibration of {data}: {} positions ({} measured), {} readings, orientations {}; local gravity {g} cm/s²",
        t.positions.len(),
        t.positions.iter().filter(|p| p.is_measured()).count(),
        t.readings,
        t.orientation.name()
    );
    let _ = writeln!(
        s,
        "model: u = b + (1 + k)·a + K_2·a², a = (I + Γ)·f (f the specific force in the {} frame, cm/s²)",
        if t.orientation == fit::Orientation::Exact {
            "block's"
        } else {
            "triad's"
        }
    );
    let _ = writeln!(s);
}

/// Each axis's bias, scale factor and `K_2`.
fn axes(s: &mut String, t: &Triad) {
    let g = t.g_cm_s2;
    let _ = writeln!(
        s,
        "axis  bias cm/s²            bias µg              scale factor ppm      K_2 µg/g²"
    );
    for j in 0..3 {
        let b = t.bias[j];
        let sf = t.scale[j];
        let k2 = t.k2.map_or("not fitted".to_string(), |q| {
            format!("{:+.1} ± {:.1}", q[j].value * g * 1e6, q[j].sigma * g * 1e6)
        });
        let _ = writeln!(
            s,
            "{:<5} {:<21} {:<20} {:<21} {k2}",
            AXES[j],
            format!("{:+.5} ± {:.5}", b.value, b.sigma),
            format!("{:+.1} ± {:.1}", b.value * 1e6 / g, b.sigma * 1e6 / g),
            format!("{:+.1} ± {:.1}", sf.value * 1e6, sf.sigma * 1e6),
        );
    }
    let _ = writeln!(s);
}

/// The misalignments Γ.
fn misalignments(s: &mut String, t: &Triad) {
    let _ = writeln!(
        s,
        "misalignment Γ, µrad (row: the axis; column: the {} axis it leans toward; ± 1 σ)",
        if t.orientation == fit::Orientation::Exact {
            "block's"
        } else {
            "triad frame's"
        }
    );
    for (j, axis) in AXES.iter().enumerate() {
        let cells: Vec<String> = (0..3)
            .map(|c| match t.misalignment[j][c] {
                Some(e) => format!("{:+.1} ± {:.1}", e.value * 1e6, e.sigma * 1e6),
                None if c == j => "—".into(),
                None => "0 (convention)".into(),
            })
            .collect();
        let _ = writeln!(
            s,
            "  {axis}: {:>20} {:>20} {:>20}",
            cells[0], cells[1], cells[2]
        );
    }
    let _ = writeln!(s);
}

/// The |g| check, the fit's χ² or σ, the coverage factor and the positions' rotation.
fn checks(s: &mut String, t: &Triad) {
    let g = t.g_cm_s2;
    let k = t.coverage_factor;
    let gc = &t.g_check;
    if gc.positions.is_empty() {
        let _ = writeln!(s, "|g| check: no position has all three axes measured");
    } else {
        let _ = writeln!(
            s,
            "|g| check ({} positions): |f̂| − g RMS {:.4} cm/s² ({:.1} µg), worst {:.4} cm/s² at `{}`; the noise gives {:.4} RMS; χ² {:.1} (p {}): {}",
            gc.positions.len(),
            gc.rms_cm_s2,
            gc.rms_cm_s2 * 1e6 / g,
            gc.worst.0,
            t.positions[gc.worst.1].label,
            gc.expected_rms_cm_s2,
            gc.chi2,
            fit::p_text(gc.p_value),
            if gc.p_value >= fit::FLAG_P {
                "consistent"
            } else {
                "NOT consistent"
            }
        );
    }
    match t.sigma_source {
        SigmaSource::Stated => {
            let _ = writeln!(
                s,
                "fit: χ² {:.1} for {} degrees of freedom (p {}), stated sigmas (RMS {:.4} cm/s²){}; {} Gauss–Newton iterations",
                t.chi2,
                t.dof,
                fit::p_text(t.p_value),
                t.sigma_cm_s2,
                if t.sigma_scale > 1.0 {
                    format!(", errors scaled by {:.2}", t.sigma_scale)
                } else {
                    String::new()
                },
                t.iterations
            );
        }
        SigmaSource::Estimated => {
            let _ = writeln!(
                s,
                "fit: σ of a reading estimated from the residuals: {:.4} cm/s² ({} degrees of freedom; no χ² test without stated sigmas); {} Gauss–Newton iterations",
                t.sigma_cm_s2, t.dof, t.iterations
            );
        }
    }
    let _ = writeln!(s, "95 % interval: value ± {k:.2} σ");
    if let Some(max) = t
        .angles
        .iter()
        .filter_map(|a| a.map(|a| a[0].value.hypot(a[1].value)))
        .reduce(f64::max)
    {
        let _ = writeln!(
            s,
            "positions' rotation from nominal (estimated): largest {:.0} µrad ({:.3}°)",
            max * 1e6,
            max.to_degrees()
        );
    }
    let _ = writeln!(s);
}

/// The correction `f = M·(u − b)` to apply.
fn correction(s: &mut String, t: &Triad) {
    let m = fit::matrix_m(t);
    let _ = writeln!(
        s,
        "correction: f = M·(u − b), u the readings (x, y, z) in cm/s² through the nominal scale factors, f in the {}",
        if t.orientation == fit::Orientation::Exact {
            "block's frame"
        } else {
            "triad's frame (x along the x axis, y in the x–y plane)"
        }
    );
    let _ = writeln!(
        s,
        "  b = ({:+.5}, {:+.5}, {:+.5}) cm/s²",
        t.bias[0].value, t.bias[1].value, t.bias[2].value
    );
    for r in 0..3 {
        let _ = writeln!(
            s,
            "  {} [{:+.9} {:+.9} {:+.9}]",
            if r == 0 { "M =" } else { "   " },
            m[(r, 0)],
            m[(r, 1)],
            m[(r, 2)]
        );
    }
    let _ = writeln!(s, "  M = (diag(1 + k)·(I + Γ))⁻¹");
    if let Some(k2) = t.k2 {
        let _ = writeln!(
            s,
            "  with K_2, first u_j − b_j less q_j·((u_j − b_j)/(1 + k_j))², q = ({:+.4e}, {:+.4e}, {:+.4e}) (cm/s²)⁻¹ = K_2/g",
            k2[0].value, k2[1].value, k2[2].value
        );
    }
}

/// The per-position table as CSV: label, line, the three residuals, `|f̂| − g` and, with
/// approximate orientations, the estimated rotation (cm/s², µrad).
#[must_use]
pub fn table_csv(t: &Triad) -> String {
    let num = |v: Option<f64>| v.map_or(String::new(), |v| format!("{v:.6}"));
    let mut s = String::from(
        "label,line,residual_x_cm_s2,residual_y_cm_s2,residual_z_cm_s2,g_check_cm_s2,rotation_urad\n",
    );
    for (i, p) in t.positions.iter().enumerate() {
        let gcheck = t.g_check.positions.iter().find(|x| x.0 == i).map(|x| x.1);
        let rot = t.angles[i].map(|a| a[0].value.hypot(a[1].value) * 1e6);
        let label = if p.label.contains([',', '"']) {
            format!("\"{}\"", p.label.replace('"', "\"\""))
        } else {
            p.label.clone()
        };
        let _ = writeln!(
            s,
            "{label},{},{},{},{},{},{}",
            p.line,
            num(t.residuals[i][0]),
            num(t.residuals[i][1]),
            num(t.residuals[i][2]),
            num(gcheck),
            num(rot)
        );
    }
    s
}
