//! Test conditions in the instrument's case frame, and the vocabulary of candidate effects.
//!
//! A [`Condition`] is one row of the case-frame data format (`docs/case-frame.md`): gravity,
//! constant rates, and sinusoidal linear and angular oscillations, all along or about the
//! case axes IA, PA, OA (right-handed). [`Condition::inputs_at`] evaluates what the
//! instrument feels at a time `t`. [`Effects`] holds the coefficients of the candidate error
//! terms that the baseline model leaves out; [`Effects::indicated_cm_s2`] is their sum, an
//! extra indicated acceleration (equivalently a torque `P·a` on the pendulum, eq. 4.2).

use std::f64::consts::TAU;

/// Local gravity, cm/s² (R-890 section 6.1).
pub const G_CM_S2: f64 = 980.4;

/// Axis indices in every `[f64; 3]` of this module.
pub const IA: usize = 0;
/// Pendulous axis index.
pub const PA: usize = 1;
/// Output axis index.
pub const OA: usize = 2;

/// One test condition (one row of a case-frame file). Every oscillation runs at `freq_hz`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Condition {
    /// Free text.
    pub label: String,
    /// Gravity's specific force along IA, PA, OA with the case at rest, in g (980.4 cm/s²).
    pub g: [f64; 3],
    /// Constant angular rate of the case about IA, PA, OA, rad/s.
    pub w_rad_s: [f64; 3],
    /// Frequency of every oscillation, Hz (0 = none).
    pub freq_hz: f64,
    /// Linear vibration amplitude along IA, PA, OA, cm/s²: `amp·sin(2πft + phase)`.
    pub lin_cm_s2: [f64; 3],
    /// Phase of each linear vibration, degrees.
    pub lin_deg: [f64; 3],
    /// Angular oscillation amplitude about IA, PA, OA, mrad: angle `amp·sin(2πft + phase)`.
    pub ang_mrad: [f64; 3],
    /// Phase of each angular oscillation, degrees.
    pub ang_deg: [f64; 3],
    /// Constant rates of the reference condition (same gravity, no oscillation), rad/s.
    pub ref_w_rad_s: [f64; 3],
    /// Measured mean indicated acceleration minus the reference's, cm/s² (if measured).
    pub measured_cm_s2: Option<f64>,
    /// 1-sigma uncertainty of `measured_cm_s2`, cm/s² (if given).
    pub sigma_cm_s2: Option<f64>,
}

/// What the instrument feels at one instant, in case axes.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct CaseInputs {
    /// Specific force along IA, PA, OA (gravity + vibration), cm/s².
    pub a_cm_s2: [f64; 3],
    /// Angular rate about IA, PA, OA, rad/s.
    pub w_rad_s: [f64; 3],
    /// Angular acceleration about IA, PA, OA, rad/s².
    pub dw_rad_s2: [f64; 3],
}

impl Condition {
    /// The reference condition: same gravity, rates `ref_w_rad_s`, no oscillation.
    #[must_use]
    pub fn reference(&self) -> Condition {
        Condition {
            label: format!("{} (reference)", self.label),
            g: self.g,
            w_rad_s: self.ref_w_rad_s,
            ref_w_rad_s: self.ref_w_rad_s,
            ..Condition::default()
        }
    }

    /// Whether anything in the condition varies with time.
    #[must_use]
    pub fn is_static(&self) -> bool {
        self.freq_hz == 0.0
            || (self.lin_cm_s2.iter().all(|&x| x == 0.0) && self.ang_mrad.iter().all(|&x| x == 0.0))
    }

    /// Case-frame inputs at time `t` (s).
    ///
    /// Angular oscillation about axis j is the small angle `φ_j(t) = amp_j·1e-3·sin(ωt + p_j)`;
    /// its rate `φ̇_j` adds to `w_rad_s[j]` and `φ̈_j` is the angular acceleration. Gravity,
    /// fixed in the laboratory, is seen from the oscillating case rotated by `−φ` to first
    /// order: `g_case = g − φ × g`. Constant rates are taken to turn the case about a
    /// gravity-fixed axis (a rate table), so they do not rotate gravity in the case frame.
    #[must_use]
    pub fn inputs_at(&self, t: f64) -> CaseInputs {
        let p = self.prepare();
        let (s, c) = (p.omega * t).sin_cos();
        p.inputs(s, c)
    }

