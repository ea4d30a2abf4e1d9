//! The triad generator written from the equations, one definition shared by the triad
//! campaign (`ptsa-campaigns/src/triad.rs`), the triad CLI tests
//! (`ptsa-host-sim/tests/cli_triad.rs`) and the triad benchmark
//! (`ptsa-host-sim/benches/triad.rs`), which include this file by its path. It uses only
//! `std` and `rand`: nothing of `ptsa_host_sim`, so that what it writes owes nothing to the
//! analyser's code (its own rotations, its own triad-frame conversion).
//!
//! The reading of axis j: `u_j = b_j + (1 + k_j)·a_j + q_j·a_j²`, `a = (I + Γ)·f`,
//! `f = g·R·n` with `n` the nominal direction and `R` a placement's rotation.

// Each includer uses a part of it.
#![allow(dead_code)]

use std::fmt::Write as _;

/// Local gravity of the generated sets (the shipped instrument file's), cm/s².
pub const G: f64 = 980.4;

/// The six faces.
#[must_use]
pub fn faces() -> Vec<[f64; 3]> {
    let mut v = Vec::new();
    for j in 0..3 {
        for s in [1.0, -1.0] {
            let mut n = [0.0; 3];
            n[j] = s;
            v.push(n);
        }
    }
    v
}

/// The twelve edge directions `(±1, ±1, 0)/√2` and their permutations.
#[must_use]
pub fn edges() -> Vec<[f64; 3]> {
    let s = 1.0 / 2f64.sqrt();
    let mut v = Vec::new();
    for (j, k) in [(0, 1), (1, 2), (0, 2)] {
        for (a, b) in [(1.0, 1.0), (1.0, -1.0), (-1.0, 1.0), (-1.0, -1.0)] {
            let mut n = [0.0; 3];
            n[j] = a * s;
            n[k] = b * s;
            v.push(n);
        }
    }
    v
}

/// The 24 proper rotations of the cube (signed permutations of determinant +1) applied
/// to `v`, normalised.
#[must_use]
pub fn cube_turns(v: [f64; 3]) -> Vec<[f64; 3]> {
    let norm = v.iter().map(|x| x * x).sum::<f64>().sqrt();
    let perms: [([usize; 3], f64); 6] = [
        ([0, 1, 2], 1.0),
        ([1, 2, 0], 1.0),
        ([2, 0, 1], 1.0),
        ([1, 0, 2], -1.0),
        ([0, 2, 1], -1.0),
        ([2, 1, 0], -1.0),
    ];
    let mut out = Vec::new();
    for (p, parity) in perms {
        for signs in 0..8u32 {
            let s: [f64; 3] = [0, 1, 2].map(|b| if signs >> b & 1 == 1 { -1.0 } else { 1.0 });
            if s[0] * s[1] * s[2] * parity < 0.0 {
                continue;
            }
            out.push([0, 1, 2].map(|r| s[r] * v[p[r]] / norm));
        }
    }
    out
}

/// The 37-position design: the 24 cube turns of (1, 2, 3)/√14, the 12 edges and the +z
/// face.
#[must_use]
pub fn design37() -> Vec<[f64; 3]> {
    let mut v = cube_turns([1.0, 2.0, 3.0]);
    v.extend(edges());
    v.push([0.0, 0.0, 1.0]);
    v
}

/// The rotation matrix of `angle` about the unit vector `axis` (Rodrigues' formula as a
/// matrix: `I cos θ + sin θ [k]× + (1 − cos θ) k kᵀ`).
#[must_use]
pub fn rotation(axis: [f64; 3], angle: f64) -> [[f64; 3]; 3] {
    let (s, c) = angle.sin_cos();
    let [x, y, z] = axis;
    [
        [
            c + x * x * (1.0 - c),
            x * y * (1.0 - c) - z * s,
            x * z * (1.0 - c) + y * s,
        ],
        [
            y * x * (1.0 - c) + z * s,
            c + y * y * (1.0 - c),
            y * z * (1.0 - c) - x * s,
        ],
        [
            z * x * (1.0 - c) - y * s,
            z * y * (1.0 - c) + x * s,
            c + z * z * (1.0 - c),
        ],
    ]
}

/// `m·v`.
#[must_use]
pub fn mul(m: &[[f64; 3]; 3], v: [f64; 3]) -> [f64; 3] {
    [0, 1, 2].map(|r| m[r][0] * v[0] + m[r][1] * v[1] + m[r][2] * v[2])
}

/// `a·b`.
#[must_use]
pub fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// `n` turned by a hand placement: about a random axis (uniform on the sphere) by an
/// angle uniform in 0.5–1°. Draws, in order: the axis's z in [−1, 1), its azimuth in
/// [0, 2π), the angle.
pub fn hand_placed(n: [f64; 3], rng: &mut impl rand::Rng) -> [f64; 3] {
    let z: f64 = rng.random_range(-1.0..1.0);
    let phi: f64 = rng.random_range(0.0..std::f64::consts::TAU);
    let rho = (1.0 - z * z).sqrt();
    let axis = [rho * phi.cos(), rho * phi.sin(), z];
    let angle = rng.random_range(0.5f64..1.0).to_radians();
    mul(&rotation(axis, angle), n)
}

