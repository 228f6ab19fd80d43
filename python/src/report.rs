//! What a call of `step` or `run` did, and the records of its steps, as Python objects.

use latticesim_runtime::{Record as RecordData, StepCost};
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// Records kept in one report (the rest are counted in `record_count`).
pub(crate) const RECORDS_KEPT: usize = 100_000;

/// Something that happened in a step that a rule author should know of: a conflict, a
/// blocked move, a saturated counter... (`latticesim run` prints them as it goes).
#[pyclass(module = "latticesim", frozen, get_all)]
pub struct Record {
    /// The step (from 1).
    step: u64,
    /// The kind, e.g. `move-conflict`.
    kind: String,
    /// `error` or `warning`.
    severity: String,
    /// The agents involved: (id, position) pairs, the position as a tuple of the run's
    /// dimension.
    agents: Vec<(u32, Vec<i32>)>,
    /// What happened, in one sentence.
    message: String,
}

impl Record {
    pub(crate) fn new(r: &RecordData, coords: usize) -> Record {
        Record {
            step: r.step,
            kind: r.kind.name().to_string(),
            severity: if r.is_error() { "error" } else { "warning" }.to_string(),
            agents: (r.agents.iter())
                .map(|(id, p)| (*id, p[..coords].to_vec()))
                .collect(),
            message: r.message.clone(),
        }
    }
}

#[pymethods]
impl Record {
    fn __str__(&self) -> String {
        format!(
            "{}[{}] step {}: {}",
            self.severity, self.kind, self.step, self.message
        )
    }

    fn __repr__(&self) -> String {
        format!("Record({})", self.__str__())
    }
}

/// What one call of `Simulation.step` or `Simulation.run` did: the steps taken, the
/// counts summed over them (firings per rule, agents executing, moves, swaps, messages),
/// the records, and whether the run is quiescent.
#[pyclass(module = "latticesim", frozen, get_all)]
pub struct Report {
    /// Steps taken by this call.
    steps: u64,
    /// The simulation's step after it.
    step: u64,
    /// Executions per rule name (file order).
    firings: Py<PyDict>,
    /// Agents that executed a rule, summed over the steps.
    executing: u64,
    /// Agent moves (each agent of a moved group counts).
    moves: u64,
    /// Of the moves, agents carried by their group.
    carried: u64,
    /// Swaps done.
    swaps: u64,
    /// Messages sent.
    messages: u64,
    /// Messages delivered.
    delivered: u64,
    /// Messages dropped.
    dropped: u64,
    /// The records of the steps (the first 100,000).
    records: Vec<Py<Record>>,
    /// How many records there were.
    record_count: u64,
    /// No agent had a rule to execute at the last step: the run is over.
    quiescent: bool,
}

impl Report {
    /// The report of steps whose costs summed to `sum` (`step` the steps taken), ending at
    /// step `at`.
    pub(crate) fn new(
        py: Python<'_>,
        rules: &[String],
        sum: &StepCost,
        at: u64,
        records: Vec<Py<Record>>,
        record_count: u64,
        quiescent: bool,
    ) -> PyResult<Report> {
        let firings = PyDict::new(py);
        for (name, n) in rules.iter().zip(&sum.firings) {
            firings.set_item(name, n)?;
        }
        Ok(Report {
            steps: sum.step,
            step: at,
            firings: firings.unbind(),
            executing: sum.executing,
            moves: sum.moves,
            carried: sum.carried,
            swaps: sum.swaps,
            messages: sum.sent,
            delivered: sum.delivered,
            dropped: sum.dropped,
            records,
            record_count,
            quiescent,
        })
    }
}

#[pymethods]
impl Report {
    /// Why the call stopped: `quiescence`, or `max-steps` (the steps asked for were taken).
    #[getter]
    fn stopped_by(&self) -> &'static str {
        if self.quiescent {
            "quiescence"
        } else {
            "max-steps"
        }
    }

    /// All firings of the steps.
    #[getter]
    fn total_firings(&self, py: Python<'_>) -> PyResult<u64> {
        let mut n = 0;
        for v in self.firings.bind(py).values() {
            n += v.extract::<u64>()?;
        }
        Ok(n)
    }

    fn __repr__(&self, py: Python<'_>) -> PyResult<String> {
        Ok(format!(
            "Report(steps={}, step={}, firings={}, moves={}, swaps={}, messages={}, records={}, quiescent={})",
            self.steps,
            self.step,
            self.total_firings(py)?,
            self.moves,
            self.swaps,
            self.messages,
            self.record_count,
            if self.quiescent { "True" } else { "False" }
        ))
    }
}
