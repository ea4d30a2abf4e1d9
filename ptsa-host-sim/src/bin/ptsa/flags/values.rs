//! The value parsers of the command line: each turns one option's text into a number (or
//! a name) in its range, or refuses it with a message that says what was expected, before
//! anything runs. A range that depends on the instrument file is checked by the
//! subcommand's request (`cmd`), once the file is loaded.

use ptsa_host_sim::lab::plan::Axis;
use ptsa_host_sim::model::effects::{CandidateId, candidate_names, resolve_candidates};

/// A number of positions or phases: a whole number from 2 to 360.
pub fn positions(s: &str) -> Result<usize, String> {
    match s.trim().parse::<usize>() {
        Ok(n @ 2..=360) => Ok(n),
        _ => Err(format!("expected a whole number from 2 to 360, not `{s}`")),
    }
}

/// The dividing head's axis on the rate table: `oa` or `pa`. `ia` is refused: IA would
/// lie along the head's horizontal axis, so the table's rate (about the vertical) has no
/// component along IA at any position, and the rows' differences carry no anisoinertia
/// (`w_IA·w_PA`), which is what the rate table measures.
pub fn rate_table_axis(s: &str) -> Result<Axis, String> {
    match s.trim() {
        "oa" => Ok(Axis::Oa),
        "pa" => Ok(Axis::Pa),
        "ia" => Err(
            "ia is not a rate-table set-up: with IA along the dividing head's axis the table's rate never reaches IA (w_IA = 0 at every position), so the rows would measure no anisoinertia (w_IA·w_PA); expected oa (IA in the IA–PA plane) or pa (IA in the IA–OA plane)"
                .into(),
        ),
        other => Err(format!(
            "expected oa (IA in the IA–PA plane) or pa (IA in the IA–OA plane), not `{other}`"
        )),
    }
}

/// A table rate, rad/s, from 0 to 100.
pub fn rate_rad_s(s: &str) -> Result<f64, String> {
    within(s, 0.0, 100.0, "a rate in rad/s from 0 to 100")
}

/// A vibration amplitude, cm/s², from 0 to 1e5.
pub fn amplitude_cm_s2(s: &str) -> Result<f64, String> {
    within(s, 0.0, 1e5, "an amplitude in cm/s² from 0 to 1e5")
}

/// One acceleration of a comma-separated list, cm/s².
pub fn accel_item(s: &str) -> Result<f64, String> {
    if s.trim().is_empty() {
        return Err(
            "an empty value in the list (a stray comma?); expected accelerations in cm/s² separated by commas, such as `-1000,0,1000`"
                .into(),
        );
    }
    finite(s)
}

/// The amplitude of a record's input sine, cm/s², more than 0.
pub fn input_amplitude_cm_s2(s: &str) -> Result<f64, String> {
    let x = finite(s)?;
    if x > 0.0 {
        Ok(x)
    } else {
        Err(format!(
            "expected an amplitude in cm/s², more than 0, not {}",
            num(x)
        ))
    }
}

/// A case-frame label: one line, no control characters.
pub fn label(s: &str) -> Result<String, String> {
    if s.chars().any(char::is_control) {
        Err(format!(
            "expected a label on one line, without control characters (a case-frame cell cannot hold them), not {s:?}"
        ))
    } else {
        Ok(s.to_string())
    }
}

/// A centrifuge arm, cm, more than 0 and at most 1e4.
pub fn arm_cm(s: &str) -> Result<f64, String> {
    let x = within(
        s,
        0.0,
        1e4,
        "an arm length in cm, more than 0 and at most 1e4",
    )?;
    if x > 0.0 {
        Ok(x)
    } else {
        Err("expected an arm length in cm, more than 0".into())
    }
}

/// A centrifuge's push, g, more than 0 and at most 1000.
pub fn g_level(s: &str) -> Result<f64, String> {
    let x = within(s, 0.0, 1000.0, "a g level from 0 to 1000 (ω²R/g)")?;
    if x > 0.0 {
        Ok(x)
    } else {
        Err("expected a g level more than 0".into())
    }
}

