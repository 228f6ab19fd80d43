//! The workloads of ../shared/bench/WORKLOADS.md through the engine, each beside the
//! hand-written native loop of `latticesim_benches::native`, so that engine/native is
//! measured in the same run. Every benchmark checks its checksum before timing.
//! Throughput is in agent-steps.

use criterion::{criterion_group, criterion_main, BatchSize, Criterion, Throughput};
use latticesim_benches::workloads::*;
use latticesim_benches::{b2_checksum, b3_checksum, engine, fresh, native, sum_c00};
use std::hint::black_box;

fn b1(c: &mut Criterion) {
    let (l, s) = (300usize, 10u64);
    let mut g = c.benchmark_group(format!("B1-L{l}-S{s}"));
    g.sample_size(10);
    g.throughput(Throughput::Elements(l as u64 * l as u64 * s));
    let base = engine(B1_RULES, &b1_agents(l as u64));
    {
        let mut e = engine(B1_RULES, &b1_agents(l as u64));
        (0..s).for_each(|_| {
            e.step();
        });
        assert_eq!(
            sum_c00(&e),
            native::b1(l, s as usize),
            "engine and native disagree"
        );
    }
    g.bench_function("native", |b| {
        b.iter(|| native::b1(black_box(l), s as usize))
    });
    g.bench_function("engine", |b| {
        b.iter_batched(
            || fresh(&base, base.opts),
            |mut e| {
                for _ in 0..s {
                    e.step();
                }
                sum_c00(&e)
            },
            BatchSize::LargeInput,
        )
    });
    g.finish();
}

fn b2(c: &mut Criterion) {
    let w = 100u64;
    let (steps, sum) = native::b2(w as usize, w as usize);
    assert_eq!((steps, sum), (86, 14720785869), "native B2 checksum");
    let base = engine(B2_RULES, &b2_agents(w, w));
    let n = base.lat.len() as u64;
    let mut g = c.benchmark_group(format!("B2-W{w}"));
    g.sample_size(10);
    g.throughput(Throughput::Elements(n * steps));
    let run = |mut e: latticesim_runtime::Engine| {
        while !e.step().quiescent {}
        e
    };
    let done = run(latticesim_runtime::Engine::new(
        base.prog.clone(),
        base.lat.clone(),
        base.opts,
    ));
    assert_eq!(
        (done.stats.steps, b2_checksum(&done)),
        (steps, sum),
        "engine B2 checksum"
    );
    g.bench_function("native", |b| {
        b.iter(|| native::b2(black_box(w as usize), w as usize))
    });
    g.bench_function("engine", |b| {
        b.iter_batched(
            || fresh(&base, base.opts),
            |e| run(e).stats.steps,
            BatchSize::LargeInput,
        )
    });
    g.finish();
}

fn b3(c: &mut Criterion) {
    let (l, s) = (100u64, 5u64);
    for k in [1u64, 16, 256] {
        let mut g = c.benchmark_group(format!("B3-L{l}-k{k}-S{s}"));
        g.sample_size(10);
        g.throughput(Throughput::Elements(l * l * s));
        let base = engine(&b3_rules(k), &b3_agents(l, k));
        let mut e = fresh(&base, base.opts);
        (0..s).for_each(|_| {
            e.step();
        });
        assert_eq!(
            b3_checksum(&e),
            native::b3(l as usize, k as usize, s as usize),
            "B3 k={k}"
        );
        g.bench_function("native", |b| {
            b.iter(|| native::b3(black_box(l as usize), k as usize, s as usize))
        });
        g.bench_function("engine", |b| {
            b.iter_batched(
                || fresh(&base, base.opts),
                |mut e| {
                    for _ in 0..s {
                        e.step();
                    }
                    e.stats.steps
                },
                BatchSize::LargeInput,
            )
        });
        g.finish();
    }
}

/// B1 through the engine with one and with two threads (results are identical).
fn b1_threads(c: &mut Criterion) {
    let (l, s) = (300usize, 10u64);
    let mut g = c.benchmark_group(format!("B1-L{l}-S{s}-threads"));
    g.sample_size(10);
    g.throughput(Throughput::Elements(l as u64 * l as u64 * s));
    let base = engine(B1_RULES, &b1_agents(l as u64));
    for threads in [1usize, 2] {
        let opts = latticesim_runtime::Options {
            threads,
            ..base.opts
        };
        g.bench_function(format!("engine-{threads}"), |b| {
            b.iter_batched(
                || fresh(&base, opts),
                |mut e| {
                    for _ in 0..s {
                        e.step();
                    }
                    sum_c00(&e)
                },
                BatchSize::LargeInput,
            )
        });
    }
    g.finish();
}

criterion_group!(benches, b1, b2, b3, b1_threads);
criterion_main!(benches);
