//! The naming campaigns cut into shards, for a runner beyond one process: Python's
//! `python -m ptsa.campaign hidden`, one Ray task per shard.
//!
//! ```text
//! part(spec, p, n)  for p in 0..n   each a task anywhere: bytes out
//! gather(spec, [bytes of 0, …, n−1], seconds)   the driver: JSON, table, failures
//! ```
//!
//! Shard `p` of `n` is the sets at positions `p`, `p + n`, `p + 2n`, … of the run in table
//! order ([`Run::shard`]), so every shard has its share of every kind. A set's outcome
//! depends on its seed alone, so the gathered run is [`whole`]'s, and its JSON the same
//! bytes, whatever the number of shards or of the workers that ran them. What travels
//! between processes is the spec (five small values) and each shard's outcomes, in
//! `postcard`'s binary form (it keeps every `f64` bit for bit, NaN included, where JSON
//! would turn a NaN into `null`).

use std::fmt;

use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};

use crate::campaign::{Campaign, Outcome, Run};
use crate::effects::Effects;
use crate::lab::Lab;
use crate::params::Params;
use crate::sigma::Sigma;
use crate::statics::Statics;

/// A naming campaign that runs in shards.
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
}

impl Name {
    /// Every campaign, in the order `--help` lists them.
    pub const ALL: [Name; 5] = [
        Name::Effects,
        Name::Statics,
        Name::Params,
        Name::Lab,
        Name::Sigma,
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
    /// Sets per kind.
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
    /// set's outcome in table order (a NaN is `null`) and the asserted rates not met. Holds
    /// no wall time, so that it depends on the spec alone.
    pub json: String,
    /// The sets that matter for the rates, one line each (as `cargo xtask hidden` logs them).
    pub notable: String,
    /// The campaign's table, with `seconds` in its first line.
    pub table: String,
    /// The asserted rates not met (empty: the campaign passes), as in `json`.
    pub failures: Vec<String>,
}

/// Run `$body` with `$c` bound to the campaign `$spec` names.
macro_rules! with_campaign {
    ($spec:expr, $c:ident => $body:expr) => {
        match $spec.name {
            Name::Effects => {
                let $c = Effects::of($spec.analytic);
                $body
            }
            Name::Statics => {
                let $c = Statics::new(!$spec.additive);
                $body
            }
            Name::Params => {
                let $c = Params::new();
                $body
            }
            Name::Lab => {
                let $c = Lab::new($spec.analytic);
                $body
            }
            Name::Sigma => {
                let $c = Sigma::new(None);
                $body
            }
        }
    };
}

/// Shard `part` of `parts` of `spec`'s run, made and analysed: its outcomes as bytes for
/// [`gather`].
///
/// # Errors
/// If `part` is not below `parts`.
pub fn part(spec: &Spec, part: usize, parts: usize) -> Result<Vec<u8>, String> {
    if part >= parts {
        return Err(format!(
            "shard {part} of {parts}: expected a shard below {parts}"
        ));
    }
    with_campaign!(spec, c => encode(&Run::shard(&c, spec.sets, spec.seed, part, parts)))
}

/// `spec`'s run from its shards' bytes, `shards[p]` being shard `p` of `shards.len()`;
/// `seconds` is the wall time the caller measured, for the table.
///
/// # Errors
/// If a shard's bytes cannot be read or do not hold the sets its place says.
pub fn gather(spec: &Spec, shards: &[Vec<u8>], seconds: f64) -> Result<Gathered, String> {
    with_campaign!(spec, c => {
        let outcomes = decode_all(shards)?;
        Ok(put_together(spec, &Run::gather(c, spec.sets, spec.seed, outcomes, seconds)?))
    })
}

/// `spec`'s run in this process ([`Run::new`]).
#[must_use]
pub fn whole(spec: &Spec) -> Gathered {
    with_campaign!(spec, c => put_together(spec, &Run::new(c, spec.sets, spec.seed)))
}

fn encode<T: Serialize>(outcomes: &[Outcome<T>]) -> Result<Vec<u8>, String> {
    postcard::to_stdvec(outcomes).map_err(|e| format!("a shard's outcomes: {e}"))
}

fn decode_all<T: DeserializeOwned>(shards: &[Vec<u8>]) -> Result<Vec<Vec<Outcome<T>>>, String> {
    shards
        .iter()
        .enumerate()
        .map(|(p, b)| {
            postcard::from_bytes(b).map_err(|e| {
                format!(
                    "shard {p} of {}: its bytes are not this campaign's outcomes: {e}",
                    shards.len()
                )
            })
        })
        .collect()
}

fn put_together<C: Campaign>(spec: &Spec, run: &Run<C>) -> Gathered
where
    C::Truth: Serialize,
{
    let failures = run.failures(false);
    let json = serde_json::json!({
        "campaign": spec.name,
        "sets": spec.sets,
        "seed": spec.seed,
        "analytic": spec.analytic,
        "additive": spec.additive,
        "outcomes": run.outcomes,
        "failures": failures,
    });
    Gathered {
        json: json.to_string(),
        notable: run.notable(),
        table: run.table(false),
        failures,
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

    #[test]
    fn shards_out_of_place_are_refused() {
        let s = spec();
        let a = part(&s, 0, 2).unwrap();
        let b = part(&s, 1, 2).unwrap();
        let e = gather(&s, &[b, a.clone()], 0.0).unwrap_err();
        assert!(e.contains("shard 0 of 2: set"), "{e}");
        let e = gather(&s, std::slice::from_ref(&a), 0.0).unwrap_err();
        assert!(e.contains("shard 0 of 1"), "{e}");
        let e = gather(&s, &[a, vec![1, 2, 3]], 0.0).unwrap_err();
        assert!(e.contains("shard 1 of 2: its bytes"), "{e}");
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
