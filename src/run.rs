//! `latticesim run`: check, compile, step until quiescence, write the results.

use crate::agents_file;
use crate::output::{self, open_output, say, write_output};
use crate::series::{Series, SeriesFile};
use crate::{colour, read, Color, RECORDS_SHOWN_PER_KIND};
use clap::ValueEnum;
use latticesim_compiler::compile;
use latticesim_runtime::{
    checkpoint, Engine, Lattice, Options, Order, RecordKind, Skip, SpaceOrder, Stats, StepCost,
    StepReport, Undo,
};
use serde_json::json;
use std::collections::BTreeMap;
use std::io::{IsTerminal, Write};
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::{Duration, Instant};

/// The arguments of `latticesim run`.
#[derive(clap::Args)]
pub struct RunArgs {
    /// The rules file.
    rules: PathBuf,
    #[command(flatten)]
    lints: crate::LintArgs,
    /// The agents file (not with --resume).
    #[arg(required_unless_present = "resume", conflicts_with = "resume")]
    agents: Option<PathBuf>,
    /// Write a checkpoint here (an exact binary snapshot of the run) at the end of the
    /// run, when interrupted (Ctrl-C), and every --checkpoint-every steps.
    #[arg(long)]
    checkpoint: Option<PathBuf>,
    /// With --checkpoint: also write it every this many steps.
    #[arg(long, requires = "checkpoint", value_parser = clap::value_parser!(u64).range(1..))]
    checkpoint_every: Option<u64>,
    /// Continue the run saved in this checkpoint (made with the same rules, --order and
    /// --static-first) instead of starting from an agents file; --max-steps counts the
    /// steps before the checkpoint too.
    #[arg(long)]
    resume: Option<PathBuf>,
    /// Stop after this many steps at the latest.
    #[arg(long, default_value_t = 10_000)]
    max_steps: u64,
    /// Write the final configuration here (agents.txt syntax); default: standard output.
    #[arg(long)]
    out: Option<PathBuf>,
    /// Write statistics here (JSON).
    #[arg(long)]
    stats: Option<PathBuf>,
    /// Write every action and record of every step here (JSON Lines).
    #[arg(long)]
    trace: Option<PathBuf>,
    /// Write what each step cost here, one row per step (firings per rule, agents
    /// executing, moves, carried agents, swaps, messages, records by kind, step time): CSV
    /// for a name ending in .csv, Parquet for .parquet.
    #[arg(long)]
    series: Option<PathBuf>,
    /// Which comes first in a step.
    #[arg(long, value_enum, default_value_t = OrderArg::ActionsFirst)]
    order: OrderArg,
    /// Rules without a move or swap act before the rules with one.
    #[arg(long)]
    static_first: bool,
    /// Stop at the first error record, keeping the state before that step.
    #[arg(long)]
    strict: bool,
    /// Leave the wall time out of --stats, so that the file is the same on every run.
    #[arg(long)]
    no_timing: bool,
    /// Threads for the per-agent work (default: all cores); the results are the same for
    /// any number.
    #[arg(long)]
    threads: Option<usize>,
    /// Evaluate every agent at every step, even those that had no valid rule and saw
    /// nothing change since (which are skipped by default); the results are the same.
    #[arg(long)]
    no_skip: bool,
    /// Keep the agents in the agents file's order. A large file whose agents are listed in
    /// no spatial order is otherwise run with its agents in space order (faster); the
    /// results are the same, agents named by their ids in the file, but for the order of
    /// one step's records.
    #[arg(long)]
    file_order: bool,
    /// Print no records or summary (errors in the input files are still printed).
    #[arg(long, short)]
    quiet: bool,
    /// Colour in diagnostics.
    #[arg(long, value_enum, default_value_t = Color::Auto)]
    color: Color,
}

#[derive(Clone, Copy, ValueEnum)]
pub enum OrderArg {
    /// Actions, then calculations and messages (the paper's order).
    ActionsFirst,
    /// Calculations and messages, then actions.
    MessagesFirst,
}

impl From<OrderArg> for Order {
    fn from(o: OrderArg) -> Order {
        match o {
            OrderArg::ActionsFirst => Order::ActionsFirst,
            OrderArg::MessagesFirst => Order::MessagesFirst,
        }
    }
}

#[derive(Clone, Copy, PartialEq, Eq)]
enum Stop {
    Quiescence,
    MaxSteps,
    Strict,
    Interrupted,
}

