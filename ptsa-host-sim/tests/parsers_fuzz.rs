//! Robustness of the two user file readers, checked with proptest: the case-frame CSV reader
//! (`discovery::caseframe`) and the instrument file (`Instrument::parse`) take arbitrary
//! bytes, arbitrary text and mutations of the shipped files (flipped and overwritten bytes,
//! truncations, deletions, inserted commas, quotes, line ends, NaN, infinities and huge
//! exponents, numbers replaced by such tokens) and must return a value or an error naming
//! the file, never panic. What they accept must keep the reader's promises (finite numbers,
//! `sigma_cm_s2` > 0, tolerance bands around their nominal), and an error must not speak
//! Rust (`f64`, `struct`, serde's `invalid type`).

use proptest::prelude::*;
use ptsa_host_sim::Condition;
use ptsa_host_sim::model::caseframe;
use ptsa_host_sim::model::condition::{Approach, RowKind};
use ptsa_host_sim::model::instrument::{Instrument, KEARFOTT_2401_TOML};

/// Cases per property: a few hundred, each a parse of at most a few kilobytes.
const CASES: u32 = 384;

/// The shipped case-frame files.
const CASE_FILES: [&str; 4] = [
    include_str!("../../data/r890-table-6.1.case.csv"),
    include_str!("../../data/r890-table-6.2.case.csv"),
    include_str!("../../data/r890-table-6.3.case.csv"),
    include_str!("../../data/synthetic-48.case.csv"),
];

/// Bytes that are inserted or that replace a number: CSV and TOML punctuation, line ends,
/// encodings' troublemakers, and numbers at and beyond the edges of `f64`.
const TOKENS: [&[u8]; 45] = [
    b",",
    b",,",
    b"\"",
    b"\"\"",
    b"\"a,b\"",
    b"'",
    b"\n",
    b"\r\n",
    b"\r",
    b"#",
    b";",
    b"\t",
    b" ",
    b"=",
    b"[",
    b"]",
    b"{",
    b"}",
    b"\"\"\"",
    "\u{feff}".as_bytes(),
    b"\0",
    b"\xFF",
    b"\xC3",
    "µ°𝄞".as_bytes(),
    b"NaN",
    b"nan",
    b"inf",
    b"-inf",
    b"+inf",
    b"1e999",
    b"-1e999",
    b"1e-999",
    b"1e308",
    b"-1.7976931348623157e308",
    b"4.9e-324",
    b"99999999999999999999",
    b"-0",
    b"0",
    b"-1",
    b"1e-3",
    b"150",
    b"2.4e8",
    b"0x10",
    b"true",
    b"1979-05-27",
];

