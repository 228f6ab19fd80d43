//! `latticesim sweep`: run rules over generated shapes of growing n, several runs at once,
//! and write one CSV row per run with every total of a run (the columns of `run --series`,
//! summed) and how it stopped; with --plot, an SVG of steps, moves, swaps and messages
//! against n with fitted power laws. Finished runs are kept as they end ([`keep`]): Ctrl-C
//! writes the table of those finished, and `--resume` runs only the others.

mod keep;

use crate::gen::AgentOptions;
use crate::output::{open_output, say, write_output};
use crate::plot::{fit, Panel, Reference};
use crate::run::OrderArg;
use crate::set::Setting;
use crate::table::{Column, Table};
use clap::ValueEnum;
use latticesim_compiler::compile;
use latticesim_runtime::shapes::{agents_text, Shape};
use latticesim_runtime::{Engine, Options, StepCost};
use rayon::prelude::*;
use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Instant;

/// The shapes a sweep generates.
#[derive(Clone, Copy, ValueEnum)]
pub enum SweepShape {
    /// A row of n agents.
    Line,
    /// A square (2D) or cube (3D) of about n agents.
    #[value(alias = "rect", alias = "box")]
    Block,
    /// A random connected polyomino or polycube of n cells.
    #[value(alias = "polyomino", alias = "polycube")]
    Connected,
}

/// Part `index` (from 1) of `count` of a sweep's runs (`--shard I/N`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Shard {
    /// Which part, from 1.
    pub index: usize,
    /// Of how many.
    pub count: usize,
}

impl std::str::FromStr for Shard {
    type Err = String;

    fn from_str(s: &str) -> Result<Shard, String> {
        let bad =
            || format!("`{s}`: write the part and the number of parts, e.g. 3/10 (parts from 1)");
        let (i, n) = s.split_once('/').ok_or_else(bad)?;
        let (index, count): (usize, usize) = (
            i.trim().parse().map_err(|_| bad())?,
            n.trim().parse().map_err(|_| bad())?,
        );
        if count == 0 || index == 0 || index > count {
            return Err(format!(
                "`{s}`: the part must be from 1 to the number of parts ({count})"
            ));
        }
        Ok(Shard { index, count })
    }
}

impl Shard {
    /// Run number `run` (from 1) belongs to this part.
    pub fn has(self, run: usize) -> bool {
        (run - 1) % self.count == self.index - 1
    }
}

