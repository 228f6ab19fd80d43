//! The workloads of ../shared/bench/WORKLOADS.md through the engine, each beside the
//! hand-written native loop of `latticesim_benches::native`, so that engine/native is
//! measured in the same run. Every benchmark checks its checksum before timing; neither
//! side's setup is timed. Throughput is in agent-steps.
//!
//! Groups (filter with `cargo bench --bench workloads -- <name>`):
//! `B1-L300-S10`, `B1-L1000-S50` (the size), `B2-W316`, `B2-W316-mixed` (B2's agents
//! scrambled, in seven states), `B3-L1000-k{1,16,256}-S20`,
//! `B1-L1000-S50-threads` (one and two threads), `P-L300-S10` (priority resolution along
//! chains of 300 agents). B2 at W = H = 1000 takes 20 s an iteration through the engine:
//! it is measured by the `scale` bench instead.

use criterion::{criterion_group, criterion_main, BatchSize, Criterion, Throughput};
use latticesim_benches::workloads::*;
use latticesim_benches::{b2_checksum, b3_checksum, engine, fresh, native, program, sum_c00};
use latticesim_benches::{sum_counter, Engine};
use std::hint::black_box;

/// Runs `steps` steps.
fn steps(mut e: Engine, s: u64) -> Engine {
    for _ in 0..s {
        e.step();
    }
    e
}

type Group<'a> = criterion::BenchmarkGroup<'a, criterion::measurement::WallTime>;

/// A group of ten samples whose throughput is `agent_steps` an iteration.
fn group<'a>(c: &'a mut Criterion, name: String, agent_steps: u64) -> Group<'a> {
    let mut g = c.benchmark_group(name);
    g.sample_size(10);
    g.throughput(Throughput::Elements(agent_steps));
    g
}

/// Times `run` on a fresh copy of `base` with `opts`; neither making the copy nor
/// dropping the engine `run` returns is timed (as the native side's setup and buffers).
fn bench_engine(
    g: &mut Group<'_>,
    name: &str,
    base: &Engine,
    opts: latticesim_runtime::Options,
    run: impl Fn(Engine) -> Engine,
) {
    g.bench_function(name, |b| {
        b.iter_batched(|| fresh(base, opts), &run, BatchSize::LargeInput)
    });
}

/// Times `run` on a fresh native setup (the setup is not timed).
fn bench_native<S, T>(g: &mut Group<'_>, setup: impl Fn() -> S, run: impl Fn(&mut S) -> T) {
    g.bench_function("native", |b| {
        b.iter_batched_ref(&setup, |st| run(black_box(st)), BatchSize::LargeInput)
    });
}

fn b1_group(c: &mut Criterion, l: u64, s: u64) {
    let mut g = group(c, format!("B1-L{l}-S{s}"), l * l * s);
    let base = Engine::new(program(B1_RULES), b1_lattice(l), Default::default());
    let expect = native::b1(l as usize, s as usize);
    assert_eq!(
        sum_c00(&steps(fresh(&base, base.opts), s)),
        expect,
        "B1 engine"
    );
    bench_native(
        &mut g,
        || native::b1_setup(l as usize),
        |st| native::b1_run(st, s as usize),
    );
    bench_engine(&mut g, "engine", &base, base.opts, |e| steps(e, s));
    g.finish();
}

fn b1(c: &mut Criterion) {
    b1_group(c, 300, 10);
    b1_group(c, 1000, 50);
}

/// B2 at W = H = 316 from `agents` (the same cells, in any order and states): run to
/// quiescence beside the native loop, the checksum checked first.
fn b2_group(c: &mut Criterion, name: &str, agents: &str) {
    let w = 316u64;
    let (steps_done, sum) = native::b2(w as usize, w as usize);
    assert_eq!((steps_done, sum), (238, 473921339434), "native B2 checksum");
    let base = engine(B2_RULES, agents);
    let n = base.lat.len() as u64;
    let mut g = group(c, name.to_string(), n * steps_done);
    let run = |mut e: Engine| {
        while !e.step().quiescent {}
        e
    };
    let done = run(fresh(&base, base.opts));
    assert_eq!(
        (done.stats.steps, b2_checksum(&done)),
        (steps_done, sum),
        "engine {name} checksum"
    );
    bench_native(
        &mut g,
        || native::b2_setup(w as usize, w as usize),
        native::b2_run,
    );
    bench_engine(&mut g, "engine", &base, base.opts, run);
    g.finish();
}

fn b2(c: &mut Criterion) {
    b2_group(c, "B2-W316", &b2_agents(316, 316));
}

/// B2's cells listed in a scrambled order, in seven states (`SGRAV<y mod 7>`), as files
/// written in no spatial order are (`latticesim gen cloud`'s): the same falls and the same
/// checksum (neither depends on the order or the states), beside the same native loop.
fn b2_mixed(c: &mut Criterion) {
    let mut lines: Vec<String> = (b2_cells(316, 316).into_iter())
        .map(|(x, y)| format!("{x},{y} SGRAV{} C00 {y}\n", y % 7))
        .collect();
    for i in (1..lines.len()).rev() {
        lines.swap(i, (i * 7919 + 13) % (i + 1));
    }
    b2_group(c, "B2-W316-mixed", &lines.concat());
}

fn b3(c: &mut Criterion) {
    let (l, s) = (1000u64, 20u64);
    for k in [1u64, 16, 256] {
        let mut g = group(c, format!("B3-L{l}-k{k}-S{s}"), l * l * s);
        let base = engine(&b3_rules(k), &b3_agents(l, k));
        assert_eq!(
            b3_checksum(&steps(fresh(&base, base.opts), s)),
            native::b3(l as usize, k as usize, s as usize),
            "B3 k={k}"
        );
        bench_native(
            &mut g,
            || native::b3_setup(l as usize, k as usize),
            |st| native::b3_run(st, k as usize, s as usize),
        );
        bench_engine(&mut g, "engine", &base, base.opts, |e| steps(e, s));
        g.finish();
    }
}

/// B1 through the engine with one and with two threads (results are identical).
fn b1_threads(c: &mut Criterion) {
    let (l, s) = (1000u64, 50u64);
    let mut g = group(c, format!("B1-L{l}-S{s}-threads"), l * l * s);
    let base = Engine::new(program(B1_RULES), b1_lattice(l), Default::default());
    for threads in [1usize, 2] {
        let opts = latticesim_runtime::Options {
            threads,
            ..base.opts
        };
        bench_engine(&mut g, &format!("engine-{threads}"), &base, opts, |e| {
            steps(e, s)
        });
    }
    g.finish();
}

/// Priority resolution where neighbours' priorities interact: every row of an L x L
/// square is a chain of dependencies (an agent's rule depends on its east neighbour's
/// priority), checked against the directly computed result.
fn priorities(c: &mut Criterion) {
    let (l, s) = (300u64, 10u64);
    let mut g = group(c, format!("P-L{l}-S{s}"), l * l * s);
    let base = engine(P_RULES, &p_agents(l));
    let done = steps(fresh(&base, base.opts), s);
    assert_eq!(
        (sum_counter(&done, 0), sum_counter(&done, 1)),
        p_expected(l, s),
        "P checksum"
    );
    bench_engine(&mut g, "engine", &base, base.opts, |e| steps(e, s));
    g.finish();
}

criterion_group!(benches, b1, b2, b2_mixed, b3, b1_threads, priorities);
criterion_main!(benches);
