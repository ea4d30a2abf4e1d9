//! `ptsa discover`: given measured data, show what the simulation gets wrong, name the cause,
//! extend the model and measure the gain (method in `docs/method/discovery.md`, data format
//! in `docs/reference/case-frame-format.md`).
//!
//! From the bottom up (a module uses only those above it; `no_import_cycles` checks it):
//!
//! * [`observation`]: what a row is observed as, measured or simulated: a value, or a
//!   response row's gain and phase.
//! * [`sim`]: the [`Simulator`] trait, the analytic model and the closed-loop adapter.
//! * [`library`]: the variables of the case inputs and of the row before, their units, the
//!   library of shapes the residuals are searched against, and the `--term` grammar.
//! * [`data`]: the fitted observations, signatures and the library over them.
//! * [`fit`]: nuisance terms, noise, stepwise selection with familywise error control.
//! * [`report`]: the `--json` object's types, every key and its meaning.
//! * [`slips`]: values in another unit or with the sign reversed, stated sigmas far from
//!   the scatter, and the likely cause of a gross error.
//! * [`problem`]: what the stages share: the [`Options`], the [`Selected`] terms, the
//!   problem after the linear selection.
//! * The stages, one a module: [`outliers`] (rows far beyond what the model and the noise
//!   allow, set aside before the selection can explain them), [`confounding`] (the
//!   selection's terms and their partners), [`refine`] (the parameters' Gauss–Newton refit
//!   through the closed loop), [`prune`], [`scan`], [`check`] and [`mirror`] (the other
//!   loop parameters that could explain what a selected one does, over [`search`]'s
//!   closed-loop χ²), [`extend`] (the extended model re-simulated), [`stability`] (each
//!   named term refitted on disjoint parts of the data: halves in time, the two
//!   approaches, blocks), [`unexplained`]
//!   (lack of fit and the search of the residuals), [`rivals`] (the forms outside the
//!   vocabulary that could stand in a named term's place), [`crossval`] (the gain out of sample),
//!   [`advice`] (rows that would break a confounding).
//! * [`calibration`]: the instrument's own model equation (absolute values, their
//!   uncertainties and correlation) from the final selection.
//! * [`correct`]: a row's counts as its reading ([`correct::counts_in`]); `ptsa correct`,
//!   a calibration applied to a record of readings (the static model equation inverted
//!   for the specific force along IA; the terms it does not apply sized after
//!   [`calibration`]'s).
//! * [`cost`]: what a discovery costs, counted before it runs.
//! * [`outcome`]: the typed result, [`Discovery`].
//! * [`show`]: text table, plots and the report section; [`sheet`]: the calibration sheet
//!   (`--sheet`); [`verdict`]: the verdict and
//!   the warnings in words; [`assemble`]: the result from the stages' findings.
//! * [`pipeline`]: the stages' order ([`discover`]).

use std::fmt::Write as _;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, Result};

use crate::model::condition::Condition;
use crate::model::effects::{CandidateId, Effects};

pub mod advice;
pub mod assemble;
pub mod calibration;
pub mod check;
pub mod confounding;
pub mod correct;
pub mod correct_record;
pub use correct_record::read_result_json;
pub mod cost;
pub mod crossval;
pub mod data;
pub mod extend;
pub mod fit;
pub mod library;
pub mod mirror;
pub mod observation;
pub mod outcome;
pub mod outliers;
pub mod pipeline;
pub mod problem;
pub mod profile;
pub mod prune;
pub mod refine;
pub mod report;
pub mod rivals;
pub mod scan;
pub mod search;
pub mod sheet;
pub mod show;
pub mod sim;
pub mod slips;
pub mod stability;
pub mod unexplained;
pub mod verdict;

pub use correct::effects_from_json;
pub use fit::TEST_STATEMENT;
pub use outcome::Discovery;
pub use pipeline::{discover, discover_with};
pub use problem::{Options, Selected, parse_candidates};
pub use sim::{AnalyticSimulator, Simulator};

