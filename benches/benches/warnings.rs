//! Files that need a warning, or have errors, for docs/performance.md ("Files with
//! warnings", issue 31), through the commands a user runs, each figure the fastest of three
//! runs, the files taken in turn: an R x R block of resting agents beside 1,000 walkers (B4
//! of shared/bench/WORKLOADS.md), the block in a state the rules test (`SREST0`), in a state
//! no rule tests (`SWALL0`, inert walls: W603), with a bond towards east declared by every
//! agent (W601 for all but the last column's, W602 for those; compared with the same file
//! without bonds, `A0000`), and with an error on every line (`SREST`, four characters:
//! E408). Measured: `latticesim check RULES --agents FILE`
//! and `latticesim run RULES FILE --max-steps 5 --out OUT`, wall time and peak memory of
//! the whole process; a file with warnings must cost at most 1.2x the time and 64 bytes
//! per agent of the clean one; the file of errors is reported (its memory must not grow
//! with its diagnostics: at most 64 bytes per line too).
//!
//! `cargo bench -p latticesim-benches --bench warnings` (R = 3162, 10^7 agents; files under
//! target/warnings/); `WARNINGS_QUICK=1`: R = 1000.

use latticesim_benches::process::{fresh, latticesim, measure_exit, root};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::Duration;

const RULES: &str = "walk\n1\nSWALK0 N**0* >C01 0000\nP1,0 C01 - C01 0001\n\nrest\n1\nSREST0 >C00 0000\nC00 - C00 0001\n";

/// The block of side `r` in `state` (each line ending with `extra`), then the walkers;
/// written once, named `name`.
fn file(dir: &Path, r: u64, (name, state, extra): (&str, &str, &str)) -> PathBuf {
    let p = dir.join(format!("{name}_{r}.txt"));
    if !p.exists() {
        let part = p.with_extension("part");
        let mut w =
            std::io::BufWriter::with_capacity(1 << 20, std::fs::File::create(&part).unwrap());
        for x in 0..r {
            for y in 0..r {
                writeln!(w, "{x},{y} S{state}{extra}").unwrap();
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
    // (name, state, the end of each block line, label, the file it is compared with)
    let kinds = [
        ("REST0", "REST0", "", "a tested state (`SREST0`)", 0),
        (
            "WALL0",
            "WALL0",
            "",
            "a state no rule tests (`SWALL0`, W603)",
            0,
        ),
        ("NOBONDS", "REST0", " A0000", "`SREST0 A0000` (no bond)", 0),
        ("BONDS", "REST0", " A0010", "`SREST0 A0010` (W601, W602)", 2),
        (
            "ERRORS",
            "REST",
            "",
            "`SREST`: an error on every line (E408)",
            0,
        ),
    ];
    let files: Vec<PathBuf> = (kinds.iter())
        .map(|&(name, state, extra, ..)| file(&dir, r, (name, state, extra)))
        .collect();
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
    println!("| command | block | agents | time | peak | bytes per agent | / clean |");
    println!("|---|---|---:|---:|---:|---:|---:|");
    for which in ["check", "run"] {
        let mut best = [(Duration::MAX, 0u64); 5];
        for _ in 0..3 {
            for (k, f) in files.iter().enumerate() {
                fresh(&out);
                let status = if k == 4 { 1 } else { 0 };
                let (t, peak) = measure_exit(&mut command(which, f), status);
                if t < best[k].0 {
                    best[k] = (t, peak);
                }
            }
        }
        for (k, &(.., label, base)) in kinds.iter().enumerate() {
            let (t, peak) = best[k];
            println!(
                "| `{which}` | {label} | {} | {:.3} s | {:.1} MB | {:.1} | {:.2} |",
                n as u64,
                t.as_secs_f64(),
                peak as f64 / 1e6,
                peak as f64 / n,
                t.as_secs_f64() / best[base].0.as_secs_f64()
            );
        }
        for k in [1, 3] {
            let (t, peak) = best[k];
            let ratio = t.as_secs_f64() / best[kinds[k].4].0.as_secs_f64();
            if ratio > 1.2 || peak as f64 / n > 64.0 {
                println!(
                    "target not met: `{which}` on {} {ratio:.2}x the clean file's time, {:.1} B/agent (at most 1.2x, 64)",
                    kinds[k].3,
                    peak as f64 / n
                );
            }
        }
        if best[4].1 as f64 / n > 64.0 {
            println!(
                "target not met: `{which}` on the file of errors {:.1} B/line (at most 64)",
                best[4].1 as f64 / n
            );
        }
    }
}
