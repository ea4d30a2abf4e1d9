//! The hidden-effect and coverage campaigns in shards (`ptsa_campaigns::shard`), for `python -m ptsa.campaign
//! hidden`: a shard's outcomes travel as bytes, the driver puts them together.

use pyo3::prelude::*;
use pyo3::types::PyBytes;

use ptsa_campaigns::shard::{self, Gathered, Name, Spec};

use crate::PtsaError;
use crate::interrupt::interruptible;

/// The campaign run `name`, `sets` per kind, `seed`, checked as the command checks it.
fn spec(name: &str, sets: usize, seed: u64, analytic: bool, additive: bool) -> PyResult<Spec> {
    let name = Name::parse(name).map_err(PtsaError::new_err)?;
    Spec::new(name, sets, seed, analytic, additive).map_err(PtsaError::new_err)
}

/// `(json, notable, table, failures)` of a gathered run.
type Out = (String, String, String, Vec<String>);

fn out(g: Gathered) -> Out {
    (g.json, g.notable, g.table, g.failures)
}

/// The campaigns' names.
#[pyfunction]
pub fn hidden_names() -> Vec<&'static str> {
    Name::ALL.iter().map(|n| n.as_str()).collect()
}

/// Refuse a campaign run the command would refuse, before any task starts.
#[pyfunction]
#[pyo3(signature = (name, sets, seed, analytic, additive))]
pub fn hidden_check(
    name: &str,
    sets: usize,
    seed: u64,
    analytic: bool,
    additive: bool,
) -> PyResult<()> {
    spec(name, sets, seed, analytic, additive).map(|_| ())
}

/// Shard `part` of `parts` of the run, made and analysed (the GIL released): its outcomes
/// as bytes for [`hidden_gather`].
#[pyfunction]
#[pyo3(signature = (name, sets, seed, analytic, additive, part, parts))]
#[allow(clippy::too_many_arguments, reason = "the Python function's arguments")]
pub fn hidden_part<'py>(
    py: Python<'py>,
    name: &str,
    sets: usize,
    seed: u64,
    analytic: bool,
    additive: bool,
    part: usize,
    parts: usize,
) -> PyResult<Bound<'py, PyBytes>> {
    let s = spec(name, sets, seed, analytic, additive)?;
    let bytes = interruptible(py, "ptsa.campaign hidden", || shard::part(&s, part, parts))?
        .map_err(PtsaError::new_err)?;
    Ok(PyBytes::new(py, &bytes))
}

/// The run from its shards' bytes, in shard order; `seconds` the wall time for the table.
#[pyfunction]
#[pyo3(signature = (name, sets, seed, analytic, additive, shards, seconds))]
#[allow(clippy::too_many_arguments, reason = "the Python function's arguments")]
pub fn hidden_gather(
    name: &str,
    sets: usize,
    seed: u64,
    analytic: bool,
    additive: bool,
    shards: Vec<Bound<'_, PyBytes>>,
    seconds: f64,
) -> PyResult<Out> {
    let s = spec(name, sets, seed, analytic, additive)?;
    let shards: Vec<Vec<u8>> = shards.iter().map(|b| b.as_bytes().to_vec()).collect();
    shard::gather(&s, &shards, seconds)
        .map(out)
        .map_err(PtsaError::new_err)
}

/// The whole run in this process, on every core (the GIL released).
#[pyfunction]
#[pyo3(signature = (name, sets, seed, analytic, additive))]
pub fn hidden_whole(
    py: Python<'_>,
    name: &str,
    sets: usize,
    seed: u64,
    analytic: bool,
    additive: bool,
) -> PyResult<Out> {
    let s = spec(name, sets, seed, analytic, additive)?;
    Ok(out(interruptible(py, "ptsa.campaign hidden", || {
        shard::whole(&s)
    })?))
}
