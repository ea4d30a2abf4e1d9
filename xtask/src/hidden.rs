//! `cargo xtask hidden [--sets N] [--seed S] [--analytic]`: the full hidden-effect campaign
//! of the discovery pipeline: N sets (default 50) of every hidden kind (each candidate's
//! physics, physics outside the vocabulary, a bias shift per block, a drift, and nulls with
//! homo- and heteroscedastic noise), made by the closed loop with the physics injected
//! (`--analytic`: by the generator's own quasi-static model, analysed with the analytic
//! simulator), analysed blind. It prints the sets that matter and one table (detection
//! power at 3, 4, 6 and 8 standard errors, partner-only namings, coverage, false selections
//! and confident misnamings per kind), and fails if an asserted rate is not met. It runs
//! the ignored test `hidden_effects_campaign` of `tests/hidden_effects.rs` (the test
//! profile is optimised).
//!
//! `cargo xtask hidden --parameters [--sets N] [--seed S]`: the hidden-parameter campaign
//! instead (`tests/hidden_params.rs`, `hidden_parameters_campaign`): response tables and
//! saturation rows of an instrument file with one parameter changed, or none, identified
//! blind through the closed loop of the shipped file; N sets (default 10) per parameter and
//! design.
//!
//! `cargo xtask hidden --statics [--sets N] [--seed S] [--additive]`: the hidden-statics
//! campaign (`tests/hidden_statics.rs`, `hidden_statics_campaign`): an IA tilt toward PA or
//! OA, a quadratic or cubic term, a bias change or a scale-factor error hidden as physics in
//! the closed loop's plant, measured in 8-, 12- and 24-point tumbles and a centrifuge after
//! an 8-point tumble, recovered blind; N sets (default 200) per kind. `--additive` leaves the
//! loop's parameters out of the pipeline's vocabulary (for comparison).
//!
//! `cargo xtask hidden --lab [--sets N] [--seed S] [--analytic]`: the lab campaign
//! (`tests/hidden_lab.rs`, `hidden_lab_campaign`): a hysteresis in angle and interleaved
//! order, a bias and a scale factor changing with temperature, a warm-up transient, and
//! outside the vocabulary a cross-axis cubic `k·a_PA³` and a sin 4φ tumble harmonic, hidden
//! at 6 and 10 SE in a 24-point tumble about OA, and nulls; N sets (default 140) per kind; `--analytic`: the
//! closed loop's reading of each position plus the physics, analysed with the analytic
//! simulator.
//!
//! `cargo xtask hidden --calibration [--sets N] [--seed S]`: the calibration-coverage
//! campaign (`tests/hidden_calibration.rs`, `hidden_calibration_campaign`): 8-, 12- and
//! 24-point tumbles and two 24-point tumbles generated from the IEEE Std 1293 model
//! equation with the instrument's absolute `K_0`, `K_1`, `δ_o`, `δ_p`, `K_2` drawn per set, analysed
//! with the analytic simulator; the `calibration` object's k = 2 intervals must cover the
//! truth 95 ± 2.5 % of the time; N sets (default 2000).
//!
//! `cargo xtask hidden --sigma [--sets N] [--seed S]`: the understated-sigma campaign
//! (`tests/hidden_sigma.rs`, `hidden_sigma_campaign`): null sets whose stated sigma is the
//! true noise over 1, 1.5, 2, 3 and 4, and sets with one effect at 6 SE, on R-890 Table
//! 6.1's 8 rows and a 24-point tumble about OA, analysed with the analytic simulator; N sets
//! (default 600) per kind.
//!
//! `cargo xtask hidden --triad [--sets N] [--seed S]`: the triad campaign
//! (`tests/hidden_triad.rs`, `hidden_triad_campaign`): triads of 8, 12 and 24 positions on a
//! precision fixture (exact orientations) and of 24 and 37 positions placed by hand (0.5–1°
//! from nominal, `--orientation approximate`), generated from the equations and calibrated
//! blind by the triad's fit; N sets (default 600) per design; the 95 % intervals' coverage
//! asserted within 95 ± 2.5 %.
//!
//! `cargo xtask hidden --stability [--sets N] [--seed S]`: the stability campaign
//! (`tests/hidden_stability.rs`, `hidden_stability_campaign`): constant truths written from
//! the IEEE 1293 equation, the sets in which a selected term is marked unstable counted
//! against the familywise 5 %; N sets in all (default 2000).

use std::fmt::Write as _;

use crate::util::{self, Error};

