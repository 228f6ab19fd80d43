//! Runs B3 through the engine for k = 1 and a larger k in turn, for profilers and quick
//! measurements: `profile_b3 [L] [k] [steps] [repeats]` prints the fastest run of each and
//! the ratio of their costs per agent-step.
use latticesim_benches::arg;
use latticesim_benches::workloads::*;
use latticesim_benches::{b3_checksum, engine, fresh};

fn main() {
    let (l, k, steps, reps) = (arg(1, 1000), arg(2, 256), arg(3, 20), arg(4, 3));
    let bases = [1, k].map(|k| engine(&b3_rules(k), &b3_agents(l, k)));
    let mut best = [f64::MAX; 2];
    for _ in 0..reps {
        for (i, base) in bases.iter().enumerate() {
            let mut e = fresh(base, base.opts);
            let t = std::time::Instant::now();
            for _ in 0..steps {
                e.step();
            }
            best[i] = best[i].min(t.elapsed().as_secs_f64());
            std::hint::black_box(b3_checksum(&e));
        }
    }
    let ns = |t: f64| t * 1e9 / (l * l * steps) as f64;
    eprintln!(
        "k=1: {:.1} ns, k={k}: {:.1} ns per agent-step; ratio {:.2}",
        ns(best[0]),
        ns(best[1]),
        best[1] / best[0]
    );
}
