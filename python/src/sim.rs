//! `Simulation`: rules running on agents, stepped from Python, its configuration seen as
//! NumPy arrays that share the engine's memory where its layout allows.

use crate::check;
use crate::report::{Record, Report, RECORDS_KEPT};
use latticesim::agents_file::{self, Source};
use latticesim_runtime::{Engine, Options, Record as RecordData, StepCost};
use latticesim_vm::model::{Column, Width};
use numpy::ndarray::{ArrayView1, ArrayView2, ShapeBuilder};
use numpy::{PyArray1, PyArray2, PyArray3, PyFixedString};
use pyo3::exceptions::{PyIOError, PyKeyError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use std::path::PathBuf;
use std::time::{Duration, Instant};

/// How long the engine steps without the GIL before it looks for Ctrl-C (it always
/// finishes the step it is in).
const SLICE: Duration = Duration::from_millis(50);

/// Rules running on agents, in lock-step, as `latticesim run` runs them.
///
/// Make one with `Simulation.from_files(rules, agents)`, `Simulation.from_text(rules_text,
/// agents_text)` or `Simulation.resume(rules, checkpoint)`; bad rules or agents raise
/// `CheckError` with every diagnostic. `step(n)` and `run(max_steps)` release the GIL and
/// stop after the current step on Ctrl-C (KeyboardInterrupt). The configuration is seen
/// through `positions`, `states`, `attachments` and `counter(name)` (read-only NumPy
/// arrays on the engine's own memory: they show each new step without a copy),
/// `counters` and `inbox` (copies), `to_pandas()` and `to_arrow()`; `write(path)` writes it
/// in agents.txt syntax (as `run --out`), `stats()` gives the document of `run --stats`,
/// `series()` the per-step costs (as `run --series`).
#[pyclass(module = "latticesim")]
pub struct Simulation {
    engine: Engine,
    /// The per-step costs, a row of `StepCost::values` per step, when kept.
    series: Option<Vec<u64>>,
    /// Why the last call stopped.
    stopped_by: &'static str,
    /// The warnings of the check.
    warnings: Py<PyList>,
    /// The names of the rules and agents files (or of the checkpoint).
    names: (String, String),
}

/// What steps taken without the GIL gathered.
#[derive(Default)]
struct Batch {
    executing: u64,
    records: Vec<RecordData>,
    record_count: u64,
    quiescent: bool,
}

impl Simulation {
    /// A simulation of an engine (new, or resumed at a later step).
    fn new(
        engine: Engine,
        series: bool,
        names: (String, String),
        warnings: Bound<'_, PyList>,
    ) -> Simulation {
        Simulation {
            stopped_by: if engine.stats.quiescent {
                "quiescence"
            } else {
                "max-steps"
            },
            engine,
            series: series.then(Vec::new),
            warnings: warnings.unbind(),
            names,
        }
    }

    /// The rules' names, in file order.
    fn rule_names(&self) -> Vec<String> {
        self.engine
            .prog
            .rules
            .iter()
            .map(|r| r.name.clone())
            .collect()
    }

    /// A checked pair of files (`load`'s verdict) as a simulation, or its errors raised.
    fn from_loaded(
        py: Python<'_>,
        loaded: agents_file::Loaded,
        opts: Options,
        threads: Option<usize>,
        series: bool,
        names: (String, String),
    ) -> PyResult<Simulation> {
        let c = &loaded.checked;
        let (Some(program), Some(lat)) = (c.rules.as_ref(), loaded.lattice) else {
            return Err(check::error(py, c, loaded.note.as_deref()));
        };
        check::warn(py, c)?;
        let warnings = check::diagnostics(py, c)?;
        let prog = latticesim_compiler::compile(program).map_err(|e| {
            PyValueError::new_err(format!(
                "internal error: the compiled program does not verify: {e}"
            ))
        })?;
        let opts = Options {
            threads: latticesim::engine_threads(threads, lat.len()),
            ..opts
        };
        let engine = Engine::new(prog, lat, opts);
        Ok(Simulation::new(engine, series, names, warnings))
    }

    /// Steps until `left` steps are taken, the run is quiescent, or `until` has passed.
    fn advance(&mut self, left: u64, until: Instant, b: &mut Batch) -> u64 {
        let mut taken = 0;
        while taken < left {
            let before = self.series.is_some().then(|| self.engine.stats.clone());
            // The report keeps its first records: the step keeps at most as many of each
            // kind (which holds them), and makes no sentence for the others, only counted.
            let room = RECORDS_KEPT.saturating_sub(b.records.len());
            self.engine.opts.records_per_step = Some(room);
            let made = |e: &Engine| e.stats.records.values().sum::<u64>();
            let made_before = made(&self.engine);
            let rep = self.engine.step();
            taken += 1;
            if let (Some(s), Some(before)) = (self.series.as_mut(), before) {
                s.extend(StepCost::of(&before, &self.engine.stats, &rep).values());
            }
            b.executing += rep.executing;
            b.record_count += made(&self.engine) - made_before;
            b.records.extend(rep.records.into_iter().take(room));
            if rep.quiescent {
                b.quiescent = true;
                break;
            }
            if Instant::now() >= until {
                break;
            }
        }
        taken
    }

    /// Takes up to `n` steps without the GIL, looking for Ctrl-C between slices; the
    /// report of the steps taken.
    fn drive(&mut self, py: Python<'_>, n: u64) -> PyResult<Report> {
        let before = self.engine.stats.clone();
        let mut b = Batch {
            quiescent: self.engine.stats.quiescent,
            ..Batch::default()
        };
        let mut left = n;
        while left > 0 && !b.quiescent {
            let until = Instant::now() + SLICE;
            let taken = py.detach(|| self.advance(left, until, &mut b));
            left -= taken;
            if let Err(e) = py.check_signals() {
                self.stopped_by = "interrupted";
                return Err(e);
            }
        }
        self.stopped_by = if b.quiescent {
            "quiescence"
        } else {
            "max-steps"
        };
        let mut sum = StepCost::of(&before, &self.engine.stats, &Default::default());
        sum.step = self.engine.stats.steps - before.steps;
        sum.executing = b.executing;
        let coords = self.engine.lat.dim.coords();
        let records = (b.records.iter())
            .map(|r| Py::new(py, Record::new(r, coords)))
            .collect::<PyResult<Vec<_>>>()?;
        Report::new(
            py,
            &self.rule_names(),
            &sum,
            self.engine.stats.steps,
            records,
            b.record_count,
            b.quiescent,
        )
    }

    /// The counter number of a name such as `C03`.
    fn counter_number(&self, name: &str) -> PyResult<u8> {
        let i = latticesim::gen::parse_counter(name).map_err(PyKeyError::new_err)?;
        if i as usize >= self.engine.lat.nc() {
            return Err(PyKeyError::new_err(format!(
                "`{name}`: {} has counters C00..C{:02}",
                self.engine.lat.dim.name(),
                self.engine.lat.nc() - 1
            )));
        }
        Ok(i)
    }
}

/// The bytes of a rules file, or OSError naming it.
fn read_rules(path: &std::path::Path) -> PyResult<Vec<u8>> {
    std::fs::read(path)
        .map_err(|e| PyIOError::new_err(format!("cannot read `{}`: {e}", path.display())))
}

/// Marks a NumPy array read-only (it views the engine's memory).
fn read_only<'py, T>(a: Bound<'py, T>) -> PyResult<Bound<'py, T>> {
    a.as_any().getattr("flags")?.setattr("writeable", false)?;
    Ok(a)
}