    /// The condition reduced to per-axis sine and cosine coefficients of the common phase
    /// `ωt`, so that [`Prepared::inputs`] needs no trigonometry (the simulator's hot path).
    #[must_use]
    pub fn prepare(&self) -> Prepared {
        let omega = TAU * self.freq_hz;
        let mut p = Prepared {
            omega,
            g: self.g.map(|x| x * G_CM_S2),
            w0: self.w_rad_s,
            ..Prepared::default()
        };
        if self.freq_hz != 0.0 {
            for j in 0..3 {
                if self.lin_cm_s2[j] != 0.0 {
                    let (sp, cp) = self.lin_deg[j].to_radians().sin_cos();
                    p.lin_s[j] = self.lin_cm_s2[j] * cp;
                    p.lin_c[j] = self.lin_cm_s2[j] * sp;
                }
                if self.ang_mrad[j] != 0.0 {
                    let amp = self.ang_mrad[j] * 1e-3;
                    let (sp, cp) = self.ang_deg[j].to_radians().sin_cos();
                    p.phi_s[j] = amp * cp;
                    p.phi_c[j] = amp * sp;
                }
            }
        }
        p
    }
}

/// A [`Condition`] prepared for fast evaluation: every oscillation written as
/// `x_s·sin(ωt) + x_c·cos(ωt)` (`sin(ωt + p) = sin ωt·cos p + cos ωt·sin p`).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Prepared {
    /// Angular frequency of every oscillation, rad/s.
    pub omega: f64,
    /// Gravity's specific force along IA, PA, OA, cm/s².
    pub g: [f64; 3],
    /// Constant rates, rad/s.
    pub w0: [f64; 3],
    /// Linear vibration, sine coefficient, cm/s².
    pub lin_s: [f64; 3],
    /// Linear vibration, cosine coefficient, cm/s².
    pub lin_c: [f64; 3],
    /// Angular oscillation, sine coefficient, rad.
    pub phi_s: [f64; 3],
    /// Angular oscillation, cosine coefficient, rad.
    pub phi_c: [f64; 3],
}

impl Prepared {
    /// Case-frame inputs given `s = sin(ωt)`, `c = cos(ωt)` (same model as
    /// [`Condition::inputs_at`]).
    #[inline]
    #[must_use]
    pub fn inputs(&self, s: f64, c: f64) -> CaseInputs {
        let w = self.omega;
        let mut a = self.g;
        let mut phi = [0.0; 3];
        let mut rate = self.w0;
        let mut dw = [0.0; 3];
        for j in 0..3 {
            a[j] += self.lin_s[j] * s + self.lin_c[j] * c;
            phi[j] = self.phi_s[j] * s + self.phi_c[j] * c;
            rate[j] += w * (self.phi_s[j] * c - self.phi_c[j] * s);
            dw[j] = -w * w * phi[j];
        }
        let phi_x_g = cross(phi, self.g);
        for j in 0..3 {
            a[j] -= phi_x_g[j];
        }
        CaseInputs {
            a_cm_s2: a,
            w_rad_s: rate,
            dw_rad_s2: dw,
        }
    }

    /// The time-invariant part: gravity and the constant rates.
    #[must_use]
    pub fn mean_inputs(&self) -> CaseInputs {
        CaseInputs {
            a_cm_s2: self.g,
            w_rad_s: self.w0,
            dw_rad_s2: [0.0; 3],
        }
    }

    /// Whether anything varies with time.
    #[must_use]
    pub fn is_dynamic(&self) -> bool {
        self.omega != 0.0
            && (self
                .lin_s
                .iter()
                .chain(&self.lin_c)
                .chain(&self.phi_s)
                .chain(&self.phi_c))
            .any(|&x| x != 0.0)
    }
}

