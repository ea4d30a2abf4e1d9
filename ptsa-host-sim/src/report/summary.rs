//! `summary.md`: everything the programme printed, every figure embedded, and what each
//! result means, rendered from a [`Programme`].

use std::fmt::Write as _;

use anyhow::Result;

use super::Programme;
use crate::output::Output;
use crate::report::experiments::appendix_a;
use crate::report::experiments::frequency_response::ResponseRow;
use crate::report::r890;

/// One experiment's tables (Markdown, titled), figures (embedded SVG) and notes.
fn section(s: &mut String, o: &Output) {
    for t in &o.tables {
        let _ = writeln!(
            s,
            "**{}** (`{}.csv`)\n\n{}",
            t.title,
            t.stem,
            t.to_markdown()
        );
    }
    for f in &o.plots {
        let _ = writeln!(s, "![{}]({}.svg)\n", f.stem, f.stem);
    }
    for n in &o.notes {
        let _ = writeln!(s, "* {n}");
    }
    s.push('\n');
}

/// The closed loop's sensitivity `1 − H` at `f_hz`, simulated and modelled, from the
/// frequency-response rows (`H` = indicated / input).
fn sensitivity(rows: &[ResponseRow], f_hz: f64) -> Option<(f64, f64)> {
    let r = rows.iter().find(|r| (r.freq_hz - f_hz).abs() < 1e-9)?;
    let s = |db: f64, deg: f64| {
        let h = num_complex::Complex64::from_polar(10f64.powf(db / 20.0), deg.to_radians());
        (1.0 - h).norm()
    };
    Some((s(r.sim_db, r.sim_deg), s(r.model_db, r.model_deg)))
}

/// Appendix A's verdict: how far the 2ω amplitudes are from the linear model, and whether
/// the loop's own measured sensitivity at that frequency accounts for it.
fn appendix_verdict(p: &Programme) -> String {
    let mut parts = Vec::new();
    let mut freq = 0.0;
    for (kind, r) in &p.appendix {
        let Some(best) = r
            .rows
            .iter()
            .max_by(|a, b| a.predicted_2w.total_cmp(&b.predicted_2w))
        else {
            continue;
        };
        freq = best.condition.freq_hz;
        if best.predicted_2w > 1e-6 {
            parts.push(format!(
                "{} {:+.0} %",
                appendix_a::name(*kind),
                100.0 * (best.simulated_2w / best.predicted_2w - 1.0)
            ));
        }
    }
    let mut v = format!(
        "**Verdict.** The rectified (DC) errors follow the linear loop model (largest differences above). The 2ω amplitudes, where the model predicts one, differ from it by {} at the largest predicted amplitude.",
        if parts.is_empty() {
            "nothing".to_string()
        } else {
            parts.join(", ")
        }
    );
    if let Some((sim, model)) = sensitivity(&p.response.rows, freq) {
        let _ = write!(
            v,
            " The pendulum's motion θ, which the 2ω term rectifies, is set by the loop's sensitivity |1/(1 + L)|; at {freq} Hz, close to the {:.0} Hz crossover, the simulated loop's sensitivity (from its measured frequency response, 1 − H) is {sim:.3} against the linear model's {model:.3}, {:+.0} %: the linear model treats the forced-binary quantizer as a unit gain, which is least accurate near crossover. A 2ω difference of that order is therefore expected from the model, not a defect of the loop; the DC term depends on the part of θ in phase with a_PA and is less sensitive.",
            crate::model::design::margins(&p.instrument, &p.info.options.config).crossover_hz,
            100.0 * (sim / model - 1.0)
        );
    }
    v
}