/// The arguments of `latticesim sweep`.
#[derive(clap::Args)]
pub struct SweepArgs {
    /// The rules file.
    rules: PathBuf,
    #[command(flatten)]
    lints: crate::LintArgs,
    /// The shapes to generate.
    #[arg(long, value_enum, default_value_t = SweepShape::Connected)]
    shape: SweepShape,
    /// The sizes n, comma-separated (of --shape, or given to --agents-cmd as `{size}`).
    #[arg(long, value_delimiter = ',', default_values_t = vec![10, 30, 100, 300, 1000])]
    sizes: Vec<u32>,
    /// Runs (seeds 1..=K) per size, or per file of --agents (default: 3 per size, 1 per
    /// file).
    #[arg(long)]
    seeds: Option<u64>,
    /// Run these agents files instead of generated shapes: a folder (every file in it) or
    /// a pattern such as `inputs/*.txt` (quote it for the shell); n is each file's agents.
    #[arg(long, conflicts_with_all = ["agents_cmd", "shape", "sizes"])]
    agents: Option<String>,
    /// Make each run's agents file with this command (run by `sh -c`), which writes it to
    /// standard output; `{size}` and `{seed}` in it are replaced by the size n and the
    /// seed, e.g. `python3 make.py {size} {seed}` (n in braces works as `{size}` does;
    /// clap's help cannot show it).
    #[arg(long, conflicts_with = "shape")]
    agents_cmd: Option<String>,
    /// Set a counter of every agent from an expression over n, x, y, z, id (the agent's
    /// line) and seed, e.g. `C00=id+1`, `C01=n`, `C02=(x+y)%2` (repeatable).
    #[arg(long, value_name = "Cnn=EXPR")]
    set: Vec<Setting>,
    #[command(flatten)]
    gen: AgentOptions,
    /// Stop a run after this many steps.
    #[arg(long, default_value_t = 100_000)]
    max_steps: u64,
    /// Which comes first in a step (as `run --order`).
    #[arg(long, value_enum, default_value_t = OrderArg::ActionsFirst)]
    order: OrderArg,
    /// Rules without a move or swap act before the rules with one (as `run --static-first`).
    #[arg(long)]
    static_first: bool,
    /// Runs at once (default: all cores).
    #[arg(long)]
    threads: Option<usize>,
    /// No progress bar (it is shown only on a terminal).
    #[arg(short, long)]
    quiet: bool,
    /// Run only part I of N of the runs (I from 1): runs I, I+N, I+2N, ... of the sweep,
    /// for a job array (Slurm, GNU parallel); `latticesim merge` joins the parts.
    #[arg(long, value_name = "I/N")]
    shard: Option<Shard>,
    /// The table of the runs: Parquet for a name ending in .parquet, else CSV. Each run is
    /// also added to `OUT.partial.csv` as it ends, so that a kill loses no finished run;
    /// it is removed once the table is written.
    #[arg(long)]
    out: PathBuf,
    /// Go on with a sweep that was interrupted (Ctrl-C) or killed: the runs already in
    /// --out and in `OUT.partial.csv` are kept, only the others run, and the table ends as
    /// the whole sweep writes it. The same command as before, with --resume.
    #[arg(long)]
    resume: bool,
    /// Also draw the metrics against n into this figure: SVG, PNG or PDF by its name (a
    /// panel per metric: every run, the mean and spread per n, the fitted power law with
    /// the 95 % interval of its exponent).
    #[arg(long)]
    plot: Option<PathBuf>,
    /// The metrics to plot and fit, comma-separated, of steps, firings, executing, moves,
    /// carried, swaps, messages, delivered, dropped, records (default: each of steps,
    /// moves, swaps and messages that occurs).
    #[arg(long, value_delimiter = ',', value_parser = ["steps", "firings", "executing", "moves", "carried", "swaps", "messages", "delivered", "dropped", "records"])]
    metrics: Option<Vec<String>>,
    /// Reference slopes to draw in every panel, comma-separated, e.g. `n,n^0.5,n log n`
    /// (through the mean of the smallest n).
    #[arg(long, value_delimiter = ',')]
    reference: Vec<Reference>,
    /// Title of the plot.
    #[arg(long, default_value = "")]
    title: String,
}

/// The result of one run of a sweep.
#[derive(Debug)]
pub struct Row {
    /// The run's number in the sweep (from 1), whatever shard ran it.
    pub run: usize,
    /// Agents.
    pub n: usize,
    /// The seed.
    pub seed: u64,
    /// What the agents were: the shape, the file or the command.
    pub input: String,
    /// It stopped at quiescence (else at the step limit).
    pub quiescent: bool,
    /// The run's totals (`step`: the steps).
    pub cost: StepCost,
    /// The rules' names, for the header.
    pub rules: Vec<String>,
    /// Wall time of the steps, in seconds.
    pub secs: f64,
}

/// What every run of a sweep shares: the rules, the counters set, how a run steps and
/// when it stops.
pub struct Setup {
    /// The rules file's name, for messages.
    pub rules_name: String,
    /// Its text.
    pub rules: Vec<u8>,
    /// Counters set in every agent before the run (`--set`).
    pub set: Vec<Setting>,
    /// A run stops after this many steps.
    pub max_steps: u64,
    /// The order of a step and which rules act first.
    pub opts: Options,
    /// Set from another thread to stop every run at its next step (a run stopped so
    /// fails, with a message that says so).
    pub cancel: Option<std::sync::Arc<std::sync::atomic::AtomicBool>>,
    /// Lint levels (after the rules file's own): a denied warning fails every run.
    pub lints: latticesim_compiler::lints::Lints,
}