/// One edit of a file's bytes; positions are taken modulo the length.
#[derive(Debug, Clone)]
enum Edit {
    /// XOR one byte with a single bit.
    Flip(usize, u8),
    /// Overwrite one byte.
    Set(usize, u8),
    /// Keep only the first `n` bytes.
    Truncate(usize),
    /// Remove up to `len` bytes from a position.
    Delete(usize, usize),
    /// Insert a token at a position.
    Insert(usize, &'static [u8]),
    /// Replace the `i`-th number outside comments with a token.
    ReplaceNumber(usize, &'static [u8]),
    /// Replace every comma with this byte (a semicolon- or tab-separated file).
    Separator(u8),
}

fn edit() -> impl Strategy<Value = Edit> {
    let token = || prop::sample::select(&TOKENS[..]);
    prop_oneof![
        (any::<usize>(), 0u8..8).prop_map(|(i, b)| Edit::Flip(i, 1 << b)),
        (any::<usize>(), any::<u8>()).prop_map(|(i, b)| Edit::Set(i, b)),
        any::<usize>().prop_map(Edit::Truncate),
        (any::<usize>(), 1usize..64).prop_map(|(i, n)| Edit::Delete(i, n)),
        (any::<usize>(), token()).prop_map(|(i, t)| Edit::Insert(i, t)),
        (any::<usize>(), token()).prop_map(|(i, t)| Edit::ReplaceNumber(i, t)),
        (any::<usize>(), token()).prop_map(|(i, t)| Edit::ReplaceNumber(i, t)),
        (any::<usize>(), token()).prop_map(|(i, t)| Edit::ReplaceNumber(i, t)),
        prop::sample::select(&b";\t"[..]).prop_map(Edit::Separator),
    ]
}

/// The byte ranges of the numbers in `bytes` outside comment lines (a digit, or a sign or
/// point before one, followed by digits, points, exponents and signs).
fn numbers(bytes: &[u8]) -> Vec<(usize, usize)> {
    let is_num = |b: u8| b.is_ascii_digit() || b"+-.eE".contains(&b);
    let mut spans = Vec::new();
    let mut line_start = 0;
    for line in bytes.split_inclusive(|&b| b == b'\n') {
        let comment = line.iter().find(|b| !b.is_ascii_whitespace()) == Some(&b'#');
        let mut i = 0;
        while !comment && i < line.len() {
            if is_num(line[i]) && line[i..].iter().take(3).any(u8::is_ascii_digit) {
                let start = i;
                while i < line.len() && is_num(line[i]) {
                    i += 1;
                }
                spans.push((line_start + start, line_start + i));
            } else {
                i += 1;
            }
        }
        line_start += line.len();
    }
    spans
}

fn apply(text: &str, edits: &[Edit]) -> Vec<u8> {
    let mut b = text.as_bytes().to_vec();
    for e in edits {
        let at = |i: usize, len: usize| if len == 0 { 0 } else { i % len };
        match *e {
            Edit::Flip(i, bit) if !b.is_empty() => {
                let i = at(i, b.len());
                b[i] ^= bit;
            }
            Edit::Set(i, v) if !b.is_empty() => {
                let i = at(i, b.len());
                b[i] = v;
            }
            Edit::Truncate(n) => b.truncate(at(n, b.len() + 1)),
            Edit::Delete(i, n) => {
                let i = at(i, b.len() + 1);
                let j = (i + n).min(b.len());
                b.drain(i..j);
            }
            Edit::Insert(i, t) => {
                let i = at(i, b.len() + 1);
                b.splice(i..i, t.iter().copied());
            }
            Edit::ReplaceNumber(i, t) => {
                let spans = numbers(&b);
                if !spans.is_empty() {
                    let (s, e) = spans[i % spans.len()];
                    b.splice(s..e, t.iter().copied());
                }
            }
            Edit::Separator(sep) => b.iter_mut().filter(|c| **c == b',').for_each(|c| *c = sep),
            Edit::Flip(..) | Edit::Set(..) => {}
        }
    }
    b
}

/// Words of Rust or serde that must not reach a user (unless the user wrote them: an error
/// may quote the input).
const RUST_WORDS: [&str; 7] = [
    "f64",
    "struct ",
    "invalid type",
    "Param",
    "PendulumT",
    "sequence",
    "Spanned",
];

/// `message` holds no word of [`RUST_WORDS`] that `input` does not hold.
fn check_words(input: &[u8], message: &str) -> Result<(), TestCaseError> {
    let input = String::from_utf8_lossy(input);
    for w in RUST_WORDS {
        prop_assert!(
            !message.contains(w) || input.contains(w),
            "`{w}` in {message}"
        );
    }
    Ok(())
}

/// A case-frame outcome keeps the reader's promises: an error names the file (and a line,
/// unless the file has no header); accepted rows hold finite numbers, `freq_hz` >= 0,
/// `sigma_cm_s2` > 0, no oscillation without a frequency, and a label.
fn check_caseframe(input: &[u8], out: anyhow::Result<Vec<Condition>>) -> Result<(), TestCaseError> {
    match out {
        Err(e) => {
            let m = format!("{e:#}");
            let line_follows = m.as_bytes().get(6).is_some_and(u8::is_ascii_digit);
            prop_assert!(
                (m.starts_with("f.csv:") && line_follows) || m.starts_with("f.csv: no header line"),
                "{m}"
            );
            check_words(input, &m)?;
        }
        Ok(rows) => {
            for c in &rows {
                let mut all = Vec::new();
                for a in [
                    c.g,
                    c.w_rad_s,
                    c.lin_cm_s2,
                    c.lin_deg,
                    c.ang_mrad,
                    c.ang_deg,
                    c.ref_w_rad_s,
                ] {
                    all.extend(a);
                }
                all.push(c.freq_hz);
                all.extend(c.measured_cm_s2);
                all.extend(c.sigma_cm_s2);
                prop_assert!(all.iter().all(|v| v.is_finite()), "{c:?}");
                prop_assert!(c.freq_hz >= 0.0, "{c:?}");
                prop_assert!(c.sigma_cm_s2.is_none_or(|s| s > 0.0), "{c:?}");
                let oscillates = c.lin_cm_s2.iter().chain(&c.ang_mrad).any(|&v| v != 0.0);
                prop_assert!(!oscillates || c.freq_hz > 0.0, "{c:?}");
                prop_assert!(!c.label.is_empty(), "{c:?}");
            }
        }
    }
    Ok(())
}

/// An instrument outcome keeps the parser's promises: an error names the file, a line and a
/// column, in user terms; an accepted file has finite values and tolerance bands that hold
/// their nominal.
fn check_instrument(
    input: &[u8],
    out: Result<Instrument, ptsa_host_sim::InstrumentError>,
) -> Result<(), TestCaseError> {
    match out {
        Err(e) => {
            let m = e.to_string();
            prop_assert_eq!(e.file.as_str(), "m.toml");
            prop_assert!(e.position().is_some() && e.column > 0, "{m}");
            prop_assert!(
                m.starts_with(&format!("m.toml:{}:{}: ", e.line, e.column)),
                "{m}"
            );
            check_words(input, &m)?;
        }
        Ok(i) => {
            prop_assert!(
                i.pendulosity_dyn_cm_per_g > 0.0 && i.pendulosity_dyn_cm_per_g.is_finite()
            );
            prop_assert!(i.freedom_rad > 0.0 && i.freedom_rad < 2.5e-3);
            prop_assert!(i.clock_hz >= 1000.0 && i.clock_hz.is_finite());
            prop_assert!(i.bias_cm_s2.abs() < i.sf_cm_s2 && i.sf_cm_s2.is_finite());
            prop_assert_eq!(i.tolerances.len(), 12);
            for t in &i.tolerances {
                prop_assert!(t.lo.is_finite() && t.hi.is_finite(), "{t:?}");
                prop_assert!(t.lo <= t.nominal && t.nominal <= t.hi, "{t:?}");
            }
        }
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig { cases: CASES, ..ProptestConfig::default() })]

    #[test]
    fn caseframe_survives_arbitrary_bytes(bytes in prop::collection::vec(any::<u8>(), 0..2048)) {
        check_caseframe(&bytes, caseframe::parse_bytes("f.csv", &bytes))?;
        check_caseframe(&bytes, caseframe::parse("f.csv", &String::from_utf8_lossy(&bytes)))?;
    }

    #[test]
    fn caseframe_survives_arbitrary_text(
        text in "[a-z_,;\"#\t\r\n 0-9.eE+-]{0,400}",
        any_text in any::<String>(),
    ) {
        let header = caseframe::column_names().join(",");
        for t in [text.clone(), format!("{header}\n{text}"), any_text.clone(), format!("{header}\n{any_text}")] {
            check_caseframe(t.as_bytes(), caseframe::parse("f.csv", &t))?;
        }
    }

    #[test]
    fn caseframe_survives_mutations_of_the_shipped_files(
        file in prop::sample::select(&CASE_FILES[..]),
        edits in prop::collection::vec(edit(), 1..5),
    ) {
        let bytes = apply(file, &edits);
        check_caseframe(&bytes, caseframe::parse_bytes("f.csv", &bytes))?;
        check_caseframe(&bytes, caseframe::parse("f.csv", &String::from_utf8_lossy(&bytes)))?;
    }

    #[test]
    fn instrument_survives_arbitrary_bytes_and_text(
        bytes in prop::collection::vec(any::<u8>(), 0..2048),
        text in "[a-z_\\[\\]{}=,.\"'# \n0-9-]{0,400}",
    ) {
        check_instrument(&bytes, Instrument::parse_bytes(&bytes, "m.toml"))?;
        check_instrument(&bytes, Instrument::parse(&String::from_utf8_lossy(&bytes), "m.toml"))?;
        check_instrument(text.as_bytes(), Instrument::parse(&text, "m.toml"))?;
    }

    #[test]
    fn instrument_survives_mutations_of_the_shipped_file(
        edits in prop::collection::vec(edit(), 1..4),
    ) {
        let bytes = apply(KEARFOTT_2401_TOML, &edits);
        check_instrument(&bytes, Instrument::parse_bytes(&bytes, "m.toml"))?;
        check_instrument(&bytes, Instrument::parse(&String::from_utf8_lossy(&bytes), "m.toml"))?;
    }

    /// The writer and the reader agree: any rows the reader can accept come back bit for
    /// bit (labels without line breaks; a row's label is never empty).
    #[test]
    fn written_rows_read_back_unchanged(
        mut rows in prop::collection::vec(condition(), 1..6),
        comment in "[ -~]{0,40}",
    ) {
        // A file that gives `temp_c` gives it on every measured row (the other case is
        // refused, next property).
        if let Some(t) = rows.iter().find_map(|r| r.temp_c) {
            for r in &mut rows {
                r.temp_c = r.temp_c.or(Some(t));
            }
        }
        let text = caseframe::to_csv(&rows, &[&comment]);
        let back = caseframe::parse("f.csv", &text).map_err(|e| TestCaseError::fail(format!("{e:#}\n{text}")))?;
        prop_assert_eq!(back.len(), rows.len());
        for (a, b) in rows.iter().zip(&back) {
            prop_assert_eq!(&a.label, &b.label);
            prop_assert_eq!(bits(a), bits(b), "{}", text);
            prop_assert_eq!(a.approach, b.approach, "{}", text);
        }
    }

    /// Temperatures on some measured rows but not on another: refused, naming the first
    /// such row's line and the column; otherwise read.
    #[test]
    fn temperatures_on_some_measured_rows_only_are_refused(
        rows in prop::collection::vec(condition(), 1..6),
    ) {
        let text = caseframe::to_csv(&rows, &[]);
        let gap = rows.iter().any(|r| r.temp_c.is_some())
            && rows.iter().any(|r| r.temp_c.is_none() && r.measured_cm_s2.is_some());
        match caseframe::parse("f.csv", &text) {
            Ok(_) => prop_assert!(!gap, "{}", text),
            Err(e) => {
                let m = format!("{e:#}");
                prop_assert!(gap, "{}\n{}", m, text);
                let line = 2 + rows
                    .iter()
                    .position(|r| r.temp_c.is_none() && r.measured_cm_s2.is_some())
                    .unwrap_or(0);
                prop_assert!(m.starts_with(&format!("f.csv:{line}: column ")), "{}", m);
                prop_assert!(m.contains("(`temp_c`) is empty in a measured row"), "{}", m);
            }
        }
    }
}

/// Every number of a row as bits (0.0 and -0.0 alike: the writer writes both as `0`).
fn bits(c: &Condition) -> Vec<u64> {
    let mut all = Vec::new();
    for a in [
        c.g,
        c.w_rad_s,
        c.lin_cm_s2,
        c.lin_deg,
        c.ang_mrad,
        c.ang_deg,
        c.ref_w_rad_s,
    ] {
        all.extend(a);
    }
    all.push(c.freq_hz);
    all.extend(c.measured_cm_s2.map_or([f64::NAN], |v| [v]));
    all.extend(c.sigma_cm_s2.map_or([f64::NAN], |v| [v]));
    all.extend(c.temp_c.map_or([f64::NAN], |v| [v]));
    all.extend(c.power_on_s.map_or([f64::NAN], |v| [v]));
    all.iter()
        .map(|v| if *v == 0.0 { 0 } else { v.to_bits() })
        .collect()
}

/// A finite number, or (often) zero.
fn num() -> impl Strategy<Value = f64> {
    prop_oneof![
        Just(0.0),
        prop::num::f64::NORMAL | prop::num::f64::SUBNORMAL | prop::num::f64::ZERO,
        -1e3..1e3,
    ]
}

fn axes() -> impl Strategy<Value = [f64; 3]> {
    [num(), num(), num()]
}

/// A row the reader accepts: a non-empty label without line breaks, `freq_hz` > 0 (so
/// oscillations are allowed), `sigma_cm_s2` > 0 or absent.
fn condition() -> impl Strategy<Value = Condition> {
    (
        "[ -~µ°\t;]{1,16}",
        (axes(), axes(), axes(), axes()),
        (axes(), axes(), axes()),
        1e-3..1e4_f64,
        prop::option::of(num()),
        prop::option::of(1e-6..1e3_f64),
        (
            prop::option::of("[a-z]([a-z0-9 ]{0,8}[a-z])?"),
            prop::option::of(num()),
            any::<bool>(),
            prop::option::of(num()),
            prop::option::of(prop_oneof![Just(Approach::Up), Just(Approach::Down)]),
            prop::option::of(0.0..1e3_f64),
        ),
    )
        .prop_map(
            |(
                label,
                (g, w, lin, lin_deg),
                (ang, ang_deg, ref_w),
                freq,
                meas,
                sigma,
                (block, time_s, absolute, temp_c, approach, on_before),
            )| Condition {
                label,
                kind: if absolute {
                    RowKind::Absolute
                } else {
                    RowKind::Difference
                },
                radius_cm: 0.0,
                block,
                time_s,
                g,
                w_rad_s: w,
                freq_hz: freq,
                lin_cm_s2: lin,
                lin_deg,
                ang_mrad: ang,
                ang_deg,
                ref_w_rad_s: ref_w,
                measured_cm_s2: meas,
                sigma_cm_s2: sigma,
                temp_c,
                approach,
                // A power-on time only with a time, at or before it.
                power_on_s: time_s
                    .zip(on_before)
                    .map(|(t, d)| (t, t - d))
                    .filter(|&(t, p)| p.is_finite() && p <= t)
                    .map(|(_, p)| p),
                ..Condition::default()
            },
        )
}