/// The Markdown of `summary.md`.
///
/// # Errors
/// The report's transcriptions are malformed.
pub fn render(p: &Programme) -> Result<String> {
    let s61 = r890::section_6_1()?;
    let s62 = r890::section_6_2()?;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "# PTSA / Kearfott 2401 host simulation: the R-890 test programme\n"
    );
    let _ = writeln!(
        s,
        "* Instrument file: `{}`\n* Noise seed {}, settling {} s, shortest window {} s; {} threads; wall time {:.2} s\n* Every figure here is reproduced by `cargo ptsa` (this report) or the subcommand named in its section. Method and model: `docs/method/host-sim.md`.\n* **Sign convention**: every difference is condition − reference (for the OA-coupling tables: dynamic − static), as in the case-frame format. The report's Tables 6.2 and 6.3 tabulate static − dynamic; their values appear negated here.\n",
        p.info.instrument,
        p.info.options.seed,
        p.info.options.warmup_s,
        p.info.options.min_window_s,
        p.info.threads,
        p.wall_s
    );
    let t = &p.tumble.tumble;
    let _ = writeln!(
        s,
        "## Scale factor and bias (section 6.1, `cargo ptsa tumble`)\n"
    );
    section(&mut s, &p.tumble.output);
    let _ = writeln!(
        s,
        "The instrument file sets the full scale to the report's SF ({} cm/s², torquer current {:.4} mA) and the bias to the report's A_b ({} cm/s²), so the tumble checks that the loop and eqs. 6.3/6.4 give back what was configured: SF error {:.3} ppm, bias error {:.5} cm/s². Eq. 6.2 as printed has a sign typo: with IA down the count gives SF(2P₂/T − 1) = −g + A_b, i.e. SF(1 − 2P₂/T) = g − A_b; eqs. 6.3 and 6.4 are right as printed.\n",
        s61.sf_cm_s2,
        p.instrument.full_current_ma,
        s61.bias_cm_s2,
        (t.sf / t.sf_configured - 1.0) * 1e6,
        t.bias - t.bias_configured
    );
    let _ = writeln!(
        s,
        "## Anisoinertia (Table 6.1, `cargo ptsa anisoinertia`)\n"
    );
    let _ = writeln!(
        s,
        "Simulated with I_PA − I_IA = {} g·cm² (the report's result) and with the baseline (0); the table rate {} rad/s, reference {} rad/s.\n",
        s62.anisoinertia_g_cm2, s62.rate_rad_s, s62.reference_rate_rad_s
    );
    section(&mut s, &p.anisoinertia.output);
    let _ = writeln!(
        s,
        "The coefficient from the simulated table as the report derives it is {:.3} cm (configured {:.3} cm; report {} cm, which divides by 0.7² = 0.49 where the exact w_IA·w_PA at 45° is 0.49875 rad²/s²).\n",
        p.anisoinertia.k_simulated_cm, p.anisoinertia.k_configured_cm, s62.coefficient_cm
    );
    let _ = writeln!(
        s,
        "## OA coupling (Tables 6.2 and 6.3, `cargo ptsa oa-coupling`)\n"
    );
    section(&mut s, &p.oa_coupling.output);
    let v = p.oa_coupling.verdict();
    let _ = writeln!(s, "{}{}.\n", v[..1].to_uppercase(), &v[1..]);
    let _ = writeln!(
        s,
        "## Appendix A (`cargo ptsa vibropendulosity`, `anisoelasticity`, `sculling`)\n"
    );
    for (_, r) in &p.appendix {
        section(&mut s, &r.output);
    }
    let _ = writeln!(s, "{}\n", appendix_verdict(p));
    let _ = writeln!(
        s,
        "## The loop (`cargo ptsa waveform`, `cargo ptsa monte-carlo`, `cargo ptsa design`)\n"
    );
    section(&mut s, &p.waveform);
    section(&mut s, &p.response.output);
    section(&mut s, &p.limit_cycle.output);
    section(&mut s, &p.monte_carlo.output);
    let _ = writeln!(
        s,
        "The compensator (`design.txt`):\n\n```text\n{}```\n",
        p.design
    );
    match &p.discovery {
        Ok(text) => {
            let _ = writeln!(s, "{text}");
        }
        Err(e) => {
            let _ = writeln!(s, "## Discovery\n\nNot available: {e}\n");
        }
    }
    let _ = writeln!(
        s,
        "## Timing\n\n{}\n",
        p.timings
            .iter()
            .map(|(n, t)| format!("{n} {t:.2} s"))
            .collect::<Vec<_>>()
            .join(", ")
    );
    Ok(s)
}
