//! The runs of a sweep, on Rust threads: the same runs and table as `latticesim sweep`
//! (`latticesim::sweep::run_agents` and `table`), the agents made by a generated shape or
//! by a Python function `agents_fn(n, seed)`.

use latticesim::sweep::{run_agents, table, Row, Setup, SweepShape};
use latticesim::table::Column;
use latticesim_runtime::shapes::{agents_text, GenOptions};
use numpy::PyArray1;
use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use rayon::prelude::*;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Duration;

/// How often a sweep looks for Ctrl-C while its runs go on.
const POLL: Duration = Duration::from_millis(20);

/// A run that failed: its number, n, seed and why.
type Failure = (usize, u32, u64, String);

/// Runs the sweep's runs `runs` (run number, n, seed) of the rules file's bytes `rules` and gives the table's columns (name
/// -> array or list, the rows in run order) and the failures (run, n, seed, message).
/// Called by `latticesim.sweep`, once for a threaded sweep or once per run on Dask.
#[pyfunction]
#[pyo3(signature = (rules, rules_name, runs, *, shape = "connected", agents_fn = None, dim = 2, state = None, first_state = None, first_east = false, ids = None, universe = false, fill_holes = false, set = Vec::new(), max_steps = 100_000, order = "actions-first", static_first = false, threads = None, allow = Vec::new(), warn = Vec::new(), deny = Vec::new(), counters = None))]
#[allow(clippy::too_many_arguments)]
pub fn sweep_runs<'py>(
    py: Python<'py>,
    rules: Vec<u8>,
    rules_name: &str,
    runs: Vec<(usize, u32, u64)>,
    shape: &str,
    agents_fn: Option<Py<PyAny>>,
    dim: u8,
    state: Option<String>,
    first_state: Option<String>,
    first_east: bool,
    ids: Option<String>,
    universe: bool,
    fill_holes: bool,
    set: Vec<String>,
    max_steps: u64,
    order: &str,
    static_first: bool,
    threads: Option<usize>,
    allow: Vec<String>,
    warn: Vec<String>,
    deny: Vec<String>,
    counters: Option<u32>,
) -> PyResult<(Bound<'py, PyDict>, Vec<Failure>)> {
    let lints = crate::lints(&allow, &warn, &deny, counters)?;
    let shape = <SweepShape as clap::ValueEnum>::from_str(shape, true).map_err(|_| {
        PyValueError::new_err(format!(
            "shape `{shape}`: use \"line\", \"block\" or \"connected\""
        ))
    })?;
    if dim != 2 && dim != 3 {
        return Err(PyValueError::new_err(format!("dim {dim}: use 2 or 3")));
    }
    let gen = GenOptions {
        three_d: dim == 3,
        state,
        first_state,
        first_east,
        fill_holes,
        ids: ids
            .as_deref()
            .map(latticesim::gen::parse_counter)
            .transpose()
            .map_err(PyValueError::new_err)?,
        universe,
        seed: 0,
    };
    let setup = Setup {
        rules_name: rules_name.to_string(),
        rules,
        set: (set.iter())
            .map(|s| s.parse())
            .collect::<Result<_, String>>()
            .map_err(|e| PyValueError::new_err(format!("set: {e}")))?,
        max_steps,
        opts: crate::options(order, static_first)?,
        cancel: Some(Arc::new(AtomicBool::new(false))),
        lints,
    };
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(latticesim::threads(
            threads,
            runs.len(),
            "one run per thread",
        ))
        .build()
        .map_err(|e| PyValueError::new_err(format!("cannot start threads: {e}")))?;
    let one = |&(run, n, seed): &(usize, u32, u64)| -> Result<Row, String> {
        let (text, input) = match &agents_fn {
            Some(f) => (agents_of(f, n, seed)?, format!("agents_fn n={n}")),
            None => (
                agents_text(
                    &shape.of(n, dim == 3),
                    &GenOptions {
                        seed,
                        ..gen.clone()
                    },
                )?,
                format!("{} n={n}", shape.name()),
            ),
        };
        let source = latticesim::agents_file::Source::Bytes(text.as_bytes());
        run_agents(&setup, run, seed, input, source)
    };
    let results = std::thread::scope(|s| -> PyResult<Vec<Result<Row, String>>> {
        let worker = s.spawn(|| pool.install(|| runs.par_iter().map(one).collect()));
        // Ctrl-C stops every run at its next step.
        while !worker.is_finished() {
            py.detach(|| std::thread::sleep(POLL));
            if let Err(e) = py.check_signals() {
                let cancel = setup.cancel.as_ref().expect("set above");
                cancel.store(true, Ordering::Relaxed);
                py.detach(|| worker.join()).ok();
                return Err(e);
            }
        }
        worker
            .join()
            .map_err(|_| PyRuntimeError::new_err("a run of the sweep panicked"))
    })?;
    let (mut rows, mut failed) = (Vec::new(), Vec::new());
    for (r, &(run, n, seed)) in results.into_iter().zip(&runs) {
        match r {
            Ok(row) => rows.push(row),
            Err(e) => failed.push((run, n, seed, e)),
        }
    }
    Ok((columns(py, &rows)?, failed))
}

/// The text of `agents_fn(n, seed)`, called with the GIL.
fn agents_of(f: &Py<PyAny>, n: u32, seed: u64) -> Result<String, String> {
    Python::attach(|py| {
        f.call1(py, (n, seed))
            .and_then(|v| v.extract::<String>(py))
            .map_err(|e| format!("agents_fn({n}, {seed}) failed: {e}"))
    })
}

/// The sweep table's columns as a dict of NumPy arrays (counts as int64, seconds as
/// float64) and lists of str.
fn columns<'py>(py: Python<'py>, rows: &[Row]) -> PyResult<Bound<'py, PyDict>> {
    let t = table(rows);
    let out = PyDict::new(py);
    for (name, col) in t.names.iter().zip(t.columns) {
        match col {
            Column::Int(v) => {
                let v: Vec<i64> = v.into_iter().map(|x| x as i64).collect();
                out.set_item(name, PyArray1::from_vec(py, v))?
            }
            Column::Float(v) => out.set_item(name, PyArray1::from_vec(py, v))?,
            Column::Text(v) => out.set_item(name, v)?,
        }
    }
    Ok(out)
}
