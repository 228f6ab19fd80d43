//! Runs B3 through the engine for k = 1 and a larger k in turn, for profilers and quick
//! measurements: `profile_b3 [L] [k] [steps] [repeats]` prints, from the fastest run of
//! each, the cost per agent-step over all the steps and the ratio of the two, then the
//! first step's time (candidate lists are made in it) and the cost of the steps after it.
use latticesim_benches::arg;
use latticesim_benches::workloads::*;
use latticesim_benches::{b3_checksum, engine, fresh};

fn main() {
    let (l, k, steps, reps) = (arg(1, 1000), arg(2, 256), arg(3, 20), arg(4, 3));
    let bases = [1, k].map(|k| engine(&b3_rules(k), &b3_agents(l, k)));
    // Per k: the fastest whole run, its first step, and the steps after it.
    let mut best = [(f64::MAX, 0.0, 0.0); 2];
    for _ in 0..reps {
        for (i, base) in bases.iter().enumerate() {
            let mut e = fresh(base, base.opts);
            let t = std::time::Instant::now();
            e.step();
            let first = t.elapsed().as_secs_f64();
            for _ in 1..steps {
                e.step();
            }
            let all = t.elapsed().as_secs_f64();
            if all < best[i].0 {
                best[i] = (all, first, all - first);
            }
            std::hint::black_box(b3_checksum(&e));
        }
    }
    let ns = |t: f64, steps: u64| t * 1e9 / (l * l * steps) as f64;
    let [one, many] = best;
    eprintln!(
        "k=1: {:.1} ns, k={k}: {:.1} ns per agent-step; ratio {:.2}",
        ns(one.0, steps),
        ns(many.0, steps),
        many.0 / one.0
    );
    if steps > 1 {
        eprintln!(
            "first step {:.2} and {:.2} ms; after it k=1: {:.2} ns, k={k}: {:.2} ns; ratio {:.2}",
            one.1 * 1e3,
            many.1 * 1e3,
            ns(one.2, steps - 1),
            ns(many.2, steps - 1),
            many.2 / one.2
        );
    }
}