/// One `ptsa discover` run, as the command line asked for it (the clap types live in the
/// binary; this is the validated request).
#[derive(Clone, Debug)]
pub struct Request {
    /// Case-frame file.
    pub data: PathBuf,
    /// Settings of the method.
    pub options: Options,
    /// Print exactly one JSON object on stdout (the text goes to stderr).
    pub json: bool,
    /// Folder for the per-row table and the plots; `None` = write nothing.
    pub out: Option<PathBuf>,
    /// Write the advised rows here as a case-frame file.
    pub advice_out: Option<PathBuf>,
    /// Write the instrument file with the fitted parameters here.
    pub write_instrument: Option<InstrumentOut>,
    /// Write the calibration sheet here (`--sheet`).
    pub sheet: Option<sheet::SheetOut>,
}

/// The stem of `ptsa discover`'s files for the data file `data` (`<name>-discover`, the name
/// without `.case.csv` or `.csv`): the per-row table `<stem>.csv`, the plots `<stem>.png`,
/// `.svg` and `<stem>-bode.*`. The suffix keeps them apart from the user's own files in the
/// same folder (above all the data file itself, whose name they share).
#[must_use]
pub fn output_stem(data: Option<&std::path::Path>) -> String {
    let name = data.and_then(std::path::Path::file_stem).map_or_else(
        || "report".to_string(),
        |s| s.to_string_lossy().into_owned(),
    );
    format!("{}-discover", name.trim_end_matches(".case"))
}

/// Where `--write-instrument` goes and what it starts from.
#[derive(Clone, Debug)]
pub struct InstrumentOut {
    /// The file to write.
    pub path: PathBuf,
    /// The text of the instrument file the analysis used.
    pub source: String,
    /// Its name, for messages.
    pub source_name: String,
}

/// The analytic simulator with the shipped instrument's gravity, boxed.
#[must_use]
pub fn analytic() -> Box<dyn Simulator> {
    Box::new(AnalyticSimulator::for_instrument(
        &crate::Instrument::kearfott_2401(),
    ))
}

/// The data file read, its raw readings (`reading`, `reading_unit`) in cm/s² through the
/// simulator's instrument file.
fn read_rows(path: &Path, sim: &dyn Simulator) -> Result<crate::model::caseframe::Frame> {
    let mut frame = crate::model::caseframe::read_frame(path)?;
    if !frame.readings.is_empty() {
        // Raw readings become cm/s² through the instrument file's nominal scale.
        let instr = sim.instrument().ok_or_else(|| {
            anyhow::anyhow!(
                "{}: a `reading` needs an instrument file to convert it, and the {} simulator has none",
                path.display(),
                sim.name()
            )
        })?;
        frame.convert_readings(&path.display().to_string(), instr)?;
    }
    Ok(frame)
}

/// `--write-instrument`: the corrected instrument file `text` written to `w` (with a
/// warning for each flagged term it holds, and a line for each term of the calibration it
/// cannot hold), or, when nothing was measured, a line saying it was not written.
fn write_instrument_file(w: &InstrumentOut, text: Option<&str>, d: &Discovery) -> Result<()> {
    let Some(t) = text else {
        eprintln!(
            "no parameter of the instrument file and no term of the model equation was measured: {} not written",
            w.path.display()
        );
        return Ok(());
    };
    crate::output::write_atomic(&w.path, t.as_bytes())?;
    eprintln!(
        "wrote {} ({} with the calibration's model-equation terms and the fitted parameters)",
        w.path.display(),
        w.source_name
    );
    let Some(cal) = d.json.calibration.as_ref() else {
        return Ok(());
    };
    for term in cal.terms.iter().filter(|t| t.measured) {
        let flags: Vec<&str> = term
            .marks
            .iter()
            .copied()
            .filter(|m| matches!(*m, "implausible" | "unstable"))
            .collect();
        if !flags.is_empty() {
            eprintln!(
                "warning: --write-instrument {}: {} ({}) is written though discover flags it ({}); see its comment in the file",
                w.path.display(),
                term.symbol,
                term.candidate,
                flags.join(", ")
            );
        }
    }
    for s in d.selected.iter().filter(|s| s.parameter.is_some()) {
        if !s.plausible || s.stable == Some(false) {
            eprintln!(
                "warning: --write-instrument {}: {} is written though discover flags it ({}); see its comment in the file",
                w.path.display(),
                s.id,
                if s.plausible {
                    "not stable between parts of the data"
                } else {
                    "outside the instrument file's tolerance"
                }
            );
        }
    }
    let beside: Vec<&str> = cal
        .changes
        .candidates
        .iter()
        .filter_map(|n| CandidateId::from_name(n))
        .filter(|id| !id.model_equation_term() && id.parameter_key().is_none())
        .map(|id| id.info().name)
        .collect();
    if !beside.is_empty() {
        eprintln!(
            "note: --write-instrument {}: not written, as an instrument file has no key for them: {} (`ptsa correct --calibration` with the --json result applies them)",
            w.path.display(),
            beside.join(", ")
        );
    }
    for dt in &cal.doubtful {
        eprintln!(
            "note: --write-instrument {}: not written: {}",
            w.path.display(),
            calibration::show::doubtful_sentence(dt)
        );
    }
    Ok(())
}

