//! The report programme's section on discovery: Tables 6.1, 6.2 and 6.3 of R-890 (the
//! shipped case-frame transcriptions, `r890::case_files`) analysed by `ptsa discover`, each on
//! its own, as one Markdown section with a summary table, each text report, and the tables
//! and plots. Discovery itself knows nothing of R-890; this is where the report meets it.

use std::fmt::Write as _;
use std::path::Path;

use anyhow::Result;

use crate::discovery::show::{estimate, text_report, write_outputs};
use crate::discovery::sim::{ClosedLoopSimulator, Simulator};
use crate::discovery::{Options, TEST_STATEMENT, discover};
use crate::report::r890;
use crate::report::{Experiment, Finding, Setup, Sink};
use crate::simulation::work::Estimate;

/// The analysis of the report's Tables 6.1, 6.2 and 6.3 as a Markdown section, for the
/// no-argument report. Writes the tables and plots into `out` when given; the Markdown links
/// to the plots relative to `out`'s parent (where the report's summary is expected).
///
/// # Errors
/// The shipped transcriptions are malformed or an output cannot be written.
pub fn section(sim: &dyn Simulator, opts: &Options, out: Option<&Path>) -> Result<String> {
    section_json(sim, opts, out).map(|(s, _)| s)
}

/// [`section`] and each case file's `ptsa discover --json` object, by file name
/// (one analysis per file serves both).
///
/// # Errors
/// As [`section`].
pub fn section_json(
    sim: &dyn Simulator,
    opts: &Options,
    out: Option<&Path>,
) -> Result<(String, serde_json::Map<String, serde_json::Value>)> {
    let mut all = serde_json::Map::new();
    let mut s = String::new();
    let _ = writeln!(
        s,
        "## Discovery: what the baseline model misses in Tables 6.1–6.3\n"
    );
    let _ = writeln!(
        s,
        "Method: `docs/method/discovery.md`. Test: {TEST_STATEMENT}.\n"
    );
    let _ = writeln!(
        s,
        "| data | rows | baseline RMS (cm/s²) | baseline χ² | selected | coefficient ± SE | indistinguishable from | extended RMS | extended χ² (p) |"
    );
    let _ = writeln!(s, "|---|---|---|---|---|---|---|---|---|");
    let mut details = String::new();
    for f in r890::case_files()? {
        let name = f.name;
        let d = discover(&f.rows, sim, opts)?;
        let j = &d.json;
        let sel = if d.selected.is_empty() {
            ("none".to_string(), "—".to_string(), "—".to_string())
        } else {
            let n: Vec<String> = d
                .selected
                .iter()
                .map(|x| x.id.info().name.to_string())
                .collect();
            let c: Vec<String> = d
                .selected
                .iter()
                .map(|x| format!("{} {}", estimate(x.coef, x.stderr), x.id.info().key))
                .collect();
            let f: Vec<String> = d
                .selected
                .iter()
                .flat_map(|x| x.confounded.iter().map(|&(o, _)| o.info().name.to_string()))
                .collect();
            (
                n.join(", "),
                c.join(", "),
                if f.is_empty() {
                    "—".into()
                } else {
                    f.join(", ")
                },
            )
        };
        let _ = writeln!(
            s,
            "| {name} | {} | {:.3} | {:.2} | {} | {} | {} | {:.3} | {:.2} ({:.2}) |",
            j.rows,
            j.baseline.rms_cm_s2,
            j.baseline.chi2,
            sel.0,
            sel.1,
            sel.2,
            j.extended.rms_cm_s2,
            j.extended.chi2,
            j.extended.p_value
        );
        let _ = writeln!(details, "\n```text\n{}```", text_report(name, &d));
        all.insert(name.to_string(), serde_json::to_value(&d.json)?);
        if let Some(dir) = out {
            let stem = name.trim_end_matches(".case.csv");
            write_outputs(dir, stem, &d)?;
            // The Markdown is meant to sit in `out`'s parent (the report folder).
            let rel = dir.file_name().map_or_else(
                || dir.display().to_string(),
                |n| n.to_string_lossy().into_owned(),
            );
            let _ = writeln!(details, "\n![{stem}]({rel}/{stem}.svg)");
        }
    }
    s.push_str(&details);
    Ok((s, all))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::discovery::sim::AnalyticSimulator;
    use crate::model::instrument::Instrument;

    fn analytic() -> AnalyticSimulator {
        AnalyticSimulator::for_instrument(&Instrument::kearfott_2401())
    }

    #[test]
    fn report_section_writes_tables_and_plots() {
        let dir = std::env::temp_dir().join(format!("ptsa-discover-{}", std::process::id()));
        let sim = AnalyticSimulator::for_instrument(&crate::Instrument::kearfott_2401());
        let md = section(&sim, &Options::default(), Some(&dir)).unwrap();
        assert!(md.contains("anisoinertia") && md.contains("lever_arm.r_pa_cm"));
        for stem in ["r890-table-6.1", "r890-table-6.2", "r890-table-6.3"] {
            for ext in ["csv", "png", "svg"] {
                let p = dir.join(format!("{stem}.{ext}"));
                assert!(
                    std::fs::metadata(&p).is_ok_and(|m| m.len() > 100),
                    "{}",
                    p.display()
                );
            }
        }
        if std::env::var_os("PTSA_KEEP_PLOTS").is_none() {
            let _ = std::fs::remove_dir_all(&dir);
        } else {
            eprintln!("{md}\nplots in {}", dir.display());
        }
    }

    #[test]
    fn table_6_1_names_anisoinertia_confounded_with_the_pa_lever_arm() {
        let rows = r890::table_6_1_case().unwrap();
        let d = discover(&rows, &analytic(), &Options::default()).unwrap();
        eprintln!("{}", text_report("table 6.1", &d));
        assert_eq!(d.json.effects.len(), 1);
        let e = &d.json.effects[0];
        assert_eq!(e.name, "anisoinertia");
        assert!(e.plausible);
        assert_eq!(e.confounded_with, vec!["lever_arm.r_pa_cm".to_string()]);
        let k = e.coefficients["k_ai_cm"];
        // The 45° rows' mean 1.47 cm/s² over w_IA·w_PA = 0.5·(1 − 0.05²) is 2.947 cm; with
        // the bias shift and the drift in the model the estimate moves by a fifth of its
        // standard error (the drift in row order is not quite orthogonal to the signature).
        assert!(
            (k - 1.47 / (0.5 * (1.0 - 0.0025))).abs() < 0.25 * e.stderr["k_ai_cm"],
            "{k}"
        );
        assert!(d.json.extended.rms_cm_s2 < 0.25 * d.json.baseline.rms_cm_s2);
        assert!(d.json.extended.p_value > 0.05);
        assert!(!d.json.unexplained.detected);
    }

    #[test]
    fn tables_6_2_and_6_3_are_null() {
        for rows in [
            r890::table_6_2_case().unwrap(),
            r890::table_6_3_case().unwrap(),
        ] {
            let d = discover(&rows, &analytic(), &Options::default()).unwrap();
            eprintln!("{}", text_report("oa coupling", &d));
            assert!(d.json.effects.is_empty());
        }
    }

    #[test]
    fn the_report_story_holds_with_the_closed_loop() {
        let sim = crate::discovery::sim::closed_loop(1);
        let d = discover(&r890::table_6_1_case().unwrap(), &*sim, &Options::default()).unwrap();
        eprintln!("{}", text_report("table 6.1 (closed loop)", &d));
        assert_eq!(d.json.effects.len(), 1);
        assert_eq!(d.json.effects[0].name, "anisoinertia");
        assert!((d.json.effects[0].coefficients["k_ai_cm"] - 2.95).abs() < 0.1);
        for rows in [
            r890::table_6_2_case().unwrap(),
            r890::table_6_3_case().unwrap(),
        ] {
            let d = discover(&rows, &*sim, &Options::default()).unwrap();
            eprintln!("{}", text_report("oa coupling (closed loop)", &d));
            assert!(d.json.effects.is_empty());
        }
    }

    #[test]
    fn a_bias_shift_between_blocks_is_a_nuisance_not_a_discovery() {
        // Table 6.1's rows, half of them with a 0.8 cm/s² shifted reference run: the shift
        // is absorbed by the block terms, anisoinertia is still named, nothing else.
        let mut rows = r890::table_6_1_case().unwrap();
        for (k, r) in rows.iter_mut().enumerate() {
            r.block = Some(if k % 2 == 0 { "a" } else { "b" }.into());
            if k % 2 == 1 {
                r.measured_cm_s2 = r.measured_cm_s2.map(|m| m + 0.8);
            }
        }
        let d = discover(&rows, &analytic(), &Options::default()).unwrap();
        eprintln!("{}", text_report("blocks", &d));
        let names: Vec<&str> = d.json.effects.iter().map(|e| e.name.as_str()).collect();
        assert_eq!(names, ["anisoinertia"]);
        let b = &d.json.nuisance.bias_shift_cm_s2;
        assert!((b["b"] - b["a"] - 0.8).abs() < 0.4, "{b:?}");
    }
}