impl Stop {
    fn name(self) -> &'static str {
        match self {
            Stop::Quiescence => "quiescence",
            Stop::MaxSteps => "max-steps",
            Stop::Strict => "strict",
            Stop::Interrupted => "interrupted",
        }
    }
}

/// Where the time of a run went, and its peak memory.
pub(crate) struct Timing {
    pub read: Duration,
    pub check: Duration,
    pub steps: Duration,
    pub write: Duration,
    /// Writing checkpoints (every `--checkpoint-every` steps and at the end), when asked for.
    pub checkpoint: Option<Duration>,
}

impl Timing {
    fn json(&self) -> serde_json::Value {
        json!({
            "read_s": self.read.as_secs_f64(),
            "check_s": self.check.as_secs_f64(),
            "steps_s": self.steps.as_secs_f64(),
            "write_s": self.write.as_secs_f64(),
            "checkpoint_s": self.checkpoint.map(|c| c.as_secs_f64()),
        })
    }
}

/// The peak resident memory of this process so far, in bytes (0 where unknown).
pub(crate) fn peak_memory() -> u64 {
    #[cfg(unix)]
    {
        // SAFETY: getrusage writes into the struct it is given.
        let mut u: libc::rusage = unsafe { std::mem::zeroed() };
        if unsafe { libc::getrusage(libc::RUSAGE_SELF, &mut u) } == 0 {
            // Kilobytes on Linux, bytes on macOS.
            let k = u.ru_maxrss.max(0) as u64;
            return if cfg!(target_os = "macos") {
                k
            } else {
                k * 1024
            };
        }
    }
    0
}

/// Bytes as MB with one decimal.
fn mb(b: u64) -> String {
    format!("{:.1} MB", b as f64 / 1e6)
}

fn stats_json(e: &Engine, stop: Stop, timing: Option<&Timing>) -> serde_json::Value {
    let mut v = stats_document(e, stop.name());
    if let Some(t) = timing {
        v["wall_time_s"] = json!(t.steps.as_secs_f64());
        v["times"] = t.json();
        v["peak_memory_bytes"] = json!(peak_memory());
        // How the run went, as the times: the same results either way.
        v["agents_in_space_order"] = json!(e.lat.in_space_order());
    }
    v
}

/// The statistics of a run (`run --stats`, without the times) that stopped by
/// `stopped_by` (`quiescence`, `max-steps`, `strict`, `interrupted`, or another word of
/// the caller's).
pub fn stats_document(e: &Engine, stopped_by: &str) -> serde_json::Value {
    let s: &Stats = &e.stats;
    let firings: Vec<serde_json::Value> = e
        .prog
        .rules
        .iter()
        .zip(&s.firings)
        .map(|(r, n)| json!({ "rule": r.name, "firings": n }))
        .collect();
    let by_kind: BTreeMap<&str, u64> = s.records.iter().map(|(k, n)| (k.name(), *n)).collect();
    let (errors, warnings) = (s.errors(), s.warnings());
    json!({
        "steps": s.steps,
        "stopped_by": stopped_by,
        "quiescent": stopped_by == Stop::Quiescence.name(),
        "agents": e.lat.len(),
        "rules": e.prog.rules.len(),
        "firings": firings,
        "moves": s.moves,
        "carried": s.carried,
        "swaps": s.swaps,
        "messages": { "sent": s.sent, "delivered": s.delivered, "dropped": s.dropped },
        "records": { "errors": errors, "warnings": warnings, "by_kind": by_kind },
    })
}

/// Prints the diagnostics of a check (only its errors when `quiet`).
fn show_diagnostics(checked: &latticesim_compiler::Checked, quiet: bool, colour: bool) {
    if !checked.diags.is_empty() && (checked.errors() > 0 || !quiet) {
        output::stderr(&checked.render(colour));
    }
}

/// Says that the files `what` were not run (with their number of errors, when it is what
/// stopped them) and gives exit status 1.
fn nothing_run(what: &str, errors: Option<usize>) -> ExitCode {
    match errors {
        Some(e) => say!(
            "{what}: {e} error{}; nothing was run",
            if e == 1 { "" } else { "s" }
        ),
        None => say!("{what}: nothing was run"),
    }
    ExitCode::from(1)
}