/// `ptsa discover`'s analysis of the case frame at `path`, nothing written: the rows read
/// (in cm/s², each with its σ) and the discovery.
///
/// # Errors
/// The file is refused (its line and column); the analysis fails (under the file's name).
pub fn analyse(
    path: &Path,
    sim: &dyn Simulator,
    opts: &Options,
) -> Result<(Vec<Condition>, Discovery)> {
    let frame = read_rows(path, sim)?;
    let d = pipeline::discover_with(&frame.rows, &frame.empty, sim, opts)
        .with_context(|| path.display().to_string())?;
    Ok((frame.rows, d))
}

/// Run `ptsa discover` with simulator `sim` (the closed loop of the instrument file and run
/// options, or the analytic model): the text (or JSON) goes to `stdout`, logs to stderr.
///
/// # Errors
/// An unreadable or malformed data file (nothing is written then), an output that cannot be
/// written, or a failing `stdout` (e.g. a closed pipe).
pub fn run(req: &Request, sim: &dyn Simulator, stdout: &mut dyn Write) -> Result<()> {
    let opts = &req.options;
    let path = &req.data;
    // The sheet's date is read first: a malformed `SOURCE_DATE_EPOCH` refuses the run before
    // any work.
    let sheet_time = req
        .sheet
        .as_ref()
        .map(|_| sheet::sheet_time())
        .transpose()?;
    let t0 = Instant::now();
    let (rows, d) = analyse(path, sim, opts)?;
    let elapsed = t0.elapsed();
    let text = show::text_report(&path.display().to_string(), &d);
    // The corrected instrument file is made before anything is written, so that a value
    // the file refuses writes nothing.
    let instrument = match &req.write_instrument {
        Some(w) => Some((w, corrected_instrument(w, &path.display().to_string(), &d)?)),
        None => None,
    };
    if let Some(out) = &req.out {
        let stem = output_stem(Some(path));
        let files = show::write_outputs(out, &stem, &d)
            .with_context(|| format!("writing {}", out.display()))?;
        let names: Vec<String> = files
            .iter()
            .filter_map(|f| f.file_name().map(|n| n.to_string_lossy().into_owned()))
            .collect();
        eprintln!("wrote {}/{{{}}}", out.display(), names.join(","));
    }
    if let (Some(out), Some(time)) = (&req.sheet, sheet_time) {
        let data_bytes = std::fs::read(path).with_context(|| path.display().to_string())?;
        let prov = sheet::Provenance {
            data: path,
            data_bytes: &data_bytes,
            rows: &rows,
            time,
        };
        let files = sheet::write(out, &prov, &d)?;
        let names: Vec<String> = files
            .iter()
            .filter_map(|f| f.file_name().map(|n| n.to_string_lossy().into_owned()))
            .collect();
        eprintln!(
            "wrote the calibration sheet {}/{{{}}}",
            out.dir.display(),
            names.join(",")
        );
    }
    eprintln!(
        "discover: {} in {:.3} s ({} simulator)",
        crate::output::count(rows.len() as u64, "row"),
        elapsed.as_secs_f64(),
        d.simulator
    );
    if let Some(p) = &req.advice_out {
        let rows = advice::all_rows(&d.json.advice);
        let comments = [
            "Rows `ptsa discover` advises adding (see its advice): measure them and append them to the data.",
        ];
        crate::output::write_atomic(
            p,
            crate::model::caseframe::to_csv(&rows, &comments).as_bytes(),
        )?;
        eprintln!(
            "wrote {} ({})",
            p.display(),
            crate::output::count(rows.len() as u64, "advised row")
        );
    }
    if let Some((w, t)) = instrument {
        write_instrument_file(w, t.as_deref(), &d)?;
    }
    if req.json {
        eprint!("{text}");
        writeln!(stdout, "{}", serde_json::to_string(&d.json)?)?;
    } else {
        write!(stdout, "{text}")?;
    }
    Ok(())
}

