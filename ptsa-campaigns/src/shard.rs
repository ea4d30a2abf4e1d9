//! The campaigns cut into shards, for a runner beyond one process: Python's
//! `python -m ptsa.campaign hidden`, one Ray task per shard.
//!
//! ```text
//! part(spec, p, n)  for p in 0..n   each a task anywhere: bytes out
//! gather(spec, [bytes of 0, …, n−1], seconds)   the driver: JSON, table, failures
//! ```
//!
//! A run is a list of pieces, each made from the spec and its index alone: a set and its
//! analysis, scored. Shard `p` of `n` is the pieces at positions `p`, `p + n`, `p + 2n`, …,
//! so every shard has its share of every kind. [`gather`] puts them back in order and
//! makes the run from them as [`whole`] does in one process. So the JSON is the same, byte
//! for byte, whatever the number of shards or workers; only wall times differ (the
//! table's, and the triad's fit times in its JSON).
//!
//! What travels between processes: the spec (five small values) out, and back each shard
//! with its spec, its place and its pieces with their indices, checked on gathering. They
//! travel in `postcard`'s binary form, which keeps every `f64` bit for bit (JSON would turn
//! a NaN into `null`).

use std::fmt;

use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};

use rayon::prelude::*;

use crate::calibration::{self, Calibration};
use crate::campaign::{self, Campaign, Run};
use crate::effects::Effects;
use crate::lab::Lab;
use crate::params::Params;
use crate::sigma::Sigma;
use crate::stability::{self, Stability};
use crate::statics::Statics;
use crate::triad::{self, TriadKind};

/// A campaign that runs in shards.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Name {
    /// Candidates' physics, physics outside the vocabulary, bias shifts, drifts, nulls
    /// ([`crate::effects`]; `cargo xtask hidden`).
    Effects,
    /// The model equation's static terms in tumbles and on a centrifuge
    /// ([`crate::statics`]; `cargo xtask hidden --statics`).
    Statics,
    /// A changed loop parameter in response tables ([`crate::params`]; `--parameters`).
    Params,
    /// A test lab's effects in a 24-point tumble ([`crate::lab`]; `--lab`).
    Lab,
    /// An understated sigma ([`crate::sigma`]; `--sigma`).
    Sigma,
    /// The calibration's k = 2 intervals' coverage ([`crate::calibration`]; `--calibration`).
    Calibration,
    /// The triad's intervals' coverage ([`crate::triad`]; `--triad`).
    Triad,
    /// False alarms of the stability test ([`crate::stability`]; `--stability`).
    Stability,
}

impl Name {
    /// Every campaign, in the order `--help` lists them.
    pub const ALL: [Name; 8] = [
        Name::Effects,
        Name::Statics,
        Name::Params,
        Name::Lab,
        Name::Sigma,
        Name::Calibration,
        Name::Triad,
        Name::Stability,
    ];

    /// The name on the command line and in the JSON.
    #[must_use]
    pub fn as_str(self) -> &'static str {
        match self {
            Name::Effects => "effects",
            Name::Statics => "statics",
            Name::Params => "params",
            Name::Lab => "lab",
            Name::Sigma => "sigma",
            Name::Calibration => "calibration",
            Name::Triad => "triad",
            Name::Stability => "stability",
        }
    }

    /// The campaign called `s`.
    ///
    /// # Errors
    /// If no campaign is called `s` (the message lists them).
    pub fn parse(s: &str) -> Result<Name, String> {
        Name::ALL
            .into_iter()
            .find(|n| n.as_str() == s)
            .ok_or_else(|| {
                let names: Vec<&str> = Name::ALL.iter().map(|n| n.as_str()).collect();
                format!(
                    "no campaign is called {s:?}: expected one of {}",
                    names.join(", ")
                )
            })
    }
}