/// The checked rules compiled and verified, or the message of an internal error and exit
/// status 2.
pub(crate) fn compiled(
    rules: &latticesim_compiler::CheckedRules,
) -> Result<latticesim_vm::Verified, ExitCode> {
    compile(rules).map_err(|e| {
        say!("internal error: the compiled program does not verify: {e}");
        ExitCode::from(2)
    })
}

/// A rules and an agents file read, checked and compiled.
pub(crate) struct Ready {
    /// The verified program.
    pub prog: latticesim_vm::Verified,
    /// The agents.
    pub lat: Lattice,
    /// The time spent reading the agents file (and building the lattice).
    pub read: Duration,
    /// The time spent checking and compiling.
    pub check: Duration,
}

/// The threads that read and write agents files (all cores, or fewer when asked).
pub fn io_threads(requested: Option<usize>) -> usize {
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    requested.unwrap_or(cores).clamp(1, cores)
}

/// Reads and checks a rules and an agents file, printing the diagnostics (only errors when
/// `quiet`): the verified program and the lattice, or the exit status (1 for errors in the
/// files, 2 for I/O).
pub(crate) fn load(
    rules: &PathBuf,
    agents: &Path,
    (quiet, colour): (bool, bool),
    threads: usize,
    levels: &latticesim_compiler::lints::Lints,
) -> Result<Ready, ExitCode> {
    let rules_bytes = read(rules)?;
    let rules_name = rules.display().to_string();
    let agents_name = agents.display().to_string();
    let loaded = agents_file::load(
        (&rules_name, &rules_bytes),
        &agents_name,
        agents_file::Source::File(agents),
        threads,
        levels,
    )
    .map_err(|e| {
        say!("error: cannot read `{agents_name}`: {e}");
        ExitCode::from(2)
    })?;
    let checked = &loaded.checked;
    show_diagnostics(checked, quiet, colour);
    if let Some(note) = &loaded.note {
        say!("{note}");
    }
    let (Some(program), Some(lat)) = (checked.rules.as_ref(), loaded.lattice) else {
        let what = format!("{rules_name}, {agents_name}");
        return Err(nothing_run(
            &what,
            loaded.note.is_none().then(|| checked.errors()),
        ));
    };
    let t = Instant::now();
    let prog = compiled(program)?;
    Ok(Ready {
        prog,
        lat,
        read: loaded.read,
        check: loaded.check + t.elapsed(),
    })
}

/// Reads a rules file and the checkpoint of a run of it: the engine in that state, or the
/// exit status (1 for errors in the rules, 2 for a checkpoint that cannot be resumed).
fn resume(
    rules: &PathBuf,
    from: &Path,
    opts: Options,
    threads: Option<usize>,
    (quiet, colour): (bool, bool),
    levels: &latticesim_compiler::lints::Lints,
) -> Result<(Engine, Duration, Duration), ExitCode> {
    let started = Instant::now();
    let cannot = |e: &dyn std::fmt::Display| {
        say!("error: cannot resume from `{}`: {e}", from.display());
        ExitCode::from(2)
    };
    let peek = peek_checkpoint_file(from).map_err(|e| cannot(&e))?;
    let opts = Options {
        threads: crate::engine_threads(threads, peek.agents.min(u32::MAX as u64) as usize),
        ..opts
    };
    let rules_bytes = read(rules)?;
    let rules_name = rules.display().to_string();
    let levels = with_checkpoint_width(levels, &peek);
    let checked = crate::check_pair((&rules_name, &rules_bytes), None, Some(peek.dim), &levels);
    show_diagnostics(&checked, quiet, colour);
    let Some(program) = checked.rules.as_ref() else {
        return Err(nothing_run(&rules_name, Some(checked.errors())));
    };
    let prog = compiled(program)?;
    let check = started.elapsed();
    let t = Instant::now();
    let engine = read_checkpoint_file(prog, opts, from).map_err(|e| cannot(&e))?;
    Ok((engine, t.elapsed(), check))
}

/// Writes a checkpoint of the engine (compressed by the file's name: `.zst`, `.gz`) whole
/// or not at all.
pub fn write_checkpoint_file(engine: &Engine, path: &Path) -> std::io::Result<()> {
    output::AtomicFile::create(path)
        .and_then(|f| {
            let mut w = agents_file::Packed::new(f.durable(), agents_file::Packing::of(path))?;
            engine.write_checkpoint(&mut w)?;
            w.finish()
        })
        .and_then(|f| f.commit())
}