/// A metric fitted and plotted against n: its name and its value in a row.
type Metric = (&'static str, fn(&Row) -> u64);

/// One run of a sweep: its agents and its seed.
enum Job {
    /// A generated shape of about n agents.
    Shape(u32),
    /// An agents file.
    File(std::path::PathBuf),
    /// The output of `--agents-cmd` for size n.
    Cmd(u32),
}

impl SweepShape {
    /// The shape of about `n` agents, in 3D when `three_d`.
    pub fn of(self, n: u32, three_d: bool) -> Shape {
        match self {
            SweepShape::Line => Shape::Line { n },
            SweepShape::Connected => Shape::Connected { n },
            SweepShape::Block => {
                let side = if three_d {
                    (n as f64).cbrt().round() as u32
                } else {
                    (n as f64).sqrt().round() as u32
                };
                Shape::Block {
                    w: side.max(1),
                    h: side.max(1),
                    d: if three_d { side.max(1) } else { 1 },
                }
            }
        }
    }

    /// Its name, as `--shape` takes it.
    pub fn name(self) -> String {
        self.to_possible_value()
            .expect("named")
            .get_name()
            .to_string()
    }
}

/// The command `--agents-cmd` `template` runs for size `n` and `seed`.
fn command_line(template: &str, n: u32, seed: u64) -> String {
    template
        .replace("{n}", &n.to_string())
        .replace("{size}", &n.to_string())
        .replace("{seed}", &seed.to_string())
}

/// The output of `--agents-cmd` `template` for size `n` and `seed` (its standard output),
/// and the command run. The command is killed when `stop` is set (Ctrl-C).
fn command_output(
    template: &str,
    n: u32,
    seed: u64,
    stop: Option<&AtomicBool>,
) -> Result<(Vec<u8>, String), String> {
    use std::io::Read;
    let cmd = command_line(template, n, seed);
    let cannot = |e: std::io::Error| format!("--agents-cmd `{cmd}`: cannot run it: {e}");
    let mut child = std::process::Command::new("sh")
        .args(["-c", &cmd])
        .stdin(std::process::Stdio::null())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .map_err(cannot)?;
    let drain = |r: Option<Box<dyn Read + Send>>| {
        std::thread::spawn(move || {
            let mut v = Vec::new();
            if let Some(mut r) = r {
                let _ = r.read_to_end(&mut v);
            }
            v
        })
    };
    let stdout = drain(child.stdout.take().map(|r| Box::new(r) as _));
    let stderr = drain(child.stderr.take().map(|r| Box::new(r) as _));
    let status = loop {
        if let Some(s) = child.try_wait().map_err(cannot)? {
            break s;
        }
        if stop.is_some_and(|s| s.load(Ordering::Relaxed)) {
            let _ = child.kill();
            let _ = child.wait();
            return Err(format!("--agents-cmd `{cmd}`: interrupted"));
        }
        std::thread::sleep(std::time::Duration::from_millis(5));
    };
    let out = std::process::Output {
        status,
        stdout: stdout.join().unwrap_or_default(),
        stderr: stderr.join().unwrap_or_default(),
    };
    if !out.status.success() {
        let err = String::from_utf8_lossy(&out.stderr);
        let last = err
            .lines()
            .rev()
            .find(|l| !l.trim().is_empty())
            .unwrap_or("");
        return Err(format!(
            "--agents-cmd `{cmd}` failed ({}){}",
            out.status,
            if last.is_empty() {
                String::new()
            } else {
                format!(": {last}")
            }
        ));
    }
    Ok((out.stdout, cmd))
}

/// Run number `run` of a sweep on the agents `source` (named `input`): read and checked
/// with the rules, counters set, stepped to quiescence or the step limit. A failure is a
/// message that names the input and the seed.
pub fn run_agents(
    setup: &Setup,
    run: usize,
    seed: u64,
    input: String,
    source: crate::agents_file::Source<'_>,
) -> Result<Row, String> {
    let what = format!("{input}, seed {seed}");
    let rules = (setup.rules_name.as_str(), setup.rules.as_slice());
    let loaded = crate::agents_file::load(rules, &input, source, 1, &setup.lints)
        .map_err(|e| format!("{what}: cannot read the agents: {e}"))?;
    let c = &loaded.checked;
    let (Some(p), Some(mut lat)) = (&c.rules, loaded.lattice) else {
        let first = c
            .diags
            .iter()
            .find(|d| d.is_error())
            .expect("no program means an error");
        let (line, col) = c
            .sources
            .line_col(first.primary.file, first.primary.span.start);
        return Err(format!(
            "{what}: {}:{line}:{col}: error[{}]: {} ({} errors in all; `latticesim check` shows them)",
            c.sources.name(first.primary.file),
            first.code.as_str(),
            first.message,
            c.errors()
        ));
    };
    for set in &setup.set {
        set.apply(&mut lat, seed)
            .map_err(|e| format!("{what}: {e}"))?;
    }
    let started = Instant::now();
    let prog = compile(p)
        .map_err(|e| format!("internal error: the compiled program does not verify: {e}"))?;
    let mut e = Engine::new(prog, lat, setup.opts);
    let (mut quiescent, mut executing) = (false, 0);
    let cancelled =
        || (setup.cancel.as_ref()).is_some_and(|c| c.load(std::sync::atomic::Ordering::Relaxed));
    while e.stats.steps < setup.max_steps {
        if cancelled() {
            return Err(format!("{what}: interrupted at step {}", e.stats.steps));
        }
        let rep = e.step();
        executing += rep.executing;
        if rep.quiescent {
            quiescent = true;
            break;
        }
    }
    Ok(Row {
        run,
        n: e.lat.len(),
        seed,
        input,
        quiescent,
        cost: StepCost::total(&e.stats, executing),
        rules: e.prog.rules.iter().map(|r| r.name.clone()).collect(),
        secs: started.elapsed().as_secs_f64(),
    })
}

/// What a run's agents are, as the table's `input` names them: the shape, the command run
/// or the file.
fn input_of(a: &SweepArgs, job: &Job, seed: u64) -> String {
    match job {
        Job::Shape(n) => format!("{} n={n}", a.shape.name()),
        Job::Cmd(n) => command_line(a.agents_cmd.as_deref().expect("asked for"), *n, seed),
        Job::File(p) => p.display().to_string(),
    }
}

/// One run of the command line's sweep: its agents made (a shape, a command's output or a
/// file), then run.
fn run_one(setup: &Setup, a: &SweepArgs, run: usize, job: &Job, seed: u64) -> Result<Row, String> {
    let (text, input): (Vec<u8>, String) = match job {
        Job::Shape(n) => (
            agents_text(&a.shape.of(*n, a.gen.three_d()), &a.gen.gen_options(seed)?)?.into_bytes(),
            input_of(a, job, seed),
        ),
        Job::Cmd(n) => command_output(
            a.agents_cmd.as_deref().expect("asked for"),
            *n,
            seed,
            setup.cancel.as_deref(),
        )?,
        Job::File(_) => (Vec::new(), input_of(a, job, seed)),
    };
    let source = match job {
        Job::File(p) => crate::agents_file::Source::File(p),
        _ => crate::agents_file::Source::Bytes(&text),
    };
    run_agents(setup, run, seed, input, source)
}

/// The metrics `--metrics` may name: name, value of a row.
const METRIC_NAMES: [Metric; 10] = [
    ("steps", |r| r.cost.step),
    ("firings", |r| r.cost.all_firings()),
    ("executing", |r| r.cost.executing),
    ("moves", |r| r.cost.moves),
    ("carried", |r| r.cost.carried),
    ("swaps", |r| r.cost.swaps),
    ("messages", |r| r.cost.sent),
    ("delivered", |r| r.cost.delivered),
    ("dropped", |r| r.cost.dropped),
    ("records", |r| r.cost.all_records()),
];

/// The points (n, value) of a metric, one per run.
fn points(rows: &[Row], f: fn(&Row) -> u64) -> Vec<(f64, f64)> {
    rows.iter().map(|r| (r.n as f64, f(r) as f64)).collect()
}

/// The metrics to plot and summarise: those `--metrics` names, else each of steps,
/// moves, swaps and messages that is above zero in some run.
fn chosen(a: &SweepArgs, rows: &[Row]) -> Vec<Metric> {
    match &a.metrics {
        Some(names) => (names.iter())
            .filter_map(|n| METRIC_NAMES.iter().find(|m| m.0 == n).copied())
            .collect(),
        None => (METRIC_NAMES.iter())
            .filter(|m| ["steps", "moves", "swaps", "messages"].contains(&m.0))
            .filter(|m| rows.iter().any(|r| m.1(r) > 0))
            .copied()
            .collect(),
    }
}

/// The table of the rows, in the order of their run numbers: the run, n, seed, the input
/// (shape, file or command), steps, how the run stopped, every other column of
/// `run --series` as the run's total, and the wall time.
pub fn table(rows: &[Row]) -> Table {
    let mut rows: Vec<&Row> = rows.iter().collect();
    rows.sort_by_key(|r| r.run);
    let rules: Vec<&str> = rows
        .first()
        .map_or(Vec::new(), |r| r.rules.iter().map(String::as_str).collect());
    let cols = StepCost::columns(&rules);
    let names = header(&rules);
    let ints = |f: &dyn Fn(&Row) -> u64| Column::Int(rows.iter().map(|r| f(r)).collect());
    let mut columns = vec![
        ints(&|r| r.run as u64),
        ints(&|r| r.n as u64),
        ints(&|r| r.seed),
        Column::Text(rows.iter().map(|r| r.input.clone()).collect()),
        ints(&|r| r.cost.step),
        Column::Text(
            (rows.iter())
                .map(|r| {
                    if r.quiescent {
                        "quiescence"
                    } else {
                        "max-steps"
                    }
                    .to_string()
                })
                .collect(),
        ),
    ];
    let values: Vec<Vec<u64>> = rows.iter().map(|r| r.cost.values()).collect();
    for i in 1..cols.len() {
        columns.push(Column::Int(values.iter().map(|v| v[i]).collect()));
    }
    columns.push(Column::Float(rows.iter().map(|r| r.secs).collect()));
    Table { names, columns }
}

/// The names of the columns of a sweep's table, for rules named `rules`.
pub(crate) fn header(rules: &[&str]) -> Vec<String> {
    let mut names: Vec<String> = ["run", "n", "seed", "input", "steps", "stopped_by"]
        .map(String::from)
        .into();
    names.extend(StepCost::columns(rules).into_iter().skip(1));
    names.push("wall_time_s".into());
    names
}

/// The runs of a sweep: per size (or file) and seed.
fn jobs(a: &SweepArgs) -> Result<Vec<(Job, u64)>, String> {
    let Some(pattern) = &a.agents else {
        let seeds = a.seeds.unwrap_or(3);
        let job = |n| {
            if a.agents_cmd.is_some() {
                Job::Cmd(n)
            } else {
                Job::Shape(n)
            }
        };
        return Ok((a.sizes.iter())
            .flat_map(|&n| (1..=seeds).map(move |s| (job(n), s)))
            .collect());
    };
    let path = std::path::Path::new(pattern);
    let mut files: Vec<std::path::PathBuf> = if path.is_dir() {
        std::fs::read_dir(path)
            .map_err(|e| format!("--agents `{pattern}`: {e}"))?
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| p.is_file())
            .collect()
    } else {
        glob::glob(pattern)
            .map_err(|e| format!("--agents `{pattern}`: {e}"))?
            .filter_map(Result::ok)
            .filter(|p| p.is_file())
            .collect()
    };
    files.sort();
    if files.is_empty() {
        return Err(format!("--agents `{pattern}`: no agents files there"));
    }
    let seeds = a.seeds.unwrap_or(1);
    Ok((files.into_iter())
        .flat_map(|f| (1..=seeds).map(move |s| (Job::File(f.clone()), s)))
        .collect())
}

