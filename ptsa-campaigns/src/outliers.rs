//! The outlier test of `ptsa discover` (`ptsa_host_sim::discovery::outliers`) on the
//! generator's sets: its false alarms on clean sets, and what it finds when one reading is
//! written wrong the way a lab writes one wrong.
//!
//! The slips are written from what happens at the bench, not from the test's statistic:
//! a decimal point shifted one place (the value ten times what was read), the sign lost, the
//! line above copied into a row, and on a tumble a `g_ia` cell left empty (read as 0 g while
//! the reading was taken at the row's true position).

use ptsa_host_sim::discovery::discover_with;
use ptsa_host_sim::discovery::sim::{AnalyticSimulator, ClosedLoopSimulator};
use ptsa_host_sim::discovery::{discover, outliers};
use ptsa_host_sim::model::caseframe::EmptyCells;
use ptsa_host_sim::simulation::sim::SimOptions;
use rayon::prelude::*;

use super::campaign::binomial_upper_tail;
use super::effects::additive;
use super::statics::{self, StaticKind};
use super::*;

fn analytic() -> AnalyticSimulator {
    AnalyticSimulator::for_instrument(&ptsa_host_sim::Instrument::kearfott_2401())
}

/// Sets of `kinds` (in turn) from seed `base`, analysed blind: how many have a row flagged.
fn flagged(base: u64, n: u64, kinds: &[Kind]) -> usize {
    let source = Generator::quasi_static();
    (0..n)
        .into_par_iter()
        .filter(|&k| {
            #[allow(clippy::cast_possible_truncation)]
            let kind = kinds[(k % kinds.len() as u64) as usize];
            let set = generate(base + k, kind, &source, &GenOptions::default());
            let d = discover(&set.rows, &analytic(), &additive()).unwrap();
            !d.json.outliers.is_empty()
        })
        .count()
}

/// Clean sets (the three null kinds: homoscedastic noise with the sigma stated or not,
/// noise differing tenfold between variance groups, noise growing with `|w_IA·w_PA|`; and
/// sets with one candidate's physics at 2–24 SE): the sets with a row flagged are
/// consistent with at most the test's familywise level, 1 % (one-sided binomial test at
/// 1 %: 300 sets of each class fail at 8 or more, a test at a true 5 % fails with
/// probability 0.999).
#[test]
fn the_outlier_test_keeps_its_level_on_clean_sets() {
    let n = 300;
    let nulls = flagged(
        50_000,
        n,
        &[Kind::Null, Kind::NullHetGroups, Kind::NullHetRate],
    );
    let candidates: Vec<Kind> = Kind::all()
        .into_iter()
        .filter(|k| k.class() == Class::Candidate)
        .collect();
    let effects = flagged(60_000, n, &candidates);
    eprintln!(
        "outlier test on clean sets: {nulls}/{n} null sets, {effects}/{n} sets with an effect flagged"
    );
    for (what, k) in [("null sets", nulls), ("sets with one effect", effects)] {
        #[allow(clippy::cast_possible_truncation)]
        let tail = binomial_upper_tail(n as usize, outliers::ALPHA, k);
        assert!(
            tail >= 0.01,
            "{what}: {k}/{n} flagged: P(>= {k}) = {tail:.2e} at the level {}",
            outliers::ALPHA
        );
    }
}

/// A slip of the pen in one row.
#[derive(Clone, Copy, Debug)]
enum Slip {
    /// The decimal point one place to the right.
    Decimal,
    /// The sign lost.
    Sign,
    /// The line above copied in.
    Copied,
    /// The units digit typed wrong (by 1 to 9).
    Digit,
}

