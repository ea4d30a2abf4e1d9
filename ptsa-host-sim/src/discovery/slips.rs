//! A user's slips, caught before they are explained as physics: measured values in another
//! unit (or with the sign reversed), stated sigmas in another unit, and the likely cause of
//! a row set aside as a suspected gross error ([`super::outliers`]).
//!
//! * **Values in another unit** ([`unit_slip`]): the least-squares ratio `k = Σ y·b / Σ b²`
//!   of the measured values `y` to the simulated baseline `b` over the values in cm/s², when
//!   the measured values are that multiple of the baseline (the rest `‖y − k·b‖` at most
//!   [`PROPORTIONAL`] of `‖y‖`) and `k` lies within [`UNIT_WINDOW`] of a known slip
//!   ([`factors`]: g, m/s², mm/s², ft/s², µg, mGal, µGal, a thousandth, the sign). A real
//!   instrument reads its simulation to within its bias and a scale-factor error of parts per
//!   thousand, so it cannot come near 1/980.4 or 1e6 by chance. `ptsa discover` refuses such
//!   data (nothing is written): every term it could name would be the unit's.
//! * **Stated sigmas in another unit** ([`sigma_check`]): the stated sigmas against the
//!   scatter `s² = χ²/ν` (in units of the stated sigmas) of the better-fitting, per degree
//!   of freedom, of two models: the largest (the nuisance terms and every testable
//!   candidate that adds an independent column, those nearest the residual first, keeping
//!   [`fit::MIN_REFERENCE_DOF`] residual degrees of freedom) and the selected one; the
//!   stated sigmas are `1/s` times the scatter. A warning when that factor is at least [`SIGMA_FACTOR`] (or at most
//!   its inverse) and `χ²` lies beyond [`SIGMA_TAIL`] in the tail on that side; the analysis
//!   goes on with the stated sigmas (a stated sigma is the user's claim), the warning at the
//!   top of the report says what they cost and what was probably meant.

use super::data::Data;
use super::fit::{self, Fitted};
use super::observation::Quantity;
use crate::model::caseframe::EmptyCells;
use crate::stats::{chi2_sf, lsq, norm, residualize};

/// Largest `‖y − k·b‖/‖y‖` of measured values `y` that count as the multiple `k` of the
/// baseline `b`.
pub const PROPORTIONAL: f64 = 0.02;

/// Largest `|ln(k/c)|` of a ratio `k` taken for the slip `c` (1 %: 1/980.4 and 1/1000 are
/// 2 % apart, and a scale-factor error of 1 % is at the shipped plausibility bound).
pub const UNIT_WINDOW: f64 = 0.01;

/// Fewest values in cm/s² the unit check needs.
pub const UNIT_MIN_ROWS: usize = 3;

/// Factor between the stated sigmas and the scatter from which a warning says so.
pub const SIGMA_FACTOR: f64 = 3.0;

/// Tail probability of `χ²` beyond which the stated sigmas are rejected for the warning.
pub const SIGMA_TAIL: f64 = 1e-3;

/// Largest `|ln|` of a sigma factor taken for a unit (the scatter is estimated to some
/// 10 % with 40 degrees of freedom).
pub const SIGMA_UNIT_WINDOW: f64 = 0.3;

/// A slip of the unit (or the sign) of measured values: what multiplies the right value,
/// and what it probably was.
#[derive(Clone, Debug, PartialEq)]
pub struct Factor {
    /// The factor `c`: the entered value is `c` times the value in cm/s².
    pub factor: f64,
    /// What was probably entered, for "were they …?": `entered in g`.
    pub meant: String,
    /// How to put it right.
    pub fix: String,
}

