//! What a command runs against, for the command line and the Python package alike: the
//! instrument file loaded and its loop checked once ([`Session`]), a gate in clock ticks
//! ([`gate_ticks`]) and the simulator of `discover` and `predict` ([`simulator`]).

use std::path::Path;

use anyhow::{Context as _, Result, bail};

use crate::Instrument;
use crate::discovery::{self, Simulator};
use crate::model::design::{LoopCheck, check_loop};
use crate::model::instrument::{SHIPPED, shipped};
use crate::output::shown_number as num;
use crate::simulation::sim::SimOptions;

/// What every command runs against: the instrument file, loaded and its loop checked
/// once, before any subcommand's own checks.
pub struct Session {
    /// The instrument.
    pub instr: Instrument,
    /// Its name for messages: the path given, or the shipped file's.
    pub name: String,
    /// Its text (for `discover --write-instrument`, which rewrites it).
    pub text: String,
    /// The loop's check (`design::check_loop`): the compensator and margins, or why the
    /// simulator cannot run this loop.
    pub checked: std::result::Result<LoopCheck, String>,
}

impl Session {
    /// The instrument file at `path` (or the shipped one), checked.
    ///
    /// # Errors
    /// The file cannot be read or is not a valid instrument file.
    pub fn load(path: Option<&Path>) -> Result<Self> {
        // A shipped instrument by its name, unless a file of that name is there.
        let name_of = |p: &Path| -> Option<String> {
            p.to_str()
                .filter(|n| shipped(n).is_some() && !p.exists())
                .map(str::to_string)
        };
        let (instr, name, text) = match path {
            Some(p) if name_of(p).is_some() => {
                let n = &name_of(p).unwrap_or_default();
                let (file, text) = shipped(n).unwrap_or_default();
                (
                    Instrument::shipped(n).map_err(anyhow::Error::msg)?,
                    format!("{file} (the shipped `{n}` file, built in)"),
                    text.to_string(),
                )
            }
            Some(p) => {
                let i = Instrument::load(p).map_err(|e| {
                    if e.position().is_none() && !p.exists() {
                        let names: Vec<&str> = SHIPPED.iter().map(|s| s.0).collect();
                        anyhow::anyhow!(
                            "{e}; expected an instrument file or a shipped instrument: {}",
                            names.join(", ")
                        )
                    } else {
                        e.into()
                    }
                })?;
                // Read again for `--write-instrument` (load has validated it as UTF-8).
                let text = std::fs::read_to_string(p)
                    .with_context(|| format!("{}: cannot read", p.display()))?;
                (i, p.display().to_string(), text)
            }
            None => (
                Instrument::kearfott_2401(),
                "data/kearfott-2401.toml (the shipped file, built in)".to_string(),
                crate::model::instrument::KEARFOTT_2401_TOML.to_string(),
            ),
        };
        Ok(Self::checked(instr, name, text))
    }

    /// The instrument file `name` given as its text (a campaign's task on a machine that
    /// does not have the file), checked as [`Session::load`] checks a file: the same
    /// session, the same messages.
    ///
    /// # Errors
    /// The text is not a valid instrument file.
    pub fn of_text(name: &str, text: &str) -> Result<Self> {
        let instr = Instrument::parse(text, name)?;
        Ok(Self::checked(instr, name.to_string(), text.to_string()))
    }

    /// The session of an instrument read, its loop checked.
    fn checked(instr: Instrument, name: String, text: String) -> Self {
        let checked = if instr.has_loop {
            check_loop(&instr)
        } else {
            Err("the file describes an instrument without a PTSA loop".to_string())
        };
        Self {
            instr,
            name,
            text,
            checked,
        }
    }

    /// The instrument file as if it gave `g_cm_s2` for its local gravity
    /// (`--local-gravity`): its text rewritten (so that `--write-instrument` and the sheet
    /// carry the gravity used) and read again, the loop checked again.
    ///
    /// # Errors
    /// The rewritten file is refused.
    pub fn set_local_gravity(&mut self, g_cm_s2: f64) -> Result<()> {
        let note = format!("--local-gravity {g_cm_s2}: the site's gravity, cm/s²");
        let text = Instrument::rewrite_gravity(&self.text, &self.name, g_cm_s2, &note)
            .with_context(|| format!("--local-gravity {g_cm_s2}"))?;
        let mut instr = Instrument::parse(&text, &self.name)?;
        instr.gravity_from_command_line = true;
        self.checked = if instr.has_loop {
            check_loop(&instr)
        } else {
            Err("the file describes an instrument without a PTSA loop".to_string())
        };
        self.instr = instr;
        self.text = text;
        self.name = format!("{} with --local-gravity {g_cm_s2}", self.name);
        Ok(())
    }