impl fmt::Display for Name {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

/// One campaign run, as the driver and every task see it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Spec {
    /// The campaign.
    pub name: Name,
    /// Sets per kind (`calibration`, `stability`: sets in all).
    pub sets: usize,
    /// The campaign's seed (a set's seed is made from it, the kind and the set's index).
    pub seed: u64,
    /// `effects` and `lab`: the data from the generator's quasi-static model, analysed with
    /// the analytic simulator (fast, no loop dynamics).
    pub analytic: bool,
    /// `statics`: the loop's parameters left out of the pipeline's vocabulary.
    pub additive: bool,
}

impl Spec {
    /// A spec, checked: at least one set per kind, `analytic` only where the campaign has
    /// it, `additive` only for `statics`.
    ///
    /// # Errors
    /// What is wrong, in the command line's words.
    pub fn new(
        name: Name,
        sets: usize,
        seed: u64,
        analytic: bool,
        additive: bool,
    ) -> Result<Spec, String> {
        if sets == 0 {
            return Err("--sets: expected at least 1 set per kind".into());
        }
        if analytic && !matches!(name, Name::Effects | Name::Lab) {
            return Err(format!(
                "--analytic: only the effects and lab campaigns have it, not {name}"
            ));
        }
        if additive && name != Name::Statics {
            return Err(format!(
                "--additive: only the statics campaign has it, not {name}"
            ));
        }
        Ok(Spec {
            name,
            sets,
            seed,
            analytic,
            additive,
        })
    }
}

/// A campaign run put together: what the command prints.
#[derive(Clone, Debug)]
pub struct Gathered {
    /// `{"campaign", "sets", "seed", "analytic", "additive", "outcomes", "failures"}`: every
    /// set's outcome in table order (a NaN is `null`) and the asserted rates not met. It
    /// holds no wall time, so that it depends on the spec alone, but for the `triad`
    /// campaign's fit times (`seconds` of each outcome).
    pub json: String,
    /// The sets that matter for the rates, one line each (as `cargo xtask hidden` logs them).
    pub notable: String,
    /// The campaign's table (the naming and triad campaigns' first line gives `seconds`).
    pub table: String,
    /// The asserted rates not met (empty: the campaign passes), as in `json`.
    pub failures: Vec<String>,
}

/// A campaign run as a list of pieces.
trait Sharded: Sync {
    /// A set and its analysis, scored.
    type Piece: Serialize + DeserializeOwned + Send;
    /// Pieces in the run.
    fn count(&self) -> usize;
    /// Piece `i`, made and analysed.
    fn piece(&self, i: usize) -> Self::Piece;
    /// Pieces are made in parallel (`false`: each one keeps every core busy already).
    fn parallel(&self) -> bool {
        true
    }
    /// The run from every piece, in order; `seconds` its wall time.
    fn finish(self, pieces: Vec<Self::Piece>, seconds: f64) -> Finished;
}

/// A naming campaign's run: its sets are [`campaign::jobs`].
struct Naming<C: Campaign> {
    campaign: C,
    sets: usize,
    seed: u64,
    jobs: Vec<(u64, C::Kind)>,
}

impl<C: Campaign> Naming<C> {
    fn new(campaign: C, spec: &Spec) -> Self {
        let jobs = campaign::jobs(&campaign, spec.sets, spec.seed);
        Naming {
            campaign,
            sets: spec.sets,
            seed: spec.seed,
            jobs,
        }
    }
}

impl<C: Campaign> Sharded for Naming<C>
where
    C::Truth: Serialize + DeserializeOwned,
{
    type Piece = campaign::Outcome<C::Truth>;
    fn count(&self) -> usize {
        self.jobs.len()
    }
    fn piece(&self, i: usize) -> Self::Piece {
        campaign::analyse_job(&self.campaign, self.jobs[i])
    }
    fn parallel(&self) -> bool {
        C::PARALLEL
    }
    fn finish(self, outcomes: Vec<Self::Piece>, seconds: f64) -> Finished {
        let run = Run {
            campaign: self.campaign,
            sets: self.sets,
            seed: self.seed,
            outcomes,
            seconds,
        };
        let failures = run.failures(false);
        finished(&run.outcomes, run.notable(), run.table(false), failures)
    }
}

/// The calibration-coverage campaign's run.
struct CoverageOfCalibration(usize, u64);

