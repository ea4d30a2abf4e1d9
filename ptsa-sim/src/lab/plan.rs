//! Test plans: ready-to-run case-frame designs (`ptsa plan`), so a test starts from a
//! standard plan, not a blank file. The rows leave `measured_cm_s2` empty for the lab to
//! fill in. The same generators give `ptsa discover`'s advice its library of feasible rows.
//!
//! * [`tumble`]: a multipoint tumble on a dividing head (IEEE Std 1293's 4-, 8-, 12- and
//!   24-point tumbles, or any number of positions), IA turning in the IA–PA plane about OA or
//!   in the IA–OA plane about PA; absolute rows.
//! * [`rate_table`]: the dividing head on a rate table (Table 6.1's procedure); difference
//!   rows against a slow reference run.
//! * [`shaker`]: the two-axis oscillator of Appendix A: blocks of phases of IA+PA and IA+OA
//!   vibration, OA rocking with PA vibration, and IA+OA rocking; difference rows.
//! * [`centrifuge`]: a centrifuge at given g levels (IEEE Std 836), IA along the arm
//!   pointing at the spin axis and away from it; absolute rows.

use crate::model::condition::{Condition, RowKind};

/// Which axis a tumble or rate-table position turns about (it lies horizontal).
#[derive(
    Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum, serde::Serialize, serde::Deserialize,
)]
pub enum Axis {
    /// IA turns in the IA–PA plane, about OA.
    Oa,
    /// IA turns in the IA–OA plane, about PA.
    Pa,
    /// IA stays horizontal and PA turns in the PA–OA plane, about IA (the cross-axis
    /// positions of a full tumble).
    Ia,
}

impl Axis {
    /// The two case axes in the vertical plane: the one at the angle's sine and at its
    /// cosine.
    fn plane_axes(self) -> (usize, usize) {
        match self {
            Axis::Oa => (0, 1),
            Axis::Pa => (0, 2),
            Axis::Ia => (2, 1),
        }
    }

    fn plane(self) -> &'static str {
        match self {
            Axis::Oa => "IA-PA plane, about OA",
            Axis::Pa => "IA-OA plane, about PA",
            Axis::Ia => "PA-OA plane, about IA",
        }
    }
}

/// Round unit-circle values within rounding of 0 or ±1 to them.
fn clean(x: f64) -> f64 {
    if x.abs() < 1e-12 {
        0.0
    } else if (x.abs() - 1.0).abs() < 1e-12 {
        x.signum()
    } else {
        x
    }
}

/// The upward unit vector in case axes at angle `deg` in `axis`'s plane (about OA or PA:
/// IA at `deg` above horizontal; about IA: OA at `deg` above horizontal).
fn up(axis: Axis, deg: f64) -> [f64; 3] {
    let (s, c) = deg.to_radians().sin_cos();
    let (a, b) = axis.plane_axes();
    let mut u = [0.0; 3];
    u[a] = clean(s);
    u[b] = clean(c);
    u
}

/// The angles of `n` equally spaced positions, starting at `offset_deg`, degrees.
fn angles(n: usize, offset_deg: f64) -> Vec<f64> {
    #[allow(clippy::cast_precision_loss)]
    let step = 360.0 / n as f64;
    #[allow(clippy::cast_precision_loss)]
    (0..n).map(|k| offset_deg + step * k as f64).collect()
}

/// A multipoint tumble: `positions` equally spaced angles (about OA or PA, of IA: 0° IA
/// horizontal, 90° IA up; about IA, of OA) in `axis`'s plane; absolute rows.
#[must_use]
pub fn tumble(positions: usize, axis: Axis) -> Vec<Condition> {
    angles(positions, 0.0)
        .into_iter()
        .map(|deg| Condition {
            label: format!("tumble {deg} deg ({})", axis.plane()),
            kind: RowKind::Absolute,
            g: up(axis, deg),
            ..Condition::default()
        })
        .collect()
}

/// The dividing head on a rate table turning about the vertical at `rate_rad_s` (reference
/// run at `ref_rate_rad_s`), IA at `positions` equally spaced angles in `axis`'s plane
/// (Table 6.1: 8 positions about OA, 1.0 and 0.05 rad/s); the proof mass `radius_cm` from
/// the table axis (0: centred, as the report's revised set-up). Difference rows.
#[must_use]
pub fn rate_table(
    positions: usize,
    axis: Axis,
    rate_rad_s: f64,
    ref_rate_rad_s: f64,
    radius_cm: f64,
) -> Vec<Condition> {
    #[allow(clippy::cast_precision_loss)]
    let step = 360.0 / positions.max(1) as f64;
    angles(positions, step)
        .into_iter()
        .map(|deg| {
            let u = up(axis, deg);
            Condition {
                label: format!(
                    "rate table {rate_rad_s} rad/s, IA {deg} deg ({}){}",
                    axis.plane(),
                    if radius_cm == 0.0 {
                        String::new()
                    } else {
                        format!(", arm {radius_cm} cm")
                    }
                ),
                g: u,
                w_rad_s: u.map(|x| rate_rad_s * x),
                ref_w_rad_s: u.map(|x| ref_rate_rad_s * x),
                radius_cm,
                ..Condition::default()
            }
        })
        .filter(|c| c.radius_cm == 0.0 || c.centripetal_cm_s2(c.w_rad_s).is_some())
        .collect()
}

