//! The plain hand-written baseline of B1F (shared/bench/WORKLOADS.md): reads a B1 agents
//! file (`x,y C00 v` lines), runs B1's rule for S steps and writes the final configuration
//! as agents.txt text (`x,y C00 v`, or `x,y` when v = 0: the default state left out, as
//! `latticesim run --out` writes it; WORKLOADS.md shows `S00000`, which loads the same) in
//! input order.
//! Single-threaded: a byte loop into columns, the padded max over the bounding box, a
//! buffered writer.
//!
//! Usage: `b1f_native AGENTS STEPS OUT`; prints the checksum (the sum of C00).

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
    if args.len() != 4 {
        eprintln!("usage: b1f_native AGENTS STEPS OUT");
        std::process::exit(2);
    }
    let steps: usize = args[2].parse().expect("STEPS is a number");
    let text = std::fs::read(&args[1]).expect("the agents file can be read");
    let (mut xs, mut ys, mut vs) = (Vec::new(), Vec::new(), Vec::new());
    let mut i = 0;
    while i < text.len() {
        if text[i] == b'\n' {
            i += 1;
            continue;
        }
        let x = num(&text, &mut i);
        i += 1; // ','
        let y = num(&text, &mut i);
        let mut v = 0;
        if i < text.len() && text[i] == b' ' {
            i += 5; // " C00 "
            v = num(&text, &mut i);
        }
        xs.push(x as i32);
        ys.push(y as i32);
        vs.push(v as i16);
        while i < text.len() && text[i] != b'\n' {
            i += 1;
        }
    }
    drop(text);
    let (x0, x1) = (*xs.iter().min().unwrap(), *xs.iter().max().unwrap());
    let (y0, y1) = (*ys.iter().min().unwrap(), *ys.iter().max().unwrap());
    let (w, h) = ((x1 - x0 + 3) as usize, (y1 - y0 + 3) as usize);
    let at = |x: i32, y: i32| (x - x0 + 1) as usize * h + (y - y0 + 1) as usize;
    let mut cur = vec![0i16; w * h];
    for k in 0..xs.len() {
        cur[at(xs[k], ys[k])] = vs[k];
    }
    let mut next = cur.clone();
    // Step 1 reads no messages; every later step takes the max of the cell and its four
    // neighbours (an empty cell holds 0 and sends nothing).
    for _ in 1..steps {
        for x in 1..w - 1 {
            let row = x * h;
            for y in 1..h - 1 {
                let c = row + y;
                next[c] = cur[c]
                    .max(cur[c - 1])
                    .max(cur[c + 1])
                    .max(cur[c - h])
                    .max(cur[c + h]);
            }
        }
        std::mem::swap(&mut cur, &mut next);
    }
    drop(next);
    let mut out = BufWriter::with_capacity(1 << 16, std::fs::File::create(&args[3]).unwrap());
    let mut sum = 0u64;
    for k in 0..xs.len() {
        let v = cur[at(xs[k], ys[k])];
        sum += v as u64;
        if v != 0 {
            writeln!(out, "{},{} C00 {v}", xs[k], ys[k]).unwrap();
        } else {
            writeln!(out, "{},{}", xs[k], ys[k]).unwrap();
        }
    }
    out.flush().unwrap();
    println!("{sum}");
}