impl Sharded for CoverageOfCalibration {
    type Piece = calibration::SetScores;
    fn count(&self) -> usize {
        self.0
    }
    fn piece(&self, i: usize) -> Self::Piece {
        calibration::piece(self.1, i as u64)
    }
    fn finish(self, pieces: Vec<Self::Piece>, _seconds: f64) -> Finished {
        let c = Calibration::from_pieces(self.0, &pieces);
        finished(&pieces, String::new(), c.table(), c.failures(false))
    }
}

/// The stability campaign's run.
struct FalseInstability(usize, u64);

impl Sharded for FalseInstability {
    type Piece = stability::SetScore;
    fn count(&self) -> usize {
        self.0
    }
    fn piece(&self, i: usize) -> Self::Piece {
        stability::piece(self.1, i as u64)
    }
    fn finish(self, pieces: Vec<Self::Piece>, _seconds: f64) -> Finished {
        let json = serde_json::to_value(&pieces).unwrap_or_default();
        let c = Stability::from_pieces(self.0, pieces);
        finished(&json, String::new(), c.table(), c.failures())
    }
}

/// The triad campaign's run: `sets` of every kind, kind by kind.
struct TriadCoverage(usize, u64);

impl Sharded for TriadCoverage {
    type Piece = triad::SetScore;
    fn count(&self) -> usize {
        TriadKind::ALL.len() * self.0
    }
    fn piece(&self, i: usize) -> Self::Piece {
        triad::piece_at(self.1, self.0, i)
    }
    fn finish(self, pieces: Vec<Self::Piece>, seconds: f64) -> Finished {
        let json = serde_json::to_value(&pieces).unwrap_or_default();
        let r = triad::from_pieces(self.0, self.1, pieces, seconds);
        finished(&json, String::new(), r.table(false), r.failures(false))
    }
}

/// Run `$body` with `$c` bound to the run `$spec` names.
macro_rules! with_run {
    ($spec:expr, $c:ident => $body:expr) => {
        match $spec.name {
            Name::Effects => {
                let $c = Naming::new(Effects::of($spec.analytic), $spec);
                $body
            }
            Name::Statics => {
                let $c = Naming::new(Statics::new(!$spec.additive), $spec);
                $body
            }
            Name::Params => {
                let $c = Naming::new(Params::new(), $spec);
                $body
            }
            Name::Lab => {
                let $c = Naming::new(Lab::new($spec.analytic), $spec);
                $body
            }
            Name::Sigma => {
                let $c = Naming::new(Sigma::new(None), $spec);
                $body
            }
            Name::Calibration => {
                let $c = CoverageOfCalibration($spec.sets, $spec.seed);
                $body
            }
            Name::Triad => {
                let $c = TriadCoverage($spec.sets, $spec.seed);
                $body
            }
            Name::Stability => {
                let $c = FalseInstability($spec.sets, $spec.seed);
                $body
            }
        }
    };
}

/// Shard `part` of `parts` of `spec`'s run, made and analysed: its pieces with their
/// indices, as bytes for [`gather`].
///
/// # Errors
/// If `part` is not below `parts`.
pub fn part(spec: &Spec, part: usize, parts: usize) -> Result<Vec<u8>, String> {
    if part >= parts {
        return Err(format!(
            "shard {part} of {parts}: expected a shard below {parts}"
        ));
    }
    with_run!(spec, r => {
        let mine: Vec<usize> = (part..r.count()).step_by(parts).collect();
        encode(spec, part, parts, make(&r, &mine))
    })
}

/// `spec`'s run from its shards' bytes, `shards[p]` being shard `p` of `shards.len()`;
/// `seconds` is the wall time the caller measured, for the table.
///
/// # Errors
/// If a shard's bytes cannot be read or do not hold the pieces its place says.
pub fn gather(spec: &Spec, shards: &[Vec<u8>], seconds: f64) -> Result<Gathered, String> {
    with_run!(spec, r => {
        let pieces = put_in_order(spec, r.count(), shards)?;
        Ok(gathered(spec, r.finish(pieces, seconds)))
    })
}

