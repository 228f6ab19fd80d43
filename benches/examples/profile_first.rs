//! Times the first step of a run from files, for profilers: `profile_first RULES AGENTS
//! [repeats] [steps]` makes the engine once, then per repeat a fresh engine from it, and
//! prints the fastest first step and (with `steps` above 1) the fastest mean of the steps
//! after it.
use latticesim_benches::{arg, engine, fresh};

fn main() {
    let path = |i: usize| std::env::args().nth(i).expect("profile_first RULES AGENTS");
    let read = |i| std::fs::read_to_string(path(i)).expect("readable");
    let base = engine(&read(1), &read(2));
    let (reps, steps) = (arg(3, 5), arg(4, 1));
    let (mut first, mut after) = (f64::MAX, f64::MAX);
    for _ in 0..reps {
        let mut e = fresh(&base, base.opts);
        let t = std::time::Instant::now();
        e.step();
        first = first.min(t.elapsed().as_secs_f64());
        let t = std::time::Instant::now();
        for _ in 1..steps {
            e.step();
        }
        after = after.min(t.elapsed().as_secs_f64() / (steps - 1).max(1) as f64);
    }
    eprint!("first step {:.3} ms", first * 1e3);
    if steps > 1 {
        eprint!(", after it {:.3} µs a step", after * 1e6);
    }
    eprintln!();
}