/// The instrument file of `w` with the calibration's values as its new nominal values:
/// each model-equation term the calibration measured (`calibration.changes`, the file's
/// value plus the fitted change in the reading's convention: the bias into its key, the
/// others into `[model_equation]`, the scale factor as `k1_ppm` against the file's
/// unchanged nominal scale factor), and the selected parameters' fitted values, each with
/// a note of its value ± 1 σ and where it came from; `None` when there is nothing to write.
/// Discover run again with the written file finds no change of those terms.
fn corrected_instrument(w: &InstrumentOut, data: &str, d: &Discovery) -> Result<Option<String>> {
    let changes: Vec<(&str, f64, String)> = d
        .selected
        .iter()
        .filter_map(|s| {
            let p = s.parameter.as_ref()?;
            let key = s.id.parameter_key()?;
            let mut note = format!(
                "ptsa discover --data {data}: fitted {} ± {} (1 σ), was {}",
                p.fitted, p.sigma, p.nominal
            );
            confounded_note(&mut note, s);
            Some((key, p.fitted, note))
        })
        .collect();
    let instr = crate::Instrument::parse(&w.source, &w.source_name)
        .with_context(|| format!("--write-instrument {}", w.path.display()))?;
    let mut terms: Vec<(CandidateId, f64, String)> = d
        .json
        .calibration
        .as_ref()
        .map(|cal| model_terms(cal, &instr, data))
        .unwrap_or_default();
    // In the file's order: the bias, then `[model_equation]`'s keys.
    terms.sort_by_key(|(id, _, _)| {
        crate::model::instrument::MODEL_EQUATION
            .iter()
            .position(|m| m.id == *id)
            .map_or(0, |k| k + 1)
    });
    if changes.is_empty() && terms.is_empty() {
        return Ok(None);
    }
    let mut t = w.source.clone();
    if !changes.is_empty() {
        t = crate::Instrument::rewrite(&t, &w.source_name, &changes)
            .with_context(|| format!("--write-instrument {}", w.path.display()))?;
    }
    if !terms.is_empty() {
        t = crate::Instrument::rewrite_model_equation(&t, &w.source_name, &terms)
            .with_context(|| format!("--write-instrument {}", w.path.display()))?;
    }
    Ok(Some(t))
}

/// The model-equation terms of the calibration `cal` as the instrument file's values: the
/// file's (`instr`) plus the fitted change, in the candidate's unit and sign, written to a
/// hundredth of its 1 σ, each with its note.
fn model_terms(
    cal: &report::Calibration,
    instr: &crate::Instrument,
    data: &str,
) -> Vec<(CandidateId, f64, String)> {
    let c = &cal.changes;
    c.candidates
        .iter()
        .enumerate()
        .filter_map(|(j, name)| {
            let id = CandidateId::from_name(name).filter(|id| id.model_equation_term())?;
            let nominal = instr.nominal_model_term(id);
            let (change, sigma) = (c.values[j], c.sigmas[j]);
            let d = decimals(sigma);
            let value: f64 = format!("{:.d$}", nominal + change)
                .parse()
                .unwrap_or(nominal + change);
            let term = cal.terms.iter().find(|t| t.candidate == *name);
            Some((
                id,
                value,
                term_note(data, id, term, (nominal, change, sigma), value),
            ))
        })
        .collect()
}