/// `spec`'s run in this process, on every core.
#[must_use]
pub fn whole(spec: &Spec) -> Gathered {
    with_run!(spec, r => {
        let t0 = std::time::Instant::now();
        let all: Vec<usize> = (0..r.count()).collect();
        let pieces = make(&r, &all).into_iter().map(|(_, p)| p).collect();
        gathered(spec, r.finish(pieces, t0.elapsed().as_secs_f64()))
    })
}

/// Pieces `indices` of `r`, each with its index; before each, a point where a host's
/// Ctrl-C may stop the work (`work::checkpoint`).
fn make<R: Sharded>(r: &R, indices: &[usize]) -> Vec<(usize, R::Piece)> {
    let one = |i: usize| {
        ptsa_host_sim::simulation::work::checkpoint();
        (i, r.piece(i))
    };
    if r.parallel() {
        indices.par_iter().map(|&i| one(i)).collect()
    } else {
        indices.iter().map(|&i| one(i)).collect()
    }
}

/// A shard as it travels: the run it belongs to, its place, its pieces.
#[derive(Serialize, Deserialize)]
struct Shard<P> {
    spec: Spec,
    part: usize,
    parts: usize,
    pieces: Vec<(usize, P)>,
}

fn encode<P: Serialize>(
    spec: &Spec,
    part: usize,
    parts: usize,
    pieces: Vec<(usize, P)>,
) -> Result<Vec<u8>, String> {
    let shard = Shard {
        spec: *spec,
        part,
        parts,
        pieces,
    };
    postcard::to_stdvec(&shard).map_err(|e| format!("a shard's outcomes: {e}"))
}

/// The `count` pieces of `spec`'s run from its shards, in order.
fn put_in_order<P: DeserializeOwned>(
    spec: &Spec,
    count: usize,
    shards: &[Vec<u8>],
) -> Result<Vec<P>, String> {
    let parts = shards.len();
    if parts == 0 {
        return Err("no shards: expected shards 0 to n - 1 of the run, in order".into());
    }
    let mut slots: Vec<Option<P>> = std::iter::repeat_with(|| None).take(count).collect();
    for (p, bytes) in shards.iter().enumerate() {
        let shard: Shard<P> = match postcard::take_from_bytes(bytes) {
            Ok((shard, [])) => shard,
            Ok(_) | Err(_) => {
                return Err(format!(
                    "shard {p} of {parts}: its bytes are not a shard of a {} campaign",
                    spec.name
                ));
            }
        };
        if shard.spec != *spec || (shard.part, shard.parts) != (p, parts) {
            return Err(format!(
                "shard {p} of {parts}: it is shard {} of {} of another run ({:?}), not of {:?}",
                shard.part, shard.parts, shard.spec, spec
            ));
        }
        for (i, piece) in shard.pieces {
            if i >= count || i % parts != p || slots[i].is_some() {
                return Err(format!(
                    "shard {p} of {parts}: set {i} is not this shard's (a run of {count} sets)"
                ));
            }
            slots[i] = Some(piece);
        }
    }
    slots
        .into_iter()
        .enumerate()
        .map(|(i, s)| {
            s.ok_or_else(|| format!("shard {} of {parts}: set {i} missing", i % parts.max(1)))
        })
        .collect()
}

/// What a run's [`Sharded::finish`] makes of its pieces.
struct Finished {
    outcomes: serde_json::Value,
    notable: String,
    table: String,
    failures: Vec<String>,
}

fn finished<O: Serialize + ?Sized>(
    outcomes: &O,
    notable: String,
    table: String,
    failures: Vec<String>,
) -> Finished {
    Finished {
        // Plain data (numbers, strings, lists): it always converts; a NaN is `null`.
        outcomes: serde_json::to_value(outcomes).unwrap_or_default(),
        notable,
        table,
        failures,
    }
}