/// An engine in the state of the checkpoint file `path` (compressed by its name), of a run
/// of the program `prog` with the order of `opts`.
pub fn read_checkpoint_file(
    prog: latticesim_vm::Verified,
    opts: Options,
    path: &Path,
) -> Result<Engine, String> {
    agents_file::open_read(path)
        .map_err(|e| e.to_string())
        .and_then(|r| Engine::read_checkpoint(prog, opts, r).map_err(|e| e.to_string()))
}

/// The levels to check the rules of a resumed run with: the checkpoint records the width of
/// counters, which the rules are then compiled in unless the command line says one (which
/// must then be the same).
pub fn with_checkpoint_width(
    levels: &latticesim_compiler::lints::Lints,
    peek: &checkpoint::Peek,
) -> latticesim_compiler::lints::Lints {
    let mut l = levels.clone();
    if levels.width_origin().is_none() {
        l.set_counters(peek.width, "the checkpoint");
    }
    l
}

/// The dimension, number of agents and width of counters of the checkpoint file `path`.
pub fn peek_checkpoint_file(path: &Path) -> Result<checkpoint::Peek, String> {
    agents_file::open_read(path)
        .map_err(|e| e.to_string())
        .and_then(|r| checkpoint::peek(r).map_err(|e| e.to_string()))
}

/// Writes a checkpoint of the engine (compressed by the file's name) whole or not at all.
fn save_checkpoint(engine: &Engine, path: &Path) -> Result<(), ExitCode> {
    write_checkpoint_file(engine, path).map_err(|e| {
        say!(
            "error: cannot write the checkpoint `{}`: {e}",
            path.display()
        );
        ExitCode::from(2)
    })
}

pub fn run(args: RunArgs) -> ExitCode {
    match run_to_end(&args) {
        Ok(c) | Err(c) => c,
    }
}

/// `latticesim run`: outputs checked, the engine started, the steps to the end, then the
/// outputs and the summary. The exit status either way.
fn run_to_end(args: &RunArgs) -> Result<ExitCode, ExitCode> {
    let colour = colour(args.color);
    // Every output path is checked (by starting its file) before anything is read or run.
    let open = |p: &Option<PathBuf>| p.as_deref().map(open_output).transpose();
    let (out_file, stats_file, trace_out) =
        match (open(&args.out), open(&args.stats), open(&args.trace)) {
            (Ok(o), Ok(s), Ok(t)) => (o, s, t),
            (Err(c), _, _) | (_, Err(c), _) | (_, _, Err(c)) => return Err(c),
        };
    if let Some(p) = &args.checkpoint {
        // Found now when it cannot be written, not at the end of a long run.
        open_output(p)?;
    }
    let series_file = args.series.as_deref().map(SeriesFile::open).transpose()?;
    let io_threads = io_threads(args.threads);
    let (engine, ready_read, ready_check) = start(args, trace_out.is_some(), colour, io_threads)?;
    let series = match series_file {
        Some(f) => {
            let names: Vec<&str> = engine.prog.rules.iter().map(|r| r.name.as_str()).collect();
            let path = args.series.as_deref().expect("opened");
            Some(f.start(&names, !args.no_timing).map_err(|e| {
                say!("error: cannot write `{}`: {e}", path.display());
                ExitCode::from(2)
            })?)
        }
        None => None,
    };
    output::poll_interrupts();
    // A resumed run says what it did beside the totals since step 0.
    let resumed_at = args.resume.is_some().then(|| engine.stats.clone());
    let started = Instant::now();
    let console = Console::new(args.quiet, args.max_steps, &engine.stats.records);
    let steps = Steps {
        engine,
        undo: None,
        console,
        trace: trace_out,
        trace_failed: false,
        series,
        series_failed: false,
        checkpoint_failed: false,
        checkpointing: Duration::ZERO,
    };
    let (mut steps, stop) = steps.run(args);
    let wall = started.elapsed().saturating_sub(steps.checkpointing);
    // Every file asked for is written, even when an earlier one (or the terminal) failed.
    let mut failed = (args.checkpoint.as_deref())
        .is_some_and(|p| !steps.checkpoint(p))
        .then(|| ExitCode::from(2));
    let Steps {
        engine,
        undo: _,
        console,
        trace,
        trace_failed,
        series,
        series_failed,
        checkpoint_failed,
        checkpointing,
    } = steps;
    let shown = console.finish();
    if trace_failed || series_failed || checkpoint_failed {
        failed = Some(ExitCode::from(2));
    }
    if let Some(s) = series {
        let path = args.series.as_deref().expect("asked for");
        if let Err(e) = s.finish() {
            say!("error: cannot write `{}`: {e}", path.display());
            failed = Some(ExitCode::from(2));
        }
    }
    if let Some(t) = trace {
        let path = t.path().to_path_buf();
        if let Err(e) = t.commit() {
            say!("error: cannot write `{}`: {e}", path.display());
            failed = Some(ExitCode::from(2));
        }
    }
    let writing = Instant::now();
    match out_file {
        Some(f) => {
            failed = agents_file::write_lattice(f, &engine.lat, io_threads)
                .err()
                .or(failed)
        }
        None => {
            let mut w = output::Stdout::new();
            let _ = engine.lat.write_agents_text(&mut w, io_threads);
        }
    }
    let timing = Timing {
        read: ready_read,
        check: ready_check,
        steps: wall,
        write: writing.elapsed(),
        checkpoint: args.checkpoint.is_some().then_some(checkpointing),
    };
    if let Some(f) = stats_file {
        let v = stats_json(&engine, stop, (!args.no_timing).then_some(&timing));
        let mut s = serde_json::to_string_pretty(&v).expect("plain data");
        s.push('\n');
        failed = write_output(f, s.as_bytes()).err().or(failed);
    }
    if let Some(c) = failed {
        return Err(c);
    }
    if !args.quiet {
        Console::more(&shown);
        say!(
            "{}",
            summary(&engine, stop, args.max_steps, &timing, resumed_at.as_ref())
        );
    }
    Ok(match stop {
        Stop::Strict => ExitCode::from(3),
        Stop::Interrupted => ExitCode::from(130),
        _ => ExitCode::SUCCESS,
    })
}

