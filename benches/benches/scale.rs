//! How the engine scales, for docs/performance.md: agent-steps per second against n (B1)
//! and against k (B3), engine/native at the sizes (B1 L = 1000, B2 W = H = 1000,
//! B3 L = 1000), thread scaling, and peak memory per agent (measured in child processes,
//! so that each figure is that workload's own peak).
//!
//! `cargo bench -p latticesim-benches --bench scale` writes docs/data/performance-*.csv
//! and docs/img/performance-*.svg and prints the tables as Markdown. Every timing is the
//! fastest of a few repeats (the machine is shared), and every engine run is checked
//! against its reference checksum or the native loop first.
//!
//! Environment: `SCALE_BIG=1` adds B1 at L = 10000 (100 million agents; about 5 GB and
//! a few minutes) to the memory table. `SCALE_QUICK=1` runs smaller sizes only (for a
//! check that the harness works).

use latticesim_benches::plot::*;
use latticesim_benches::workloads::*;
use latticesim_benches::{b2_checksum, b3_checksum, engine, fresh, native, program, sum_c00};
use latticesim_benches::{Engine, Lcg};
use latticesim_runtime::{LatticeBuilder, Options};
use latticesim_vm::model::Dim;
use plotters::prelude::*;
use std::fmt::Write as _;
use std::path::PathBuf;
use std::time::{Duration, Instant};

/// The fastest of `reps` runs of `f` (each given a fresh setup, which is not timed).
fn best<S, T>(reps: usize, mut setup: impl FnMut() -> S, mut f: impl FnMut(S) -> T) -> Duration {
    (0..reps)
        .map(|_| {
            let s = setup();
            let t = Instant::now();
            let out = std::hint::black_box(f(s));
            let d = t.elapsed();
            // Dropping what the run leaves is not timed (nor is it in criterion's
            // `iter_batched`).
            drop(out);
            d
        })
        .min()
        .unwrap_or_default()
}

fn run_steps(mut e: Engine, s: u64) -> Engine {
    for _ in 0..s {
        e.step();
    }
    e
}

fn b1_engine(l: u64, threads: usize) -> Engine {
    Engine::new(
        program(B1_RULES),
        b1_lattice(l),
        Options {
            threads,
            ..Options::default()
        },
    )
}

struct Out {
    data: PathBuf,
    img: PathBuf,
    md: String,
}

impl Out {
    fn csv(&self, name: &str, header: &str, rows: &[String]) {
        let mut s = format!("{header}\n");
        for r in rows {
            s += r;
            s.push('\n');
        }
        std::fs::write(self.data.join(name), s).expect("write CSV");
    }
}

/// Agent-steps per second against n: B1 through the engine (one thread) and natively, over
/// the 50 steps of WORKLOADS.md's checksums; and what the engine's first step takes alone
/// (it also makes the candidate lists and the plan of senders, and touches new columns).
fn b1_by_n(out: &mut Out, sizes: &[u64]) -> Vec<(u64, f64, f64)> {
    let s = 50u64;
    let mut rows = Vec::new();
    let mut firsts = Vec::new();
    for &l in sizes {
        let n = l * l;
        let base = b1_engine(l, 1);
        let expect = native::b1(l as usize, s as usize);
        assert_eq!(
            sum_c00(&run_steps(fresh(&base, base.opts), s)),
            expect,
            "B1 L={l}"
        );
        let reps = if n >= 5_000_000 { 2 } else { 3 };
        let eng = best(reps, || fresh(&base, base.opts), |e| run_steps(e, s));
        let first = best(reps, || fresh(&base, base.opts), |e| run_steps(e, 1));
        let nat = best(
            reps,
            || native::b1_setup(l as usize),
            |mut st| (native::b1_run(&mut st, s as usize), st),
        );
        let per = |d: Duration| (n * s) as f64 / d.as_secs_f64();
        rows.push((n, per(eng), per(nat)));
        firsts.push((first, eng / s as u32));
        eprintln!(
            "B1 L={l}: engine {:.1} M/s, native {:.1} M/s",
            per(eng) / 1e6,
            per(nat) / 1e6
        );
    }
    out.csv(
        "performance-b1-n.csv",
        "n,engine_agent_steps_per_s,native_agent_steps_per_s",
        &rows
            .iter()
            .map(|(n, e, v)| format!("{n},{e:.0},{v:.0}"))
            .collect::<Vec<_>>(),
    );
    let _ = writeln!(
        out.md,
        "\n#### B1 ({s} steps, one thread): agent-steps per second against n\n\n| n | engine | native | engine / native | engine's first step | its mean step |\n|---:|---:|---:|---:|---:|---:|"
    );
    for ((n, e, v), (first, mean)) in rows.iter().zip(&firsts) {
        let _ = writeln!(
            out.md,
            "| {n} | {:.1} M/s | {:.0} M/s | 1/{:.1} | {:.3} ms | {:.3} ms |",
            e / 1e6,
            v / 1e6,
            v / e,
            first.as_secs_f64() * 1e3,
            mean.as_secs_f64() * 1e3
        );
    }
    rows
}