/// One row of a clean set written wrong ([`Slip`], in turn), in sets of every kind but the
/// out-of-vocabulary ones: in designs of 10 rows or more, a slip of at least 20 times the
/// set's noise is flagged in 95 % of the sets or more, and 10 to 20 times in 75 % or more;
/// another row than the slipped one is flagged in at most 2 % of all sets. Designs of
/// fewer rows are shown, not asserted: with six or eight rows and up to five terms the
/// held-out test keeps one to three degrees of freedom and needs a slip of 50 noise
/// standard deviations or more.
#[test]
fn a_slip_of_the_pen_is_found_and_set_aside() {
    let source = Generator::quasi_static();
    let kinds: Vec<Kind> = Kind::all()
        .into_iter()
        .filter(|k| matches!(k.class(), Class::Candidate | Class::Null))
        .collect();
    let n = 320u64;
    let results: Vec<(f64, bool, bool, String, usize)> = (0..n)
        .into_par_iter()
        .map(|k| {
            #[allow(clippy::cast_possible_truncation)]
            let kind = kinds[(k % kinds.len() as u64) as usize];
            let mut set = generate(70_000 + k, kind, &source, &GenOptions::default());
            let sigma: f64 = set.truth.sigma.parse().unwrap_or(f64::NAN);
            let mut r = rng(80_000 + k);
            let j = r.int(1, set.rows.len() - 1);
            let read = set.rows[j].measured_cm_s2.unwrap();
            let slip = [Slip::Decimal, Slip::Sign, Slip::Copied, Slip::Digit][(k % 4) as usize];
            #[allow(clippy::cast_precision_loss)]
            let written = match slip {
                Slip::Decimal => 10.0 * read,
                Slip::Sign => -read,
                Slip::Copied => set.rows[j - 1].measured_cm_s2.unwrap(),
                Slip::Digit => read + r.sign() * r.int(1, 9) as f64,
            };
            set.rows[j].measured_cm_s2 = Some(written);
            let d = discover(&set.rows, &analytic(), &additive()).unwrap();
            let label = &set.rows[j].label;
            let found = d.json.outliers.iter().any(|o| &o.row == label);
            let other = d.json.outliers.iter().any(|o| &o.row != label);
            let what = format!(
                "{slip:?} {} in {} ({} rows, sigma {})",
                kind.name(),
                set.truth.design.name(),
                set.rows.len(),
                set.truth.sigma
            );
            (
                (written - read).abs() / sigma,
                found,
                other,
                what,
                set.rows.len(),
            )
        })
        .collect();
    let band = |lo: f64, hi: f64, small: bool| -> (usize, usize) {
        let b: Vec<_> = results
            .iter()
            .filter(|r| r.0 >= lo && r.0 < hi && (r.4 < 10) == small)
            .collect();
        (b.iter().filter(|r| r.1).count(), b.len())
    };
    let (g20, n20) = band(20.0, f64::INFINITY, false);
    let (g10, n10) = band(10.0, 20.0, false);
    let (g5, n5) = band(5.0, 10.0, false);
    let (s20, m20) = band(20.0, f64::INFINITY, true);
    let other = results.iter().filter(|r| r.2).count();
    eprintln!(
        "slips found, designs of 10 rows or more: >= 20 sigma {g20}/{n20}, 10-20 sigma {g10}/{n10}, 5-10 sigma {g5}/{n5}; fewer rows, >= 20 sigma {s20}/{m20}; another row flagged in {other}/{}",
        results.len()
    );
    for r in results.iter().filter(|r| r.0 >= 10.0 && !r.1) {
        eprintln!("missed at {:.1} sigma: {}", r.0, r.3);
    }
    #[allow(clippy::cast_precision_loss)]
    let rate = |k: usize, n: usize| k as f64 / n.max(1) as f64;
    assert!(n20 >= 40 && rate(g20, n20) >= 0.95, "{g20}/{n20}");
    assert!(n10 >= 20 && rate(g10, n10) >= 0.75, "{g10}/{n10}");
    assert!(
        rate(other, results.len()) <= 0.02,
        "{other}/{}",
        results.len()
    );
}

/// Tumbles (the statics campaign's designs and its closed-loop data: 8-, 12- and 24-point
/// tumbles and a centrifuge after an 8-point tumble, unperturbed or with a static effect)
/// with the `g_ia` cell of one row where `|g_ia| ≥ 0.5` left empty: the reading, taken at
/// the row's true position, is then read as taken at `g_ia = 0`, 490 cm/s² off or more. With
/// the reader's record of the empty cell the row is flagged and the empty cell named as its
/// cause in every set; without the record (a 0 typed in) it is flagged all the same.
#[test]
fn an_empty_g_cell_in_a_tumble_is_found_and_named() {
    let sim = ClosedLoopSimulator {
        instrument: ptsa_host_sim::Instrument::kearfott_2401(),
        options: SimOptions::default(),
    };
    let kinds = [
        StaticKind::Unperturbed,
        StaticKind::BiasChange,
        StaticKind::TiltTowardPa,
        StaticKind::Quadratic,
    ];
    let results: Vec<(bool, bool, bool)> = (0..12u64)
        .into_par_iter()
        .map(|k| {
            #[allow(clippy::cast_possible_truncation)]
            let mut set = statics::generate(90_000 + k, kinds[(k % 4) as usize]);
            let mut r = rng(91_000 + k);
            let candidates: Vec<usize> = (0..set.rows.len())
                .filter(|&i| set.rows[i].g[0].abs() >= 0.5)
                .collect();
            let j = candidates[r.int(0, candidates.len() - 1)];
            set.rows[j].g[0] = 0.0;
            let empty = [EmptyCells {
                row: j,
                line: j + 2,
                columns: vec!["g_ia"],
            }];
            let opts = statics::options(true);
            let label = set.rows[j].label.clone();
            let with = discover_with(&set.rows, &empty, &sim, &opts).unwrap();
            let named = with
                .json
                .outliers
                .iter()
                .any(|o| o.row == label && o.cause.contains("its cell `g_ia`") && !o.kept);
            let alone = with.json.outliers.len() == 1;
            let without = discover(&set.rows, &sim, &opts).unwrap();
            let found = without.json.outliers.iter().any(|o| o.row == label);
            (named, alone, found)
        })
        .collect();
    eprintln!("empty g_ia cells: {results:?}");
    assert!(results.iter().all(|r| r.0 && r.1), "{results:?}");
    assert!(results.iter().all(|r| r.2), "{results:?}");
}
