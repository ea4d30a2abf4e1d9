//! Test fixtures of R-890 and their kinematics: each produces [`Condition`]s (case-frame
//! rows) and, where the proof mass sits off the centre of rotation, a lever arm.
//!
//! Case axes IA, PA, OA are right-handed. Specific force is "up" positive: IA up gives
//! `g_ia = +1`. A lever arm `r` (cm, case axes) is the proof mass's offset from the centre of
//! rotation: it feels `dw × r + w × (w × r)` (the `lever_arm` effect of [`Effects`]), which
//! the simulator adds through the `lever_arm` candidate of [`Effects`].

use crate::model::condition::{Condition, IA, OA, PA, cross};
use crate::model::effects::{CandidateId, Effects};
use crate::model::instrument::Instrument;

/// A condition and the lever arm of the fixture (cm, case axes).
#[derive(Clone, Debug, PartialEq)]
pub struct Setup {
    /// The case-frame row.
    pub cond: Condition,
    /// Proof-mass offset from the centre of rotation, cm.
    pub lever_cm: [f64; 3],
}

impl Setup {
    /// `effects` plus this fixture's lever arm.
    #[must_use]
    pub fn effects(&self, effects: &Effects) -> Effects {
        let mut e = *effects;
        e.add_lever_arm_cm(self.lever_cm);
        e
    }
}

/// A constant specific force `accel_cm_s2` along IA and nothing else (the plain static
/// loop); `g_cm_s2` is the local gravity that the case frame's `g_*` columns are in.
#[must_use]
pub fn along_ia(accel_cm_s2: f64, g_cm_s2: f64) -> Condition {
    Condition {
        label: format!("{accel_cm_s2} cm/s^2 along IA"),
        g: [accel_cm_s2 / g_cm_s2, 0.0, 0.0],
        ..Condition::default()
    }
}

/// Gravity with IA at `ia_deg` above the horizontal in the vertical IA–PA plane (the
/// dividing head of Figs. 6.1–6.2; OA horizontal): `g_ia = sin φ`, `g_pa = cos φ`.
#[must_use]
pub fn dividing_head(ia_deg: f64) -> Condition {
    let (s, c) = ia_deg.to_radians().sin_cos();
    Condition {
        label: format!("IA {ia_deg} deg"),
        g: [clean(s), clean(c), 0.0],
        ..Condition::default()
    }
}

/// Round the `1e-16`-ish values of `sin`/`cos` at multiples of 90° to 0 and ±1, so that
/// 180° gives `g_ia = 0`, not 1.2e-16.
fn clean(x: f64) -> f64 {
    if x.abs() < 1e-12 {
        0.0
    } else if (x.abs() - 1.0).abs() < 1e-12 {
        x.signum()
    } else {
        x
    }
}

/// The dividing head on the rate table (Fig. 6.1): IA at `ia_deg` above horizontal, table
/// rate `rate_rad_s` about the vertical, so `w_ia = ω sin φ`, `w_pa = ω cos φ`; the
/// reference is the same position at `ref_rate_rad_s` (the report's 0.05 rad/s). `lever_cm`
/// is the CG's offset from the table axis (0 in the report's revised set-up).
#[must_use]
pub fn rate_table(ia_deg: f64, rate_rad_s: f64, ref_rate_rad_s: f64, lever_cm: [f64; 3]) -> Setup {
    let mut cond = dividing_head(ia_deg);
    let [s, c, _] = cond.g;
    cond.label = format!("IA {ia_deg} deg, {rate_rad_s} rad/s");
    cond.w_rad_s = [rate_rad_s * s, rate_rad_s * c, 0.0];
    cond.ref_w_rad_s = [ref_rate_rad_s * s, ref_rate_rad_s * c, 0.0];
    Setup { cond, lever_cm }
}