/// A `--term` expression, parsed (the column of a bad token and what was expected there).
pub fn term(s: &str) -> Result<ptsa_host_sim::discovery::library::Term, String> {
    ptsa_host_sim::discovery::library::parse_term(s).map_err(|e| format!("`{s}`: {e}"))
}

/// `--candidates`' long help, with every known name.
pub fn candidates_help() -> String {
    format!(
        "Candidate effects, comma separated: effect names (`lever_arm` = its three components) or candidate names (`lever_arm.r_pa_cm`); default all. Known: {}",
        candidate_names().join(", ")
    )
}

/// One item of `--candidates`: an effect (all its candidates) or a candidate.
pub fn candidate(s: &str) -> Result<Vec<CandidateId>, String> {
    if s.trim().is_empty() {
        return Err(format!(
            "an empty name in the list (a stray comma?); expected names separated by commas, such as `anisoinertia,lever_arm`; known: {}",
            candidate_names().join(", ")
        ));
    }
    resolve_candidates(s.trim())
}

/// A number, any.
fn number(s: &str) -> Result<f64, String> {
    s.trim()
        .parse::<f64>()
        .map_err(|_| format!("`{s}` is not a number"))
}

pub use ptsa_host_sim::output::shown_number as num;

/// A finite number.
pub fn finite(s: &str) -> Result<f64, String> {
    let x = number(s)?;
    if x.is_finite() {
        Ok(x)
    } else {
        Err(format!("expected a finite number, not {x}"))
    }
}

/// A finite number within `[lo, hi]`.
fn within(s: &str, lo: f64, hi: f64, what: &str) -> Result<f64, String> {
    let x = finite(s)?;
    if (lo..=hi).contains(&x) {
        Ok(x)
    } else {
        Err(format!("expected {what}, not {}", num(x)))
    }
}

/// A time, s, from 0 to 1e9.
pub fn non_negative_s(s: &str) -> Result<f64, String> {
    within(s, 0.0, 1e9, "a time in seconds from 0 to 1e9")
}

/// A time, s, more than 0 and at most 1e9.
pub fn positive_s(s: &str) -> Result<f64, String> {
    let x = within(
        s,
        0.0,
        1e9,
        "a time in seconds, more than 0 and at most 1e9",
    )?;
    if x > 0.0 {
        Ok(x)
    } else {
        Err(format!(
            "expected a time in seconds, more than 0, not {}",
            num(x)
        ))
    }
}

/// More than 0; the upper limit, half the limit-cycle frequency, depends on the instrument
/// file and is checked with it.
pub fn positive_hz(s: &str) -> Result<f64, String> {
    let x = finite(s)?;
    if x > 0.0 {
        Ok(x)
    } else {
        Err(format!(
            "expected a frequency in Hz, more than 0, not {}",
            num(x)
        ))
    }
}

/// An uncertainty, cm/s², more than 0.
pub fn positive_cm_s2(s: &str) -> Result<f64, String> {
    let x = finite(s)?;
    if x > 0.0 {
        Ok(x)
    } else {
        Err(format!(
            "expected an uncertainty in cm/s², more than 0, not {}",
            num(x)
        ))
    }
}

/// A local gravity, cm/s², within 970 to 990 (anywhere on or near the Earth's surface:
/// 978.0 at the equator to 983.2 at the poles, less with height).
pub fn local_gravity_cm_s2(s: &str) -> Result<f64, String> {
    let x = finite(s)?;
    if (970.0..=990.0).contains(&x) {
        Ok(x)
    } else {
        Err(format!(
            "expected a local gravity in cm/s² from 970 to 990 (standard gravity is 980.665; 9.8 would be m/s²), not {}",
            num(x)
        ))
    }
}

/// An anisoinertia, g·cm², |value| below 100.
pub fn anisoinertia_g_cm2(s: &str) -> Result<f64, String> {
    let x = finite(s)?;
    if x.abs() < 100.0 {
        Ok(x)
    } else {
        Err(format!(
            "expected |I_PA − I_IA| below 100 g·cm² (the instrument file's range; the float's I_OA is 14 g·cm²), not {}",
            num(x)
        ))
    }
}