/// The fitted growth of the metrics chosen, and the plot.
fn outputs(
    a: &SweepArgs,
    rows: &[Row],
    plot_file: Option<crate::output::AtomicFile>,
) -> Result<(), ExitCode> {
    let metrics = chosen(a, rows);
    let fits: Vec<String> = (metrics.iter())
        .filter_map(|&(name, f)| fit(&points(rows, f)).map(|f| format!("{name} ~ {}", f.text())))
        .collect();
    say!(
        "{}; {}; wrote {}",
        crate::plural(rows.len(), "run"),
        if fits.is_empty() {
            "nothing to fit (too few sizes, or no metric above zero)".to_string()
        } else {
            fits.join(", ")
        },
        a.out.display()
    );
    let Some(f) = plot_file else {
        return Ok(());
    };
    let panels: Vec<Panel> = (metrics.iter())
        .map(|&(name, v)| Panel {
            name,
            points: points(rows, v),
        })
        .collect();
    let format = crate::plot::format_of(f.path()).expect("checked before the runs");
    match crate::plot::svg(&a.title, &panels, &a.reference)
        .and_then(|svg| crate::plot::encode(&svg, format))
    {
        Ok(bytes) => write_output(f, &bytes),
        Err(e) => {
            say!("error: cannot draw `{}`: {e}", f.path().display());
            Err(ExitCode::from(2))
        }
    }
}