/// The engine of a run, from the agents file or the checkpoint, with the time it took to
/// read and to check the files.
fn start(
    args: &RunArgs,
    trace: bool,
    colour: bool,
    io_threads: usize,
) -> Result<(Engine, Duration, Duration), ExitCode> {
    let opts = Options {
        threads: 1,
        order: args.order.into(),
        static_first: args.static_first,
        trace,
        skip: if args.no_skip { Skip::Off } else { Skip::Auto },
        space_order: match args.file_order {
            true => SpaceOrder::Off,
            false => SpaceOrder::Auto,
        },
        // The records shown; a trace has them all.
        records_per_step: (!trace).then_some(RECORDS_SHOWN_PER_KIND as usize),
    };
    let levels = args.lints.lints()?;
    let shown = (args.quiet, colour);
    match (&args.resume, &args.agents) {
        (Some(from), _) => resume(&args.rules, from, opts, args.threads, shown, &levels),
        (None, Some(agents)) => {
            let r = load(&args.rules, agents, shown, io_threads, &levels)?;
            let opts = Options {
                threads: crate::engine_threads(args.threads, r.lat.len()),
                ..opts
            };
            Ok((Engine::new(r.prog, r.lat, opts), r.read, r.check))
        }
        (None, None) => unreachable!("clap requires an agents file or --resume"),
    }
}

/// A run's steps and what they write as they go: the trace, the checkpoints every N steps,
/// the records and progress on the terminal.
struct Steps {
    engine: Engine,
    /// With `--strict`, after a step with an error record: the state before it.
    undo: Option<(Undo, Stats)>,
    console: Console,
    trace: Option<output::AtomicFile>,
    trace_failed: bool,
    /// The per-step series, when asked for (given up when it cannot be written).
    series: Option<Series>,
    series_failed: bool,
    checkpoint_failed: bool,
    /// The time spent writing checkpoints.
    checkpointing: Duration,
}

impl Steps {
    /// Writes the checkpoint to `path`, timed; false when it failed (said).
    fn checkpoint(&mut self, path: &Path) -> bool {
        let t = Instant::now();
        let ok = save_checkpoint(&self.engine, path).is_ok();
        self.checkpointing += t.elapsed();
        ok
    }

    /// Steps to quiescence, `--max-steps`, an error record with `--strict`, or Ctrl-C;
    /// returns which.
    fn run(mut self, args: &RunArgs) -> (Steps, Stop) {
        let stop = self.steps(args);
        if let Some(before) = self.undo.take() {
            self.engine = self.engine.undo(before);
        }
        (self, stop)
    }

