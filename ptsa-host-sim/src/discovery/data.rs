//! The measured rows as the method sees them: residual to explain (measured − baseline),
//! stated sigmas, blocks, times, variance groups, replicates, the signature of every
//! candidate and the generic basis of the case inputs used to look for unexplained
//! structure.

use std::collections::BTreeMap;

use super::sim::{AnalyticSimulator, Simulator, gross_effect_cm_s2};
use crate::condition::{CaseInputs, Condition};
use crate::effects::{CandidateId, Effects};

/// How the drift term's time is measured.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TimeUnit {
    /// The case frame's `time_s`, s.
    Seconds,
    /// Row order (no `time_s` column), rows.
    Row,
}

/// One candidate's signature over the fitted rows.
#[derive(Clone, Debug)]
pub struct Signature {
    /// The candidate.
    pub id: CandidateId,
    /// Predicted condition − reference difference per unit coefficient, cm/s² per unit.
    pub col: Vec<f64>,
    /// Identically zero here (every entry cancels to rounding between condition and
    /// reference).
    pub null: bool,
}

/// The fitted rows.
#[derive(Clone, Debug)]
pub struct Data {
    /// Index of each fitted row in the caller's rows.
    pub rows: Vec<usize>,
    /// Measured values, cm/s².
    pub y: Vec<f64>,
    /// Baseline (simulated) values, cm/s².
    pub base: Vec<f64>,
    /// Stated sigmas (the row's `sigma_cm_s2`, else the explicit `--sigma`), cm/s².
    pub stated: Vec<Option<f64>>,
    /// Whether each row is absolute (else a difference).
    pub absolute: Vec<bool>,
    /// Block of each row (index into `block_names`).
    pub block: Vec<usize>,
    /// Block names (`"all"` when the file has no `block` column).
    pub block_names: Vec<String>,
    /// Time of each row, in `time_unit`.
    pub time: Vec<f64>,
    /// What `time` is.
    pub time_unit: TimeUnit,
    /// Variance group of each row (index into `group_names`): block × excitation.
    pub group: Vec<usize>,
    /// Variance group names.
    pub group_names: Vec<String>,
    /// Replicate set of each row: rows with identical conditions (and block) share it.
    pub replicate: Vec<usize>,
    /// Signatures of the candidates asked for, in registry order.
    pub signatures: Vec<Signature>,
    /// The generic basis: `(name, column)`.
    pub features: Vec<(String, Vec<f64>)>,
}

impl Data {
    /// Number of fitted rows.
    #[must_use]
    pub fn n(&self) -> usize {
        self.y.len()
    }

    /// Residual to explain, `measured − baseline`, cm/s².
    #[must_use]
    pub fn resid(&self, i: usize) -> f64 {
        self.y[i] - self.base[i]
    }
}

/// The excitation of a row, for its variance group.
fn excitation(c: &Condition) -> &'static str {
    if c.is_static() {
        "static"
    } else {
        "oscillating"
    }
}

/// The key of a row's conditions, equal for replicated rows (bit-identical inputs).
fn replicate_key(c: &Condition) -> Vec<u64> {
    let mut k: Vec<u64> = Vec::with_capacity(24);
    for v in [
        c.g,
        c.w_rad_s,
        c.lin_cm_s2,
        c.lin_deg,
        c.ang_mrad,
        c.ang_deg,
        c.ref_w_rad_s,
    ] {
        k.extend(v.iter().map(|x| x.to_bits()));
    }
    k.push(c.freq_hz.to_bits());
    k
}

/// Index of `key` in `names`, appended if new.
fn intern(names: &mut Vec<String>, key: String) -> usize {
    if let Some(i) = names.iter().position(|n| *n == key) {
        i
    } else {
        names.push(key);
        names.len() - 1
    }
}