/// The slips [`unit_slip`] knows, with the instrument file's gravity `g` (cm/s²).
#[must_use]
pub fn factors(g: f64) -> Vec<Factor> {
    let f = |factor: f64, meant: &str, fix: String| Factor {
        factor,
        meant: meant.to_string(),
        fix,
    };
    vec![
        f(
            1.0 / g,
            "entered in g",
            format!("multiply by {g} (1 g = {g} cm/s², the instrument file's gravity)"),
        ),
        f(0.01, "entered in m/s²", "multiply by 100".into()),
        f(10.0, "entered in mm/s² (or with a decimal point shifted)", "divide by 10".into()),
        f(1.0 / 30.48, "entered in ft/s²", "multiply by 30.48".into()),
        f(
            1e6 / g,
            "entered in µg",
            format!("multiply by {} (1 µg = {g}e-6 cm/s²)", g * 1e-6),
        ),
        f(1e3, "entered in mGal", "divide by 1000 (1 mGal = 0.001 cm/s²)".into()),
        f(1e6, "entered in µGal", "divide by 1e6 (1 µGal = 1e-6 cm/s²)".into()),
        f(1e-3, "scaled by 1/1000 (a unit 1000 times larger than cm/s²)", "multiply by 1000".into()),
        f(
            -1.0,
            "entered with the sign reversed (IA the other way, or a difference taken as reference − condition)",
            "change the sign: a value is the indicated acceleration along IA, condition − reference in a difference row".into(),
        ),
    ]
}

/// `"1/980.4 of"`, `"10 times"`, `"the negative of"`: how a value relates to another by `c`.
#[must_use]
pub fn relation(c: f64) -> String {
    if (c + 1.0).abs() < 1e-9 {
        return "the negative of".to_string();
    }
    let sign = if c < 0.0 { "minus " } else { "" };
    let a = c.abs();
    if a < 1.0 {
        format!("{sign}1/{} of", crate::output::significant(1.0 / a, 5))
    } else {
        format!("{sign}{} times", crate::output::significant(a, 5))
    }
}

/// The slip `k` is near, if any: `|ln(k/c)| ≤ window`.
fn nearest(k: f64, g: f64, window: f64) -> Option<Factor> {
    factors(g)
        .into_iter()
        .filter(|f| f.factor * k > 0.0)
        .map(|f| ((k / f.factor).ln().abs(), f))
        .filter(|(d, _)| *d <= window)
        .min_by(|a, b| a.0.total_cmp(&b.0))
        .map(|(_, f)| f)
}

/// Measured values in cm/s² that are a known slip's multiple of the simulated ones.
#[derive(Clone, Debug, PartialEq)]
pub struct UnitSlip {
    /// The slip.
    pub slip: Factor,
    /// The least-squares ratio measured/simulated.
    pub ratio: f64,
    /// The offset fitted beside the ratio, in the values' unit, when the values are the
    /// multiple only once an offset is taken out (a bias beyond the file's), else `None`.
    pub offset: Option<f64>,
    /// The values it rests on.
    pub rows: usize,
}

impl UnitSlip {
    /// `sign` or `unit`.
    fn kind(&self) -> &'static str {
        if self.slip.factor < 0.0 {
            "sign"
        } else {
            "unit"
        }
    }

    /// What the values look like and what was probably meant.
    fn what(&self) -> String {
        format!(
            "the measured values are {} the simulated ones (measured/simulated = {} by least squares over the {} values in cm/s²{}): were they {}?",
            relation(self.slip.factor),
            crate::output::significant(self.ratio, 5),
            self.rows,
            self.offset.map_or(String::new(), |c| format!(
                ", with an offset of {} in the values' own unit",
                crate::output::significant(c, 3)
            )),
            self.slip.meant,
        )
    }

    /// The one-line message: what the values look like, what was probably meant, how to fix
    /// it.
    #[must_use]
    pub fn message(&self) -> String {
        format!(
            "{} expected cm/s² along IA; a {} slip is not analysed as physics: {} in `measured_cm_s2` and run again (or, if the values are right as they are, `--units-as-given` analyses them with a warning)",
            self.what(),
            self.kind(),
            self.slip.fix
        )
    }

    /// The warning when the values are analysed as given (`--units-as-given`).
    #[must_use]
    pub fn kept_message(&self) -> String {
        format!(
            "{} analysed as given (--units-as-given): if this is a {} slip, what follows explains it as physics",
            self.what(),
            self.kind()
        )
    }
}

