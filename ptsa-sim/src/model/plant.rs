//! The pendulum, torquer and pickoff electronics as a linear system, discretised exactly
//! with a zero-order hold on the torquer command and the disturbance torque.
//!
//! State `x = [θ, θ', i, y]`:
//!
//! * `θ` (rad), the pendulum angle about OA; `θ'` (rad/s);
//! * `i`, the torquer current as a fraction of the regulated full current (±1);
//! * `y` (rad), the demodulated pickoff after the demodulator's ripple filter.
//!
//! ```text
//! I·θ'' + C·θ' + K_eff·θ = d − F·i          (eq. 4.2; F = torque at full current = P·SF)
//! τ·i' = u − i                              (current regulator, u = ±1 from the PTSA)
//! y'   = ω_d·(θ − y)                        (demodulator low-pass)
//! ```
//!
//! `K_eff = K + P·a_PA − (I_PA − I_IA)·(W_IA² − W_PA²)` collects the spring and the
//! time-invariant parts of eq. 4.2's `θ` terms; their oscillating parts, and everything that
//! does not depend on `θ`, form the disturbance torque `d` (see `sim.rs`). Between clock
//! edges `u` is constant, and `d` is held at its mid-interval value, so
//! `x[k+1] = Φ·x[k] + Γu·u[k] + Γd·d[k]` is exact for `u` and exact to `O(T²)` for a smooth
//! `d`. `Φ = e^{AT}` and `Γ = ∫₀ᵀ e^{Aσ} dσ·B` come from one matrix exponential of the
//! augmented matrix `[[A, B], [0, 0]]·T` (scaling and squaring, Taylor series).
//!
//! The stops at `±θ_s` add a stiff, lossy contact `−K_s·(θ ∓ θ_s) − C_s·θ'`: a second and a
//! third discretisation, chosen by the sign of `θ` beyond the stop at the start of each tick.

use crate::model::instrument::Instrument;

/// Number of plant states.
pub const NX: usize = 4;

/// Matrix exponential of an `n×n` matrix (row-major, `n ≤ 8`): scaling and squaring with a
/// 20-term Taylor series; accurate to a few ulp for the well-scaled matrices used here.
#[must_use]
pub fn expm(a: &[[f64; 8]; 8], n: usize) -> [[f64; 8]; 8] {
    let norm = (0..n)
        .map(|r| (0..n).map(|c| a[r][c].abs()).sum::<f64>())
        .fold(0.0, f64::max);
    let mut squarings = 0u32;
    let mut scale = 1.0;
    while norm * scale > 0.25 {
        scale *= 0.5;
        squarings += 1;
    }
    let mut m = [[0.0; 8]; 8];
    for r in 0..n {
        for c in 0..n {
            m[r][c] = a[r][c] * scale;
        }
    }
    // Taylor: E = I + M + M²/2! + ...
    let mut e = [[0.0; 8]; 8];
    let mut term = [[0.0; 8]; 8];
    for r in 0..n {
        e[r][r] = 1.0;
        term[r][r] = 1.0;
    }
    for k in 1..=20 {
        term = matmul(&term, &m, n);
        let inv = 1.0 / f64::from(k);
        for row in term.iter_mut().take(n) {
            for x in row.iter_mut().take(n) {
                *x *= inv;
            }
        }
        for r in 0..n {
            for c in 0..n {
                e[r][c] += term[r][c];
            }
        }
    }
    for _ in 0..squarings {
        e = matmul(&e, &e, n);
    }
    e
}

fn matmul(a: &[[f64; 8]; 8], b: &[[f64; 8]; 8], n: usize) -> [[f64; 8]; 8] {
    let mut out = [[0.0; 8]; 8];
    for r in 0..n {
        for c in 0..n {
            let mut s = 0.0;
            for k in 0..n {
                s += a[r][k] * b[k][c];
            }
            out[r][c] = s;
        }
    }
    out
}

