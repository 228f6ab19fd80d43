//! The plain hand-written baseline of B2F (shared/bench/WORKLOADS.md): reads a B2 agents
//! file (`x,y` or `x,y C00 v` lines, x-major and bottom up within a column), runs B2's
//! rule (fall one cell south when that cell was empty at the start of the step and
//! C00 > 0; then C00 = C00 - 1) until a step in which no agent moves, and writes the final
//! configuration as agents.txt text (`x,y`, with ` C00 v` when v != 0; the default state
//! left out, as `latticesim run --out` writes it) in input
//! order. Single-threaded: a byte loop into columns, an occupancy grid over the bounding
//! box, a buffered writer.
//!
//! Usage: `b2f_native AGENTS OUT [THREADS]`; prints the steps and the checksum (the sum of
//! x * 100003 + y over the agents), and the stepping time. With THREADS > 1 (not the
//! bench's baseline, which is one thread: a measure of what the machine's cores give a
//! plain program) the columns are cut into as many runs of whole columns, one per thread,
//! each stepping its own agents with a barrier (spinning) after each step to agree whether
//! any moved; the output is the same.

use std::io::{BufWriter, Write};

fn num(b: &[u8], i: &mut usize) -> i64 {
    let neg = b[*i] == b'-';
    if neg {
        *i += 1;
    }
    let mut v = 0i64;
    while *i < b.len() && b[*i].is_ascii_digit() {
        v = v * 10 + (b[*i] - b'0') as i64;
        *i += 1;
    }
    if neg {
        -v
    } else {
        v
    }
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    if args.len() != 3 && args.len() != 4 {
        eprintln!("usage: b2f_native AGENTS OUT [THREADS]");
        std::process::exit(2);
    }
    let threads: usize = args
        .get(3)
        .map_or(1, |t| t.parse().expect("THREADS: a number"));
    let text = std::fs::read(&args[1]).expect("the agents file can be read");
    let (mut xs, mut ys, mut cs) = (Vec::new(), Vec::new(), Vec::new());
    let mut i = 0;
    while i < text.len() {
        if text[i] == b'\n' {
            i += 1;
            continue;
        }
        let x = num(&text, &mut i);
        i += 1; // ','
        let y = num(&text, &mut i);
        let mut c = 0;
        if i < text.len() && text[i] == b' ' {
            i += 5; // " C00 "
            c = num(&text, &mut i);
        }
        xs.push(x as i32);
        ys.push(y as i32);
        cs.push(c as i16);
        while i < text.len() && text[i] != b'\n' {
            i += 1;
        }
    }
    drop(text);
    let (x0, x1) = (*xs.iter().min().unwrap(), *xs.iter().max().unwrap());
    let (y0, y1) = (*ys.iter().min().unwrap(), *ys.iter().max().unwrap());
    // One row of cells below the box: nothing falls past C00 = 0 there, but the test
    // of the cell below needs it.
    let h = (y1 - y0 + 2) as usize;
    let w = (x1 - x0 + 1) as usize;
    let at = |x: i32, y: i32| (x - x0) as usize * h + (y - y0 + 1) as usize;
    let mut occ = vec![false; w * h];
    for k in 0..xs.len() {
        occ[at(xs[k], ys[k])] = true;
    }
    let start = std::time::Instant::now();
    let steps = if threads <= 1 {
        run(&xs, (&mut ys, &mut cs), &mut occ, at)
    } else {
        run_threads(threads, &xs, (&mut ys, &mut cs), &mut occ, at)
    };
    let stepping = start.elapsed();
    let mut out = BufWriter::with_capacity(1 << 16, std::fs::File::create(&args[2]).unwrap());
    let mut sum = 0u64;
    for k in 0..xs.len() {
        sum = sum.wrapping_add((xs[k] as i64 * 100003 + ys[k] as i64) as u64);
        if cs[k] != 0 {
            writeln!(out, "{},{} C00 {}", xs[k], ys[k], cs[k]).unwrap();
        } else {
            writeln!(out, "{},{}", xs[k], ys[k]).unwrap();
        }
    }
    out.flush().unwrap();
    println!("{steps} {sum} {:.3}", stepping.as_secs_f64());
}

