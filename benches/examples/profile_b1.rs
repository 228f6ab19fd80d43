//! Runs B1 (L = 300, 10 steps) through the engine once, for profilers.
use latticesim_benches::workloads::*;

fn main() {
    let l: u64 = std::env::args()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(300);
    let mut e = latticesim_benches::engine(B1_RULES, &b1_agents(l));
    let t = std::time::Instant::now();
    for _ in 0..10 {
        e.step();
    }
    eprintln!("{:?} for {} agent-steps", t.elapsed(), l * l * 10);
    println!("{}", latticesim_benches::sum_c00(&e));
}
