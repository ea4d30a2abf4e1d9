//! `ptsa monte-carlo --yield N`: the production yield over the tolerance box
//! ([`ptsa_host_sim::simulation::yield_study`]), as a table or JSON on stdout.

use std::fmt::Write as _;
use std::io::Write;

use anyhow::Result;
use clap::Args;
use ptsa_host_sim::output::{Column, Table, num, text};
use ptsa_host_sim::simulation::sim::SimOptions;
use ptsa_host_sim::simulation::yield_study::{
    self, DEFAULT_FRACTIONS, DEFAULT_GATE_S, DEFAULT_GATES, DEFAULT_GM_DB, DEFAULT_PM_DEG, Plan,
    Spec, YieldJson,
};

use super::{Ctx, gate_ticks};
use crate::flags::values::{fraction_fs, gates, instruments, limit, positive_s};
use crate::work::{self, Work};

/// The yield study's options (`monte-carlo --yield N ...`).
#[derive(Args, Debug, Clone)]
pub struct YieldArgs {
    /// Draw N instruments (a count, no unit) from the tolerance box (each toleranced parameter uniform
    /// between its limits, seeded by --seed), run each through the closed loop across
    /// ±full scale, and report the figures' distributions and the fraction within the
    /// specification (the --spec-* limits), instead of the corners' margins.
    #[arg(long = "yield", value_name = "N", value_parser = instruments,
          conflicts_with = "samples")]
    pub instruments: Option<u64>,
    /// The inputs along IA, fractions of full scale (−1 to 1), comma separated.
    #[arg(long, value_name = "LIST", value_delimiter = ',', value_parser = fraction_fs,
          requires = "instruments", default_values_t = DEFAULT_FRACTIONS)]
    pub fractions: Vec<f64>,
    /// The gate at each input, s.
    #[arg(long, value_name = "S", value_parser = positive_s, requires = "instruments",
          default_value_t = DEFAULT_GATE_S)]
    pub gate_s: f64,
    /// Gates at each input, a count with no unit (2 to 10 000); the noise at rest is their
    /// standard deviation.
    #[arg(long, value_name = "N", value_parser = gates, requires = "instruments",
          default_value_t = DEFAULT_GATES)]
    pub gates: u64,
    /// Largest |scale-factor error| within the specification, ppm.
    #[arg(long, value_name = "PPM", value_parser = limit, requires = "instruments")]
    pub spec_sf_ppm: Option<f64>,
    /// Largest |bias| within the specification, cm/s².
    #[arg(long, value_name = "CM_S2", value_parser = limit, requires = "instruments")]
    pub spec_bias_cm_s2: Option<f64>,
    /// Largest departure from the fitted line within the specification, ppm of full scale.
    #[arg(long, value_name = "PPM", value_parser = limit, requires = "instruments")]
    pub spec_linearity_ppm_fs: Option<f64>,
    /// Largest gate-to-gate standard deviation at rest within the specification, cm/s².
    #[arg(long, value_name = "CM_S2", value_parser = limit, requires = "instruments")]
    pub spec_noise_cm_s2: Option<f64>,
    /// Smallest phase margin within the specification, degrees (R-890's goal: 45).
    #[arg(long, value_name = "DEG", value_parser = limit, requires = "instruments",
          default_value_t = DEFAULT_PM_DEG)]
    pub spec_pm_deg: f64,
    /// Smallest gain margin within the specification, dB (R-890's goal: 6).
    #[arg(long, value_name = "DB", value_parser = limit, requires = "instruments",
          default_value_t = DEFAULT_GM_DB)]
    pub spec_gm_db: f64,
    /// Print exactly one JSON object: the plan, the yield and its 95 % interval, each
    /// figure's distribution and every instrument (every key: docs/reference/json.md).
    #[arg(long, requires = "instruments")]
    pub json: bool,
}

/// A yield study to run.
pub struct Request {
    plan: Plan,
    opts: SimOptions,
    json: bool,
    force: bool,
}