/// Whether the values in cm/s² of `data` are a known slip's multiple of the baseline
/// (module docs); `g` is the instrument file's gravity. The multiple is taken through the
/// origin, and, where that is not close, with an offset: an instrument whose bias is
/// beyond what its file expects (a consumer part's 0.1 g) is still a slip's multiple of
/// its simulation once the offset is taken out, whatever the class's bounds.
#[must_use]
pub fn unit_slip(data: &Data, g: f64) -> Option<UnitSlip> {
    let v: Vec<usize> = (0..data.n())
        .filter(|&i| data.quantity[i] == Quantity::Value && data.base[i].is_finite())
        .collect();
    if v.len() < UNIT_MIN_ROWS {
        return None;
    }
    let y: Vec<f64> = v.iter().map(|&i| data.y[i]).collect();
    let b: Vec<f64> = v.iter().map(|&i| data.base[i]).collect();
    let slip = |ratio: f64, offset: Option<f64>| {
        nearest(ratio, g, UNIT_WINDOW).map(|slip| UnitSlip {
            slip,
            ratio,
            offset,
            rows: v.len(),
        })
    };
    if let Some(k) = multiple(&y, &b, false) {
        return slip(k.0, None);
    }
    multiple(&y, &b, true).and_then(|(k, c)| slip(k, Some(c)))
}

/// The least-squares `k` (and, `with_offset`, the offset `c`) of `y ≈ k·b (+ c)`, when the
/// rest is at most [`PROPORTIONAL`] of `‖y‖`; with an offset only where `b` varies (its
/// spread about its mean at least a tenth of its size), so that the slope means something.
fn multiple(y: &[f64], b: &[f64], with_offset: bool) -> Option<(f64, f64)> {
    #[allow(clippy::cast_precision_loss)]
    let n = y.len() as f64;
    let (ym, bm) = if with_offset {
        (y.iter().sum::<f64>() / n, b.iter().sum::<f64>() / n)
    } else {
        (0.0, 0.0)
    };
    let (mut yb, mut bb) = (0.0, 0.0);
    for (yi, bi) in y.iter().zip(b) {
        yb += (yi - ym) * (bi - bm);
        bb += (bi - bm) * (bi - bm);
    }
    let b_size = b.iter().map(|x| x * x).sum::<f64>();
    if bb <= 0.0 || (with_offset && bb < 0.01 * b_size) {
        return None;
    }
    let k = yb / bb;
    let c = ym - k * bm;
    let rest: Vec<f64> = y.iter().zip(b).map(|(yi, bi)| yi - k * bi - c).collect();
    let (off, size) = (norm(&rest), norm(y));
    (off.is_finite() && off <= PROPORTIONAL * size).then_some((k, c))
}

/// Smallest `|baseline|` of a row whose own ratio measured/baseline [`row_slips`] reads,
/// cm/s² (about 0.01 g: below it a ratio is noise).
pub const ROW_SLIP_MIN_CM_S2: f64 = 10.0;

/// The values in cm/s² of `data` whose own ratio to the baseline is within twice
/// [`UNIT_WINDOW`] of a known slip (a row typed in g among rows in cm/s²), where the
/// baseline is at least [`ROW_SLIP_MIN_CM_S2`]: suspects the outlier search tests first,
/// all together, so that several of them do not mask one another
/// ([`super::outliers::search`]).
#[must_use]
pub fn row_slips(data: &Data, g: f64) -> Vec<usize> {
    (0..data.n())
        .filter(|&i| {
            data.quantity[i] == Quantity::Value
                && data.base[i].abs() >= ROW_SLIP_MIN_CM_S2
                && data.y[i] != 0.0
                && nearest(data.y[i] / data.base[i], g, 2.0 * UNIT_WINDOW).is_some()
        })
        .collect()
}