/// Cost per agent-step against k: B3 at L through the engine and natively.
fn b3_by_k(out: &mut Out, l: u64, ks: &[u64]) -> Vec<(u64, f64, f64)> {
    let s = 20u64;
    let n = l * l;
    let mut rows = Vec::new();
    for &k in ks {
        let base = engine(&b3_rules(k), &b3_agents(l, k));
        let e = run_steps(fresh(&base, base.opts), s);
        assert_eq!(
            b3_checksum(&e),
            native::b3(l as usize, k as usize, s as usize),
            "B3 k={k}"
        );
        let eng = best(3, || fresh(&base, base.opts), |e| run_steps(e, s));
        let nat = best(
            3,
            || native::b3_setup(l as usize, k as usize),
            |mut st| (native::b3_run(&mut st, k as usize, s as usize), st),
        );
        let ns = |d: Duration| d.as_secs_f64() * 1e9 / (n * s) as f64;
        rows.push((k, ns(eng), ns(nat)));
        eprintln!(
            "B3 k={k}: engine {:.2} ns, native {:.3} ns",
            ns(eng),
            ns(nat)
        );
    }
    out.csv(
        "performance-b3-k.csv",
        "k,engine_ns_per_agent_step,native_ns_per_agent_step",
        &rows
            .iter()
            .map(|(k, e, v)| format!("{k},{e:.3},{v:.4}"))
            .collect::<Vec<_>>(),
    );
    // k = 1 is the one workload whose rule leaves every state as it is; from k = 2 on,
    // every agent changes state every step.
    let at = |k: u64| rows.iter().find(|r| r.0 == k).map_or(f64::NAN, |r| r.1);
    let (k1, k2) = (at(1), at(2));
    let _ = writeln!(
        out.md,
        "\n#### B3 (L = {l}, 20 steps): cost per agent-step against k\n\n| k | engine | relative to k = 1 | relative to k = 2 | native |\n|---:|---:|---:|---:|---:|"
    );
    for (k, e, v) in &rows {
        let _ = writeln!(
            out.md,
            "| {k} | {e:.2} ns | {:.2} | {:.2} | {v:.2} ns |",
            e / k1,
            e / k2
        );
    }
    rows
}