/// The spec's run as the command prints it.
fn gathered(spec: &Spec, f: Finished) -> Gathered {
    let json = serde_json::json!({
        "campaign": spec.name,
        "sets": spec.sets,
        "seed": spec.seed,
        "analytic": spec.analytic,
        "additive": spec.additive,
        "outcomes": f.outcomes,
        "failures": f.failures,
    });
    Gathered {
        json: json.to_string(),
        notable: f.notable,
        table: f.table,
        failures: f.failures,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spec() -> Spec {
        Spec::new(Name::Sigma, 1, 7, false, false).unwrap()
    }

    #[test]
    fn shards_gathered_are_the_whole_run_whatever_their_count() {
        let s = spec();
        let whole = whole(&s);
        for parts in [1, 3] {
            let shards: Vec<Vec<u8>> = (0..parts).map(|p| part(&s, p, parts).unwrap()).collect();
            let g = gather(&s, &shards, 0.0).unwrap();
            assert_eq!(g.json, whole.json, "{parts} shards");
            assert_eq!(g.failures, whole.failures);
        }
    }

    /// The JSON without the triad's fit times (`seconds`), the one figure that differs.
    fn timeless(json: &str) -> serde_json::Value {
        let mut v: serde_json::Value = serde_json::from_str(json).unwrap();
        for o in v["outcomes"].as_array_mut().unwrap() {
            o.as_object_mut().unwrap().remove("seconds");
        }
        v
    }

    #[test]
    fn coverage_and_stability_campaigns_in_shards_are_the_whole_run() {
        for (name, sets) in [
            (Name::Calibration, 3),
            (Name::Stability, 2),
            (Name::Triad, 1),
        ] {
            let s = Spec::new(name, sets, 5, false, false).unwrap();
            let whole = whole(&s);
            let shards: Vec<Vec<u8>> = (0..2).map(|p| part(&s, p, 2).unwrap()).collect();
            let g = gather(&s, &shards, 0.0).unwrap();
            assert_eq!(timeless(&g.json), timeless(&whole.json), "{name}");
            assert_eq!(g.failures, whole.failures, "{name}");
            if name != Name::Triad {
                assert_eq!(g.table, whole.table, "{name}");
            }
        }
    }

    #[test]
    fn shards_out_of_place_are_refused() {
        let s = spec();
        let a = part(&s, 0, 2).unwrap();
        let b = part(&s, 1, 2).unwrap();
        let e = gather(&s, &[b.clone(), a.clone()], 0.0).unwrap_err();
        assert!(e.contains("shard 0 of 2: it is shard 1 of 2"), "{e}");
        let e = gather(&s, std::slice::from_ref(&a), 0.0).unwrap_err();
        assert!(e.contains("shard 0 of 1: it is shard 0 of 2"), "{e}");
        let e = gather(&s, &[a.clone(), vec![1, 2, 3]], 0.0).unwrap_err();
        assert!(e.contains("shard 1 of 2: its bytes are not"), "{e}");
        let other = Spec { seed: 8, ..s };
        let c = part(&other, 1, 2).unwrap();
        let e = gather(&s, &[a.clone(), c], 0.0).unwrap_err();
        assert!(e.contains("of another run"), "{e}");
        let mut longer = a.clone();
        longer.push(0);
        let e = gather(&s, &[longer, b], 0.0).unwrap_err();
        assert!(e.contains("shard 0 of 2: its bytes are not"), "{e}");
        assert!(gather(&s, &[], 0.0).unwrap_err().contains("no shards"));
    }

    #[test]
    fn specs_a_campaign_does_not_have_are_refused() {
        assert!(Spec::new(Name::Sigma, 0, 1, false, false).is_err());
        let e = Spec::new(Name::Params, 1, 1, true, false).unwrap_err();
        assert!(e.contains("--analytic"), "{e}");
        let e = Spec::new(Name::Effects, 1, 1, false, true).unwrap_err();
        assert!(e.contains("--additive"), "{e}");
        let e = Name::parse("efects").unwrap_err();
        assert!(e.contains("effects, statics, params, lab, sigma"), "{e}");
        assert_eq!(Name::parse("lab"), Ok(Name::Lab));
    }
}