/// The comment above a model-equation term `--write-instrument` writes: the value in the
/// file's key, unit and IEEE sign, ± 1 σ, the calibration's term it is (its symbol and
/// input-referred value, its status and marks), the nominal it changed and the data it
/// came from.
fn term_note(
    data: &str,
    id: CandidateId,
    term: Option<&report::CalibrationTerm>,
    (nominal, change, sigma): (f64, f64, f64),
    value: f64,
) -> String {
    let (key, unit, sign) = crate::model::instrument::MODEL_EQUATION
        .iter()
        .find(|m| m.id == id)
        .map_or(("bias_cm_s2", "cm/s²", 1.0), |m| (m.key, m.unit, m.sign));
    let d = decimals(sigma);
    // `+ 0.0`: a nominal 0 under the sign −1 is written 0, not −0.
    let mut note = format!(
        "ptsa discover --data {data}: {key} = {:.d$} ± {:.d$} {unit} (1 σ, the reading's coefficient): the nominal {} plus the fitted change {:.d$}",
        sign * value + 0.0,
        sigma,
        sign * nominal + 0.0,
        sign * change + 0.0
    );
    if let Some(t) = term {
        let _ = write!(
            note,
            "; the calibration's {} = {} {} (input-referred), {}",
            t.symbol,
            calibration::show::digits(t.value, t.sigma),
            t.unit,
            t.status.replace('_', " ")
        );
        if !t.marks.is_empty() {
            let _ = write!(note, " ({})", t.marks.join(", "));
        }
        if !t.confounded_with.is_empty() {
            let _ = write!(
                note,
                "; indistinguishable in these data from {}",
                t.confounded_with.join(", ")
            );
        }
    }
    note
}

/// `; indistinguishable in these data from …` after `note` when `s` has partners.
fn confounded_note(note: &mut String, s: &Selected) {
    if !s.confounded.is_empty() {
        let others: Vec<&str> = s.confounded.iter().map(|(o, _)| o.info().name).collect();
        let _ = write!(
            note,
            "; indistinguishable in these data from {}",
            others.join(", ")
        );
    }
}

/// The decimals that write a value of standard error `sigma` to a hundredth of it (at least
/// 0, at most 17).
fn decimals(sigma: f64) -> usize {
    if sigma > 0.0 && sigma.is_finite() {
        let d = -(sigma / 100.0).log10().floor();
        // Clamped to 0..=17: a whole number.
        #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
        let d = d.clamp(0.0, 17.0) as usize;
        d
    } else {
        17
    }
}

/// What the instrument should read in each row (`ptsa predict`): the simulator's prediction
/// with `effects` put into the plant ([`Simulator::observe`]), in the flat form of the
/// prediction table ([`observation::Observation::values`]): `[cm/s²]` for a difference or
/// absolute row, `[gain, phase_deg]` for a response row.
#[must_use]
pub fn predict(rows: &[Condition], sim: &dyn Simulator, effects: &Effects) -> Vec<Vec<f64>> {
    let rows = crate::model::condition::with_history(rows, sim.g_cm_s2());
    let jobs: Vec<(&Condition, &Effects)> = rows.iter().map(|r| (r, effects)).collect();
    sim.observe_all(&jobs)
        .iter()
        .map(observation::Observation::values)
        .collect()
}

#[cfg(test)]
mod tests {
    use std::path::Path;

    use super::*;

    fn request(data: PathBuf, out: PathBuf) -> Request {
        Request {
            write_instrument: None,
            sheet: None,
            data,
            options: Options::default(),
            json: true,
            out: Some(out),
            advice_out: None,
        }
    }