    fn steps(&mut self, args: &RunArgs) -> Stop {
        // A run resumed after it ended by quiescence has ended.
        if args.resume.is_some() && self.engine.stats.quiescent {
            return Stop::Quiescence;
        }
        while self.engine.stats.steps < args.max_steps {
            let before = args.strict.then(|| self.engine.undo_point());
            let stats_before = self.series.is_some().then(|| self.engine.stats.clone());
            let t = Instant::now();
            let rep = self.engine.step();
            let secs = t.elapsed().as_secs_f64();
            self.console.records(&rep, &self.engine.stats.records);
            if rep.executing == 0 && self.engine.stats.steps == 1 && !args.quiet {
                say!("warning: no rule fired in the first step (no agent's precondition held), so the run ends at once");
            }
            self.trace_step(&rep);
            // (A step keeps its first records of each kind: any error kind made, one.)
            if args.strict && rep.records.iter().any(|r| r.is_error()) {
                self.undo = before;
                return Stop::Strict;
            }
            if let Some(b) = stats_before {
                let cost = StepCost::of(&b, &self.engine.stats, &rep);
                self.series_row(&cost, (!args.no_timing).then_some(secs), args);
            }
            if rep.quiescent {
                return Stop::Quiescence;
            }
            let steps = self.engine.stats.steps;
            if let (Some(p), Some(every)) = (&args.checkpoint, args.checkpoint_every) {
                if steps.is_multiple_of(every) && steps < args.max_steps {
                    self.checkpoint_failed |= !self.checkpoint(p);
                }
            }
            if output::interrupted() {
                return Stop::Interrupted;
            }
            self.console.progress(steps);
        }
        Stop::MaxSteps
    }

    /// The step's row of the series. A series that cannot be written is given up (its
    /// unfinished file removed); the run goes on and its other outputs are still written.
    fn series_row(&mut self, cost: &StepCost, secs: Option<f64>, args: &RunArgs) {
        let Some(s) = self.series.as_mut() else {
            return;
        };
        if let Err(e) = s.push(cost, secs) {
            let path = args.series.as_deref().expect("asked for");
            say!(
                "error: cannot write `{}`: {e}; the run goes on without it",
                path.display()
            );
            self.series = None;
            self.series_failed = true;
        }
    }

    /// The step's trace events and records as JSON lines of the trace, when there is one.
    /// A trace that cannot be written is given up (its unfinished file removed); the run
    /// goes on and its other outputs are still written.
    fn trace_step(&mut self, rep: &StepReport) {
        let Some(w) = self.trace.as_mut() else {
            return;
        };
        let step = self.engine.stats.steps;
        let mut ok = true;
        for ev in &rep.trace {
            let mut v = serde_json::to_value(ev).expect("plain data");
            v["step"] = json!(step);
            ok &= writeln!(w, "{v}").is_ok();
        }
        for r in &rep.records {
            let v = json!({
                "event": "record",
                "step": step,
                "kind": r.kind.name(),
                "severity": if r.is_error() { "error" } else { "warning" },
                "agents": r.agents.iter().map(|(id, p)| json!({"id": id, "pos": p})).collect::<Vec<_>>(),
                "message": r.message,
            });
            ok &= writeln!(w, "{v}").is_ok();
        }
        if !ok {
            say!(
                "error: cannot write `{}`; the run goes on without it",
                w.path().display()
            );
            self.trace = None;
            self.trace_failed = true;
        }
    }
}

/// What a run shows on the terminal while it steps: the first records of each kind, and
/// a progress bar once it has taken a second.
struct Console {
    quiet: bool,
    show_progress: bool,
    max_steps: u64,
    started: Instant,
    bar: Option<indicatif::ProgressBar>,
    /// Per kind: the records shown, the records the run made (counted from the engine's
    /// totals: a step's report keeps only the records shown), the totals last seen.
    printed: BTreeMap<RecordKind, u64>,
    made: BTreeMap<RecordKind, u64>,
    seen: BTreeMap<RecordKind, u64>,
}

impl Console {
    /// `totals`: the engine's counts of records at the start (a resumed run's checkpoint's).
    fn new(quiet: bool, max_steps: u64, totals: &BTreeMap<RecordKind, u64>) -> Console {
        Console {
            quiet,
            show_progress: !quiet && std::io::stderr().is_terminal(),
            max_steps,
            started: Instant::now(),
            bar: None,
            printed: BTreeMap::new(),
            made: BTreeMap::new(),
            seen: totals.clone(),
        }
    }