/// `cargo xtask hidden --help`.
pub const USAGE: &str = "\
hidden [--parameters | --statics [--additive] | --lab | --sigma | --calibration | --triad |
        --stability | --noise-terms] [--sets N] [--seed S] [--analytic]
    The full hidden-effect campaign of the discovery pipeline (the ignored test
    hidden_effects_campaign): N sets per candidate effect and N null sets, generated,
    analysed blind; prints every set and the rates, fails if the contract's are not met.
    --parameters the hidden-parameter campaign instead (hidden_parameters_campaign): the
                 loop's parameters changed in the instrument file, identified from
                 response tables and saturation rows through the closed loop
    --statics    the hidden-statics campaign instead (hidden_statics_campaign): IA
                 tilts, quadratic and cubic terms, bias changes and scale-factor errors
                 hidden in the closed loop's plant, recovered from tumbles and a centrifuge
    --additive   with --statics: the pipeline tests the additive terms only (the loop's
                 parameters left out of its vocabulary)
    --lab        the lab campaign instead (hidden_lab_campaign): a hysteresis in angle
                 and interleaved order, a bias and a scale factor per degree C over a
                 warming ramp, a warm-up transient, a cubic in a_PA and a sin 4phi
                 harmonic, at 6 and 10 SE in a 24-point tumble, and nulls
    --sigma      the understated-sigma campaign instead (hidden_sigma_campaign): nulls
                 whose stated sigma is the true noise over 1, 1.5, 2, 3 and 4, and an
                 effect at 6 SE, on Table 6.1's 8 rows and a 24-point tumble (analytic)
    --calibration the calibration-coverage campaign instead
                 (hidden_calibration_campaign): tumbles of 8, 12 and 24 positions and
                 two 24-point tumbles from the IEEE 1293 equation with absolute
                 coefficients drawn per set (one set in three given as counts over
                 a gate, pulses and ticks); the k = 2 intervals of the calibration
                 must cover the truth 95 +- 2.5 % of the time (analytic)
    --triad      the triad campaign instead (hidden_triad_campaign): triads of 8, 12
                 and 24 positions on a precision fixture and of 24 and 37 placed by
                 hand (0.5-1 deg off), calibrated blind; 95 % coverage asserted
    --stability  the stability campaign instead (hidden_stability_campaign): tumbles of
                 24 and 48 points with constant truths from the IEEE 1293 equation;
                 the share of sets with a term marked unstable, at most 5 % (analytic)
    --noise-terms the noise-terms campaign instead (hidden_terms_campaign): static
                 records of readings with IEEE 952's terms made from their physics
                 (a counter's quantization, white noise, a walk, a ramp, Kasdin's
                 flicker), identified blind by noise --readings --identify; false
                 inclusions at most the familywise 5 %, 95 % coverage asserted
    --sets N     sets per candidate and null sets, a whole number > 0 (default 50;
                 10 per parameter and design with --parameters; 200 per kind with
                 --statics; 140 per kind with --lab; 600 per kind with --sigma;
                 2000 sets in all with --calibration; 600 per design with --triad;
                 2000 sets in all with --stability; 200 per kind with --noise-terms)
    --seed S     seed of the campaign, a whole number (default 4242)
    --analytic   generate with the quasi-static model instead of the closed-loop
                 simulator (faster, no loop dynamics; not with --parameters or
                 --statics; with --lab: the closed loop's reading of each position plus
                 the physics, analysed with the analytic simulator)";

/// One campaign as asked for on the command line, validated.
pub struct Campaign {
    sets: Option<String>,
    seed: Option<String>,
    analytic: bool,
    which: &'static Which,
    additive: bool,
}

/// One campaign: its flag (none for the default), its ignored test (file and name), its
/// default `--sets`, and why `--analytic` is refused with it (`None`: allowed).
struct Which {
    flag: Option<&'static str>,
    test: &'static str,
    name: &'static str,
    default_sets: &'static str,
    no_analytic: Option<&'static str>,
}

/// Every campaign, the default (the hidden-effect one) first.
const CAMPAIGNS: &[Which] = &[
    Which {
        flag: None,
        test: "hidden_effects",
        name: "hidden_effects_campaign",
        default_sets: "50",
        no_analytic: None,
    },
    Which {
        flag: Some("--parameters"),
        test: "hidden_params",
        name: "hidden_parameters_campaign",
        default_sets: "10",
        no_analytic: Some("the parameters are seen through the closed loop only"),
    },
    Which {
        flag: Some("--statics"),
        test: "hidden_statics",
        name: "hidden_statics_campaign",
        default_sets: "200",
        no_analytic: Some(
            "the statics are generated by the closed loop only (its absolute rows are fast)",
        ),
    },
    Which {
        flag: Some("--lab"),
        test: "hidden_lab",
        name: "hidden_lab_campaign",
        default_sets: "140",
        no_analytic: None,
    },
    Which {
        flag: Some("--sigma"),
        test: "hidden_sigma",
        name: "hidden_sigma_campaign",
        default_sets: "600",
        no_analytic: Some("the sigma campaign is analysed with the analytic simulator already"),
    },
    Which {
        flag: Some("--calibration"),
        test: "hidden_calibration",
        name: "hidden_calibration_campaign",
        default_sets: "2000",
        no_analytic: Some(
            "the calibration campaign is analysed with the analytic simulator already",
        ),
    },
    Which {
        flag: Some("--triad"),
        test: "hidden_triad",
        name: "hidden_triad_campaign",
        default_sets: "600",
        no_analytic: Some("the triad's readings come from its own equations"),
    },
    Which {
        flag: Some("--noise-terms"),
        test: "hidden_terms",
        name: "hidden_terms_campaign",
        default_sets: "200",
        no_analytic: Some("the records of readings have no loop to simulate"),
    },
    Which {
        flag: Some("--stability"),
        test: "hidden_stability",
        name: "hidden_stability_campaign",
        default_sets: "2000",
        no_analytic: Some("the stability campaign is analysed with the analytic simulator already"),
    },
];