/// Stated sigmas far from the scatter of the data.
#[derive(Clone, Debug, PartialEq)]
pub struct SigmaSlip {
    /// Stated sigma over the scatter.
    pub factor: f64,
    /// The scatter, cm/s², when every value states the same sigma (else `None`).
    pub scatter_cm_s2: Option<f64>,
    /// That common stated sigma, cm/s².
    pub stated_cm_s2: Option<f64>,
    /// `χ²` of the model the scatter is taken from (the better, per degree of freedom, of
    /// the largest model and the selected one).
    pub chi2: f64,
    /// Degrees of freedom.
    pub dof: usize,
    /// Where the sigmas came from: `--sigma`, `sigma_cm_s2`, or both.
    pub source: &'static str,
    /// The unit the stated sigmas were probably in, if one fits.
    pub meant: Option<&'static str>,
    /// Far enough from the scatter for a warning: the factor at least [`SIGMA_FACTOR`] (or
    /// at most its inverse) and `χ²` beyond [`SIGMA_TAIL`] in the tail on that side.
    pub far: bool,
}

impl SigmaSlip {
    /// The one-line warning.
    #[must_use]
    pub fn message(&self) -> String {
        let how = if self.factor >= 1.0 {
            format!("{} times", crate::output::significant(self.factor, 2))
        } else {
            format!("1/{} of", crate::output::significant(1.0 / self.factor, 2))
        };
        let scatter = match (self.stated_cm_s2, self.scatter_cm_s2) {
            (Some(s), Some(x)) => format!(
                "the stated sigma ({} {} cm/s²) is {how} the scatter of the residuals ({} cm/s²",
                self.source,
                crate::output::significant(s, 3),
                crate::output::significant(x, 2)
            ),
            _ => format!(
                "the stated sigmas ({}) are {how} the scatter of the residuals (",
                self.source
            ),
        };
        let meant = self
            .meant
            .map_or_else(String::new, |u| format!("; was it meant in {u}?"));
        let consequence = if self.factor >= 1.0 {
            "with sigmas this large the tests see only effects that many times larger, so a `selected: none` says little: state the sigma in cm/s², or leave it out to have it estimated"
        } else {
            "the tests then rest on the residuals' own scale (the F test) and the coefficients' errors are scaled up; if the sigmas are right, the data hold structure no candidate explains"
        };
        format!(
            "{scatter}; chi2 {} for {} dof){meant} {consequence}",
            crate::output::significant(self.chi2, 3),
            self.dof
        )
    }
}

/// The stated sigmas of `data` against the scatter of the better of the largest and the selected model of `f` (module
/// docs; `g`, the instrument file's gravity, for µg and g); `None` when some sigma is
/// estimated or the data hold response rows (their sigmas are not in cm/s²).
#[must_use]
pub fn sigma_check(
    data: &Data,
    f: &Fitted,
    default_sigma: Option<f64>,
    g: f64,
) -> Option<SigmaSlip> {
    if !f.stated() || data.quantity.iter().any(|&q| q != Quantity::Value) {
        return None;
    }
    let (chi2, dof) = scatter_fit(data, f)?;
    #[allow(clippy::cast_precision_loss)]
    let nu = dof as f64;
    let s = (chi2 / nu).sqrt();
    if !(s > 0.0 && s.is_finite()) {
        return None;
    }
    let factor = 1.0 / s;
    let upper = chi2_sf(chi2, nu);
    let far = (factor >= SIGMA_FACTOR && 1.0 - upper <= SIGMA_TAIL)
        || (factor <= 1.0 / SIGMA_FACTOR && upper <= SIGMA_TAIL);
    let (common, source) = stated_sigmas(data, default_sigma)?;
    Some(SigmaSlip {
        factor,
        scatter_cm_s2: common.map(|c| c * s),
        stated_cm_s2: common,
        chi2,
        dof,
        source,
        meant: meant_unit(factor, g),
        far,
    })
}

/// `(χ², degrees of freedom)` of the model the scatter is taken from: the better, per degree
/// of freedom, of the largest model ([`largest_model`]) and the selected one of `f`;
/// `None` when neither has a degree of freedom or a fit fails.
fn scatter_fit(data: &Data, f: &Fitted) -> Option<(f64, usize)> {
    let z = f.weighted_target();
    let big = largest_model(data, f, &z)?;
    let r = lsq(&z, &big)?;
    // The better of the largest model and the selected one, per degree of freedom: the
    // greedy largest model can miss the terms that matter in a small design (six
    // centrifuge rows), and the selected one holds nothing when the sigmas are too large.
    [
        (r.chi2, data.n().saturating_sub(big.len())),
        (f.fit.chi2, f.dof()),
    ]
    .into_iter()
    .filter(|&(_, d)| d > 0)
    .min_by(|a, b| {
        #[allow(clippy::cast_precision_loss)]
        let (x, y) = (a.0 / a.1 as f64, b.0 / b.1 as f64);
        x.total_cmp(&y)
    })
}

