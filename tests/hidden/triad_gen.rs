//! The triad generator written from the equations, one definition shared by the triad
//! campaign (`tests/hidden/triad.rs`), the triad CLI tests
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