/// How a run of the command line's sweep ended.
enum Outcome {
    /// It finished (and is in the journal).
    Done(Row),
    /// It failed, with the message.
    Failed(String),
    /// It was stopped (Ctrl-C, or the journal could not be written) or never started.
    Stopped,
}

/// Runs the jobs (run number, agents, seed) on `--threads` threads, each finished run
/// added to the journal as it ends; `stop` (Ctrl-C, or a journal that cannot be written)
/// stops every run at its next step and starts no other.
fn run_all(
    a: &SweepArgs,
    setup: &Setup,
    jobs: &[&(usize, Job, u64)],
    journal: &keep::Journal,
    stop: &AtomicBool,
) -> Result<Vec<Outcome>, ExitCode> {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(crate::threads(
            a.threads,
            jobs.len(),
            &format!("the sweep has {} runs", jobs.len()),
        ))
        .build()
        .map_err(|e| {
            say!("error: cannot start threads: {e}");
            ExitCode::from(2)
        })?;
    // Runs done, failures and the time left, on a terminal only.
    use std::io::IsTerminal;
    let bar = if a.quiet || !std::io::stderr().is_terminal() {
        indicatif::ProgressBar::hidden()
    } else {
        let b = indicatif::ProgressBar::new(jobs.len() as u64);
        b.set_style(
            indicatif::ProgressStyle::with_template(
                "{bar:30} {pos}/{len} runs{msg} [{elapsed_precise}, about {eta} left]",
            )
            .expect("valid template"),
        );
        b
    };
    let failed = std::sync::atomic::AtomicUsize::new(0);
    let outcomes = pool.install(|| {
        jobs.par_iter()
            .map(|(run, job, seed)| {
                if stop.load(Ordering::SeqCst) {
                    return Outcome::Stopped;
                }
                let r = run_one(setup, a, *run, job, *seed);
                bar.inc(1);
                match r {
                    Ok(row) => {
                        if journal.add(&row).is_err() {
                            stop.store(true, Ordering::SeqCst);
                        }
                        Outcome::Done(row)
                    }
                    Err(_) if stop.load(Ordering::SeqCst) => Outcome::Stopped,
                    Err(e) => {
                        let f = 1 + failed.fetch_add(1, Ordering::Relaxed);
                        bar.set_message(format!(", {f} failed"));
                        Outcome::Failed(e)
                    }
                }
            })
            .collect()
    });
    bar.finish_and_clear();
    Ok(outcomes)
}