/// The single-axis angular oscillator (Fig. 6.3): OA along the table axis, oscillation
/// `amp_mrad·sin(2πft)` about OA. `ia_vertical` false: table top horizontal, OA up (Table
/// 6.2, IA horizontal); true: table top turned 90° about the tilt axis, IA up (Table 6.3).
#[must_use]
pub fn angular_oscillator(
    freq_hz: f64,
    amp_mrad: f64,
    ia_vertical: bool,
    lever_cm: [f64; 3],
) -> Setup {
    let g = if ia_vertical {
        [1.0, 0.0, 0.0]
    } else {
        [0.0, 0.0, 1.0]
    };
    let mut ang = [0.0; 3];
    ang[OA] = amp_mrad;
    Setup {
        cond: Condition {
            label: format!(
                "{freq_hz} Hz, {amp_mrad} mrad about OA, IA {}",
                if ia_vertical {
                    "vertical"
                } else {
                    "horizontal"
                }
            ),
            g,
            freq_hz,
            ang_mrad: ang,
            ..Condition::default()
        },
        lever_cm,
    }
}

/// Which Appendix A set-up.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum TwoAxisKind {
    /// Fig. A.2: Y about IA, Z about PA, radius along OA: IA and PA vibrations.
    Vibropendulous,
    /// Fig. A.4: Y about IA, Z about OA, radius along PA: IA and OA vibrations.
    Anisoelastic,
    /// Fig. A.5: Z about OA (OA angular input), Y about IA with radius along OA: PA vibration.
    Sculling,
}

/// The two-axis oscillator of Appendix A: `θ_y = θ_my·sin(ωt + ψ)`, `θ_z = θ_mz·sin(ωt)`,
/// proof mass at radius `r_cm` along the fixture's X axis, which is vertical.
///
/// The tangential accelerations `dw × r` enter the row as linear vibrations (exact, one
/// frequency); the centripetal terms `w × (w × r)` (second order, DC and 2ω, along the
/// radius) are left out of the row, as they are along OA (A.2, A.5) or PA (A.4) and do not
/// reach IA.
#[must_use]
pub fn two_axis(
    kind: TwoAxisKind,
    freq_hz: f64,
    theta_my_mrad: f64,
    theta_mz_mrad: f64,
    psi_deg: f64,
    r_cm: f64,
) -> Condition {
    let (y_axis, z_axis, radius, g) = match kind {
        // Signs of r chosen to match the figures' IA_z = +r θ_mz ω² sin ωt.
        TwoAxisKind::Vibropendulous => (IA, PA, [0.0, 0.0, -r_cm], [0.0, 0.0, -1.0]),
        TwoAxisKind::Anisoelastic => (IA, OA, [0.0, -r_cm, 0.0], [0.0, -1.0, 0.0]),
        TwoAxisKind::Sculling => (IA, OA, [0.0, 0.0, r_cm], [0.0, 0.0, 1.0]),
    };
    let mut ang = [0.0; 3];
    let mut ang_deg = [0.0; 3];
    ang[y_axis] = theta_my_mrad;
    ang_deg[y_axis] = psi_deg;
    ang[z_axis] = theta_mz_mrad;
    // dw_j = −θ_j ω² sin(ωt + p_j): phasor (complex amplitude of sin) −θ ω² e^{jp}.
    let w = std::f64::consts::TAU * freq_hz;
    let mut re = [0.0; 3];
    let mut im = [0.0; 3];
    for j in 0..3 {
        let a = -ang[j] * 1e-3 * w * w;
        let (s, c) = ang_deg[j].to_radians().sin_cos();
        re[j] = a * c;
        im[j] = a * s;
    }
    let lr = cross(re, radius);
    let li = cross(im, radius);
    let mut lin = [0.0; 3];
    let mut lin_deg = [0.0; 3];
    for j in 0..3 {
        lin[j] = lr[j].hypot(li[j]);
        lin_deg[j] = if lin[j] > 0.0 {
            li[j].atan2(lr[j]).to_degrees()
        } else {
            0.0
        };
    }
    Condition {
        label: format!("{kind:?} {freq_hz} Hz, psi {psi_deg} deg"),
        g,
        freq_hz,
        lin_cm_s2: lin,
        lin_deg,
        ang_mrad: ang,
        ang_deg,
        ..Condition::default()
    }
}

