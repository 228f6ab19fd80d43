//! Runs B2 to quiescence through the engine, for profilers, and prints its time against
//! the native loop's: `profile_b2 [W] [threads] [reps]`. The two run step by step in
//! turn, so that a slower moment of a noisy machine slows both.
use latticesim_benches::arg;
use latticesim_benches::native;
use latticesim_benches::workloads::*;
use std::time::{Duration, Instant};

fn main() {
    let (w, threads, reps) = (arg(1, 316), arg(2, 1) as usize, arg(3, 1));
    for _ in 0..reps {
        let e = latticesim_benches::engine(B2_RULES, &b2_agents(w, w));
        let opts = latticesim_runtime::Options { threads, ..e.opts };
        let mut e = latticesim_runtime::Engine::new(e.prog, e.lat, opts);
        let mut st = native::b2_setup(w as usize, w as usize);
        let (mut engine, mut native) = (Duration::ZERO, Duration::ZERO);
        loop {
            let t = Instant::now();
            let quiet = e.step().quiescent;
            engine += t.elapsed();
            let t = Instant::now();
            let moved = native::b2_step(std::hint::black_box(&mut st));
            native += t.elapsed();
            assert_eq!(quiet, !moved, "the engine and the native loop differ");
            if quiet {
                break;
            }
        }
        let n = e.lat.len() as u64;
        eprintln!(
            "{engine:?} for {} agent-steps ({n} agents, {} steps, {} moves) with {threads} thread(s); native {native:?}; engine/native 1/{:.1}",
            n * e.stats.steps,
            e.stats.steps,
            e.stats.moves,
            engine.as_secs_f64() / native.as_secs_f64()
        );
        assert_eq!(latticesim_benches::b2_checksum(&e), native::b2_sum(&st));
        println!("{}", native::b2_sum(&st));
    }
}