/// The columns of the largest model of `f` for the weighted target `z`: the nuisance terms
/// and every testable candidate that adds an independent column, those nearest the
/// residual first, keeping [`fit::MIN_REFERENCE_DOF`] residual degrees of freedom.
fn largest_model<'a>(data: &Data, f: &'a Fitted, z: &[f64]) -> Option<Vec<&'a [f64]>> {
    let n = data.n();
    let cols = f.unit_columns();
    let mut big: Vec<&[f64]> = cols[..f.n_nuisance()].to_vec();
    let base = lsq(z, &big)?;
    let min_partial = (1.0 - f.settings.confound_cos * f.settings.confound_cos)
        .max(0.0)
        .sqrt();
    let mut rest: Vec<(f64, &[f64])> = f
        .family
        .iter()
        .filter_map(|&id| f.candidate_column(data, id).map(|(u, _)| u))
        .map(|u| {
            let d: f64 = u.iter().zip(&base.resid).map(|(a, b)| a * b).sum();
            (d.abs(), u)
        })
        .collect();
    rest.sort_by(|a, b| b.0.total_cmp(&a.0));
    for (_, u) in rest {
        if big.len() + fit::MIN_REFERENCE_DOF >= n {
            break;
        }
        if norm(&residualize(u, &big)) >= min_partial {
            big.push(u);
        }
    }
    Some(big)
}

/// The stated sigma of every value of `data` without the simulator's scatter (the row's own
/// or `--sigma`, `default_sigma`): the one they all state, if they do, and where they came
/// from; `None` when a value states none.
fn stated_sigmas(data: &Data, default_sigma: Option<f64>) -> Option<(Option<f64>, &'static str)> {
    let own: Vec<f64> = (0..data.n())
        .map(|i| {
            let s = data.stated[i]?;
            Some(
                (s * s - data.sim_sigma[i] * data.sim_sigma[i])
                    .max(0.0)
                    .sqrt(),
            )
        })
        .collect::<Option<_>>()?;
    let common = own
        .iter()
        .all(|&x| (x - own[0]).abs() <= 1e-9 * own[0].abs())
        .then_some(own[0]);
    let from_flag = default_sigma.is_some_and(|d| own.iter().any(|&x| (x - d).abs() <= 1e-12 * d));
    let from_file = default_sigma.is_none_or(|d| own.iter().any(|&x| (x - d).abs() > 1e-12 * d));
    let source = match (from_flag, from_file) {
        (true, false) => "--sigma",
        (false, _) => "sigma_cm_s2",
        (true, true) => "sigma_cm_s2 and --sigma",
    };
    Some((common, source))
}

/// The unit the stated sigmas were probably in, when the stated sigma over the scatter,
/// `factor`, is within [`SIGMA_UNIT_WINDOW`] of its conversion to cm/s² (`g`, the
/// instrument file's gravity, for µg and g).
fn meant_unit(factor: f64, g: f64) -> Option<&'static str> {
    let units: [(&'static str, f64); 4] = [
        ("µg (1 µg ≈ 0.00098 cm/s²)", 1.0 / (1e-6 * g)),
        ("mm/s² (1 mm/s² = 0.1 cm/s²)", 10.0),
        ("m/s² (1 m/s² = 100 cm/s²)", 0.01),
        ("g (1 g ≈ 980 cm/s²)", 1.0 / g),
    ];
    units
        .iter()
        .find(|(_, c)| (factor / c).ln().abs() <= SIGMA_UNIT_WINDOW)
        .map(|(u, _)| *u)
}

