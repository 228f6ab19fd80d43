//! Runs B3 through the engine, for profilers: `profile_b3 [L] [k] [steps]`.
use latticesim_benches::workloads::*;

fn main() {
    let arg = |i: usize, default: u64| {
        std::env::args()
            .nth(i)
            .and_then(|s| s.parse().ok())
            .unwrap_or(default)
    };
    let (l, k, steps) = (arg(1, 1000), arg(2, 16), arg(3, 20));
    let mut e = latticesim_benches::engine(&b3_rules(k), &b3_agents(l, k));
    let t = std::time::Instant::now();
    for _ in 0..steps {
        e.step();
    }
    let agent_steps = l * l * steps;
    eprintln!(
        "{:?} for {agent_steps} agent-steps: {:.1} M agent-steps/s",
        t.elapsed(),
        agent_steps as f64 / t.elapsed().as_secs_f64() / 1e6
    );
    println!("{}", latticesim_benches::b3_checksum(&e));
}
