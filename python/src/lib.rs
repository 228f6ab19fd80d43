//! `latticesim._latticesim`: the Rust half of the Python package `latticesim` (the pure
//! Python half, `python/latticesim/`, adds the pandas and Dask glue). It calls the same
//! code as the command line: loading and checking (`latticesim::agents_file::load`),
//! the engine, the statistics document of `run --stats`, the agents writer of `run --out`,
//! checkpoints and the sweep's runs.

use pyo3::prelude::*;

mod check;
mod report;
mod sim;
mod sweep;

/// The order of a step and which rules act first, from the names the command line takes.
pub(crate) fn options(order: &str, static_first: bool) -> PyResult<latticesim_runtime::Options> {
    use latticesim::run::OrderArg;
    use pyo3::exceptions::PyValueError;
    let o = <OrderArg as clap::ValueEnum>::from_str(order, true).map_err(|_| {
        PyValueError::new_err(format!(
            "order `{order}`: use \"actions-first\" (the paper's) or \"messages-first\""
        ))
    })?;
    Ok(latticesim_runtime::Options {
        order: o.into(),
        static_first,
        ..Default::default()
    })
}

/// Lint levels and the width of counters from keyword arguments, as the command line's
/// `--allow`, `--warn`, `--deny` and `--counters` (after the rules file's directives).
pub(crate) fn lints(
    allow: &[String],
    warn: &[String],
    deny: &[String],
    counters: Option<u32>,
) -> PyResult<latticesim_compiler::lints::Lints> {
    let counters = counters.map(|b| (b, format!("counters={b}")));
    latticesim::levels(allow, warn, deny, counters).map_err(pyo3::exceptions::PyValueError::new_err)
}

#[pymodule]
fn _latticesim(m: &Bound<'_, PyModule>) -> PyResult<()> {
    if let Some(text) = latticesim::processor::check() {
        return Err(pyo3::exceptions::PyImportError::new_err(text));
    }
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add("CheckError", m.py().get_type::<check::CheckError>())?;
    m.add("CheckWarning", m.py().get_type::<check::CheckWarning>())?;
    m.add_class::<check::Diagnostic>()?;
    m.add_class::<report::Record>()?;
    m.add_class::<report::Report>()?;
    m.add_class::<sim::Simulation>()?;
    m.add_function(wrap_pyfunction!(sweep::sweep_runs, m)?)?;
    Ok(())
}