#[pymethods]
impl Simulation {
    /// Reads and checks a rules file and an agents file (plain, `.gz` or `.zst`) as
    /// `latticesim run` does; raises `CheckError` with every diagnostic when they have
    /// errors, warns (`CheckWarning`) of their warnings.
    ///
    /// order: "actions-first" (the paper's) or "messages-first"; static_first: rules
    /// without a move or swap act first (as `run --static-first`); threads: the engine's
    /// threads (default: all cores, one per 1,024 agents at most); series: keep the
    /// per-step costs for `series()`; allow, warn, deny: lint levels, lists of codes (W603),
    /// names or "warnings", as `--allow`, `--warn` and `--deny` (a denied warning is an
    /// error: `CheckError`); counters: 16 or 32, as `--counters`.
    #[staticmethod]
    #[pyo3(signature = (rules, agents, *, order = "actions-first", static_first = false, threads = None, series = true, allow = Vec::new(), warn = Vec::new(), deny = Vec::new(), counters = None))]
    #[allow(clippy::too_many_arguments)]
    fn from_files(
        py: Python<'_>,
        rules: PathBuf,
        agents: PathBuf,
        order: &str,
        static_first: bool,
        threads: Option<usize>,
        series: bool,
        allow: Vec<String>,
        warn: Vec<String>,
        deny: Vec<String>,
        counters: Option<u32>,
    ) -> PyResult<Simulation> {
        let opts = crate::options(order, static_first)?;
        let levels = crate::lints(&allow, &warn, &deny, counters)?;
        let rules_bytes = read_rules(&rules)?;
        let names = (rules.display().to_string(), agents.display().to_string());
        let io = latticesim::run::io_threads(threads);
        let loaded = py
            .detach(|| {
                agents_file::load(
                    (&names.0, &rules_bytes),
                    &names.1,
                    Source::File(&agents),
                    io,
                    &levels,
                )
            })
            .map_err(|e| PyIOError::new_err(format!("cannot read `{}`: {e}", names.1)))?;
        Simulation::from_loaded(py, loaded, opts, threads, series, names)
    }

