//! Runs B1 through the engine once, for profilers: `profile_b1 [L] [threads] [steps]`.
use latticesim_benches::workloads::*;

fn main() {
    let arg = |i: usize, default: u64| {
        std::env::args()
            .nth(i)
            .and_then(|s| s.parse().ok())
            .unwrap_or(default)
    };
    let (l, threads, steps) = (arg(1, 300), arg(2, 1) as usize, arg(3, 10));
    let e = latticesim_benches::engine(B1_RULES, &b1_agents(l));
    let opts = latticesim_runtime::Options { threads, ..e.opts };
    let mut e = latticesim_runtime::Engine::new(e.prog, e.lat, opts);
    let t = std::time::Instant::now();
    for _ in 0..steps {
        e.step();
    }
    eprintln!(
        "{:?} for {} agent-steps with {threads} thread(s)",
        t.elapsed(),
        l * l * steps
    );
    println!("{}", latticesim_benches::sum_c00(&e));
}