/// A standard normal draw.
pub fn normal(rng: &mut impl rand::Rng) -> f64 {
    rng.sample(rand_distr::StandardNormal)
}

/// A triad's coefficients: bias (cm/s²), scale-factor change, `Γ` (rad, row = axis) and
/// `q` (`K_2` in (cm/s²)⁻¹).
#[derive(Clone, Copy, Debug, Default)]
pub struct TriadTruth {
    /// Bias, cm/s².
    pub b: [f64; 3],
    /// Scale-factor change.
    pub k: [f64; 3],
    /// Misalignment, rad.
    pub gamma: [[f64; 3]; 3],
    /// `K_2`, (cm/s²)⁻¹.
    pub q: [f64; 3],
}

impl TriadTruth {
    /// The three noise-free readings of the specific force `f` (cm/s²).
    #[must_use]
    pub fn readings(&self, f: [f64; 3]) -> [f64; 3] {
        [0, 1, 2].map(|j| {
            let a = f[j] + (0..3).map(|k| self.gamma[j][k] * f[k]).sum::<f64>();
            self.b[j] + (1.0 + self.k[j]) * a + self.q[j] * a * a
        })
    }
}

/// The truth in the triad's own frame (x along the x axis's input axis `e_x + Γ_x`, y in
/// the plane of the x and y input axes): Gram–Schmidt of the rows `r_j` of `I + Γ` gives
/// the frame `E`; `L_jk = r_j·E_k` is lower triangular, and the same readings follow from
/// `Γ'_jk = L_jk/L_jj`, `1 + k'_j = (1 + k_j)·L_jj`, `q'_j = q_j·L_jj²`.
#[must_use]
#[allow(clippy::needless_range_loop)] // j indexes L, k, q and Γ alike
pub fn in_triad_frame(t: &TriadTruth) -> TriadTruth {
    let r: [[f64; 3]; 3] =
        [0, 1, 2].map(|j| [0, 1, 2].map(|k| f64::from(u8::from(j == k)) + t.gamma[j][k]));
    let unit = |v: [f64; 3]| {
        let n = dot(v, v).sqrt();
        v.map(|x| x / n)
    };
    let ex = unit(r[0]);
    let ey = unit({
        let d = dot(r[1], ex);
        [0, 1, 2].map(|i| r[1][i] - d * ex[i])
    });
    let ez = [
        ex[1] * ey[2] - ex[2] * ey[1],
        ex[2] * ey[0] - ex[0] * ey[2],
        ex[0] * ey[1] - ex[1] * ey[0],
    ];
    let e = [ex, ey, ez];
    let l: [[f64; 3]; 3] = [0, 1, 2].map(|j| [0, 1, 2].map(|k| dot(r[j], e[k])));
    let mut out = *t;
    for j in 0..3 {
        out.k[j] = (1.0 + t.k[j]) * l[j][j] - 1.0;
        out.q[j] = t.q[j] * l[j][j] * l[j][j];
        for k in 0..3 {
            out.gamma[j][k] = if j == k { 0.0 } else { l[j][k] / l[j][j] };
        }
    }
    out
}

/// A triad file (`label`, the nominal gravity, the three readings, `sigma_cm_s2` when
/// `sigma` is given) of rows `(nominal direction, readings)`, labelled `p1`, `p2`, …;
/// `comment` a `#` line first when not empty.
#[must_use]
pub fn triad_csv(rows: &[([f64; 3], [f64; 3])], sigma: Option<f64>, comment: &str) -> String {
    let mut s = String::new();
    if !comment.is_empty() {
        let _ = writeln!(s, "# {comment}");
    }
    s.push_str("label,g_x,g_y,g_z,measured_x_cm_s2,measured_y_cm_s2,measured_z_cm_s2");
    s.push_str(if sigma.is_some() {
        ",sigma_cm_s2\n"
    } else {
        "\n"
    });
    for (i, (n, u)) in rows.iter().enumerate() {
        let _ = write!(
            s,
            "p{},{},{},{},{},{},{}",
            i + 1,
            n[0],
            n[1],
            n[2],
            u[0],
            u[1],
            u[2]
        );
        if let Some(sg) = sigma {
            let _ = write!(s, ",{sg}");
        }
        s.push('\n');
    }
    s
}

/// A raw stream's timing and noise (a block turned by hand between positions, `imu_tk`'s
/// protocol).
#[derive(Clone, Copy, Debug)]
pub struct StreamSpec {
    /// Samples per second.
    pub rate_hz: f64,
    /// The rest at the first position before the first turn, s.
    pub rest_s: f64,
    /// Each later position held for a time uniform in this range, s.
    pub hold_s: (f64, f64),
    /// Each turn's length, s.
    pub move_s: f64,
    /// The hand's push during a turn: an acceleration `A·sin(2πτ)` along a random
    /// direction, τ the turn's elapsed fraction, A uniform up to this, cm/s².
    pub push_cm_s2: f64,
    /// White noise per sample and axis, cm/s².
    pub sigma_cm_s2: f64,
}