    /// Checks rules and agents given as text (named `rules_name` and `agents_name` in
    /// diagnostics); otherwise as `from_files`.
    #[staticmethod]
    #[pyo3(signature = (rules_text, agents_text, *, rules_name = "rules.txt", agents_name = "agents.txt", order = "actions-first", static_first = false, threads = None, series = true, allow = Vec::new(), warn = Vec::new(), deny = Vec::new(), counters = None))]
    #[allow(clippy::too_many_arguments)]
    fn from_text(
        py: Python<'_>,
        rules_text: &str,
        agents_text: &str,
        rules_name: &str,
        agents_name: &str,
        order: &str,
        static_first: bool,
        threads: Option<usize>,
        series: bool,
        allow: Vec<String>,
        warn: Vec<String>,
        deny: Vec<String>,
        counters: Option<u32>,
    ) -> PyResult<Simulation> {
        let opts = crate::options(order, static_first)?;
        let levels = crate::lints(&allow, &warn, &deny, counters)?;
        let io = latticesim::run::io_threads(threads);
        let loaded = py
            .detach(|| {
                agents_file::load(
                    (rules_name, rules_text.as_bytes()),
                    agents_name,
                    Source::Bytes(agents_text.as_bytes()),
                    io,
                    &levels,
                )
            })
            .map_err(|e| PyIOError::new_err(e.to_string()))?;
        let names = (rules_name.to_string(), agents_name.to_string());
        Simulation::from_loaded(py, loaded, opts, threads, series, names)
    }

    /// Continues a run from a checkpoint (`checkpoint(path)` or `run --checkpoint`) of the
    /// same rules, with the same order and static_first; the series starts afresh.
    #[staticmethod]
    #[pyo3(signature = (rules, checkpoint, *, order = "actions-first", static_first = false, threads = None, series = true, allow = Vec::new(), warn = Vec::new(), deny = Vec::new(), counters = None))]
    #[allow(clippy::too_many_arguments)]
    fn resume(
        py: Python<'_>,
        rules: PathBuf,
        checkpoint: PathBuf,
        order: &str,
        static_first: bool,
        threads: Option<usize>,
        series: bool,
        allow: Vec<String>,
        warn: Vec<String>,
        deny: Vec<String>,
        counters: Option<u32>,
    ) -> PyResult<Simulation> {
        let opts = crate::options(order, static_first)?;
        let levels = crate::lints(&allow, &warn, &deny, counters)?;
        let cannot = |e: String| {
            PyValueError::new_err(format!(
                "cannot resume from `{}`: {e}",
                checkpoint.display()
            ))
        };
        let peek = latticesim::run::peek_checkpoint_file(&checkpoint).map_err(cannot)?;
        let (dim, agents) = (peek.dim, peek.agents);
        let rules_bytes = read_rules(&rules)?;
        let rules_name = rules.display().to_string();
        let c = latticesim::check_pair(
            (&rules_name, &rules_bytes),
            None,
            Some(dim),
            &latticesim::run::with_checkpoint_width(&levels, &peek),
        );
        let Some(program) = c.rules.as_ref() else {
            return Err(check::error(py, &c, None));
        };
        check::warn(py, &c)?;
        let prog = latticesim_compiler::compile(program)
            .map_err(|e| PyValueError::new_err(format!("internal error: {e}")))?;
        let opts = Options {
            threads: latticesim::engine_threads(threads, agents.min(u32::MAX as u64) as usize),
            ..opts
        };
        let engine = py
            .detach(|| latticesim::run::read_checkpoint_file(prog, opts, &checkpoint))
            .map_err(cannot)?;
        let names = (rules_name, checkpoint.display().to_string());
        Ok(Simulation::new(
            engine,
            series,
            names,
            check::diagnostics(py, &c)?,
        ))
    }

