//! Runs B1 through the engine, for profilers and quick measurements:
//! `profile_b1 [L] [threads] [steps] [repeats]` prints the fastest of the repeats.
use latticesim_benches::arg;
use latticesim_benches::workloads::*;

fn main() {
    let (l, threads, steps, reps) = (arg(1, 300), arg(2, 1) as usize, arg(3, 10), arg(4, 1));
    // Built without an agents file, so that a profile shows the steps rather than parsing.
    let opts = latticesim_runtime::Options {
        threads,
        ..Default::default()
    };
    let base =
        latticesim_runtime::Engine::new(latticesim_benches::program(B1_RULES), b1_lattice(l), opts);
    let mut best = std::time::Duration::MAX;
    let mut native = std::time::Duration::MAX;
    let mut sum = 0;
    for _ in 0..reps {
        let t = std::time::Instant::now();
        std::hint::black_box(latticesim_benches::native::b1(l as usize, steps as usize));
        native = native.min(t.elapsed());
        let mut e = latticesim_benches::fresh(&base, opts);
        let t = std::time::Instant::now();
        for _ in 0..steps {
            e.step();
        }
        best = best.min(t.elapsed());
        sum = latticesim_benches::sum_c00(&e);
    }
    let agent_steps = l * l * steps;
    eprintln!(
        "{best:?} for {agent_steps} agent-steps with {threads} thread(s): {:.1} M agent-steps/s; native {native:?}: engine/native = 1/{:.1}",
        agent_steps as f64 / best.as_secs_f64() / 1e6,
        best.as_secs_f64() / native.as_secs_f64()
    );
    println!("{sum}");
}