/// One exact discretisation: `x' = Φ x + Γu u + Γd d`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Zoh {
    /// State transition over one tick.
    pub phi: [[f64; NX]; NX],
    /// Response to the torquer command `u` held over the tick.
    pub gu: [f64; NX],
    /// Response to a disturbance torque `d` (dyn·cm) held over the tick.
    pub gd: [f64; NX],
}

impl Zoh {
    /// Discretise with stiffness `k` (dyn·cm/rad) and damping `c` (dyn·cm·s) on the pendulum.
    #[must_use]
    #[allow(clippy::needless_range_loop)]
    pub fn new(instr: &Instrument, k: f64, c: f64) -> Self {
        let t = 1.0 / instr.clock_hz;
        let inertia = instr.inertia_dyn_cm_s2;
        let f = instr.full_torque_dyn_cm();
        let tau = instr.torquer_tau_s;
        let wd = std::f64::consts::TAU * instr.demod_bandwidth_hz;
        let mut m = [[0.0; 8]; 8];
        // A
        m[0][1] = 1.0;
        m[1][0] = -k / inertia;
        m[1][1] = -c / inertia;
        m[1][2] = -f / inertia;
        m[2][2] = -1.0 / tau;
        m[3][0] = wd;
        m[3][3] = -wd;
        // B: column 4 = u, column 5 = d
        m[2][4] = 1.0 / tau;
        m[1][5] = 1.0 / inertia;
        for row in &mut m {
            for x in row.iter_mut() {
                *x *= t;
            }
        }
        let e = expm(&m, 6);
        let mut z = Zoh {
            phi: [[0.0; NX]; NX],
            gu: [0.0; NX],
            gd: [0.0; NX],
        };
        for r in 0..NX {
            for c in 0..NX {
                z.phi[r][c] = e[r][c];
            }
            z.gu[r] = e[r][4];
            z.gd[r] = e[r][5];
        }
        z
    }

    /// One step. Uses the structure of `Φ`: the demodulator output `y` feeds nothing back,
    /// and the current `i` depends only on itself, so `Φ[0..3][3]` and the off-diagonal
    /// entries of row 2 are exactly zero (the exponential of a block-triangular matrix is
    /// block-triangular; a unit test checks it).
    #[allow(clippy::inline_always, reason = "per-tick path")]
    #[inline(always)]
    #[must_use]
    pub fn step(&self, x: &[f64; NX], add: &[f64; NX]) -> [f64; NX] {
        let y = step_lanes::<1>(|r, c, _| self.phi[r][c], &x.map(|v| [v]), &add.map(|v| [v]));
        y.map(|v| v[0])
    }

    /// The general product `Φ x + add` (reference for [`Zoh::step`]).
    #[must_use]
    pub fn step_full(&self, x: &[f64; NX], add: &[f64; NX]) -> [f64; NX] {
        let mut out = *add;
        for (o, row) in out.iter_mut().zip(&self.phi) {
            *o += row.iter().zip(x).map(|(a, b)| a * b).sum::<f64>();
        }
        out
    }
}

/// `K` discretisations side by side, structure of arrays (`phi[r][c][lane]`, only the entries
/// [`Zoh::step`] uses), for the batch engine's lanes: [`ZohLanes::step`] is [`Zoh::step`] lane
/// by lane, the same operations in the same order, so bit-identical, and written so that
/// the compiler can run several lanes per SIMD instruction.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ZohLanes<const K: usize> {
    /// `Φ[r][c]` of each lane (the structural zeros of [`Zoh::step`] are left at 0).
    pub phi: [[[f64; K]; NX]; NX],
}