/// Build the data of the rows with a measurement. `baseline` is the simulator's value of
/// every row; `default_sigma` the explicit `--sigma`, if any.
///
/// # Errors
/// `time_s` given on some measured rows but not on others.
pub fn build(
    rows: &[Condition],
    baseline: &[f64],
    default_sigma: Option<f64>,
    candidates: &[CandidateId],
    sim: &dyn Simulator,
) -> anyhow::Result<Data> {
    let fitted: Vec<usize> = (0..rows.len())
        .filter(|&i| rows[i].measured_cm_s2.is_some())
        .collect();
    let with_time = fitted.iter().filter(|&&i| rows[i].time_s.is_some()).count();
    if with_time > 0 && with_time < fitted.len() {
        let i = fitted
            .iter()
            .find(|&&i| rows[i].time_s.is_none())
            .copied()
            .unwrap_or(0);
        anyhow::bail!(
            "`time_s` is given for {with_time} of the {} measured rows but not for row {} (`{}`); expected it on every measured row or on none (then the drift is fitted in row order)",
            fitted.len(),
            i + 1,
            rows[i].label
        );
    }
    let time_unit = if with_time > 0 {
        TimeUnit::Seconds
    } else {
        TimeUnit::Row
    };
    let mut block_names = Vec::new();
    let mut group_names = Vec::new();
    let mut keys: Vec<Vec<u64>> = Vec::new();
    let (mut block, mut group, mut replicate, mut time) = (vec![], vec![], vec![], vec![]);
    for (k, &i) in fitted.iter().enumerate() {
        let r = &rows[i];
        let b = r.block.clone().unwrap_or_else(|| "all".to_string());
        let bi = intern(&mut block_names, b.clone());
        block.push(bi);
        group.push(intern(&mut group_names, format!("{b}/{}", excitation(r))));
        let mut key = replicate_key(r);
        key.push(bi as u64);
        replicate.push(if let Some(p) = keys.iter().position(|x| *x == key) {
            p
        } else {
            keys.push(key);
            keys.len() - 1
        });
        #[allow(clippy::cast_precision_loss)]
        time.push(r.time_s.unwrap_or(k as f64));
    }
    let g = sim.g_cm_s2();
    let fitted_rows: Vec<&Condition> = fitted.iter().map(|&i| &rows[i]).collect();
    Ok(Data {
        y: fitted
            .iter()
            .map(|&i| rows[i].measured_cm_s2.unwrap_or(0.0))
            .collect(),
        base: fitted.iter().map(|&i| baseline[i]).collect(),
        absolute: fitted
            .iter()
            .map(|&i| rows[i].kind == crate::condition::RowKind::Absolute)
            .collect(),
        stated: fitted
            .iter()
            .map(|&i| rows[i].sigma_cm_s2.or(default_sigma))
            .collect(),
        block,
        block_names,
        time,
        time_unit,
        group,
        group_names,
        replicate,
        signatures: signatures(&fitted_rows, candidates, g),
        features: features(&fitted_rows, g),
        rows: fitted,
    })
}

/// Signature columns: the analytic effect of each row with a unit coefficient (a difference
/// or an absolute value by the row's kind; exact for these linear terms: the loop indicates
/// their time average), and whether the column is identically zero here (every entry cancels
/// to rounding against the gross size of the term in the condition and its reference).
#[must_use]
pub fn signatures(rows: &[&Condition], candidates: &[CandidateId], g_cm_s2: f64) -> Vec<Signature> {
    let analytic = AnalyticSimulator {
        g_cm_s2,
        bias_cm_s2: 0.0,
        loop_bias: [0.0; 2],
    };
    candidates
        .iter()
        .map(|&id| {
            let e = Effects::only(id, 1.0);
            // Entries that cancel to rounding (a mean of a sinusoid over its samples) are 0.
            let col: Vec<f64> = rows
                .iter()
                .map(|r| {
                    let x = analytic.effect_cm_s2(r, &e);
                    if x.abs() <= 1e-9 * gross_effect_cm_s2(r, &e, g_cm_s2) {
                        0.0
                    } else {
                        x
                    }
                })
                .collect();
            let null = col.iter().all(|&x| x == 0.0);
            Signature { id, col, null }
        })
        .collect()
}

/// Samples per oscillation period for the time averages (exact for products of two
/// sinusoids of the row's frequency).
const SAMPLES: u32 = 8;