/// `n` static accelerations along IA spread evenly over ±0.9 of the instrument's full scale,
/// cm/s² (one: 0): the static conditions of `ptsa bench --batch N` and `benches/batch.rs`,
/// each a condition through [`along_ia`].
#[must_use]
pub fn spread_accels(instr: &Instrument, n: usize) -> Vec<f64> {
    #[allow(clippy::cast_precision_loss)]
    let step = |i: usize| {
        if n < 2 {
            0.0
        } else {
            -0.9 + 1.8 * i as f64 / (n - 1) as f64
        }
    };
    (0..n).map(|i| step(i) * instr.sf_cm_s2).collect()
}

/// `n` different oscillating conditions with effects, the dynamic conditions of
/// `ptsa bench --batch N --dynamic` and `benches/batch.rs` (`dynamic_*`). Condition `j` (0 to
/// `n − 1`) has gravity `g_pa = 1`, `g_ia = 0.1·j/n` and the frequency `10 + 40·j/n` Hz
/// (10 to 47.5 Hz for 16); an even `j` oscillates about OA with `1 + 1.6·j/n` mrad, an odd
/// `j` vibrates along IA with `100 + 320·j/n` cm/s² and along PA with 200 cm/s² at 30°.
/// Every one carries sculling (`k_sc_s2` = 1e-3 s²) and anisoinertia (`k_ai_cm` = 2 cm), so
/// the effects' torque is computed each tick.
#[must_use]
pub fn oscillating_spread(n: usize) -> Vec<(Condition, Effects)> {
    #[allow(clippy::cast_precision_loss, reason = "j < n, a count of conditions")]
    let (nf, at) = (n as f64, |j: usize| j as f64);
    (0..n)
        .map(|j| {
            let jf = at(j);
            let mut c = Condition {
                label: format!("oscillating {j}"),
                g: [0.1 * jf / nf, 1.0, 0.0],
                freq_hz: 10.0 + 40.0 * jf / nf,
                ..Condition::default()
            };
            if j % 2 == 0 {
                c.ang_mrad[OA] = 1.0 + 1.6 * jf / nf;
            } else {
                c.lin_cm_s2[IA] = 100.0 + 320.0 * jf / nf;
                c.lin_cm_s2[PA] = 200.0;
                c.lin_deg[PA] = 30.0;
            }
            let e = Effects::only(CandidateId::Sculling, 1e-3).with(CandidateId::Anisoinertia, 2.0);
            (c, e)
        })
        .collect()
}