impl<const K: usize> ZohLanes<K> {
    /// The discretisations of `K` lanes.
    #[must_use]
    #[allow(clippy::needless_range_loop)]
    pub fn new(zoh: [&Zoh; K]) -> Self {
        let mut phi = [[[0.0; K]; NX]; NX];
        for (l, z) in zoh.iter().enumerate() {
            for r in 0..NX {
                for c in 0..NX {
                    phi[r][c][l] = z.phi[r][c];
                }
            }
        }
        Self { phi }
    }

    /// One step of every lane: `x[j][lane]` (state `j`) to `Φ x + add` ([`Zoh::step`]'s
    /// expression).
    #[allow(clippy::inline_always, reason = "per-tick path")]
    #[inline(always)]
    #[must_use]
    pub fn step(&self, x: &[[f64; K]; NX], add: &[[f64; K]; NX]) -> [[f64; K]; NX] {
        step_lanes::<K>(|r, c, l| self.phi[r][c][l], x, add)
    }
}

/// `Φ x + add` for `K` lanes, `x[j][lane]`, with `Φ[r][c]` of a lane given by `phi(r, c,
/// lane)`: the one expression of a plant step, [`Zoh::step`] with one lane and
/// [`ZohLanes::step`] with many. Only the entries that are not structurally zero enter (the
/// demodulator does not feed the pendulum or the torquer current, the current not itself),
/// in a fixed order of operations.
#[allow(clippy::inline_always, reason = "per-tick path")]
#[inline(always)]
fn step_lanes<const K: usize>(
    phi: impl Fn(usize, usize, usize) -> f64,
    x: &[[f64; K]; NX],
    add: &[[f64; K]; NX],
) -> [[f64; K]; NX] {
    let p = |r, c, l| phi(r, c, l);
    let mut y = [[0.0; K]; NX];
    for l in 0..K {
        y[0][l] = add[0][l] + (p(0, 0, l) * x[0][l] + p(0, 1, l) * x[1][l]) + p(0, 2, l) * x[2][l];
        y[1][l] = add[1][l] + (p(1, 0, l) * x[0][l] + p(1, 1, l) * x[1][l]) + p(1, 2, l) * x[2][l];
        y[2][l] = add[2][l] + p(2, 2, l) * x[2][l];
        y[3][l] = add[3][l]
            + (p(3, 0, l) * x[0][l] + p(3, 1, l) * x[1][l])
            + (p(3, 2, l) * x[2][l] + p(3, 3, l) * x[3][l]);
    }
    y
}

/// The three discretisations (free, on the upper stop, on the lower stop) and the constant
/// torque each adds.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Plant {
    /// `[free, upper stop, lower stop]`.
    pub zoh: [Zoh; 3],
    /// Constant torque of each region, dyn·cm: `0`, `+K_s·θ_s`, `−K_s·θ_s`.
    pub stop_torque: [f64; 3],
    /// Stop angle, rad.
    pub theta_stop: f64,
}

impl Plant {
    /// Discretise for an effective stiffness `k_eff` (dyn·cm/rad, see the module docs).
    #[must_use]
    pub fn new(instr: &Instrument, k_eff: f64) -> Self {
        let ks = instr.stop_stiffness_dyn_cm_rad;
        let cs = instr.stop_damping_dyn_cm_s;
        let c = instr.damping_dyn_cm_s;
        let free = Zoh::new(instr, k_eff, c);
        let stop = Zoh::new(instr, k_eff + ks, c + cs);
        let ts = instr.freedom_rad;
        Self {
            zoh: [free, stop, stop],
            stop_torque: [0.0, ks * ts, -ks * ts],
            theta_stop: ts,
        }
    }