impl Default for StreamSpec {
    fn default() -> Self {
        StreamSpec {
            rate_hz: 100.0,
            rest_s: 15.0,
            hold_s: (2.0, 4.0),
            move_s: 1.5,
            push_cm_s2: 60.0,
            sigma_cm_s2: 1.0,
        }
    }
}

/// A unit vector across `a` (for a turn between opposite directions).
fn across(a: [f64; 3]) -> [f64; 3] {
    let k = (0..3)
        .min_by(|&i, &j| a[i].abs().total_cmp(&a[j].abs()))
        .unwrap_or(0);
    let mut e = [0.0; 3];
    e[k] = 1.0;
    let d = dot(e, a);
    let v = [0, 1, 2].map(|i| e[i] - d * a[i]);
    let n = dot(v, v).sqrt();
    v.map(|x| x / n)
}

/// The stream being written: its samples so far.
struct StreamWriter<'a> {
    truth: &'a TriadTruth,
    spec: &'a StreamSpec,
    samples: u64,
    text: String,
}

impl StreamWriter<'_> {
    /// One sample of the specific force `f` (cm/s²): its time, s.
    fn sample(&mut self, f: [f64; 3], rng: &mut impl rand::Rng) -> f64 {
        #[allow(clippy::cast_precision_loss)]
        let time = self.samples as f64 / self.spec.rate_hz;
        let u = self.truth.readings(f);
        let e = [normal(rng), normal(rng), normal(rng)].map(|x| x * self.spec.sigma_cm_s2);
        let _ = writeln!(
            self.text,
            "{time},{},{},{}",
            u[0] + e[0],
            u[1] + e[1],
            u[2] + e[2]
        );
        self.samples += 1;
        time
    }

    /// The direction `n` held for `secs`: the hold's first and last times, s.
    fn hold(&mut self, n: [f64; 3], secs: f64, rng: &mut impl rand::Rng) -> (f64, f64) {
        #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
        let m = (secs * self.spec.rate_hz).round() as usize;
        let f = n.map(|x| x * G);
        let first = self.sample(f, rng);
        let mut last = first;
        for _ in 1..m {
            last = self.sample(f, rng);
        }
        (first, last)
    }

    /// The turn from `a` to `b` about the axis across both, the hand's push on top.
    fn turn(&mut self, a: [f64; 3], b: [f64; 3], rng: &mut impl rand::Rng) {
        let c = [
            a[1] * b[2] - a[2] * b[1],
            a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0],
        ];
        let sn = dot(c, c).sqrt();
        let angle = sn.atan2(dot(a, b));
        let axis = if sn > 1e-9 {
            c.map(|x| x / sn)
        } else {
            across(a)
        };
        let z: f64 = rng.random_range(-1.0..1.0);
        let phi: f64 = rng.random_range(0.0..std::f64::consts::TAU);
        let r = (1.0 - z * z).sqrt();
        let amp: f64 = rng.random_range(0.0..self.spec.push_cm_s2);
        let push = [r * phi.cos(), r * phi.sin(), z].map(|x| x * amp);
        #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
        let m = (self.spec.move_s * self.spec.rate_hz).round() as usize;
        for i in 0..m {
            #[allow(clippy::cast_precision_loss)]
            let tau = (i as f64 + 0.5) / m as f64;
            let share = 0.5 * (1.0 - (std::f64::consts::PI * tau).cos());
            let n = mul(&rotation(axis, share * angle), a);
            let p = (std::f64::consts::TAU * tau).sin();
            let f = [0, 1, 2].map(|j| n[j] * G + push[j] * p);
            self.sample(f, rng);
        }
    }
}

/// A stream (`time_s` and the three readings, cm/s²) of the triad `t` turned through the
/// gravity directions `dirs` (unit vectors, the triad's frame): `dirs[0]` held for the
/// rest, each next one reached by a turn about the axis across both (the angle's share
/// `(1 − cos πτ)/2` at the turn's fraction τ) with the hand's push on top, then held.
/// Also each hold's true span, s (the rest first).
pub fn stream_csv(
    t: &TriadTruth,
    dirs: &[[f64; 3]],
    spec: &StreamSpec,
    rng: &mut impl rand::Rng,
) -> (String, Vec<(f64, f64)>) {
    let mut w = StreamWriter {
        truth: t,
        spec,
        samples: 0,
        text: String::from(
            "# a triad turned by hand: the generator's stream\ntime_s,measured_x_cm_s2,measured_y_cm_s2,measured_z_cm_s2\n",
        ),
    };
    let mut spans = vec![w.hold(dirs[0], spec.rest_s, rng)];
    for pair in dirs.windows(2) {
        w.turn(pair[0], pair[1], rng);
        let secs = rng.random_range(spec.hold_s.0..spec.hold_s.1);
        spans.push(w.hold(pair[1], secs, rng));
    }
    (w.text, spans)
}
