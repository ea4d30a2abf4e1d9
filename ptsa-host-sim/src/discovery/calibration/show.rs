//! The calibration in words: the equation written out with the instrument's values, the
//! table (text, Markdown), and the text report's block. Every number here is one of
//! [`Calibration`]'s; nothing is computed again.

use std::fmt::Write as _;

use crate::discovery::report::{Calibration, CalibrationTerm, DoubtfulTerm};
use crate::output::{Cell, Table, significant, text};

/// `x` to the digits its uncertainty `u` warrants (two significant digits of `u`), or to
/// six significant digits without one.
#[must_use]
pub fn digits(x: f64, u: Option<f64>) -> String {
    match u {
        Some(u) if u > 0.0 && u.is_finite() && x.is_finite() => {
            #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
            let d = (1.0 - u.log10().floor()).clamp(0.0, 12.0) as usize;
            let t = format!("{x:.d$}");
            if t.starts_with('-') && t[1..].chars().all(|c| c == '0' || c == '.') {
                t[1..].to_string()
            } else {
                t
            }
        }
        _ => significant(x, 6),
    }
}

/// `value ± sigma unit` to the digits `sigma` warrants.
fn estimate(value: f64, sigma: Option<f64>, unit: &str) -> String {
    match sigma {
        Some(s) => format!("{} ± {} {unit}", digits(value, Some(s)), significant(s, 2)),
        None => format!("{} {unit}", digits(value, None)),
    }
}

/// The model equation written out with the instrument's values: `K_1`, `K_0` and every
/// other term that is measured or has a non-zero nominal value.
#[must_use]
pub fn equation_with_values(c: &Calibration) -> String {
    let find = |s: &str| c.terms.iter().find(|t| t.symbol == s);
    let v = |t: &CalibrationTerm| format!("{} {}", digits(t.value, t.sigma), t.unit);
    let mut s = String::new();
    if let Some(k1) = find("K_1") {
        let _ = write!(s, "E/({}) = ", v(k1));
    }
    if let Some(k0) = find("K_0") {
        s.push_str(&v(k0));
        s.push_str(" + a_i");
    }
    let factor = |symbol: &str| match symbol {
        "K_2" => "a_i²",
        "K_3" => "a_i³",
        "δ_o" => "a_p",
        "δ_p" => "a_o",
        "K_ip" => "a_i·a_p",
        "K_io" => "a_i·a_o",
        "K_po" => "a_p·a_o",
        "K_pp" => "a_p²",
        _ => "a_o²",
    };
    for t in &c.terms {
        if matches!(t.symbol.as_str(), "K_0" | "K_1") || !(t.measured || t.value != 0.0) {
            continue;
        }
        let value = v(t);
        let value = if t.value < 0.0 {
            format!("({})", value.replacen('-', "−", 1))
        } else {
            value
        };
        let sign = if t.symbol == "δ_p" { '−' } else { '+' };
        let _ = write!(s, " {sign} {value}·{}", factor(&t.symbol));
    }
    s
}

/// The calibration table: symbol, candidate, value, 1 σ, k = 2, unit, nominal,
/// change (with its unit), status and marks.
#[must_use]
pub fn table(stem: &str, c: &Calibration) -> Table {
    let mut t = Table::new(
        stem,
        "the instrument's own model equation (IEEE Std 1293, input-referred)",
        &[
            "symbol",
            "candidate",
            "value",
            "1σ",
            "k=2",
            "unit",
            "nominal",
            "change",
            "change unit",
            "status",
        ],
    );
    for term in &c.terms {
        let shown = |x: f64, u: Option<f64>| Cell::Text(digits(x, u));
        let u = term.sigma;
        let mut status = term.status.replace('_', " ");
        if !term.marks.is_empty() {
            status = format!("{status} ({})", term.marks.join(", "));
        }
        t.rows.push(vec![
            text(term.symbol.clone()),
            text(term.candidate.clone()),
            if term.measured {
                shown(term.value, u)
            } else {
                text(format!("{} (nominal)", digits(term.value, None)))
            },
            u.map_or(Cell::Missing, |u| text(significant(u, 2))),
            term.expanded_k2
                .map_or(Cell::Missing, |u| text(significant(u, 2))),
            text(term.unit.clone()),
            shown(term.nominal, u.or(Some(term.nominal.abs() * 1e-6))),
            if term.measured {
                shown(term.change, term.change_sigma)
            } else {
                Cell::Missing
            },
            text(term.change_unit.clone()),
            text(status),
        ]);
    }
    t
}