/// The likely cause of a row set aside as a suspected gross error, in words: its input
/// cells left empty and read as 0, a value in another unit or with the sign reversed, the
/// value another row should read, or none found.
#[must_use]
pub fn cause(
    measured: f64,
    expected: f64,
    scale: f64,
    empty: Option<&EmptyCells>,
    others: &[(&str, f64)],
    g: f64,
) -> String {
    if let Some(e) = empty.filter(|e| !e.columns.is_empty()) {
        let cells: Vec<String> = e.columns.iter().map(|c| format!("`{c}`")).collect();
        return format!(
            "its {} {} (line {}) {} empty and read as 0, which the case frame allows but the reading does not fit: fill {} in",
            if cells.len() == 1 { "cell" } else { "cells" },
            cells.join(", "),
            e.line,
            if cells.len() == 1 { "was" } else { "were" },
            if cells.len() == 1 { "it" } else { "them" },
        );
    }
    if expected.abs() > 10.0 * scale && measured != 0.0 {
        let k = measured / expected;
        if let Some(f) = nearest(k, g, 2.0 * UNIT_WINDOW) {
            return format!(
                "its value is {} what the model expects ({} cm/s²): {}, {}? ({})",
                relation(f.factor),
                crate::output::significant(expected, 5),
                if f.factor > 0.0 {
                    "a unit slip"
                } else {
                    "a sign slip"
                },
                f.meant,
                f.fix
            );
        }
    }
    let close: Vec<&(&str, f64)> = others
        .iter()
        .filter(|(_, v)| (measured - v).abs() <= 3.0 * scale)
        .collect();
    if let [(label, _)] = close.as_slice() {
        return format!(
            "its value is what row `{label}` should read: rows swapped, or a line copied?"
        );
    }
    "no slip found in the file (no empty cell, no unit or sign slip, no other row's value): a typing error, a run disturbed on this row only, or physics only this row shows (--keep-outliers keeps it, and the test for unexplained structure then sees it)".to_string()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn relations_read_as_a_person_would_say_them() {
        assert_eq!(relation(1.0 / 980.4), "1/980.4 of");
        assert_eq!(relation(0.01), "1/100 of");
        assert_eq!(relation(10.0), "10 times");
        assert_eq!(relation(1e6), "1e6 times");
        assert_eq!(relation(1.0 / 30.48), "1/30.48 of");
        assert_eq!(relation(-1.0), "the negative of");
        assert_eq!(relation(1e6 / 980.4), "1020 times");
    }

    #[test]
    fn the_nearest_slip_is_found_within_its_window_only() {
        let g = 980.4;
        let n = |k: f64| nearest(k, g, UNIT_WINDOW).map(|f| f.meant);
        assert_eq!(n(1.003 / g).as_deref(), Some("entered in g"));
        // 1/1000 and 1/980.4 are 2 % apart: each is told from the other.
        assert!(n(1e-3).unwrap().starts_with("scaled by 1/1000"));
        assert_eq!(n(1.0), None);
        assert_eq!(n(1.02), None);
        assert!(
            n(-0.995)
                .unwrap()
                .starts_with("entered with the sign reversed")
        );
        assert_eq!(n(0.0101).as_deref(), Some("entered in m/s²"));
        assert_eq!(n(0.0105), None);
    }

    #[test]
    fn a_row_names_its_empty_cell_first() {
        let e = EmptyCells {
            row: 3,
            line: 7,
            columns: vec!["g_ia"],
        };
        let c = cause(834.0, -112.0, 0.01, Some(&e), &[], 980.4);
        assert!(
            c.starts_with("its cell `g_ia` (line 7) was empty and read as 0"),
            "{c}"
        );
        let c = cause(0.5, 490.2, 0.01, None, &[], 980.4);
        assert!(
            c.contains("1/980.4 of what the model expects")
                && c.contains("unit slip, entered in g"),
            "{c}"
        );
        let c = cause(
            12.0,
            490.2,
            0.01,
            None,
            &[("other", 12.005), ("far", 20.0)],
            980.4,
        );
        assert!(c.contains("what row `other` should read"), "{c}");
        let c = cause(12.0, 490.2, 0.01, None, &[], 980.4);
        assert!(c.starts_with("no slip found"), "{c}");
    }
}