/// Cross product.
#[must_use]
pub fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// Coefficients of the candidate effects (all zero in the baseline model). The names and
/// keys are part of the `ptsa discover` contract.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Effects {
    /// `anisoinertia`: `k_ai_cm·w_IA·w_PA`; `k_ai_cm = (I_PA − I_IA)/(m·l)`, cm.
    pub k_ai_cm: f64,
    /// `lever_arm`: proof-mass offset from the centre of rotation, cm (IA, PA, OA); the
    /// term is the IA component of `dw × r + w × (w × r)`.
    pub r_cm: [f64; 3],
    /// `vibropendulosity`: `k_ip_s2_cm·a_IA·a_PA`, s²/cm.
    pub k_ip_s2_cm: f64,
    /// `anisoelasticity`: `k_io_s2_cm·a_IA·a_OA`, s²/cm.
    pub k_io_s2_cm: f64,
    /// `nonlinearity`: `k2_s2_cm·a_IA²`, s²/cm.
    pub k2_s2_cm: f64,
    /// `sculling`: `k_sc_s2·dw_OA·a_PA`, s².
    pub k_sc_s2: f64,
}

impl Effects {
    /// Whether every coefficient is zero.
    #[must_use]
    pub fn is_zero(&self) -> bool {
        *self == Effects::default()
    }

    /// Sum of the effect terms at one instant: extra indicated acceleration along IA, cm/s².
    #[must_use]
    pub fn indicated_cm_s2(&self, i: &CaseInputs) -> f64 {
        let [a_ia, a_pa, a_oa] = i.a_cm_s2;
        let w = i.w_rad_s;
        let dw = i.dw_rad_s2;
        let r = self.r_cm;
        let lever = cross(dw, r)[IA] + cross(w, cross(w, r))[IA];
        self.k_ai_cm * w[IA] * w[PA]
            + lever
            + self.k_ip_s2_cm * a_ia * a_pa
            + self.k_io_s2_cm * a_ia * a_oa
            + self.k2_s2_cm * a_ia * a_ia
            + self.k_sc_s2 * dw[OA] * a_pa
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn anisoinertia_at_45_degrees_matches_the_report_arithmetic() {
        // Table 6.1 geometry: IA 45° above horizontal, table rate 1 rad/s about the vertical.
        let phi = 45f64.to_radians();
        let c = Condition {
            g: [phi.sin(), phi.cos(), 0.0],
            w_rad_s: [phi.sin(), phi.cos(), 0.0],
            ..Condition::default()
        };
        let e = Effects {
            k_ai_cm: 3.0,
            ..Effects::default()
        };
        let x = e.indicated_cm_s2(&c.inputs_at(0.0));
        assert!((x - 1.5).abs() < 1e-12, "{x}");
    }

    #[test]
    fn lever_arm_along_pa_gives_centripetal_ia_term() {
        // w about IA and PA, r along PA: w × (w × r) = w (w·r) − r |w|²; IA part = w_IA w_PA r_PA.
        let c = Condition {
            w_rad_s: [0.6, 0.8, 0.0],
            ..Condition::default()
        };
        let e = Effects {
            r_cm: [0.0, 2.0, 0.0],
            ..Effects::default()
        };
        let x = e.indicated_cm_s2(&c.inputs_at(0.0));
        assert!((x - 0.6 * 0.8 * 2.0).abs() < 1e-12, "{x}");
    }

    #[test]
    fn oscillation_about_oa_tilts_gravity_into_ia() {
        // IA horizontal, PA up (g_pa = 1): a rotation φ about OA moves gravity into IA.
        let c = Condition {
            g: [0.0, 1.0, 0.0],
            freq_hz: 1.0,
            ang_mrad: [0.0, 0.0, 2.0],
            ..Condition::default()
        };
        let i = c.inputs_at(0.25); // sin = 1: φ_OA = 2 mrad
        // −(φ × g)_IA = −(φ_PA g_OA − φ_OA g_PA) = φ_OA g_PA
        assert!((i.a_cm_s2[IA] - 2e-3 * G_CM_S2).abs() < 1e-9);
        assert!((i.dw_rad_s2[OA] + 2e-3 * TAU * TAU).abs() < 1e-9);
    }
}
