//! `latticesim sweep`: run rules over generated shapes of growing n, several runs at once,
//! and write one CSV row per run with every total of a run (the columns of `run --series`,
//! summed) and how it stopped; with --plot, an SVG of steps, moves, swaps and messages
//! against n with fitted power laws.

use crate::gen::AgentOptions;
use crate::output::{open_output, say, write_output};
use crate::plot::{fit, Panel, Reference};
use crate::run::OrderArg;
use crate::series::csv_field;
use crate::set::Setting;
use clap::ValueEnum;
use latticesim_compiler::compile;
use latticesim_runtime::shapes::{agents_text, Shape};
use latticesim_runtime::{Engine, Options, StepCost};
use rayon::prelude::*;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

#[derive(Clone, Copy, ValueEnum)]
enum SweepShape {
    /// A row of n agents.
    Line,
    /// A square (2D) or cube (3D) of about n agents.
    #[value(alias = "rect", alias = "box")]
    Block,
    /// A random connected polyomino or polycube of n cells.
    #[value(alias = "polyomino", alias = "polycube")]
    Connected,
}

/// The arguments of `latticesim sweep`.
#[derive(clap::Args)]
pub struct SweepArgs {
    /// The rules file.
    rules: PathBuf,
    /// The shapes to generate.
    #[arg(long, value_enum, default_value_t = SweepShape::Connected)]
    shape: SweepShape,
    /// The sizes n, comma-separated (of --shape, or given to --agents-cmd as {n}).
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
    /// standard output; `{n}` and `{seed}` in it are replaced by the size and the seed,
    /// e.g. `python3 make.py {n} {seed}`.
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
    /// The CSV file.
    #[arg(long)]
    out: PathBuf,
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

struct Row {
    n: usize,
    seed: u64,
    /// What the agents were: the shape, the file or the command.
    input: String,
    quiescent: bool,
    /// The run's totals (`step`: the steps).
    cost: StepCost,
    /// The rules' names, for the header.
    rules: Vec<String>,
    secs: f64,
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

/// The shape of about `n` agents that `--shape` asks for.
fn shape(a: &SweepArgs, n: u32) -> Shape {
    let three_d = a.gen.three_d();
    match a.shape {
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

/// The output of `--agents-cmd` `template` for size `n` and `seed` (its standard output),
/// and the command run.
fn command_output(template: &str, n: u32, seed: u64) -> Result<(Vec<u8>, String), String> {
    let cmd = template
        .replace("{n}", &n.to_string())
        .replace("{seed}", &seed.to_string());
    let out = std::process::Command::new("sh")
        .args(["-c", &cmd])
        .stdin(std::process::Stdio::null())
        .output()
        .map_err(|e| format!("--agents-cmd `{cmd}`: cannot run it: {e}"))?;
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

fn run_one(rules: &[u8], a: &SweepArgs, job: &Job, seed: u64) -> Result<Row, String> {
    let rules_name = a.rules.display().to_string();
    let (text, input): (Vec<u8>, String) = match job {
        Job::Shape(n) => (
            agents_text(&shape(a, *n), &a.gen.gen_options(seed)?)?.into_bytes(),
            format!(
                "{} n={n}",
                a.shape.to_possible_value().expect("named").get_name()
            ),
        ),
        Job::Cmd(n) => command_output(a.agents_cmd.as_deref().expect("asked for"), *n, seed)?,
        Job::File(p) => (Vec::new(), p.display().to_string()),
    };
    let source = match job {
        Job::File(p) => crate::agents_file::Source::File(p),
        _ => crate::agents_file::Source::Bytes(&text),
    };
    let what = format!("{input}, seed {seed}");
    let loaded = crate::agents_file::load((&rules_name, rules), &input, source, 1)
        .map_err(|e| format!("{what}: cannot read the agents: {e}"))?;
    drop(text);
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
    for set in &a.set {
        set.apply(&mut lat, seed)
            .map_err(|e| format!("{what}: {e}"))?;
    }
    let started = Instant::now();
    let prog = compile(p)
        .map_err(|e| format!("internal error: the compiled program does not verify: {e}"))?;
    let opts = Options {
        order: a.order.into(),
        static_first: a.static_first,
        ..Options::default()
    };
    let mut e = Engine::new(prog, lat, opts);
    let (mut quiescent, mut executing) = (false, 0);
    while e.stats.steps < a.max_steps {
        let rep = e.step();
        executing += rep.executing;
        if rep.quiescent {
            quiescent = true;
            break;
        }
    }
    Ok(Row {
        n: e.lat.len(),
        seed,
        input,
        quiescent,
        cost: StepCost::total(&e.stats, executing),
        rules: e.prog.rules.iter().map(|r| r.name.clone()).collect(),
        secs: started.elapsed().as_secs_f64(),
    })
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

/// The CSV of the rows: n, seed, the input (shape, file or command), steps, how the run
/// stopped, every other column of
/// `run --series` as the run's total, and the wall time.
fn csv(rows: &[Row]) -> String {
    let rules: Vec<&str> = rows
        .first()
        .map_or(Vec::new(), |r| r.rules.iter().map(String::as_str).collect());
    let cols = StepCost::columns(&rules);
    let mut head = vec![
        "n".to_string(),
        "seed".into(),
        "input".into(),
        "steps".into(),
        "stopped_by".into(),
    ];
    head.extend(cols.iter().skip(1).map(|c| csv_field(c)));
    head.push("wall_time_s".into());
    let mut out = head.join(",") + "\n";
    for r in rows {
        let stop = if r.quiescent {
            "quiescence"
        } else {
            "max-steps"
        };
        let mut line = vec![
            r.n.to_string(),
            r.seed.to_string(),
            csv_field(&r.input),
            r.cost.step.to_string(),
            stop.into(),
        ];
        line.extend(r.cost.values().iter().skip(1).map(u64::to_string));
        line.push(format!("{:.6}", r.secs));
        out += &(line.join(",") + "\n");
    }
    out
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

/// The CSV of the rows, the fitted growth of the metrics chosen, and the plot.
fn outputs(
    a: &SweepArgs,
    rows: &[Row],
    out_file: crate::output::AtomicFile,
    plot_file: Option<crate::output::AtomicFile>,
) -> Result<(), ExitCode> {
    write_output(out_file, csv(rows).as_bytes())?;
    let metrics = chosen(a, rows);
    let fits: Vec<String> = (metrics.iter())
        .filter_map(|&(name, f)| fit(&points(rows, f)).map(|f| format!("{name} ~ {}", f.text())))
        .collect();
    say!(
        "{} runs; {}; wrote {}",
        rows.len(),
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
    let jobs = match jobs(&a) {
        Ok(j) => j,
        Err(e) => {
            say!("error: {e}");
            return ExitCode::from(2);
        }
    };
    let pool = match rayon::ThreadPoolBuilder::new()
        .num_threads(crate::threads(
            a.threads,
            jobs.len(),
            &format!("the sweep has {} runs", jobs.len()),
        ))
        .build()
    {
        Ok(p) => p,
        Err(e) => {
            say!("error: cannot start threads: {e}");
            return ExitCode::from(2);
        }
    };
    let results: Vec<Result<Row, String>> = pool.install(|| {
        jobs.par_iter()
            .map(|(job, s)| run_one(&rules, &a, job, *s))
            .collect()
    });
    // The runs that failed are named; the others are written all the same.
    let (mut rows, mut failed) = (Vec::with_capacity(results.len()), 0);
    for r in results {
        match r {
            Ok(row) => rows.push(row),
            Err(e) => {
                say!("error: {e}");
                failed += 1;
            }
        }
    }
    if let Err(c) = outputs(&a, &rows, out_file, plot_file) {
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