    /// Shows the step's records, up to [`RECORDS_SHOWN_PER_KIND`] of each kind in a run,
    /// and counts those the step made (`totals`: the engine's counts after it).
    fn records(&mut self, rep: &StepReport, totals: &BTreeMap<RecordKind, u64>) {
        for r in &rep.records {
            let n = self.printed.entry(r.kind).or_insert(0);
            if !self.quiet && *n < RECORDS_SHOWN_PER_KIND {
                *n += 1;
                let line = format!("{r}");
                match &self.bar {
                    Some(b) => b.println(line),
                    None => say!("{line}"),
                }
            }
        }
        for (&k, &t) in totals {
            let seen = self.seen.entry(k).or_insert(0);
            *self.made.entry(k).or_insert(0) += t.saturating_sub(*seen);
            *seen = t;
        }
    }

    /// The progress bar at `steps`, started after a second.
    fn progress(&mut self, steps: u64) {
        if self.show_progress
            && self.bar.is_none()
            && self.started.elapsed() > Duration::from_secs(1)
        {
            let b = indicatif::ProgressBar::new(self.max_steps);
            b.set_style(
                indicatif::ProgressStyle::with_template(
                    "{spinner} step {pos} of at most {len} [{elapsed_precise}] {msg}",
                )
                .expect("valid template"),
            );
            self.bar = Some(b);
        }
        if let Some(b) = &self.bar {
            b.set_position(steps);
        }
    }

    /// Clears the bar; the records of each kind the run made.
    fn finish(self) -> BTreeMap<RecordKind, u64> {
        if let Some(b) = self.bar {
            b.finish_and_clear();
        }
        self.made
    }

    /// How many records of each kind were not shown.
    fn more(shown: &BTreeMap<RecordKind, u64>) {
        for (k, n) in shown {
            if *n > RECORDS_SHOWN_PER_KIND {
                say!(
                    "... and {} more {} records",
                    n - RECORDS_SHOWN_PER_KIND,
                    k.name()
                );
            }
        }
    }
}

/// The summary line of a run; `resumed_at`, the totals of a resumed run's checkpoint: the
/// run's own counts come first, then the totals since step 0.
fn summary(
    engine: &Engine,
    stop: Stop,
    max_steps: u64,
    timing: &Timing,
    resumed_at: Option<&Stats>,
) -> String {
    let s = &engine.stats;
    let why = match stop {
        Stop::Quiescence => "quiescent".to_string(),
        Stop::MaxSteps => format!("stopped at --max-steps {max_steps}"),
        Stop::Strict => {
            "stopped by --strict at an error record; the state is the one before that step".into()
        }
        Stop::Interrupted => "interrupted".into(),
    };
    let counts = |s: &Stats, b: Option<&Stats>| {
        let d = |f: fn(&Stats) -> u64| f(s) - b.map_or(0, f);
        format!(
            "{} rule firings, {} moves, {} swaps, {} messages sent ({} delivered, {} dropped), {} error records, {} warnings",
            d(|s| s.firings.iter().sum()),
            d(|s| s.moves),
            d(|s| s.swaps),
            d(|s| s.sent),
            d(|s| s.delivered),
            d(|s| s.dropped),
            d(Stats::errors),
            d(Stats::warnings),
        )
    };
    let work = match resumed_at {
        None => format!("{} steps, {why}: {}", s.steps, counts(s, None)),
        Some(b) => format!(
            "resumed at step {}, {} steps, {why}: {}; since step 0: {} steps, {}",
            b.steps,
            s.steps - b.steps,
            counts(s, Some(b)),
            s.steps,
            counts(s, None)
        ),
    };
    let checkpoint = timing
        .checkpoint
        .map(|c| format!(", checkpoint {:.3} s", c.as_secs_f64()))
        .unwrap_or_default();
    format!(
        "{} agents, {work}; read {:.3} s, check {:.3} s, steps {:.3} s, write {:.3} s{checkpoint}, peak memory {}",
        engine.lat.len(),
        timing.read.as_secs_f64(),
        timing.check.as_secs_f64(),
        timing.steps.as_secs_f64(),
        timing.write.as_secs_f64(),
        mb(peak_memory()),
    )
}