/// The step of the report programme (see [`crate::report::Experiment`]).
#[derive(Clone, Copy, Debug)]
pub struct Step;

impl Experiment for Step {
    fn name(&self) -> &'static str {
        "discovery"
    }

    /// The closed-loop ticks and the least squares of Tables 6.1–6.3's analyses
    /// ([`crate::discovery::cost`]), the part that always runs.
    fn work(&self, s: Setup<'_>) -> Result<Estimate> {
        let sim = ClosedLoopSimulator {
            instrument: s.instr.clone(),
            options: *s.opts,
        };
        let mut e = Estimate::default();
        for f in r890::case_files()? {
            let c = crate::discovery::cost::Cost::of(
                &f.rows,
                &sim,
                crate::model::effects::CandidateId::ALL,
            );
            e.ticks += c.ticks;
            e.other_s += c.seconds() - c.ticks.seconds();
        }
        Ok(e)
    }

    /// The section, or why it is missing (the programme goes on without it).
    fn run(&self, s: Setup<'_>, to: &mut Sink<'_>) -> Result<Finding> {
        let sim = ClosedLoopSimulator {
            instrument: s.instr.clone(),
            options: *s.opts,
        };
        let section = section(
            &sim,
            &Options::for_instrument(s.instr),
            Some(&to.dir.join("discover")),
        )
        .map_err(|e| format!("{e:#}"));
        Ok(Finding::Discovery(section))
    }
}
