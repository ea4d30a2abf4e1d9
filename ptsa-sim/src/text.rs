//! Text the layers share: numbers for a reader, and the check that a generated reference
//! page under `docs/reference/` is the one the code makes.

/// `x` with `digits` significant digits for a reader, trailing zeros dropped: plain from
/// 1e-3 up to 1e6 (`0.02991`, `1960.8`; the integer part is never cut: `21121` to 4
/// digits), in exponent form beyond
/// (`2.991e-8`, `1.5e6`); `0` for zero, Rust's `NaN` and `inf` as they are.
#[must_use]
pub fn significant(x: f64, digits: usize) -> String {
    if !x.is_finite() {
        return format!("{x}");
    }
    if x == 0.0 {
        return "0".into();
    }
    let digits = digits.clamp(1, 17);
    let trim = |t: &str| -> String {
        if t.contains('.') {
            t.trim_end_matches('0').trim_end_matches('.').to_string()
        } else {
            t.to_string()
        }
    };
    // Rounded to `digits` first, so that 999_999.7 goes to exponent form as 1e6.
    let e = format!("{x:.p$e}", p = digits - 1);
    let (mantissa, exp) = e.split_once('e').unwrap_or((&e, "0"));
    let exp: i32 = exp.parse().unwrap_or(0);
    if (-3..6).contains(&exp) {
        // `digits` ≤ 17 and `exp` in −3..6: no truncation, no sign lost after `max(0)`.
        #[allow(
            clippy::cast_possible_truncation,
            clippy::cast_possible_wrap,
            clippy::cast_sign_loss
        )]
        let decimals = (digits as i32 - 1 - exp).max(0) as usize;
        trim(&format!("{x:.decimals$}"))
    } else {
        format!("{}e{exp}", trim(mantissa))
    }
}

/// Whether the generated page `docs/reference/NAME` (under the repository's `docs/`) holds
/// `want`; with `PTSA_WRITE_REFERENCE` set in the environment it is written first. The
/// reference pages' tests (options, candidates, JSON keys, instrument file, case frame)
/// check their page with it.
///
/// # Panics
/// The page cannot be written when asked to.
#[must_use]
pub fn reference_page_is_current(name: &str, want: &str) -> bool {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../docs/reference")
        .join(name);
    if std::env::var_os("PTSA_WRITE_REFERENCE").is_some() {
        std::fs::write(&path, want).expect("docs/reference is writable");
    }
    std::fs::read_to_string(&path).is_ok_and(|have| have == want)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn significant_digits() {
        for (x, d, want) in [
            (2.990_511_374_147_487e-8, 4, "2.991e-8"),
            (0.1 + 0.2, 6, "0.3"),
            (1960.8, 6, "1960.8"),
            (21_121.1, 4, "21121"),
            (21_121.1, 6, "21121.1"),
            (-0.000_123_456, 3, "-1.23e-4"),
            (0.001_234_56, 3, "0.00123"),
            (999_999.7, 6, "1e6"),
            (999.96, 4, "1000"),
            (200.000_000_000_000_03, 6, "200"),
            (-0.0, 3, "0"),
            (3.0e-8, 4, "3e-8"),
            (0.001_019_99, 5, "0.00102"),
            (0.001_020_37, 5, "0.0010204"),
            (94_878.2, 3, "94878"),
            (2.8e-5, 2, "2.8e-5"),
            (1e6, 5, "1e6"),
        ] {
            assert_eq!(significant(x, d), want, "{x} to {d} digits");
        }
        assert_eq!(significant(f64::NAN, 3), "NaN");
    }
}
