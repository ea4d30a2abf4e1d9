//! Counts in: an absolute row's measurement given as the pulses `P` of positive torque the
//! forced-binary loop counted over a gate of `T` clock ticks (R-890 section 6.1, eqs.
//! 6.3/6.4; case-frame columns `pulses` and `ticks`, `docs/reference/case-frame-format.md`), turned into the
//! indicated acceleration `SF·(2P/T − 1)` with the instrument file's nominal scale factor,
//! and the counting's own error.
//!
//! The counting error. Over a gate the loop's pulses balance the input's charge, but what
//! the loop holds between pulses at the gate's two ends (the quantizer's sub-tick carry,
//! what the pendulum, the torquer and the compensator hold) is counted in the gate before
//! or after: `P = T·d + c₁ − c₀`, with `d` the true mean duty over the gate and `c₀`, `c₁`
//! the carry at its start and end, in pulses. The model: each carry uniform over one pulse
//! ([`CARRY_VAR`] = 1/12 pulse²), the two ends independent (a gate of many limit cycles).
//! Then `E[P] = T·d` (the reading is unbiased) and `Var P = 2·CARRY_VAR = 1/6` pulse², and
//! since one pulse is `2·SF/T` of indication, the reading's 1-sigma counting error is
//! `(2·SF/T)·√(1/6) ≈ 0.816·SF/T` ([`counting_sigma_cm_s2`]). The simulated loop's static
//! gates scatter by just that (`tests/cli_counts.rs`,
//! `the_counting_error_is_the_simulated_loops`; 110 gates of 1 s through `ptsa static`:
//! 0.270 cm/s² against the model's 0.269, `docs/reference/case-frame-format.md`). Under a sine the carry
//! spreads wider (`lab::response::CARRY_VAR`, ±1 pulse, for the short gates of a counter
//! record). Not in it: the limit-cycle ripple of a gate that is not a whole number of limit
//! cycles (a cut cycle leaves up to `N·d·(1 − d)` pulses, 16 at `N` = 64 ticks and `d` =
//! 1/2), which gates of whole limit cycles (whole seconds at 64 kHz) do not have.

use crate::model::condition::Condition;

/// The variance of the charge the loop holds at a static gate's boundary, pulse²: uniform
/// over one pulse.
pub const CARRY_VAR: f64 = 1.0 / 12.0;

/// The largest count the case frame takes, 2^53: every whole number up to it is exact in
/// an `f64`.
pub const MAX_COUNT: f64 = 9_007_199_254_740_992.0;

/// The indicated acceleration of `pulses` of positive torque in a gate of `ticks` clock
/// ticks, `SF·(2P/T − 1)`, cm/s², with the nominal scale factor `sf_cm_s2` (cm/s²).
#[must_use]
pub fn indicated_cm_s2(pulses: f64, ticks: f64, sf_cm_s2: f64) -> f64 {
    sf_cm_s2 * (2.0 * pulses / ticks - 1.0)
}

/// The 1-sigma counting error of a reading over a gate of `ticks` clock ticks, cm/s²:
/// one pulse `2·SF/T` times `√(2·CARRY_VAR)` = `√(1/6)` (the carry at each end of the
/// gate, module docs).
#[must_use]
pub fn counting_sigma_cm_s2(ticks: f64, sf_cm_s2: f64) -> f64 {
    2.0 * sf_cm_s2.abs() / ticks * (2.0 * CARRY_VAR).sqrt()
}

/// The whole number of pulses a gate of `ticks` ticks counts at an indicated acceleration
/// `a_cm_s2`: `P = round(T·(1 + a/SF)/2)`, within 0 and `ticks` (the inverse of
/// [`indicated_cm_s2`] to within half a pulse).
#[must_use]
pub fn pulses_for(a_cm_s2: f64, ticks: f64, sf_cm_s2: f64) -> f64 {
    (ticks * (1.0 + a_cm_s2 / sf_cm_s2) / 2.0)
        .round()
        .clamp(0.0, ticks)
}

/// The rows with every row's counts turned into its measurement: `measured_cm_s2` =
/// [`indicated_cm_s2`] and `counting_sigma_cm_s2` = [`counting_sigma_cm_s2`] with the
/// instrument's nominal scale factor `sf_cm_s2`, cm/s². The counts stay in the row; rows
/// without counts are unchanged. The reader has refused a row with counts and
/// `measured_cm_s2` both, so the conversion replaces nothing the lab gave.
#[must_use]
pub fn with_counts(rows: &[Condition], sf_cm_s2: f64) -> Vec<Condition> {
    rows.iter()
        .map(|r| {
            let mut r = r.clone();
            if let (Some(p), Some(t)) = (r.pulses, r.ticks) {
                r.measured_cm_s2 = Some(indicated_cm_s2(p, t, sf_cm_s2));
                r.counting_sigma_cm_s2 = Some(counting_sigma_cm_s2(t, sf_cm_s2));
            }
            r
        })
        .collect()
}

/// Whether any row gives its measurement as counts.
#[must_use]
pub fn any_counts(rows: &[Condition]) -> bool {
    rows.iter().any(|r| r.pulses.is_some() || r.ticks.is_some())
}