    /// Region of the state: 0 free, 1 beyond `+θ_s`, 2 beyond `−θ_s`.
    #[allow(clippy::inline_always, reason = "per-tick path")]
    #[inline(always)]
    #[must_use]
    pub fn region(&self, theta: f64) -> usize {
        if theta.abs() <= self.theta_stop {
            0
        } else if theta > 0.0 {
            1
        } else {
            2
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn expm_of_a_rotation() {
        let mut a = [[0.0; 8]; 8];
        a[0][1] = -1.0;
        a[1][0] = 1.0;
        let e = expm(&a, 2);
        assert!((e[0][0] - 1f64.cos()).abs() < 1e-14);
        assert!((e[1][0] - 1f64.sin()).abs() < 1e-14);
    }

    #[test]
    fn zoh_matches_the_first_order_current_exactly() {
        let i = Instrument::kearfott_2401();
        let z = Zoh::new(&i, 1540.0, 76400.0);
        let a = (-1.0 / i.clock_hz / i.torquer_tau_s).exp();
        assert!((z.phi[2][2] - a).abs() < 1e-13);
        assert!((z.gu[2] - (1.0 - a)).abs() < 1e-13);
    }

    #[test]
    #[allow(clippy::float_cmp)]
    fn structural_zeros_of_phi_are_exact() {
        let i = Instrument::kearfott_2401();
        for z in Plant::new(&i, 1540.0).zoh {
            for r in 0..3 {
                assert_eq!(z.phi[r][3], 0.0);
            }
            assert_eq!(z.phi[2][0], 0.0);
            assert_eq!(z.phi[2][1], 0.0);
            let x = [1e-5, -2e-3, 0.3, 7e-6];
            let a = [1e-9, 2e-7, 0.01, 3e-9];
            let (s, f) = (z.step(&x, &a), z.step_full(&x, &a));
            for k in 0..NX {
                assert!(
                    (s[k] - f[k]).abs() <= 1e-15 * f[k].abs().max(1e-12),
                    "{s:?} {f:?}"
                );
            }
        }
    }

    #[test]
    fn lanes_step_is_step_bit_for_bit() {
        // Three lanes of different discretisations, states and inputs over many steps.
        let i = Instrument::kearfott_2401();
        let p = Plant::new(&i, 1540.0);
        let q = Plant::new(&i, 2.5e4);
        let zs = [&p.zoh[0], &p.zoh[1], &q.zoh[0]];
        let lanes = ZohLanes::<3>::new(zs);
        let mut xs = [
            [1e-5, -2e-3, 0.3, 7e-6],
            [-3e-4, 0.1, -0.9, 2e-4],
            [0.0; NX],
        ];
        let adds = [
            [1e-9, 2e-7, 0.01, 3e-9],
            [-4e-8, 1e-6, -0.02, 5e-10],
            [3e-7, -1e-5, 0.2, 0.0],
        ];
        for _ in 0..1000 {
            let mut x = [[0.0; 3]; NX];
            let mut a = [[0.0; 3]; NX];
            for l in 0..3 {
                for j in 0..NX {
                    x[j][l] = xs[l][j];
                    a[j][l] = adds[l][j];
                }
            }
            let y = lanes.step(&x, &a);
            for l in 0..3 {
                let want = zs[l].step(&xs[l], &adds[l]);
                for j in 0..NX {
                    assert_eq!(y[j][l].to_bits(), want[j].to_bits());
                }
                xs[l] = want;
            }
        }
    }

    #[test]
    fn static_gain_of_the_pendulum() {
        // Hold d constant: θ settles at d/K. Iterate the ZOH long enough (time constant C/K).
        let i = Instrument::kearfott_2401();
        let k = 1e7; // stiff, so that it settles fast: C/K = 7.6 ms
        let z = Zoh::new(&i, k, i.damping_dyn_cm_s);
        let mut x = [0.0; NX];
        let add = [
            z.gd[0] * 100.0,
            z.gd[1] * 100.0,
            z.gd[2] * 100.0,
            z.gd[3] * 100.0,
        ];
        for _ in 0..64_000 {
            x = z.step(&x, &add);
        }
        assert!((x[0] - 1e-5).abs() < 1e-12, "{x:?}");
        assert!((x[3] - 1e-5).abs() < 1e-12, "{x:?}");
    }
}