/// The lines every rendering of the calibration carries under its table, each a sentence:
/// the convention of `K_0` and the reading's offset where the two differ, the local
/// gravity and its source, the doubtful terms with what they would change, the notes.
#[must_use]
pub fn statements(c: &Calibration) -> Vec<String> {
    let mut v = Vec::new();
    let k0 = c.terms.iter().find(|t| t.symbol == "K_0");
    if let Some(k0) = k0.filter(|t| t.measured) {
        let o = &c.reading_offset;
        if o.differs {
            v.push(format!(
                "K_0 = {} is input-referred (the input that reads as zero); the reading's offset at zero input (output-referred, a data sheet's zero-g offset, K_0·K_1 over the nominal K_1) is {} ({}).",
                estimate(k0.value, k0.sigma, &k0.unit),
                estimate(o.value, o.sigma, &k0.unit),
                estimate(o.value_cgs, o.sigma_cgs, "cm/s²"),
            ));
        } else {
            v.push(format!(
                "K_0 = {} is input-referred; the reading's offset (output-referred) is the same within its 1 σ here.",
                estimate(k0.value, k0.sigma, &k0.unit)
            ));
        }
    }
    v.push(format!(
        "Local gravity {} cm/s² ({}): every value in g is of this gravity.",
        significant(c.local_gravity_cm_s2, 9),
        c.gravity_source
    ));
    for d in &c.doubtful {
        v.push(doubtful_sentence(d));
    }
    v.extend(c.notes.iter().cloned());
    v
}

/// What a doubtful term would change: "… left out of the calibration …; if it were real it
/// would be …, and with it `K_0` = …".
#[must_use]
pub fn doubtful_sentence(d: &DoubtfulTerm) -> String {
    let name = d
        .symbol
        .as_ref()
        .map_or_else(|| d.candidate.clone(), |s| format!("{s} ({})", d.candidate));
    let Some([value, sigma]) = d.if_real else {
        return format!(
            "{name} was selected but is left out of the calibration ({}); it cannot be fitted beside the calibration's terms (its column is made of {}).",
            d.why.join(", "),
            d.not_separable_from.join(", ")
        );
    };
    let core: Vec<String> = d
        .core_with_it
        .iter()
        .map(|c| {
            format!(
                "{} = {}",
                c.symbol,
                estimate(c.value, Some(c.sigma), &c.unit)
            )
        })
        .collect();
    format!(
        "{name} was selected but is left out of the calibration ({}), so that it cannot move the core terms; if it were real it would be {}, and with it {}.",
        d.why.join(", "),
        estimate(value, Some(sigma), &d.unit),
        if core.is_empty() {
            "no core term is fitted".to_string()
        } else {
            core.join(", ")
        }
    )
}

/// The text block of `ptsa discover`'s report: the equation with its values, the table,
/// then [`statements`].
#[must_use]
pub fn text_block(c: &Calibration) -> String {
    let mut s = String::from(
        "calibration: the instrument's own model equation (IEEE Std 1293; absolute values, input-referred, 1 σ and k = 2):\n",
    );
    let _ = writeln!(s, "  {}", equation_with_values(c));
    let unit = c
        .equation
        .split("E the output in ")
        .nth(1)
        .and_then(|r| r.split(',').next())
        .unwrap_or("pulse/s");
    let _ = writeln!(
        s,
        "  (a_i, a_p, a_o in g; E in {unit}; the terms not written are nominal 0; {} noise, {} dof)",
        c.noise, c.dof
    );
    let t = table("calibration", c).to_text();
    for line in t.lines().skip(1) {
        s.push_str("  ");
        s.push_str(line);
        s.push('\n');
    }
    for n in statements(c) {
        let _ = writeln!(s, "  note: {n}");
    }
    s
}