    /// Takes up to `n` steps (fewer when the run becomes quiescent): the report of them.
    #[pyo3(signature = (n = 1))]
    fn step(&mut self, py: Python<'_>, n: u64) -> PyResult<Report> {
        self.drive(py, n)
    }

    /// Steps until quiescence or until `max_steps` more steps are taken: the report of
    /// the steps. Ctrl-C stops it after the current step (KeyboardInterrupt); the
    /// simulation keeps the state it reached.
    #[pyo3(signature = (max_steps = 100_000))]
    fn run(&mut self, py: Python<'_>, max_steps: u64) -> PyResult<Report> {
        self.drive(py, max_steps)
    }

    /// Steps taken so far.
    #[getter]
    fn steps(&self) -> u64 {
        self.engine.stats.steps
    }

    /// No agent had a rule to execute at the last step.
    #[getter]
    fn quiescent(&self) -> bool {
        self.engine.stats.quiescent
    }

    /// Number of agents.
    #[getter]
    fn agents(&self) -> usize {
        self.engine.lat.len()
    }

    /// 2 or 3.
    #[getter]
    fn dim(&self) -> usize {
        self.engine.lat.dim.coords()
    }

    /// The rules' names, in file order.
    #[getter]
    fn rules(&self) -> Vec<String> {
        self.rule_names()
    }

    /// The checker's warnings about the files (a list of `Diagnostic`).
    #[getter]
    fn warnings(&self, py: Python<'_>) -> Py<PyList> {
        self.warnings.clone_ref(py)
    }