/// Engine/native for B2 to quiescence on a W x W box.
fn b2_ratio(out: &mut Out, sizes: &[u64]) {
    let mut rows = Vec::new();
    for &w in sizes {
        let base = engine(B2_RULES, &b2_agents(w, w));
        let n = base.lat.len() as u64;
        let run = |mut e: Engine| {
            while !e.step().quiescent {}
            e
        };
        let done = run(fresh(&base, base.opts));
        let (steps, sum) = native::b2(w as usize, w as usize);
        assert_eq!(
            (done.stats.steps, b2_checksum(&done)),
            (steps, sum),
            "B2 W={w}"
        );
        let reps = if w >= 1000 { 2 } else { 3 };
        let eng = best(reps, || fresh(&base, base.opts), run);
        let nat = best(
            reps,
            || native::b2_setup(w as usize, w as usize),
            |mut st| (native::b2_run(&mut st), st),
        );
        let per = |d: Duration| (n * steps) as f64 / d.as_secs_f64();
        eprintln!(
            "B2 W={w}: engine {:.1} M/s, native {:.1} M/s",
            per(eng) / 1e6,
            per(nat) / 1e6
        );
        rows.push((w, n, steps, per(eng), per(nat)));
    }
    out.csv(
        "performance-b2.csv",
        "w,n,steps,engine_agent_steps_per_s,native_agent_steps_per_s",
        &rows
            .iter()
            .map(|(w, n, s, e, v)| format!("{w},{n},{s},{e:.0},{v:.0}"))
            .collect::<Vec<_>>(),
    );
    let _ = writeln!(
        out.md,
        "\n#### B2 (to quiescence, one thread)\n\n| W = H | n | steps | engine | native | engine / native |\n|---:|---:|---:|---:|---:|---:|"
    );
    for (w, n, s, e, v) in &rows {
        let _ = writeln!(
            out.md,
            "| {w} | {n} | {s} | {:.1} M/s | {:.0} M/s | 1/{:.1} |",
            e / 1e6,
            v / 1e6,
            v / e
        );
    }
}

/// B1 with one and two threads.
fn threads(out: &mut Out, l: u64) -> Vec<(usize, f64)> {
    let s = 50u64;
    let mut rows = Vec::new();
    let mut one = 0.0;
    let bases = [1usize, 2].map(|t| b1_engine(l, t));
    // One and two threads in turn, five times, the fastest of each: both meet the process
    // (what the allocator holds) and the machine (its other core is busy now and then) in
    // the same states.
    let mut fastest = [Duration::MAX; 2];
    for _ in 0..5 {
        for (f, base) in fastest.iter_mut().zip(&bases) {
            *f = (*f).min(best(1, || fresh(base, base.opts), |e| run_steps(e, s)));
        }
    }
    for (base, d) in bases.iter().zip(fastest) {
        let t = base.opts.threads;
        let per = (l * l * s) as f64 / d.as_secs_f64();
        if t == 1 {
            one = per;
        }
        eprintln!("B1 L={l} threads {t}: {:.1} M/s", per / 1e6);
        rows.push((t, per));
    }
    out.csv(
        "performance-threads.csv",
        "threads,agent_steps_per_s",
        &rows
            .iter()
            .map(|(t, p)| format!("{t},{p:.0}"))
            .collect::<Vec<_>>(),
    );
    let _ = writeln!(
        out.md,
        "\n#### B1 (L = {l}, 50 steps): threads\n\n| threads | engine | speed-up |\n|---:|---:|---:|"
    );
    for (t, p) in &rows {
        let _ = writeln!(out.md, "| {t} | {:.1} M/s | {:.2} |", p / 1e6, p / one);
    }
    rows
}

/// The memory child: builds one workload, runs it, prints `agents peak_bytes`.
fn memory_child(spec: &str) {
    let words: Vec<&str> = spec.split_whitespace().collect();
    let num = |i: usize| {
        words
            .get(i)
            .and_then(|w| w.parse::<u64>().ok())
            .unwrap_or(0)
    };
    let (n, e) = match words.first().copied() {
        Some("b1") => {
            let (l, s) = (num(1), num(2));
            let e = run_steps(b1_engine(l, num(3).max(1) as usize), s);
            (l * l, e)
        }
        Some("sparse") => {
            // n agents at distinct random cells of a side x side universe.
            let (n, side, s) = (num(1), num(2), num(3));
            let mut g = Lcg::new(7);
            let mut b = LatticeBuilder::new(Dim::Two, None, n as usize);
            let mut seen = rustc_hash::FxHashSet::default();
            while (seen.len() as u64) < n {
                let p = [g.below(side) as i32, g.below(side) as i32, 0];
                if seen.insert(p) {
                    b.push(p, *b"00000", 0, &[(0, (seen.len() % 1000) as i32)]);
                }
            }
            drop(seen);
            let lat = b.finish();
            let e = run_steps(Engine::new(program(B1_RULES), lat, Options::default()), s);
            (n, e)
        }
        _ => panic!("unknown memory workload {spec:?}"),
    };
    std::hint::black_box(&e);
    let status = std::fs::read_to_string("/proc/self/status").unwrap_or_default();
    let kb = |key: &str| {
        status
            .lines()
            .find(|l| l.starts_with(key))
            .and_then(|l| l.split_whitespace().nth(1))
            .and_then(|v| v.parse::<u64>().ok())
            .unwrap_or(0)
    };
    println!("{n} {} {}", kb("VmHWM:") * 1024, e.bytes());
}