/// The runs of this sweep already finished (`--resume`), read from the table and its
/// journal; without `--resume`, none (a note says when a journal of finished runs is
/// replaced).
fn kept_runs(a: &SweepArgs, jobs: &[(usize, Job, u64)]) -> Result<Vec<Row>, ExitCode> {
    if !a.resume {
        let j = keep::journal_path(&a.out);
        if j.is_file() {
            say!(
                "note: `{}` holds runs of an earlier sweep that did not end; they are dropped (--resume keeps them)",
                j.display()
            );
        }
        return Ok(Vec::new());
    }
    let planned = (jobs.iter())
        .map(|(run, job, seed)| {
            let p = keep::Planned {
                input: input_of(a, job, *seed),
                seed: *seed,
            };
            (*run, p)
        })
        .collect();
    keep::resumed(&a.out, &planned).map_err(|e| {
        say!("error: {e}");
        ExitCode::from(2)
    })
}

/// `latticesim sweep`.
pub fn sweep(a: SweepArgs) -> ExitCode {
    let out_file = match open_output(&a.out) {
        Ok(f) => f,
        Err(c) => return c,
    };
    if let Some(p) = (a.plot.as_deref()).filter(|p| crate::plot::format_of(p).is_none()) {
        say!(
            "error: --plot `{}`: a plot is written as SVG, PNG or PDF (a name ending in .svg, .png or .pdf)",
            p.display()
        );
        return ExitCode::from(2);
    }
    let plot_file = match a.plot.as_deref().map(open_output).transpose() {
        Ok(f) => f,
        Err(c) => return c,
    };
    let rules = match crate::read(&a.rules) {
        Ok(b) => b,
        Err(c) => return c,
    };
    if let Err(e) = a.gen.gen_options(0) {
        say!("error: {e}");
        return ExitCode::from(2);
    }
    let lints = match a.lints.lints() {
        Ok(l) => l,
        Err(c) => return c,
    };
    let jobs: Vec<(usize, Job, u64)> = match jobs(&a) {
        Ok(j) => (j.into_iter().enumerate())
            .map(|(i, (job, seed))| (i + 1, job, seed))
            .filter(|(run, ..)| a.shard.is_none_or(|s| s.has(*run)))
            .collect(),
        Err(e) => {
            say!("error: {e}");
            return ExitCode::from(2);
        }
    };
    let kept = match kept_runs(&a, &jobs) {
        Ok(k) => k,
        Err(c) => return c,
    };
    let done: std::collections::HashSet<usize> = kept.iter().map(|r| r.run).collect();
    let todo: Vec<&(usize, Job, u64)> = jobs.iter().filter(|j| !done.contains(&j.0)).collect();
    if a.resume {
        say!(
            "resuming: {} of {} runs are done; running the other {}",
            kept.len(),
            jobs.len(),
            todo.len()
        );
    }
    let journal = match keep::Journal::create(&a.out, &kept) {
        Ok(j) => j,
        Err(e) => {
            say!("error: {e}");
            return ExitCode::from(2);
        }
    };
    // Ctrl-C from now on stops the runs at their next step; what finished is written.
    let stop = Arc::new(AtomicBool::new(false));
    crate::output::also_on_interrupt(stop.clone());
    crate::output::poll_interrupts();
    let setup = Setup {
        rules_name: a.rules.display().to_string(),
        rules,
        set: a.set.clone(),
        max_steps: a.max_steps,
        opts: Options {
            order: a.order.into(),
            static_first: a.static_first,
            // Counts alone are kept of a run: the same in any order of the agents, and
            // no record needs its sentence.
            space_order: latticesim_runtime::SpaceOrder::Auto,
            records_per_step: Some(0),
            ..Options::default()
        },
        cancel: Some(stop.clone()),
        lints,
    };
    let outcomes = match run_all(&a, &setup, &todo, &journal, &stop) {
        Ok(r) => r,
        Err(c) => return c,
    };
    // The runs that failed are named; the others are written all the same.
    let (mut rows, mut failed, mut stopped) = (kept, 0, 0);
    for o in outcomes {
        match o {
            Outcome::Done(row) => rows.push(row),
            Outcome::Failed(e) => {
                say!("error: {e}");
                failed += 1;
            }
            Outcome::Stopped => stopped += 1,
        }
    }
    if stopped > 0 {
        // Ctrl-C, or the journal failed: the table of the runs finished, no plot.
        let journal_failed = journal.error();
        if let Some(e) = &journal_failed {
            say!("error: {e}; the sweep stopped");
        }
        if let Err(c) = table(&rows).commit(out_file) {
            journal.keep_or_remove(rows.len());
            return c;
        }
        journal.remove();
        say!(
            "{}: {} of {} runs finished, in `{}`; the same command with --resume runs the other {}",
            if journal_failed.is_some() {
                "stopped"
            } else {
                "interrupted"
            },
            rows.len(),
            jobs.len(),
            a.out.display(),
            jobs.len() - rows.len()
        );
        return ExitCode::from(if journal_failed.is_some() { 2 } else { 130 });
    }
    if let Err(c) = table(&rows).commit(out_file) {
        journal.keep_or_remove(rows.len());
        return c;
    }
    journal.remove();
    if let Err(c) = outputs(&a, &rows, plot_file) {
        return c;
    }
    if failed > 0 {
        say!(
            "{failed} of {} runs failed; `{}` holds the others",
            failed + rows.len(),
            a.out.display()
        );
        return ExitCode::from(1);
    }
    let idle = rows.iter().filter(|r| r.cost.all_firings() == 0).count();
    if idle > 0 {
        say!(
            "warning: {idle} of {} runs fired no rule at all (none in their first step); do the agents start in states the rules test (--state, --first-state)?",
            rows.len()
        );
    }
    if rows.iter().any(|r| !r.quiescent) {
        say!(
            "warning: some runs stopped at --max-steps {} before quiescence",
            a.max_steps
        );
    }
    ExitCode::SUCCESS
}