/// The two-axis oscillator of Appendix A at `freq_hz` with IA up: `phases` equally spaced
/// phases each of IA+PA vibration, IA+OA vibration, OA rocking (`rock_mrad`) with PA
/// vibration, and IA+OA rocking; vibration amplitudes `amp_cm_s2`. Difference rows.
#[must_use]
pub fn shaker(freq_hz: f64, amp_cm_s2: f64, rock_mrad: f64, phases: usize) -> Vec<Condition> {
    let mut rows = Vec::new();
    for (b, what) in [
        "IA+PA vibration",
        "IA+OA vibration",
        "OA rocking + PA vibration",
        "IA+OA rocking",
    ]
    .iter()
    .enumerate()
    {
        for psi in angles(phases, 0.0) {
            let mut c = Condition {
                label: format!("shaker {what} {freq_hz} Hz phase {psi} deg"),
                g: [1.0, 0.0, 0.0],
                freq_hz,
                ..Condition::default()
            };
            match b {
                0 => {
                    c.lin_cm_s2 = [amp_cm_s2, amp_cm_s2, 0.0];
                    c.lin_deg = [0.0, psi, 0.0];
                }
                1 => {
                    c.lin_cm_s2 = [amp_cm_s2, 0.0, amp_cm_s2];
                    c.lin_deg = [0.0, 0.0, psi];
                }
                2 => {
                    c.ang_mrad = [0.0, 0.0, rock_mrad];
                    c.lin_cm_s2 = [0.0, amp_cm_s2, 0.0];
                    c.lin_deg = [0.0, psi, 0.0];
                }
                _ => {
                    c.ang_mrad = [rock_mrad, 0.0, rock_mrad];
                    c.ang_deg = [0.0, 0.0, psi];
                }
            }
            rows.push(c);
        }
    }
    rows
}

/// A centrifuge with the proof mass `radius_cm` from the (vertical) spin axis, at each of
/// `g_levels` (the arm's push in g: `ω² R = level·g`), IA along the arm pointing at the axis
/// and, for each level, pointing away from it (a negative radius), OA up. Absolute rows.
#[must_use]
pub fn centrifuge(radius_cm: f64, g_levels: &[f64], g_cm_s2: f64) -> Vec<Condition> {
    let mut rows = Vec::new();
    for &level in g_levels {
        let w = (level * g_cm_s2 / radius_cm.abs()).sqrt();
        for (sign, dir) in [(1.0, "IA in"), (-1.0, "IA out")] {
            rows.push(Condition {
                label: format!("centrifuge {level} g, {dir}, arm {} cm", radius_cm.abs()),
                kind: RowKind::Absolute,
                g: [0.0, 0.0, 1.0],
                w_rad_s: [0.0, 0.0, w],
                radius_cm: sign * radius_cm.abs(),
                ..Condition::default()
            });
        }
    }
    rows
}

#[cfg(test)]
#[allow(clippy::float_cmp)] // exact unit vectors, by `clean`
mod tests {
    use super::*;
    use crate::model::condition::{IA, OA, PA};

    #[test]
    fn a_24_point_tumble_about_oa_sweeps_gravity_through_ia_and_pa() {
        let t = tumble(24, Axis::Oa);
        assert_eq!(t.len(), 24);
        assert!(
            t.iter()
                .all(|r| r.kind == RowKind::Absolute && r.g[OA] == 0.0)
        );
        assert_eq!(t[6].g, [1.0, 0.0, 0.0]); // 90°: IA up
        assert_eq!(t[12].g, [0.0, -1.0, 0.0]);
        let p = tumble(4, Axis::Pa);
        assert_eq!(p[1].g, [1.0, 0.0, 0.0]);
        assert_eq!(p[0].g[OA], 1.0);
    }

    #[test]
    fn centrifuge_rows_push_along_ia_by_the_g_level() {
        let g = 980.4;
        let rows = centrifuge(50.0, &[2.0, 5.0], g);
        for (r, want) in rows.iter().zip([2.0, -2.0, 5.0, -5.0]) {
            let i = r.inputs_at(0.0, g);
            assert!(
                (i.a_cm_s2[IA] - want * g).abs() < 1e-6,
                "{} {}",
                r.label,
                i.a_cm_s2[IA]
            );
            assert!(i.a_cm_s2[PA].abs() < 1e-9 && (i.a_cm_s2[OA] - g).abs() < 1e-9);
        }
    }

    #[test]
    fn rate_table_is_table_6_1s_procedure() {
        let t = rate_table(8, Axis::Oa, 1.0, 0.05, 0.0);
        assert_eq!(t.len(), 8);
        let r45 = &t[0];
        assert!((r45.w_rad_s[IA] * r45.w_rad_s[PA] - 0.5).abs() < 1e-12);
        assert_eq!(shaker(10.0, 300.0, 1.0, 8).len(), 32);
    }
}