/// The campaign `args` ask for (`cargo xtask hidden`'s options), validated.
pub fn parse(args: &[String]) -> Result<Campaign, Error> {
    let mut sets: Option<String> = None;
    let mut seed: Option<String> = None;
    let mut analytic = false;
    let mut additive = false;
    let mut which: Option<&'static Which> = None;
    let mut it = args.iter();
    while let Some(a) = it.next() {
        match a.as_str() {
            "--sets" => {
                let n = it
                    .next()
                    .ok_or_else(|| Error::Usage("--sets needs a number".into()))?
                    .clone();
                if n.parse::<usize>().map_or(true, |n| n == 0) {
                    return Err(Error::Usage(format!(
                        "--sets {n}: expected a whole number > 0"
                    )));
                }
                sets = Some(n);
            }
            "--seed" => {
                let s = it
                    .next()
                    .ok_or_else(|| Error::Usage("--seed needs a number".into()))?
                    .clone();
                s.parse::<u64>()
                    .map_err(|_| Error::Usage(format!("--seed {s}: expected a whole number")))?;
                seed = Some(s);
            }
            "--analytic" => analytic = true,
            "--additive" => additive = true,
            other => {
                let c = CAMPAIGNS
                    .iter()
                    .find(|c| c.flag == Some(other))
                    .ok_or_else(|| Error::Usage(format!("unknown option `{other}`")))?;
                if let Some(w) = which.filter(|w| w.flag != c.flag) {
                    return Err(Error::Usage(format!(
                        "{} with {other}: one campaign at a time",
                        w.flag.unwrap_or_default()
                    )));
                }
                which = Some(c);
            }
        }
    }
    let which = which.unwrap_or(&CAMPAIGNS[0]);
    if let (true, Some(why)) = (analytic, which.no_analytic) {
        return Err(Error::Usage(format!(
            "--analytic with {}: {why}",
            which.flag.unwrap_or_default()
        )));
    }
    if additive && which.flag != Some("--statics") {
        return Err(Error::Usage("--additive goes with --statics".into()));
    }
    Ok(Campaign {
        sets,
        seed,
        analytic,
        which,
        additive,
    })
}

#[cfg(test)]
impl Campaign {
    /// The campaign's ignored test.
    pub fn name(&self) -> &'static str {
        self.which.name
    }
}

/// Every campaign's ignored test.
#[cfg(test)]
pub fn campaign_names() -> impl Iterator<Item = &'static str> {
    CAMPAIGNS.iter().map(|c| c.name)
}

/// The campaign's command: `cargo test` of its ignored test, with its sets, seed and
/// switches in the environment; and the command as a person would type it.
pub fn command(c: &Campaign) -> (std::process::Command, String) {
    let Which {
        test,
        name,
        default_sets,
        ..
    } = *c.which;
    let sets = c.sets.clone().unwrap_or_else(|| default_sets.to_string());
    let mut cmd = std::process::Command::new(util::cargo());
    cmd.current_dir(util::root())
        .args([
            "test",
            "-p",
            "ptsa-tests",
            "--test",
            test,
            name,
            "--",
            "--exact",
            "--ignored",
            "--nocapture",
        ])
        .env("PTSA_HIDDEN_SETS", &sets);
    let mut shown = format!("PTSA_HIDDEN_SETS={sets}");
    if let Some(s) = &c.seed {
        cmd.env("PTSA_HIDDEN_SEED", s);
        let _ = write!(shown, " PTSA_HIDDEN_SEED={s}");
    }
    if c.analytic {
        cmd.env("PTSA_HIDDEN_ANALYTIC", "1");
        shown.push_str(" PTSA_HIDDEN_ANALYTIC=1");
    }
    if c.additive {
        cmd.env("PTSA_HIDDEN_ADDITIVE", "1");
        shown.push_str(" PTSA_HIDDEN_ADDITIVE=1");
    }
    let _ = write!(
        shown,
        " cargo test -p ptsa-tests --test {test} {name} -- --exact --ignored --nocapture"
    );
    (cmd, shown)
}

/// `cargo xtask hidden`.
pub fn run(args: &[String]) -> Result<(), Error> {
    let (mut cmd, shown) = command(&parse(args)?);
    eprintln!("+ {shown}");
    let t0 = std::time::Instant::now();
    let status = cmd
        .status()
        .map_err(|e| format!("cannot start cargo: {e}"))?;
    eprintln!(
        "xtask hidden: {:.0} s wall, build included",
        t0.elapsed().as_secs_f64()
    );
    if status.success() {
        Ok(())
    } else {
        Err(format!(
            "the campaign failed ({status}): an asserted rate is not met (NOT MET lines under the table), or the build above failed"
        )
        .into())
    }
}