    /// Positions, agents x dim int32 (x, y[, z]), read-only, on the engine's memory.
    #[getter]
    fn positions(slf: Bound<'_, Self>) -> PyResult<Bound<'_, PyArray2<i32>>> {
        let this = slf.borrow();
        let lat = &this.engine.lat;
        if lat.is_empty() {
            return read_only(PyArray2::zeros(slf.py(), (0, lat.dim.coords()), false));
        }
        let flat: &[i32] = lat.pos.as_flattened();
        let shape = (lat.len(), lat.dim.coords()).strides((3, 1));
        let view = ArrayView2::from_shape(shape, flat).expect("three coordinates per agent");
        // SAFETY: the array keeps the simulation alive; the engine writes positions in
        // place and never reallocates them (agents are neither added nor removed).
        let a = unsafe { PyArray2::borrow_from_array(&view, slf.clone().into_any()) };
        read_only(a)
    }

    /// States, one 5-byte string (numpy dtype `S5`) per agent, read-only, on the engine's
    /// memory.
    #[getter]
    fn states(slf: Bound<'_, Self>) -> PyResult<Bound<'_, PyArray1<PyFixedString<5>>>> {
        let this = slf.borrow();
        let st: &[[u8; 5]] = &this.engine.lat.state;
        // SAFETY: PyFixedString<5> is a transparent wrapper of [u8; 5].
        let st: &[PyFixedString<5>] =
            unsafe { std::slice::from_raw_parts(st.as_ptr().cast(), st.len()) };
        let view = ArrayView1::from(st);
        // SAFETY: as for `positions`.
        let a = unsafe { PyArray1::borrow_from_array(&view, slf.clone().into_any()) };
        read_only(a)
    }

    /// Attachment bits, one uint8 per agent (bit i: bonded towards direction i of N, W,
    /// E, S, A, B), read-only, on the engine's memory.
    #[getter]
    fn attachments(slf: Bound<'_, Self>) -> PyResult<Bound<'_, PyArray1<u8>>> {
        let this = slf.borrow();
        let view = ArrayView1::from(&this.engine.lat.attach[..]);
        // SAFETY: as for `positions`.
        let a = unsafe { PyArray1::borrow_from_array(&view, slf.clone().into_any()) };
        read_only(a)
    }

    /// The names of the counters that have a column (set by the agents or used by the
    /// rules), in number order: the columns of `counters`.
    #[getter]
    fn counter_names(&self) -> Vec<String> {
        (self.engine.lat.counter_numbers().iter())
            .map(|i| format!("C{i:02}"))
            .collect()
    }

    /// The counters, agents x counter_names, int16 (int32 with 32-bit counters; a copy:
    /// the engine keeps a column per counter).
    #[getter]
    fn counters<'py>(&self, py: Python<'py>) -> Bound<'py, PyAny> {
        let lat = &self.engine.lat;
        let nums = lat.counter_numbers();
        let cols: Vec<&Column> = (nums.iter())
            .map(|&i| {
                lat.counter_column(i)
                    .expect("a counter in use has a column")
            })
            .collect();
        let shape = (lat.len(), nums.len());
        match lat.width() {
            Width::W16 => {
                let mut out = numpy::ndarray::Array2::<i16>::zeros(shape);
                for (j, col) in cols.iter().enumerate() {
                    (out.column_mut(j).iter_mut().zip(col.narrow())).for_each(|(o, v)| *o = *v);
                }
                PyArray2::from_owned_array(py, out).into_any()
            }
            Width::W32 => {
                let mut out = numpy::ndarray::Array2::<i32>::zeros(shape);
                for (j, col) in cols.iter().enumerate() {
                    (out.column_mut(j).iter_mut().enumerate()).for_each(|(a, o)| *o = col.get(a));
                }
                PyArray2::from_owned_array(py, out).into_any()
            }
        }
    }

    /// One counter (e.g. "C00"), int16 per agent (int32 with 32-bit counters): read-only
    /// on the engine's memory when it has a column, else zeros.
    fn counter<'py>(slf: Bound<'py, Self>, name: &str) -> PyResult<Bound<'py, PyAny>> {
        let this = slf.borrow();
        let i = this.counter_number(name)?;
        let Some(col) = this.engine.lat.counter_column(i) else {
            let n = this.engine.lat.len();
            return Ok(match this.engine.lat.width() {
                Width::W16 => PyArray1::<i16>::zeros(slf.py(), n, false).into_any(),
                Width::W32 => PyArray1::<i32>::zeros(slf.py(), n, false).into_any(),
            });
        };
        // SAFETY: as for `positions`; a counter's column never moves once made.
        let a = latticesim_vm::each_width!(col, v => {
            let view = ArrayView1::from(&v[..]);
            read_only(unsafe { PyArray1::borrow_from_array(&view, slf.clone().into_any()) })?
                .into_any()
        });
        Ok(a)
    }

    /// The numeric slots (from 1, as `#N01`) that have inboxes: the last axis of `inbox`.
    #[getter]
    fn inbox_slots(&self) -> Vec<u32> {
        (self.engine.lat.slot_numbers().iter())
            .map(|&s| s as u32 + 1)
            .collect()
    }

    /// The numeric messages received at the last step, agents x directions (N, W, E, S[,
    /// A, B]) x inbox_slots, int16 (int32 with 32-bit counters; a copy).
    #[getter]
    fn inbox<'py>(&self, py: Python<'py>) -> Bound<'py, PyAny> {
        let lat = &self.engine.lat;
        let slots = lat.slot_numbers();
        let dirs = lat.dim.dirs();
        let shape = (lat.len(), dirs, slots.len());
        match lat.width() {
            Width::W16 => {
                let mut out = numpy::ndarray::Array3::<i16>::zeros(shape);
                for ((a, d, k), v) in out.indexed_iter_mut() {
                    *v = lat.inbox(a as u32, d as u8, slots[k]) as i16;
                }
                PyArray3::from_owned_array(py, out).into_any()
            }
            Width::W32 => {
                let mut out = numpy::ndarray::Array3::<i32>::zeros(shape);
                for ((a, d, k), v) in out.indexed_iter_mut() {
                    *v = lat.inbox(a as u32, d as u8, slots[k]);
                }
                PyArray3::from_owned_array(py, out).into_any()
            }
        }
    }

    /// The text messages received at the last step, agents x directions, `S5` (b"" where
    /// none came; a copy).
    #[getter]
    fn text_inbox<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<PyFixedString<5>>> {
        let lat = &self.engine.lat;
        let dirs = lat.dim.dirs();
        let out = numpy::ndarray::Array2::from_shape_fn((lat.len(), dirs), |(a, d)| {
            PyFixedString(lat.inbox_text(a as u32, d as u8).unwrap_or([0; 5]))
        });
        PyArray2::from_owned_array(py, out)
    }

    /// The configuration in agents.txt syntax (as `run --out` writes it).
    fn to_text(&self) -> String {
        self.engine.lat.to_agents_text()
    }

    /// Writes the configuration in agents.txt syntax (compressed for `.gz`, `.zst`), whole
    /// or not at all, as `run --out` does.
    fn write(&self, py: Python<'_>, path: PathBuf) -> PyResult<()> {
        let threads = latticesim::run::io_threads(None);
        py.detach(|| {
            latticesim::output::AtomicFile::create(&path)
                .and_then(|f| agents_file::commit_lattice(f, &self.engine.lat, threads))
        })
        .map_err(|e| PyIOError::new_err(format!("cannot write `{}`: {e}", path.display())))
    }

    /// Writes a checkpoint (`.zst`, `.gz` compress it) to continue with
    /// `Simulation.resume` or `latticesim run --resume`.
    fn checkpoint(&self, py: Python<'_>, path: PathBuf) -> PyResult<()> {
        py.detach(|| latticesim::run::write_checkpoint_file(&self.engine, &path))
            .map_err(|e| {
                PyIOError::new_err(format!(
                    "cannot write the checkpoint `{}`: {e}",
                    path.display()
                ))
            })
    }

    /// The statistics as `latticesim run --stats` writes them (without the times): steps,
    /// stopped_by, quiescent, agents, rules, firings, moves, carried, swaps, messages,
    /// records.
    fn stats<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let doc = latticesim::run::stats_document(&self.engine, self.stopped_by);
        py.import("json")?.call_method1("loads", (doc.to_string(),))
    }

    /// The per-step costs as columns (name -> int64 array), as `run --series` writes them.
    fn series_columns<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let Some(s) = &self.series else {
            return Err(PyValueError::new_err(
                "this simulation keeps no series (made with series=False)",
            ));
        };
        let rules = self.rule_names();
        let rules: Vec<&str> = rules.iter().map(String::as_str).collect();
        let columns = StepCost::columns(&rules);
        let width = columns.len();
        let out = PyDict::new(py);
        for (j, name) in columns.iter().enumerate() {
            let col: Vec<i64> = s.iter().skip(j).step_by(width).map(|&v| v as i64).collect();
            out.set_item(name, PyArray1::from_vec(py, col))?;
        }
        Ok(out)
    }

    /// The per-step costs as a pandas DataFrame, a row per step, the columns of
    /// `run --series`: step, firings, firings:RULE..., executing, moves, carried, swaps,
    /// sent, delivered, dropped, records, records:KIND...
    fn series<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let cols = self.series_columns(py)?;
        py.import("pandas")?.call_method1("DataFrame", (cols,))
    }

    /// The configuration as a pandas DataFrame, a row per agent (the index is the agent's
    /// id, its line among the agents): x, y[, z], state, attach (the bits of
    /// `attachments`), and a column per counter of `counter_names`.
    fn to_pandas<'py>(slf: Bound<'py, Self>) -> PyResult<Bound<'py, PyAny>> {
        let py = slf.py();
        let cols = PyDict::new(py);
        let this = slf.borrow();
        let lat = &this.engine.lat;
        for (k, axis) in ["x", "y", "z"].iter().take(lat.dim.coords()).enumerate() {
            let v: Vec<i32> = lat.pos.iter().map(|p| p[k]).collect();
            cols.set_item(axis, PyArray1::from_vec(py, v))?;
        }
        let states: Vec<&str> = (lat.state.iter())
            .map(|s| std::str::from_utf8(s).unwrap_or("?????"))
            .collect();
        cols.set_item("state", states)?;
        cols.set_item("attach", PyArray1::from_slice(py, &lat.attach))?;
        for i in lat.counter_numbers() {
            let col = lat
                .counter_column(i)
                .expect("a counter in use has a column");
            let name = format!("C{i:02}");
            latticesim_vm::each_width!(col, v => cols.set_item(name, PyArray1::from_slice(py, v)))?;
        }
        drop(this);
        py.import("pandas")?.call_method1("DataFrame", (cols,))
    }

    /// The configuration as a pyarrow Table (the columns of `to_pandas`).
    fn to_arrow<'py>(slf: Bound<'py, Self>) -> PyResult<Bound<'py, PyAny>> {
        let py = slf.py();
        let df = Simulation::to_pandas(slf)?;
        let kw = PyDict::new(py);
        kw.set_item("preserve_index", false)?;
        py.import("pyarrow")?
            .getattr("Table")?
            .call_method("from_pandas", (df,), Some(&kw))
    }

    fn __repr__(&self) -> String {
        format!(
            "Simulation({}, {}: {}, {}D, {}, step {}{})",
            self.names.0,
            self.names.1,
            latticesim::plural(self.engine.lat.len(), "agent"),
            self.engine.lat.dim.coords(),
            latticesim::plural(self.engine.prog.rules.len(), "rule"),
            self.engine.stats.steps,
            if self.engine.stats.quiescent {
                ", quiescent"
            } else {
                ""
            }
        )
    }
}