    /// `warm_up.a_cm_s2` is read with the time constant `discover --json` writes beside it,
    /// and refused without one, the message naming what is expected.
    #[test]
    fn a_warm_up_at_an_estimated_tau_is_read_with_its_time_constant() {
        let with: serde_json::Value = serde_json::from_str(
            r#"{"effects": [{"name": "warm_up", "coefficients": {"a_cm_s2": 0.3},
                 "time_constant": {"tau_s": 288.0}}]}"#,
        )
        .unwrap();
        let e = effects_from_json(&with).unwrap();
        assert_eq!(e.get(CandidateId::WarmUp).to_bits(), 0.3f64.to_bits());
        assert_eq!(e.warm_up_tau_s().to_bits(), 288.0f64.to_bits());
        assert!((e.warm_up_cm_s2(Some(288.0)) - 0.3 / std::f64::consts::E).abs() < 1e-15);
        let without: serde_json::Value = serde_json::from_str(
            r#"{"effects": [{"name": "warm_up", "coefficients": {"a_cm_s2": 0.3}}]}"#,
        )
        .unwrap();
        let m = format!("{:#}", effects_from_json(&without).unwrap_err());
        assert!(
            m.contains("`warm_up.a_cm_s2` needs its time constant")
                && m.contains("\"time_constant\": {\"tau_s\""),
            "{m}"
        );
        // A grid point needs none.
        let grid: serde_json::Value = serde_json::from_str(
            r#"{"effects": [{"name": "warm_up", "coefficients": {"a_span4_cm_s2": 0.3}}]}"#,
        )
        .unwrap();
        let g = effects_from_json(&grid).unwrap();
        assert_eq!(g.get(CandidateId::WarmUpSpan4).to_bits(), 0.3f64.to_bits());
    }

    /// The code of a module file: without its unit tests (a test may use any module) and
    /// without comments (a doc link is no dependency).
    fn code(text: &str) -> String {
        let text = text
            .split("\n#[cfg(test)]\nmod tests")
            .next()
            .unwrap_or_default();
        text.lines()
            .map(|l| l.split("//").next().unwrap_or_default())
            .collect::<Vec<_>>()
            .join("\n")
    }

    /// The identifiers at the head of each path in a `use` brace group `{a, b::C, d as e}`
    /// that starts `s` (after its `{`), at the group's top level.
    fn group_heads(s: &str) -> Vec<String> {
        let mut heads = Vec::new();
        let (mut depth, mut item, mut at_head) = (0, String::new(), true);
        for ch in s.chars() {
            match ch {
                '{' => {
                    depth += 1;
                    at_head = false;
                }
                '}' if depth == 0 => break,
                '}' => depth -= 1,
                ',' if depth == 0 => {
                    heads.push(std::mem::take(&mut item));
                    at_head = true;
                }
                ':' if depth == 0 => at_head = false,
                c if depth == 0 && c.is_whitespace() && !item.is_empty() => at_head = false,
                c if depth == 0 && at_head && (c.is_alphanumeric() || c == '_' || c == '*') => {
                    item.push(c);
                }
                _ => {}
            }
        }
        heads.push(item);
        heads.into_iter().filter(|h| !h.is_empty()).collect()
    }

    /// Every `(from, to)` use between discovery's modules, from each file's code: a child's
    /// `super::NAME` or `crate::discovery::NAME` (NAME a sibling module, or an item of
    /// `mod.rs`: then the edge goes to `mod`), and `mod.rs`'s own `NAME::` paths.
    fn uses(files: &[(String, String)]) -> std::collections::BTreeSet<(String, String)> {
        let modules: Vec<&str> = files
            .iter()
            .map(|(m, _)| m.as_str())
            .filter(|m| *m != "mod")
            .collect();
        let target = |name: &str| -> String {
            if modules.contains(&name) {
                name.to_string()
            } else {
                "mod".to_string()
            }
        };
        let mut edges = std::collections::BTreeSet::new();
        for (m, text) in files {
            let code = code(text);
            if m == "mod" {
                for &other in &modules {
                    let pat = format!("{other}::");
                    for (at, _) in code.match_indices(&pat) {
                        let before = code[..at].chars().next_back().unwrap_or(' ');
                        if !(before.is_alphanumeric() || before == '_' || before == ':') {
                            edges.insert((m.clone(), other.to_string()));
                        }
                    }
                }
                continue;
            }
            for prefix in ["super::", "crate::discovery::"] {
                for (at, _) in code.match_indices(prefix) {
                    let rest = &code[at + prefix.len()..];
                    let heads = if let Some(group) = rest.strip_prefix('{') {
                        group_heads(group)
                    } else {
                        vec![
                            rest.chars()
                                .take_while(|c| c.is_alphanumeric() || *c == '_' || *c == '*')
                                .collect(),
                        ]
                    };
                    for h in heads.iter().filter(|h| !h.is_empty() && *h != "self") {
                        let to = target(h);
                        if to != *m {
                            edges.insert((m.clone(), to));
                        }
                    }
                }
            }
        }
        edges
    }

    /// A cycle among `edges`, as the modules along it, if there is one.
    fn cycle(edges: &std::collections::BTreeSet<(String, String)>) -> Option<Vec<String>> {
        fn visit(
            node: &str,
            edges: &std::collections::BTreeSet<(String, String)>,
            path: &mut Vec<String>,
            done: &mut std::collections::BTreeSet<String>,
        ) -> Option<Vec<String>> {
            if let Some(k) = path.iter().position(|p| p == node) {
                let mut c = path[k..].to_vec();
                c.push(node.to_string());
                return Some(c);
            }
            if done.contains(node) {
                return None;
            }
            path.push(node.to_string());
            for (_, to) in edges.iter().filter(|(from, _)| from == node) {
                if let Some(c) = visit(to, edges, path, done) {
                    return Some(c);
                }
            }
            path.pop();
            done.insert(node.to_string());
            None
        }
        let mut done = std::collections::BTreeSet::new();
        edges
            .iter()
            .find_map(|(from, _)| visit(from, edges, &mut Vec::new(), &mut done))
    }

    /// Every `.rs` file of `src/discovery` as `(module, text)` (`mod.rs` as `mod`).
    fn discovery_files() -> Vec<(String, String)> {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("src/discovery");
        let mut files: Vec<(String, String)> = std::fs::read_dir(&dir)
            .unwrap()
            .map(|e| e.unwrap().path())
            .filter(|p| p.extension().is_some_and(|x| x == "rs"))
            .map(|p| {
                let m = p.file_stem().unwrap().to_string_lossy().into_owned();
                (m, std::fs::read_to_string(&p).unwrap())
            })
            .collect();
        files.sort();
        files
    }

    /// Discovery's modules in layers, bottom-up, as docs/method/code.md lists them: each uses
    /// only those before it (a new module takes its place here).
    const LAYERS: [&str; 34] = [
        "observation",
        "sim",
        "library",
        "data",
        "fit",
        "profile",
        "report",
        "slips",
        "problem",
        "outliers",
        "confounding",
        "refine",
        "search",
        "prune",
        "scan",
        "check",
        "mirror",
        "extend",
        "stability",
        "unexplained",
        "rivals",
        "crossval",
        "advice",
        "calibration",
        "correct",
        "correct_record",
        "cost",
        "outcome",
        "show",
        "verdict",
        "sheet",
        "assemble",
        "pipeline",
        "mod",
    ];

    #[test]
    fn no_import_cycles_between_discovery_modules() {
        let files = discovery_files();
        assert!(files.len() > 10, "{} files", files.len());
        let edges = uses(&files);
        // The check sees the uses it must see (a check that finds no edge finds no cycle).
        for e in [
            ("pipeline", "refine"),
            ("refine", "problem"),
            ("mod", "pipeline"),
        ] {
            assert!(
                edges.contains(&(e.0.to_string(), e.1.to_string())),
                "{e:?} not found"
            );
        }
        if let Some(c) = cycle(&edges) {
            panic!(
                "import cycle between discovery's modules: {} (a module may use only those below it: see the list in discovery/mod.rs)",
                c.join(" -> ")
            );
        }
        let mut listed: Vec<&str> = LAYERS.to_vec();
        listed.sort_unstable();
        let mut found: Vec<&str> = files.iter().map(|(m, _)| m.as_str()).collect();
        found.sort_unstable();
        assert_eq!(
            found, listed,
            "the files under src/discovery against LAYERS"
        );
        let layer = |m: &str| LAYERS.iter().position(|l| *l == m);
        for (from, to) in &edges {
            assert!(
                layer(to) < layer(from),
                "discovery::{from} uses discovery::{to}, listed above it in LAYERS (and in docs/method/code.md)"
            );
        }
    }

    #[test]
    fn the_cycle_check_finds_a_cycle_through_groups_and_mod_rs() {
        let f = |m: &str, t: &str| (m.to_string(), t.to_string());
        let files = [
            f(
                "a",
                "use super::{b::{self, X}, c as d};\n// use super::z;\n",
            ),
            f("b", "fn g() { crate::discovery::c::h() }"),
            f(
                "c",
                "use super::Request;\n#[cfg(test)]\nmod tests {\n use super::a;\n}",
            ),
            f(
                "mod",
                "pub use a::A;\npub mod b;\nfn r() { crate::output::a::x(); }",
            ),
        ];
        let edges = uses(&files);
        let want: std::collections::BTreeSet<(String, String)> = [
            ("a", "b"),
            ("a", "c"),
            ("b", "c"),
            ("c", "mod"),
            ("mod", "a"),
        ]
        .iter()
        .map(|(x, y)| (x.to_string(), y.to_string()))
        .collect();
        assert_eq!(edges, want);
        let c = cycle(&edges).expect("a cycle");
        assert_eq!(c.first(), c.last(), "{c:?}");
        let mut acyclic = edges.clone();
        acyclic.remove(&("c".to_string(), "mod".to_string()));
        assert_eq!(cycle(&acyclic), None);
    }

    /// A 12-position tumble about OA with a bias of 0.5 cm/s² and 0.02 cm/s² of seeded
    /// noise (stated), written to `dir` as a case-frame file.
    fn tumble_file(dir: &Path) -> PathBuf {
        use rand::SeedableRng as _;
        use rand_distr::Distribution as _;
        let sim = analytic();
        let truth = Effects::only(crate::model::effects::CandidateId::Bias, 0.5);
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
        let noise = rand_distr::Normal::new(0.0, 0.02).unwrap();
        let mut rows = crate::lab::plan::tumble(12, crate::lab::plan::Axis::Oa);
        for r in &mut rows {
            r.measured_cm_s2 = Some(sim.absolute_cm_s2(r, &truth) + noise.sample(&mut rng));
            r.sigma_cm_s2 = Some(0.02);
        }
        let p = dir.join("tumble.case.csv");
        std::fs::write(&p, crate::model::caseframe::to_csv(&rows, &[])).unwrap();
        p
    }

    /// Discovery knows nothing of R-890 (its tables, its programme: `report/`) and nothing
    /// above its layer: no file under `src/discovery` (comments and tests included) names
    /// the report's module, its data or the bench. (The names are put together here so that
    /// this file does not hold them either.)
    #[test]
    fn discovery_knows_nothing_of_the_report() {
        let bad = [
            concat!("r", "890"),
            concat!("crate::", "report"),
            concat!("crate::", "bench"),
        ];
        for (m, text) in discovery_files() {
            for (n, line) in text.lines().enumerate() {
                for bad in bad {
                    assert!(
                        !line.contains(bad),
                        "src/discovery/{m}.rs:{}: `{bad}`: {line}",
                        n + 1
                    );
                }
            }
        }
    }

    #[test]
    fn run_writes_table_and_plots_and_a_bad_file_writes_nothing() {
        let base = tempfile::tempdir().unwrap();
        let data = tumble_file(base.path());
        let out = base.path().join("ok");
        let mut stdout = Vec::new();
        run(&request(data, out.clone()), &*analytic(), &mut stdout).unwrap();
        let v: serde_json::Value = serde_json::from_slice(&stdout).unwrap();
        assert_eq!(v["effects"][0]["name"], "bias");
        for ext in ["csv", "png", "svg"] {
            assert!(out.join(format!("tumble-discover.{ext}")).exists(), "{ext}");
        }
        let bad = base.path().join("bad.case.csv");
        std::fs::write(&bad, "label,g_ia,measured_cm_s2\nx,1,0.5\ny,1,zz\n").unwrap();
        let out_bad = base.path().join("bad-out");
        let e = run(
            &request(bad, out_bad.clone()),
            &*analytic(),
            &mut Vec::new(),
        )
        .unwrap_err();
        let msg = format!("{e:#}");
        assert!(
            msg.contains("bad.case.csv:3") && msg.contains("measured_cm_s2"),
            "{msg}"
        );
        assert!(!out_bad.exists());
    }
}
