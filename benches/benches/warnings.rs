//! Files that need a warning, for docs/performance.md ("Files with warnings", issue 31),
//! through the commands a user runs, each figure the fastest of three runs, the two files
//! taken in turn: an R x R block of resting agents beside 1,000 walkers (B4 of
//! shared/bench/WORKLOADS.md), the block once in a state the rules test (`SREST0`) and once
//! in a state no rule tests (`SWALL0`, inert walls: W603 on the fast path). Measured:
//! `latticesim check RULES --agents FILE` and `latticesim run RULES FILE --max-steps 5 --out
//! OUT`, wall time and peak memory of the whole process; the inert file must cost at most
//! 1.2x the time and 64 bytes per agent.
//!
//! `cargo bench -p latticesim-benches --bench warnings` (R = 3162, 10^7 agents; files under
//! target/warnings/); `WARNINGS_QUICK=1`: R = 1000.

use latticesim_benches::process::{fresh, latticesim, measure, root};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::Duration;

const RULES: &str = "walk\n1\nSWALK0 N**0* >C01 0000\nP1,0 C01 - C01 0001\n\nrest\n1\nSREST0 >C00 0000\nC00 - C00 0001\n";

/// The block of side `r` in `state`, then the walkers; written once.
fn file(dir: &Path, r: u64, state: &str) -> PathBuf {
    let p = dir.join(format!("{state}_{r}.txt"));
    if !p.exists() {
        let part = p.with_extension("part");
        let mut w =
            std::io::BufWriter::with_capacity(1 << 20, std::fs::File::create(&part).unwrap());
        for x in 0..r {
            for y in 0..r {
                writeln!(w, "{x},{y} S{state}").unwrap();
            }
        }
        for i in 0..1000 {
            writeln!(w, "{},{} SWALK0 C01 1000", 2 * i, r + 1).unwrap();
        }
        w.flush().unwrap();
        drop(w);
        std::fs::rename(&part, &p).unwrap();
    }
    p
}

fn main() {
    if std::env::args().any(|a| a == "--list") {
        return;
    }
    let quick = std::env::var_os("WARNINGS_QUICK").is_some();
    let r: u64 = if quick { 1000 } else { 3162 };
    let exe = latticesim();
    let dir = root().join("target/warnings");
    std::fs::create_dir_all(&dir).unwrap();
    let rules = dir.join("rules.txt");
    std::fs::write(&rules, RULES).unwrap();
    let files = [file(&dir, r, "REST0"), file(&dir, r, "WALL0")];
    let out = dir.join("out.txt");
    let n = (r * r + 1000) as f64;
    let command = |which: &str, f: &Path| {
        let mut c = Command::new(&exe);
        match which {
            "check" => c.arg("check").arg(&rules).arg("--agents").arg(f),
            _ => c
                .args(["run", "-q", "--max-steps", "5", "--out"])
                .arg(&out)
                .arg(&rules)
                .arg(f),
        };
        c.stderr(Stdio::null());
        c
    };
    println!("| command | block in | agents | time | peak | bytes per agent | / tested |");
    println!("|---|---|---:|---:|---:|---:|---:|");
    for which in ["check", "run"] {
        let mut best = [(Duration::MAX, 0u64); 2];
        for _ in 0..3 {
            for (k, f) in files.iter().enumerate() {
                fresh(&out);
                let (t, peak) = measure(&mut command(which, f));
                if t < best[k].0 {
                    best[k] = (t, peak);
                }
            }
        }
        for (k, label) in [
            "a tested state (`SREST0`)",
            "a state no rule tests (`SWALL0`, W603)",
        ]
        .iter()
        .enumerate()
        {
            let (t, peak) = best[k];
            println!(
                "| `{which}` | {label} | {} | {:.3} s | {:.1} MB | {:.1} | {:.2} |",
                n as u64,
                t.as_secs_f64(),
                peak as f64 / 1e6,
                peak as f64 / n,
                t.as_secs_f64() / best[0].0.as_secs_f64()
            );
        }
        let (t, peak) = best[1];
        let ratio = t.as_secs_f64() / best[0].0.as_secs_f64();
        if ratio > 1.2 || peak as f64 / n > 64.0 {
            println!(
                "target not met: `{which}` on the inert file {ratio:.2}x the tested file's time, {:.1} B/agent (at most 1.2x, 64)",
                peak as f64 / n
            );
        }
    }
}
