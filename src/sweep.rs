//! `latticesim sweep`: run rules over generated shapes of growing n, several runs at once,
//! and write one CSV row per run (and, with --plot, an SVG of steps and moves against n with
//! fitted power laws).

use crate::gen::AgentOptions;
use crate::output::{open_output, say, write_output};
use clap::ValueEnum;
use latticesim_compiler::compile;
use latticesim_runtime::shapes::{agents_text, Shape};
use latticesim_runtime::{Engine, Options};
use plotters::prelude::*;
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
    /// The sizes n, comma-separated.
    #[arg(long, value_delimiter = ',', default_values_t = vec![10, 30, 100, 300, 1000])]
    sizes: Vec<u32>,
    /// Runs (seeds 1..=K) per size.
    #[arg(long, default_value_t = 3)]
    seeds: u64,
    #[command(flatten)]
    agents: AgentOptions,
    /// Stop a run after this many steps.
    #[arg(long, default_value_t = 100_000)]
    max_steps: u64,
    /// Runs at once (default: all cores).
    #[arg(long)]
    threads: Option<usize>,
    /// The CSV file.
    #[arg(long)]
    out: PathBuf,
    /// Also draw steps and moves against n into this SVG file.
    #[arg(long)]
    plot: Option<PathBuf>,
    /// Title of the plot.
    #[arg(long, default_value = "")]
    title: String,
}

struct Row {
    n: usize,
    seed: u64,
    steps: u64,
    quiescent: bool,
    moves: u64,
    messages: u64,
    secs: f64,
}

/// Least-squares fit of log y = a + b log x; returns (a, b).
pub fn fit_power(points: &[(f64, f64)]) -> Option<(f64, f64)> {
    let pts: Vec<(f64, f64)> = points
        .iter()
        .filter(|p| p.0 > 0.0 && p.1 > 0.0)
        .map(|p| (p.0.ln(), p.1.ln()))
        .collect();
    let k = pts.len() as f64;
    if pts.len() < 2 {
        return None;
    }
    let (sx, sy) = pts.iter().fold((0.0, 0.0), |a, p| (a.0 + p.0, a.1 + p.1));
    let (mx, my) = (sx / k, sy / k);
    let sxx: f64 = pts.iter().map(|p| (p.0 - mx).powi(2)).sum();
    let sxy: f64 = pts.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    if sxx == 0.0 {
        return None;
    }
    let b = sxy / sxx;
    Some((my - b * mx, b))
}

fn run_one(rules: &[u8], a: &SweepArgs, n: u32, seed: u64) -> Result<Row, String> {
    let three_d = a.agents.three_d();
    let shape = match a.shape {
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
    };
    let agents = agents_text(&shape, &a.agents.gen_options(seed)?)?;
    let loaded = crate::agents_file::load(
        (&a.rules.display().to_string(), rules),
        "generated agents",
        crate::agents_file::Source::Bytes(agents.as_bytes()),
        1,
    )
    .map_err(|e| format!("n = {n}, seed {seed}: cannot read the generated agents: {e}"))?;
    drop(agents);
    let c = &loaded.checked;
    let (Some(p), Some(lat)) = (&c.rules, loaded.lattice) else {
        let first = c
            .diags
            .iter()
            .find(|d| d.is_error())
            .expect("no program means an error");
        let (line, col) = c
            .sources
            .line_col(first.primary.file, first.primary.span.start);
        return Err(format!(
            "n = {n}, seed {seed}: {}:{line}:{col}: error[{}]: {} ({} errors in all; `latticesim check` shows them)",
            c.sources.name(first.primary.file),
            first.code.as_str(),
            first.message,
            c.errors()
        ));
    };
    let started = Instant::now();
    let prog = compile(p)
        .map_err(|e| format!("internal error: the compiled program does not verify: {e}"))?;
    let mut e = Engine::new(prog, lat, Options::default());
    let mut quiescent = false;
    while e.stats.steps < a.max_steps {
        if e.step().quiescent {
            quiescent = true;
            break;
        }
    }
    Ok(Row {
        n: e.lat.len(),
        seed,
        steps: e.stats.steps,
        quiescent,
        moves: e.stats.moves,
        messages: e.stats.sent,
        secs: started.elapsed().as_secs_f64(),
    })
}

