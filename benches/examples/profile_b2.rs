//! Runs B2 to quiescence through the engine once, for profilers: `profile_b2 [W] [threads]`.
use latticesim_benches::arg;
use latticesim_benches::workloads::*;

fn main() {
    let (w, threads) = (arg(1, 316), arg(2, 1) as usize);
    let e = latticesim_benches::engine(B2_RULES, &b2_agents(w, w));
    let opts = latticesim_runtime::Options { threads, ..e.opts };
    let mut e = latticesim_runtime::Engine::new(e.prog, e.lat, opts);
    let t = std::time::Instant::now();
    while !e.step().quiescent {}
    let n = e.lat.len() as u64;
    eprintln!(
        "{:?} for {} agent-steps ({} agents, {} steps) with {threads} thread(s)",
        t.elapsed(),
        n * e.stats.steps,
        n,
        e.stats.steps
    );
    let mut st = latticesim_benches::native::b2_setup(w as usize, w as usize);
    let t = std::time::Instant::now();
    std::hint::black_box(latticesim_benches::native::b2_run(&mut st));
    eprintln!("{} moves; native {:?}", e.stats.moves, t.elapsed());
    println!("{}", latticesim_benches::b2_checksum(&e));
}