/// Parameter identification's shape, for `ptsa bench --batch N --dynamic --shared-condition`
/// and `benches/batch.rs` (`ident_*`): one oscillating condition (2 mrad about OA at 20 Hz,
/// `g_pa = 1`) and `n` copies of `instr` whose spring is `1 + 0.16·j/n` times the file's (0
/// to 15 % stiffer for 16), as the parameter sides of `ptsa discover` are.
#[must_use]
pub fn shared_condition_spread(instr: &Instrument, n: usize) -> (Condition, Vec<Instrument>) {
    let mut cond = Condition {
        label: "20 Hz, 2 mrad about OA".into(),
        g: [0.0, 1.0, 0.0],
        freq_hz: 20.0,
        ..Condition::default()
    };
    cond.ang_mrad[OA] = 2.0;
    #[allow(clippy::cast_precision_loss, reason = "j < n, a count of instruments")]
    let instrs = (0..n)
        .map(|j| {
            let mut i = instr.clone();
            i.spring_dyn_cm_rad *= 1.0 + 0.16 * j as f64 / n as f64;
            i
        })
        .collect();
    (cond, instrs)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spread_covers_nine_tenths_of_full_scale() {
        let i = Instrument::kearfott_2401();
        let a = spread_accels(&i, 16);
        assert_eq!(a.len(), 16);
        assert!((a[0] + 0.9 * i.sf_cm_s2).abs() < 1e-9);
        assert!((a[15] - 0.9 * i.sf_cm_s2).abs() < 1e-9);
        assert_eq!(spread_accels(&i, 1), vec![0.0]);
    }

    /// With 16 the sets are bit for bit the ones `benches/batch.rs` wrote out before they
    /// moved here (`0.1·j/16`, `10 + 2.5·j`, `1 + 0.1·j`, `100 + 20·j`; spring `1 + 0.01·j`),
    /// so criterion's earlier figures measure the same runs.
    #[test]
    #[allow(clippy::float_cmp, reason = "the same bits are the point")]
    fn sixteen_are_the_benches_earlier_sets() {
        let set = oscillating_spread(16);
        assert_eq!(set.len(), 16);
        for (j, (c, e)) in set.iter().enumerate() {
            let jf = f64::from(u8::try_from(j).unwrap());
            assert_eq!(c.g, [0.1 * jf / 16.0, 1.0, 0.0]);
            assert_eq!(c.freq_hz, 10.0 + 2.5 * jf);
            if j % 2 == 0 {
                assert_eq!(c.ang_mrad, [0.0, 0.0, 1.0 + 0.1 * jf]);
                assert_eq!(c.lin_cm_s2, [0.0; 3]);
            } else {
                assert_eq!(c.ang_mrad, [0.0; 3]);
                assert_eq!(c.lin_cm_s2[IA], 100.0 + 20.0 * jf);
                assert_eq!((c.lin_cm_s2[PA], c.lin_deg[PA]), (200.0, 30.0));
            }
            assert!(c.prepare(980.665).is_dynamic());
            assert_eq!(
                *e,
                Effects::only(CandidateId::Sculling, 1e-3).with(CandidateId::Anisoinertia, 2.0)
            );
        }
        let i = Instrument::kearfott_2401();
        let (c, instrs) = shared_condition_spread(&i, 16);
        assert_eq!(
            (c.freq_hz, c.ang_mrad[OA], c.g),
            (20.0, 2.0, [0.0, 1.0, 0.0])
        );
        for (j, k) in instrs.iter().enumerate() {
            let jf = f64::from(u8::try_from(j).unwrap());
            assert_eq!(k.spring_dyn_cm_rad, i.spring_dyn_cm_rad * (1.0 + 0.01 * jf));
        }
        // Any count stays in range: 64 conditions below 50 Hz, springs below 16 % stiffer.
        let last = &oscillating_spread(64)[63].0;
        assert!(last.freq_hz < 50.0 && last.lin_cm_s2[IA] < 420.0);
        let k = &shared_condition_spread(&i, 64).1[63];
        assert!(k.spring_dyn_cm_rad < 1.16 * i.spring_dyn_cm_rad);
        assert_eq!(oscillating_spread(1)[0].0.freq_hz, 10.0);
    }

    #[test]
    fn table_6_1_geometry() {
        let s = rate_table(45.0, 1.0, 0.05, [0.0; 3]);
        let i = s.cond.inputs_at(0.0, 980.4);
        assert!((i.w_rad_s[IA] * i.w_rad_s[PA] - 0.5).abs() < 1e-12);
        assert!((s.cond.reference().w_rad_s[IA] - 0.05 * 0.5f64.sqrt()).abs() < 1e-12);
        let s = rate_table(180.0, 1.0, 0.05, [0.0; 3]);
        assert!(s.cond.g[IA].abs() < 1e-15 && (s.cond.g[PA] + 1.0).abs() < 1e-15);
    }

    #[test]
    fn vibropendulous_inputs_match_fig_a2() {
        let (f, my, mz, r) = (20.0, 1.0, 2.0, 5.0);
        let c = two_axis(TwoAxisKind::Vibropendulous, f, my, mz, 90.0, r);
        let w = std::f64::consts::TAU * f;
        // IA_z = r θ_mz ω² sin ωt, PA_y = −r θ_my ω² sin(ωt + ψ).
        assert!((c.lin_cm_s2[IA] - r * mz * 1e-3 * w * w).abs() < 1e-9);
        assert!(c.lin_deg[IA].abs() < 1e-9);
        assert!((c.lin_cm_s2[PA] - r * my * 1e-3 * w * w).abs() < 1e-9);
        assert!(
            (c.lin_deg[PA] - (90.0 - 180.0)).abs() < 1e-9,
            "{}",
            c.lin_deg[PA]
        );
    }
}