/// Peak memory per agent of each workload, each in its own process.
fn memory(out: &mut Out, cases: &[(&str, String)]) -> Vec<(String, u64, f64, f64)> {
    let exe = std::env::current_exe().expect("own path");
    // The process's own baseline (code, allocator, a tiny lattice).
    let probe = |spec: &str| -> (u64, u64, u64) {
        let o = std::process::Command::new(&exe)
            .env("SCALE_MEMORY_CHILD", spec)
            .output()
            .expect("run the memory child");
        let text = String::from_utf8_lossy(&o.stdout);
        let v: Vec<u64> = text
            .split_whitespace()
            .filter_map(|w| w.parse().ok())
            .collect();
        assert!(
            v.len() == 3,
            "memory child failed: {}",
            String::from_utf8_lossy(&o.stderr)
        );
        (v[0], v[1], v[2])
    };
    let (_, base, _) = probe("b1 10 1");
    let mut rows = Vec::new();
    for (name, spec) in cases {
        let (n, peak, held) = probe(spec);
        let per = (peak.saturating_sub(base)) as f64 / n as f64;
        let held = held as f64 / n as f64;
        eprintln!("memory {name}: {per:.1} B/agent peak, {held:.1} B/agent held");
        rows.push((name.to_string(), n, per, held));
    }
    out.csv(
        "performance-memory.csv",
        "workload,n,peak_bytes_per_agent,held_bytes_per_agent",
        &rows
            .iter()
            .map(|(w, n, p, h)| format!("\"{w}\",{n},{p:.1},{h:.1}"))
            .collect::<Vec<_>>(),
    );
    let _ = writeln!(
        out.md,
        "\n#### Peak memory per agent (peak resident size above the process's {:.1} MB baseline)\n\n| workload | n | peak per agent | held by the engine per agent |\n|---|---:|---:|---:|",
        base as f64 / 1e6
    );
    for (w, n, p, h) in &rows {
        let _ = writeln!(out.md, "| {w} | {n} | {p:.1} B | {h:.1} B |");
    }
    rows
}

fn main() {
    if let Ok(spec) = std::env::var("SCALE_MEMORY_CHILD") {
        memory_child(&spec);
        return;
    }
    // cargo bench passes `--bench`; a filter argument that is not ours means another
    // bench target was asked for.
    if std::env::args()
        .skip(1)
        .any(|a| !a.starts_with('-') && !"scale".contains(a.as_str()))
    {
        return;
    }
    let quick = std::env::var("SCALE_QUICK").is_ok();
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("..")
        .join("docs");
    let mut out = Out {
        data: root.join("data"),
        img: root.join("img"),
        md: String::new(),
    };
    std::fs::create_dir_all(&out.data).expect("docs/data");
    std::fs::create_dir_all(&out.img).expect("docs/img");
    let (b1_sizes, big_l, b2_sizes, b3_l): (&[u64], u64, &[u64], u64) = if quick {
        (&[30, 100], 100, &[60], 100)
    } else {
        (&[100, 316, 1000, 3162], 1000, &[316, 1000], 1000)
    };
    if std::env::var("SCALE_PLOT_ONLY").is_err() {
        measure(&mut out, quick, (b1_sizes, big_l, b2_sizes, b3_l));
    }
    // The plots are drawn from the CSV files (SCALE_PLOT_ONLY=1 redraws them alone).
    plots(&out);
    println!("{}", out.md);
}