#[cfg(test)]
#[allow(clippy::float_cmp)]
mod tests {
    use super::*;
    use crate::model::condition::RowKind;

    /// The shipped instrument's nominal scale factor, cm/s².
    const SF: f64 = 21_121.1;

    #[test]
    fn counts_convert_as_eqs_6_3_and_6_4() {
        // All pulses positive: +SF; none: −SF; half: 0.
        assert_eq!(indicated_cm_s2(64_000.0, 64_000.0, SF), SF);
        assert_eq!(indicated_cm_s2(0.0, 64_000.0, SF), -SF);
        assert_eq!(indicated_cm_s2(32_000.0, 64_000.0, SF), 0.0);
        // 1 g up on a 60 s gate at 64 kHz: P = T·(1 + g/SF)/2.
        let t = 3_840_000.0;
        let p = pulses_for(980.4, t, SF);
        assert_eq!(p, 2_009_123.0);
        let a = indicated_cm_s2(p, t, SF);
        assert!((a - 980.4).abs() <= SF / t, "{a}");
        // One pulse is 2·SF/T; the counting sigma is √(1/6) of it.
        let s = counting_sigma_cm_s2(t, SF);
        assert!((s - 2.0 * SF / t * (1.0f64 / 6.0).sqrt()).abs() < 1e-15);
        assert!((s - 0.004_49).abs() < 1e-5, "{s}");
        // A reading beyond full scale counts every tick or none.
        assert_eq!(pulses_for(2.0 * SF, 100.0, SF), 100.0);
        assert_eq!(pulses_for(-2.0 * SF, 100.0, SF), 0.0);
    }

    #[test]
    fn with_counts_fills_the_measurement_and_its_counting_sigma() {
        let rows = vec![
            Condition {
                label: "up".into(),
                kind: RowKind::Absolute,
                g: [1.0, 0.0, 0.0],
                pulses: Some(2_009_123.0),
                ticks: Some(3_840_000.0),
                ..Condition::default()
            },
            Condition {
                label: "given".into(),
                kind: RowKind::Absolute,
                measured_cm_s2: Some(1.5),
                ..Condition::default()
            },
        ];
        assert!(any_counts(&rows));
        let out = with_counts(&rows, SF);
        assert_eq!(
            out[0].measured_cm_s2,
            Some(indicated_cm_s2(2_009_123.0, 3_840_000.0, SF))
        );
        assert_eq!(
            out[0].counting_sigma_cm_s2,
            Some(counting_sigma_cm_s2(3_840_000.0, SF))
        );
        assert_eq!(out[0].pulses, rows[0].pulses);
        assert_eq!(out[1], rows[1]);
        assert!(!any_counts(&rows[1..]));
    }

    /// The model's variance, checked by drawing it: `P = T·d + c₁ − c₀` with the carries
    /// uniform over one pulse scatters by `√(1/6)` pulse about `T·d`.
    #[test]
    fn the_counting_model_scatters_by_its_stated_sigma() {
        // A plain LCG: the test needs no quality beyond uniformity.
        let mut s: u64 = 0x2545_F491_4F6C_DD1D;
        let mut u = || {
            s = s
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            #[allow(clippy::cast_precision_loss)]
            let x = (s >> 11) as f64 / (1u64 << 53) as f64;
            x - 0.5
        };
        let n = 200_000;
        let (t, d) = (64_000.0, 0.523_456);
        let mut sum2 = 0.0;
        for _ in 0..n {
            let p = t * d + u() - u();
            let e = indicated_cm_s2(p, t, SF) - SF * (2.0 * d - 1.0);
            sum2 += e * e;
        }
        #[allow(clippy::cast_precision_loss)]
        let rms = (sum2 / f64::from(n)).sqrt();
        let want = counting_sigma_cm_s2(t, SF);
        assert!((rms / want - 1.0).abs() < 0.01, "{rms} against {want}");
    }

    proptest::proptest! {
        /// For any whole P ≤ T and any scale factor: the reading lies within ±SF, the
        /// inverse gives P back exactly, a reading between two counts' goes to the
        /// nearer, and the counting sigma is √(1/6) of a pulse.
        #[test]
        fn conversion_and_inverse(
            t in 1u64..=(1u64 << 40),
            frac in 0.0f64..=1.0,
            sf in 1e-3f64..1e7,
            off in -0.49f64..0.49,
        ) {
            #[allow(clippy::cast_precision_loss)]
            let tf = t as f64;
            let p = (tf * frac).floor();
            let a = indicated_cm_s2(p, tf, sf);
            proptest::prop_assert!(a.abs() <= sf * (1.0 + 1e-12), "{a} beyond ±{sf}");
            proptest::prop_assert_eq!(pulses_for(a, tf, sf), p);
            // Off by less than half a pulse: still P.
            let pulse = 2.0 * sf / tf;
            let near = (a + off * pulse).clamp(-sf, sf);
            proptest::prop_assert_eq!(pulses_for(near, tf, sf), p);
            let s = counting_sigma_cm_s2(tf, sf);
            proptest::prop_assert!((s / pulse - (1.0f64 / 6.0).sqrt()).abs() < 1e-12);
        }
    }
}