impl YieldArgs {
    /// The study: the gate against the loop's limit cycle, the box not empty.
    ///
    /// # Errors
    /// The file has no tolerances; the gate does not fit.
    pub fn request(&self, ctx: &Ctx, opts: SimOptions, force: bool) -> Result<Option<Request>> {
        let Some(instruments) = self.instruments else {
            return Ok(None);
        };
        yield_study::check_box(&ctx.instr, &ctx.name)
            .map_err(|e| anyhow::anyhow!("--yield {instruments}: {e}"))?;
        let ticks = gate_ticks("--gate-s", self.gate_s, &ctx.instr, &opts)?;
        #[allow(clippy::cast_precision_loss)]
        let gate_s = ticks as f64 / ctx.instr.clock_hz;
        let plan = Plan {
            instruments,
            seed: opts.seed,
            fractions_of_full_scale: self.fractions.clone(),
            gate_s,
            gates: self.gates,
            warmup_s: opts.warmup_s,
            spec: Spec {
                sf_error_ppm: self.spec_sf_ppm,
                bias_cm_s2: self.spec_bias_cm_s2,
                linearity_ppm_fs: self.spec_linearity_ppm_fs,
                noise_cm_s2: self.spec_noise_cm_s2,
                phase_margin_deg: Some(self.spec_pm_deg),
                gain_margin_db: Some(self.spec_gm_db),
            },
        };
        plan.check()
            .map_err(|e| anyhow::anyhow!("--yield {instruments}: {e}"))?;
        Ok(Some(Request {
            plan,
            opts,
            json: self.json,
            force,
        }))
    }
}

/// Run the study (refused beyond the work limit without `--no-limit`), in pieces of 64
/// instruments with a progress line; the table or the JSON on `out`.
///
/// # Errors
/// Refused work; stdout cannot be written.
pub fn run(ctx: &Ctx, req: &Request, out: &mut dyn Write) -> Result<()> {
    let (instr, plan) = (&ctx.instr, &req.plan);
    let ticks = yield_study::gate_ticks(plan.gate_s, instr.clock_hz);
    let per = req.opts.warmup_ticks(instr.clock_hz) + ticks * plan.gates;
    #[allow(clippy::cast_precision_loss)]
    let jobs = (plan.instruments * plan.fractions_of_full_scale.len() as u64) as f64;
    let est = Work::new(instr, &req.opts).gate(per).times(jobs).check(
        req.force,
        &format!("the yield study of {} instruments", plan.instruments),
    )?;
    let p = work::Progress::start(&format!("yield, {} instruments", plan.instruments), &est);
    let units = yield_study::units(instr, &req.opts, plan, 0..plan.instruments);
    p.finish();
    let y = yield_study::summary(instr, plan, units);
    if req.json {
        writeln!(out, "{}", serde_json::to_string(&y)?)?;
    } else {
        write!(out, "{}", table(&y))?;
    }
    Ok(())
}

/// The distributions with their limits, then the yield.
fn table(y: &YieldJson) -> String {
    let s = &y.plan.spec;
    let rows: [(&str, &str, Option<f64>, &str); 6] = [
        ("sf_error_ppm", "ppm", s.sf_error_ppm, "|x| <="),
        ("bias_cm_s2", "cm/s^2", s.bias_cm_s2, "|x| <="),
        ("linearity_ppm_fs", "ppm FS", s.linearity_ppm_fs, "<="),
        ("noise_cm_s2", "cm/s^2", s.noise_cm_s2, "<="),
        ("phase_margin_deg", "deg", s.phase_margin_deg, ">="),
        ("gain_margin_db", "dB", s.gain_margin_db, ">="),
    ];
    let mut t = Table::new(
        "yield",
        &format!(
            "yield over the tolerance box: {} instruments (seed {}), each at {} inputs across +-full scale ({} cm/s^2), {} gates of {} s each:",
            y.plan.instruments,
            y.plan.seed,
            y.plan.fractions_of_full_scale.len(),
            y.full_scale_cm_s2,
            y.plan.gates,
            y.plan.gate_s
        ),
        &[
            "figure", "unit", "min", "p05", "median", "p95", "max", "spec", "outside",
        ],
    );
    for (name, unit, lim, how) in rows {
        let d = &y.distributions[name];
        t.rows.push(vec![
            text(name),
            text(unit),
            num(d.min, 4),
            num(d.p05, 4),
            num(d.median, 4),
            num(d.p95, 4),
            num(d.max, 4),
            text(lim.map_or_else(|| "-".to_string(), |l| format!("{how} {l}"))),
            text(y.broken.get(name).copied().unwrap_or(0).to_string()),
        ]);
    }
    let mut s = t.to_fixed_text(&[
        Column::left(18),
        Column::left(7),
        Column::right(12),
        Column::right(12),
        Column::right(12),
        Column::right(12),
        Column::right(12),
        Column::left(12),
        Column::right(8),
    ]);
    let _ = writeln!(
        s,
        "within the specification: {} of {} = {:.1} % (95 % Clopper-Pearson interval {:.1} to {:.1} %)",
        y.within_spec,
        y.plan.instruments,
        100.0 * y.yield_fraction,
        100.0 * y.yield_ci95[0],
        100.0 * y.yield_ci95[1]
    );
    s
}