/// The plots of docs/performance.md, from the CSV files of docs/data.
fn plots(out: &Out) {
    let table = |name: &str| -> Vec<Vec<f64>> {
        std::fs::read_to_string(out.data.join(name))
            .unwrap_or_default()
            .lines()
            .skip(1)
            .map(|l| l.split(',').filter_map(|v| v.parse().ok()).collect())
            .collect()
    };
    let col = |t: &[Vec<f64>], x: usize, y: usize| -> Vec<(f64, f64)> {
        t.iter()
            .filter(|r| r.len() > x.max(y))
            .map(|r| (r[x], r[y]))
            .collect()
    };
    let (b1, b3, th) = (
        table("performance-b1-n.csv"),
        table("performance-b3-k.csv"),
        table("performance-threads.csv"),
    );
    // Memory rows: the workload (quoted, with commas), then n, peak and held per agent.
    let memory: Vec<(String, f64, f64)> =
        std::fs::read_to_string(out.data.join("performance-memory.csv"))
            .unwrap_or_default()
            .lines()
            .skip(1)
            .filter_map(|l| {
                let mut f = l.rsplitn(4, ',');
                let (_, peak, n) = (f.next()?, f.next()?.parse().ok()?, f.next()?.parse().ok()?);
                Some((f.next()?.trim_matches('"').to_string(), n, peak))
            })
            .collect();
    let pick = |b1: bool| -> Vec<(f64, f64)> {
        memory
            .iter()
            .filter(|m| m.0.starts_with("B1") == b1)
            .map(|m| (m.1, m.2))
            .collect()
    };
    let plots = [
        plot_lines(
            &out.img.join("performance-memory.svg"),
            "Peak memory per agent against n",
            ("agents n", "bytes per agent"),
            (power_of_ten, plain),
            &[
                ("B1 (dense square)", pick(true), BLUE),
                ("scattered agents (hash map)", pick(false), RED),
            ],
        ),
        plot_lines(
            &out.img.join("performance-b1-n.svg"),
            "B1: agent-steps per second against n (one thread)",
            ("agents n", "agent-steps per second"),
            (power_of_ten, rate),
            &[
                ("engine", col(&b1, 0, 1), BLUE),
                ("native", col(&b1, 0, 2), RED),
            ],
        ),
        plot_lines(
            &out.img.join("performance-b3-k.svg"),
            "B3 (L = 1000): cost per agent-step against k",
            ("rules k", "time per agent-step"),
            (plain, nanoseconds),
            &[
                ("engine", col(&b3, 0, 1), BLUE),
                ("native", col(&b3, 0, 2), RED),
            ],
        ),
        plot_lines(
            &out.img.join("performance-threads.svg"),
            "B1 (L = 1000): agent-steps per second against threads",
            ("threads", "agent-steps per second"),
            (plain, rate),
            &[("engine", col(&th, 0, 1), BLUE)],
        ),
    ];
    for p in plots {
        if let Err(e) = p {
            eprintln!("plot: {e}");
        }
    }
}

/// Every measurement of the report: B1 by n, B3 by k, B2, threads, memory.
fn measure(
    out: &mut Out,
    quick: bool,
    (b1_sizes, big_l, b2_sizes, b3_l): (&[u64], u64, &[u64], u64),
) {
    b1_by_n(out, b1_sizes);
    b3_by_k(out, b3_l, &[1, 2, 4, 16, 64, 256]);
    b2_ratio(out, b2_sizes);
    threads(out, big_l);
    let mut cases = vec![
        (format!("B1 L={big_l}, 50 steps"), format!("b1 {big_l} 50")),
        (
            "1,000,000 agents scattered in 1,000,000 x 1,000,000, B1 rules, 10 steps".to_string(),
            "sparse 1000000 1000000 10".to_string(),
        ),
        (
            "1,000,000 agents scattered in 10,000 x 10,000, B1 rules, 10 steps".to_string(),
            "sparse 1000000 10000 10".to_string(),
        ),
    ];
    if quick {
        cases.truncate(1);
    } else {
        cases.insert(1, ("B1 L=3162, 50 steps".into(), "b1 3162 50".into()));
    }
    if std::env::var("SCALE_BIG").is_ok() {
        cases.push((
            "B1 L=10000, 50 steps, 2 threads".into(),
            "b1 10000 50 2".into(),
        ));
    }
    let refs: Vec<(&str, String)> = cases.iter().map(|(a, b)| (a.as_str(), b.clone())).collect();
    memory(out, &refs);
}