/// An offset of the proof mass, cm, from −100 to 100.
pub fn lever_cm(s: &str) -> Result<f64, String> {
    within(
        s,
        -100.0,
        100.0,
        "an offset in cm between −100 and 100 (the fixtures are table-top sized)",
    )
}

/// A radius, cm, from 0 to 100.
pub fn radius_cm(s: &str) -> Result<f64, String> {
    within(s, 0.0, 100.0, "a radius in cm from 0 to 100")
}

/// An angular amplitude, mrad, from 0 to 100.
pub fn amplitude_mrad(s: &str) -> Result<f64, String> {
    within(
        s,
        0.0,
        100.0,
        "an amplitude in mrad from 0 to 100 (the oscillator model is small-angle)",
    )
}

/// A whole number in `lo..=hi`; `what` names it ("a seed", "ticks per run").
fn whole_in(s: &str, lo: u64, hi: u64, what: &str) -> Result<u64, String> {
    match s.trim().parse::<u64>() {
        Ok(n) if (lo..=hi).contains(&n) => Ok(n),
        _ => Err(format!(
            "expected {what}: a whole number from {lo} to {hi}, not `{s}`"
        )),
    }
}

/// A seed: any whole number of 64 bits.
pub fn seed(s: &str) -> Result<u64, String> {
    whole_in(s, 0, u64::MAX, "a seed")
}

/// Clock ticks per run: what the core's 32-bit counters hold.
pub fn ticks(s: &str) -> Result<u64, String> {
    whole_in(
        s,
        1,
        u64::from(u32::MAX),
        "ticks per run (the core's counters are 32-bit)",
    )
}

/// A number of limit cycles, 1 or more.
pub fn cycles(s: &str) -> Result<u64, String> {
    whole_in(s, 1, u64::MAX, "a number of limit cycles")
}

/// A number of corners of the tolerance box, 1 to 100 000.
pub fn count(s: &str) -> Result<usize, String> {
    let n = whole_in(s, 1, 100_000, "a number of corners")?;
    usize::try_from(n).map_err(|e| e.to_string())
}

/// A number of static conditions for `bench --batch`, 1 to 64.
pub fn batch_conditions(s: &str) -> Result<usize, String> {
    let n = whole_in(s, 1, 64, "a number of static conditions")?;
    usize::try_from(n).map_err(|e| e.to_string())
}

/// Loops interleaved per core: a power of two up to the batch engine's most.
pub fn lanes(s: &str) -> Result<usize, String> {
    let max = ptsa_host_sim::simulation::batch::MAX_LANES;
    match s.trim().parse::<usize>() {
        Ok(k) if k.is_power_of_two() && k <= max => Ok(k),
        _ => Err(format!(
            "expected lanes per core: a power of two from 1 to {max} (1, 2, 4, 8, 16), not `{s}`"
        )),
    }
}

/// A number of runs, 1 to 1000.
pub fn runs(s: &str) -> Result<usize, String> {
    let n = whole_in(s, 1, 1000, "a number of runs")?;
    usize::try_from(n).map_err(|e| e.to_string())
}

/// A number of instruments for `monte-carlo --yield`, 1 to 10⁶.
pub fn instruments(s: &str) -> Result<u64, String> {
    use ptsa_host_sim::simulation::yield_study::MAX_INSTRUMENTS;
    whole_in(s, 1, MAX_INSTRUMENTS, "a number of instruments")
}

/// A number of gates at each input, 2 to 10 000.
pub fn gates(s: &str) -> Result<u64, String> {
    use ptsa_host_sim::simulation::yield_study::GATES;
    whole_in(s, *GATES.start(), *GATES.end(), "a number of gates")
}

/// A limit of a specification: a finite number, 0 or more.
pub fn limit(s: &str) -> Result<f64, String> {
    within(s, 0.0, f64::MAX, "a limit, 0 or more")
}

/// A fraction of full scale, from −1 to 1.
pub fn fraction_fs(s: &str) -> Result<f64, String> {
    within(s, -1.0, 1.0, "a fraction of full scale from -1 to 1")
}