/// Steps the agents to the end on this thread: the number of steps.
fn run(
    xs: &[i32],
    (ys, cs): (&mut [i32], &mut [i16]),
    occ: &mut [bool],
    at: impl Fn(i32, i32) -> usize,
) -> u64 {
    let mut steps = 0;
    loop {
        steps += 1;
        if !step(xs, (ys, cs), occ.as_mut_ptr(), &at) {
            return steps;
        }
    }
}

/// One step of the agents (their cells in `occ`): whether any moved. Each step visits the
/// agents in input order: bottom up within a column, so the agent just below may already
/// have left its cell this step, which still counts as filled.
fn step(
    xs: &[i32],
    (ys, cs): (&mut [i32], &mut [i16]),
    occ: *mut bool,
    at: &impl Fn(i32, i32) -> usize,
) -> bool {
    let mut moved = false;
    let mut left = usize::MAX;
    for k in 0..xs.len() {
        let cell = at(xs[k], ys[k]);
        // SAFETY: cells of the grid (`at` of an agent, and the row below it); each thread
        // steps whole columns, whose cells no other thread touches.
        unsafe {
            if cs[k] > 0 && !*occ.add(cell - 1) && left != cell - 1 {
                *occ.add(cell) = false;
                *occ.add(cell - 1) = true;
                ys[k] -= 1;
                cs[k] -= 1;
                moved = true;
                left = cell;
            } else {
                left = usize::MAX;
            }
        }
    }
    moved
}

/// [`run`] on `threads` threads, each a run of whole columns (agents are x-major), all
/// agreeing after each step whether any agent moved.
fn run_threads(
    threads: usize,
    xs: &[i32],
    (ys, cs): (&mut [i32], &mut [i16]),
    occ: &mut [bool],
    at: impl Fn(i32, i32) -> usize + Sync,
) -> u64 {
    use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering::*};
    let n = xs.len();
    let mut cuts = vec![0];
    for t in 1..threads {
        let mut k = (n * t / threads).max(cuts[t - 1]);
        while k > 0 && k < n && xs[k] == xs[k - 1] {
            k += 1;
        }
        cuts.push(k);
    }
    cuts.push(n);
    // A barrier that spins: arrivals, and the round it ends.
    let (arrived, round) = (AtomicUsize::new(0), AtomicUsize::new(0));
    let wait = || {
        let r = round.load(Acquire);
        if arrived.fetch_add(1, AcqRel) + 1 == threads {
            arrived.store(0, Relaxed);
            round.store(r + 1, Release);
        } else {
            while round.load(Acquire) == r {
                std::hint::spin_loop();
            }
        }
    };
    // Whether any moved, per step (two, used in turn, each cleared a step ahead).
    let moved = [AtomicBool::new(false), AtomicBool::new(false)];
    let steps = AtomicUsize::new(0);
    let occ = occ.as_mut_ptr() as usize;
    std::thread::scope(|s| {
        let (mut ys, mut cs) = (ys, cs);
        for t in 0..threads {
            let len = cuts[t + 1] - cuts[t];
            let (y, rest) = std::mem::take(&mut ys).split_at_mut(len);
            let (c, crest) = std::mem::take(&mut cs).split_at_mut(len);
            (ys, cs) = (rest, crest);
            let x = &xs[cuts[t]..cuts[t + 1]];
            let (wait, moved, steps, at) = (&wait, &moved, &steps, &at);
            s.spawn(move || {
                let mut k = 0;
                loop {
                    k += 1;
                    if step(x, (&mut *y, &mut *c), occ as *mut bool, at) {
                        moved[k % 2].store(true, Relaxed);
                    }
                    wait();
                    let any = moved[k % 2].load(Relaxed);
                    if t == 0 {
                        moved[(k + 1) % 2].store(false, Relaxed);
                    }
                    wait();
                    if !any {
                        steps.store(k, Relaxed);
                        return;
                    }
                }
            });
        }
    });
    steps.load(Relaxed) as u64
}
