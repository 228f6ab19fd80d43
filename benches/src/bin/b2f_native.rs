//! The plain hand-written baseline of B2F (shared/bench/WORKLOADS.md): reads a B2 agents
//! file (`x,y` or `x,y C00 v` lines, x-major and bottom up within a column), runs B2's
//! rule (fall one cell south when that cell was empty at the start of the step and
//! C00 > 0; then C00 = C00 - 1) until a step in which no agent moves, and writes the final
//! configuration as agents.txt text (`x,y`, with ` C00 v` when v != 0; the default state
//! left out, as `latticesim run --out` writes it) in input
//! order. Single-threaded: a byte loop into columns, an occupancy grid over the bounding
//! box, a buffered writer.
//!
//! Usage: `b2f_native AGENTS OUT`; prints the steps and the checksum (the sum of
//! x * 100003 + y over the agents).

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
    if args.len() != 3 {
        eprintln!("usage: b2f_native AGENTS OUT");
        std::process::exit(2);
    }
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
    // Each step visits the agents in input order: bottom up within a column, so the agent
    // just below may already have left its cell this step, which still counts as filled.
    let mut steps = 0u64;
    loop {
        steps += 1;
        let mut moved = false;
        let mut left = usize::MAX;
        for k in 0..xs.len() {
            let cell = at(xs[k], ys[k]);
            if cs[k] > 0 && !occ[cell - 1] && left != cell - 1 {
                occ[cell] = false;
                occ[cell - 1] = true;
                ys[k] -= 1;
                cs[k] -= 1;
                moved = true;
                left = cell;
            } else {
                left = usize::MAX;
            }
        }
        if !moved {
            break;
        }
    }
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
    println!("{steps} {sum}");
}