/// The log-log plot of steps and moves against n, as SVG text.
fn plot(title: &str, rows: &[Row]) -> Result<String, String> {
    let steps: Vec<(f64, f64)> = rows.iter().map(|r| (r.n as f64, r.steps as f64)).collect();
    let moves: Vec<(f64, f64)> = rows.iter().map(|r| (r.n as f64, r.moves as f64)).collect();
    let fs = fit_power(&steps).ok_or("too few points to fit the steps")?;
    let fm = fit_power(&moves);
    let xmin = rows.iter().map(|r| r.n).min().unwrap_or(1).max(1) as f64;
    let xmax = rows.iter().map(|r| r.n).max().unwrap_or(2).max(2) as f64;
    let ymax = rows
        .iter()
        .map(|r| r.steps.max(r.moves))
        .max()
        .unwrap_or(2)
        .max(2) as f64;
    let e = |e: DrawingAreaErrorKind<std::io::Error>| e.to_string();
    let mut svg = String::new();
    let root = SVGBackend::with_string(&mut svg, (720, 450)).into_drawing_area();
    root.fill(&WHITE).map_err(e)?;
    let mut chart = ChartBuilder::on(&root)
        .caption(title, ("sans-serif", 20))
        .margin(15)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d(
            (xmin * 0.8..xmax * 1.25).log_scale(),
            (1.0..ymax * 2.0).log_scale(),
        )
        .map_err(e)?;
    chart
        .configure_mesh()
        .x_desc("agents n")
        .y_desc("count")
        .draw()
        .map_err(e)?;
    let curve = |(a, b): (f64, f64)| {
        (0..=50).map(move |i| {
            let x = xmin * (xmax / xmin).powf(i as f64 / 50.0);
            (x, (a + b * x.ln()).exp())
        })
    };
    chart
        .draw_series(steps.iter().map(|&p| Circle::new(p, 3, BLUE.filled())))
        .map_err(e)?
        .label(format!("steps (fit: n^{:.2})", fs.1))
        .legend(|(x, y)| Circle::new((x + 10, y), 3, BLUE.filled()));
    chart
        .draw_series(LineSeries::new(curve(fs), BLUE))
        .map_err(e)?;
    if let Some(fm) = fm {
        chart
            .draw_series(
                moves
                    .iter()
                    .filter(|p| p.1 > 0.0)
                    .map(|&p| TriangleMarker::new(p, 4, RED.filled())),
            )
            .map_err(e)?
            .label(format!("moves (fit: n^{:.2})", fm.1))
            .legend(|(x, y)| TriangleMarker::new((x + 10, y), 4, RED.filled()));
        chart
            .draw_series(LineSeries::new(curve(fm), RED))
            .map_err(e)?;
    }
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .position(SeriesLabelPosition::UpperLeft)
        .draw()
        .map_err(e)?;
    root.present().map_err(e)?;
    drop(chart);
    drop(root);
    Ok(svg)
}

pub fn sweep(a: SweepArgs) -> ExitCode {
    let out_file = match open_output(&a.out) {
        Ok(f) => f,
        Err(c) => return c,
    };
    let plot_file = match a.plot.as_deref().map(open_output).transpose() {
        Ok(f) => f,
        Err(c) => return c,
    };
    let rules = match crate::read(&a.rules) {
        Ok(b) => b,
        Err(c) => return c,
    };
    if let Err(e) = a.agents.gen_options(0) {
        say!("error: {e}");
        return ExitCode::from(2);
    }
    let jobs: Vec<(u32, u64)> = a
        .sizes
        .iter()
        .flat_map(|&n| (1..=a.seeds).map(move |s| (n, s)))
        .collect();
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
            .map(|&(n, s)| run_one(&rules, &a, n, s))
            .collect()
    });
    let mut rows = Vec::with_capacity(results.len());
    for r in results {
        match r {
            Ok(row) => rows.push(row),
            Err(e) => {
                say!("error: {e}");
                return ExitCode::from(1);
            }
        }
    }
    let mut csv = String::from("n,seed,steps,stopped_by,moves,messages,wall_time_s\n");
    for r in &rows {
        csv += &format!(
            "{},{},{},{},{},{},{:.6}\n",
            r.n,
            r.seed,
            r.steps,
            if r.quiescent {
                "quiescence"
            } else {
                "max-steps"
            },
            r.moves,
            r.messages,
            r.secs
        );
    }
    if let Err(c) = write_output(out_file, csv.as_bytes()) {
        return c;
    }
    let fs = fit_power(
        &rows
            .iter()
            .map(|r| (r.n as f64, r.steps as f64))
            .collect::<Vec<_>>(),
    );
    let fm = fit_power(
        &rows
            .iter()
            .map(|r| (r.n as f64, r.moves as f64))
            .collect::<Vec<_>>(),
    );
    say!(
        "{} runs; steps ~ n^{}, moves ~ n^{}; wrote {}",
        rows.len(),
        fs.map_or("?".into(), |f| format!("{:.2}", f.1)),
        fm.map_or("-".into(), |f| format!("{:.2}", f.1)),
        a.out.display()
    );
    if let Some(f) = plot_file {
        match plot(&a.title, &rows) {
            Ok(svg) => {
                if let Err(c) = write_output(f, svg.as_bytes()) {
                    return c;
                }
            }
            Err(e) => {
                say!("error: cannot draw `{}`: {e}", f.path().display());
                return ExitCode::from(2);
            }
        }
    }
    if rows.iter().any(|r| !r.quiescent) {
        say!(
            "warning: some runs stopped at --max-steps {} before quiescence",
            a.max_steps
        );
    }
    ExitCode::SUCCESS
}

#[cfg(test)]
mod tests {
    use super::fit_power;

    #[test]
    fn fits_a_power_law() {
        let pts: Vec<(f64, f64)> = [10.0, 100.0, 1000.0]
            .iter()
            .map(|&n: &f64| (n, 3.0 * n.powf(0.5)))
            .collect();
        let (a, b) = fit_power(&pts).unwrap();
        assert!((b - 0.5).abs() < 1e-9);
        assert!((a.exp() - 3.0).abs() < 1e-9);
        assert!(fit_power(&[(1.0, 1.0)]).is_none());
    }
}