    /// The compensator of a loop the simulator can run. Every subcommand but `design` and
    /// `response` (which simulate nothing) asks for it first, so that such a file is
    /// refused before anything else.
    ///
    /// # Errors
    /// The loop check's refusal, under the file's name.
    pub fn config(&self) -> Result<ptsa_core::Config> {
        self.require_loop()?;
        match &self.checked {
            Ok(c) => Ok(c.config),
            Err(e) => bail!("{}: {e}", self.name),
        }
    }

    /// Refuse a file without a PTSA loop, for a command that runs or designs the loop.
    ///
    /// # Errors
    /// The file has no loop: one line naming it and what works with it.
    pub fn require_loop(&self) -> Result<()> {
        if self.instr.has_loop {
            return Ok(());
        }
        bail!(
            "{}: an instrument without a PTSA loop (no [pendulum], [pickoff], [torquer], [electronics], [stops]): this command runs the loop; with this file only discover and predict (on the analytic model), plan and instrument work",
            self.name
        )
    }

    /// The loop's configuration for `discover` and `predict`: the checked loop's, or for a
    /// file without a loop the default (the analytic model, which [`simulator`] then
    /// uses, runs no loop), with a warning when `--seed` is given a value other than the
    /// default, which nothing then uses.
    ///
    /// # Errors
    /// The loop of a file with one cannot be simulated.
    pub fn model_config(&self, seed: u64) -> Result<ptsa_core::Config> {
        if self.instr.has_loop {
            return self.config();
        }
        if seed != SimOptions::default().seed {
            eprintln!(
                "warning: --seed {seed} is not used: {} has no PTSA loop, and the analytic model it is analysed with has no noise to seed",
                self.name
            );
        }
        Ok(ptsa_core::Config::DEFAULT)
    }
}

/// A counting gate of `gate_s` seconds (the option `flag`, which the refusal names), in
/// clock ticks: at least one limit cycle, at most what the core's 32-bit counters hold.
///
/// # Errors
/// The gate is shorter than a limit cycle or longer than the counters hold.
pub fn gate_ticks(flag: &str, gate_s: f64, instr: &Instrument, opts: &SimOptions) -> Result<u64> {
    let per_cycle = f64::from(opts.config.ticks_per_cycle);
    let ticks = (gate_s * instr.clock_hz).round();
    if ticks.is_nan() || ticks < per_cycle {
        bail!(
            "{flag} {}: expected a gate of at least one limit cycle, {} s ({per_cycle} ticks at {} Hz); {} s is {} ticks",
            num(gate_s),
            num(per_cycle / instr.clock_hz),
            num(instr.clock_hz),
            num(gate_s),
            num(ticks)
        );
    }
    let max = f64::from(u32::MAX);
    if ticks > max {
        bail!(
            "{flag} {}: expected a gate of at most {} s, the longest the core's 32-bit counters hold ({} ticks at {} Hz); {} s is {} ticks",
            num(gate_s),
            (max / instr.clock_hz).floor(),
            u32::MAX,
            num(instr.clock_hz),
            num(gate_s),
            num(ticks)
        );
    }
    // Checked: a whole number from one limit cycle to u32::MAX.
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
    Ok(ticks as u64)
}

/// The simulator of `discover` and `predict`: the closed loop of the instrument file, or
/// with `analytic` (and always for a file without a PTSA loop) the quasi-static analytic
/// model.
#[must_use]
pub fn simulator(
    instr: &Instrument,
    config: ptsa_core::Config,
    analytic: bool,
    seed: u64,
) -> Box<dyn Simulator> {
    if analytic || !instr.has_loop {
        Box::new(discovery::AnalyticSimulator::for_instrument(instr))
    } else {
        Box::new(discovery::sim::ClosedLoopSimulator {
            instrument: instr.clone(),
            options: SimOptions {
                seed,
                config,
                ..SimOptions::default()
            },
        })
    }
}