/// The case inputs of a row as the nine signals of the generic basis.
fn signals(i: &CaseInputs) -> [f64; 9] {
    let [a0, a1, a2] = i.a_cm_s2;
    let [w0, w1, w2] = i.w_rad_s;
    let [d0, d1, d2] = i.dw_rad_s2;
    [a0, a1, a2, w0, w1, w2, d0, d1, d2]
}

const SIGNAL_NAMES: [&str; 9] = [
    "a_IA", "a_PA", "a_OA", "w_IA", "w_PA", "w_OA", "dw_IA", "dw_PA", "dw_OA",
];

/// Time averages over one period of the nine signals and their 45 pairwise products, in a
/// condition, by [`SAMPLES`] equally spaced samples (one sample if static).
fn averages(c: &Condition, g_cm_s2: f64) -> [f64; 54] {
    let p = c.prepare(g_cm_s2);
    let n = if c.is_static() { 1 } else { SAMPLES };
    let mut out = [0.0; 54];
    for k in 0..n {
        let ph = std::f64::consts::TAU * f64::from(k) / f64::from(n);
        let (s, co) = ph.sin_cos();
        let x = signals(&p.inputs(s, co));
        let mut m = 0;
        for (j, v) in x.iter().enumerate() {
            out[m] += v;
            m += 1;
            for w in &x[j..] {
                out[m] += v * w;
                m += 1;
            }
        }
    }
    for v in &mut out {
        *v /= f64::from(n);
    }
    out
}

/// The names of [`averages`]' entries.
fn average_names() -> Vec<String> {
    let mut names = Vec::with_capacity(54);
    for (j, a) in SIGNAL_NAMES.iter().enumerate() {
        names.push(format!("mean({a})"));
        for b in &SIGNAL_NAMES[j..] {
            names.push(if a == b {
                format!("mean({a}²)")
            } else {
                format!("mean({a}·{b})")
            });
        }
    }
    names
}

/// The generic basis over the rows: each feature is the condition's average minus the
/// reference's; features that vanish here or that repeat an earlier one (|cos| > 0.9999)
/// are left out.
#[must_use]
pub fn features(rows: &[&Condition], g_cm_s2: f64) -> Vec<(String, Vec<f64>)> {
    let per_row: Vec<[f64; 54]> = rows
        .iter()
        .map(|r| {
            let c = averages(r, g_cm_s2);
            let f = match r.kind {
                crate::condition::RowKind::Difference => averages(&r.reference(), g_cm_s2),
                crate::condition::RowKind::Absolute => [0.0; 54],
            };
            let mut d = [0.0; 54];
            for k in 0..54 {
                // Differences that cancel to rounding are zero.
                let scale = c[k].abs().max(f[k].abs());
                d[k] = if (c[k] - f[k]).abs() <= 1e-9 * scale {
                    0.0
                } else {
                    c[k] - f[k]
                };
            }
            d
        })
        .collect();
    let mut out: Vec<(String, Vec<f64>)> = Vec::new();
    let norm = |v: &[f64]| v.iter().map(|x| x * x).sum::<f64>().sqrt();
    for (k, name) in average_names().into_iter().enumerate() {
        let col: Vec<f64> = per_row.iter().map(|d| d[k]).collect();
        let nk = norm(&col);
        if nk == 0.0 {
            continue;
        }
        let repeats = out.iter().any(|(_, o)| {
            let dot: f64 = o.iter().zip(&col).map(|(a, b)| a * b).sum();
            (dot / (norm(o) * nk)).abs() > 0.9999
        });
        if !repeats {
            out.push((name, col));
        }
    }
    out
}

/// Rows per replicate set, for sets of two or more.
#[must_use]
pub fn replicate_sets(data: &Data, subset: &[usize]) -> Vec<Vec<usize>> {
    let mut sets: BTreeMap<usize, Vec<usize>> = BTreeMap::new();
    for &i in subset {
        sets.entry(data.replicate[i]).or_default().push(i);
    }
    sets.into_values().filter(|s| s.len() > 1).collect()
}
