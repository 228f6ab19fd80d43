//! 32-bit counters (the extension, docs/language.md), for docs/performance.md ("32-bit
//! counters", issue 31), through the commands a user runs, each figure the fastest of three
//! runs taken in turn:
//! - B1F (shared/bench/WORKLOADS.md; L = 1000, 50 steps, the file to `--out`): the plain
//!   hand-written `b1f_native`, `latticesim run` with `--counters 16` and with
//!   `--counters 32`, and at 32 bits on the same file with every value times 65,537 (past
//!   16 bits, as ids are); the outputs of both widths on the same file must be the same;
//! - leader election (examples/leader-election, `gen connected --ids C00`) on 30,000 agents
//!   in both widths, and on 10^6 agents at 32 bits (no 16-bit run can hold its ids): one
//!   leader, the agent with id n, and every agent holding n, checked from the output.
//!
//! `cargo bench -p latticesim-benches --bench counters` (files under target/counters/);
//! `COUNTERS_QUICK=1`: 10^5 agents instead of 10^6.

use latticesim_benches::process::{b1f_file, fresh, latticesim, measure, root, same_files};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Duration;

/// A connected shape of `n` agents in `INIT0` with ids 1..n in C00.
fn ids_file(exe: &Path, dir: &Path, n: u64) -> PathBuf {
    let p = dir.join(format!("ids_{n}.txt"));
    if !p.exists() {
        let ok = Command::new(exe)
            .args(["gen", "connected", "--n", &n.to_string(), "--seed", "3"])
            .args(["--state", "INIT0", "--ids", "C00", "--out"])
            .arg(&p)
            .output()
            .expect("latticesim gen")
            .status
            .success();
        assert!(ok, "latticesim gen");
    }
    p
}

/// Checks a leader election's output: one `LEAD0`, with id `n`, and `C01 n` everywhere.
fn one_leader(out: &Path, n: u64) {
    let text = std::fs::read_to_string(out).unwrap();
    let (mut leaders, mut agents) = (Vec::new(), 0u64);
    for l in text.lines().filter(|l| !l.is_empty()) {
        agents += 1;
        let w: Vec<&str> = l.split_whitespace().collect();
        let c = |name: &str| {
            (w.iter().position(|&x| x == name)).and_then(|i| w.get(i + 1)?.parse::<u64>().ok())
        };
        assert_eq!(
            c("C01"),
            Some(n),
            "an agent that does not hold the largest id: {l}"
        );
        if w.contains(&"SLEAD0") {
            leaders.push(c("C00"));
        }
    }
    assert_eq!(agents, n);
    assert_eq!(
        leaders,
        [Some(n)],
        "one leader, the agent with the largest id"
    );
}

/// The fastest of three runs of each command, taken in turn.
fn best_of(cmds: &mut [(String, Command, PathBuf)]) -> Vec<(Duration, u64)> {
    let mut best = vec![(Duration::MAX, 0u64); cmds.len()];
    for _ in 0..3 {
        for (k, (_, c, out)) in cmds.iter_mut().enumerate() {
            fresh(out);
            let (t, peak) = measure(c);
            if t < best[k].0 {
                best[k] = (t, peak);
            }
        }
    }
    best
}

fn main() {
    if std::env::args().any(|a| a == "--list") {
        return;
    }
    let quick = std::env::var_os("COUNTERS_QUICK").is_some();
    let exe = latticesim();
    let dir = root().join("target/counters");
    std::fs::create_dir_all(&dir).unwrap();
    let native = PathBuf::from(env!("CARGO_BIN_EXE_b1f_native"));
    let flood = root().join("examples/maxflood/rules.txt");
    let le = root().join("examples/leader-election/rules.txt");
    let out = |name: &str| dir.join(format!("out_{name}.txt"));
    let run = |rules: &Path, input: &Path, o: &Path, extra: &[&str]| {
        let mut c = Command::new(&exe);
        c.args(["run", "-q"])
            .args(extra)
            .arg("--out")
            .arg(o)
            .arg(rules)
            .arg(input);
        c
    };

    // B1F in both widths, beside the native baseline.
    let (b1, b1_wide) = (b1f_file(&dir, 1000, 1), b1f_file(&dir, 1000, 65_537));
    let steps = ["--max-steps", "50"];
    let mut native_cmd = Command::new(&native);
    native_cmd.arg(&b1).arg("50").arg(out("native"));
    let mut cmds = vec![
        ("`b1f_native` (i16)".to_string(), native_cmd, out("native")),
        (
            "`latticesim run --counters 16`".to_string(),
            run(
                &flood,
                &b1,
                &out("b1_16"),
                &[&steps[..], &["--counters", "16"]].concat(),
            ),
            out("b1_16"),
        ),
        (
            "`latticesim run --counters 32`".to_string(),
            run(
                &flood,
                &b1,
                &out("b1_32"),
                &[&steps[..], &["--counters", "32"]].concat(),
            ),
            out("b1_32"),
        ),
        (
            "`latticesim run --counters 32`, values x 65,537".to_string(),
            run(
                &flood,
                &b1_wide,
                &out("b1_32w"),
                &[&steps[..], &["--counters", "32"]].concat(),
            ),
            out("b1_32w"),
        ),
    ];
    let best = best_of(&mut cmds);
    assert!(
        same_files(&out("b1_16"), &out("b1_32")),
        "16-bit and 32-bit counters give other results on B1F"
    );
    let n = 1e6;
    println!("B1F, L = 1000, 50 steps, file to file (10^6 agents):\n");
    println!("| program | time | peak | bytes per agent | / native | / 16-bit |");
    println!("|---|---:|---:|---:|---:|---:|");
    for (k, (label, ..)) in cmds.iter().enumerate() {
        let (t, peak) = best[k];
        println!(
            "| {label} | {:.3} s | {:.1} MB | {:.1} | {:.2} | {:.2} |",
            t.as_secs_f64(),
            peak as f64 / 1e6,
            peak as f64 / n,
            t.as_secs_f64() / best[0].0.as_secs_f64(),
            t.as_secs_f64() / best[1].0.as_secs_f64(),
        );
    }

    // Leader election in both widths, and past 32,767 agents.
    let small = ids_file(&exe, &dir, 30_000);
    let big_n = if quick { 100_000 } else { 1_000_000 };
    let big = ids_file(&exe, &dir, big_n);
    let mut cmds = vec![
        (
            "30,000 agents, `--counters 16`".to_string(),
            run(&le, &small, &out("le_16"), &["--counters", "16"]),
            out("le_16"),
        ),
        (
            "30,000 agents, 32-bit (the rules' directive)".to_string(),
            run(&le, &small, &out("le_32"), &[]),
            out("le_32"),
        ),
        (
            format!("{big_n} agents, 32-bit (the rules' directive)"),
            run(&le, &big, &out("le_big"), &[]),
            out("le_big"),
        ),
    ];
    let best = best_of(&mut cmds);
    one_leader(&out("le_16"), 30_000);
    one_leader(&out("le_32"), 30_000);
    one_leader(&out("le_big"), big_n);
    println!("\nLeader election (examples/leader-election), file to file; every output checked: one leader, id n:\n");
    println!("| run | time | peak | bytes per agent | / 16-bit |");
    println!("|---|---:|---:|---:|---:|");
    for (k, (label, ..)) in cmds.iter().enumerate() {
        let (t, peak) = best[k];
        let agents = if k < 2 { 30_000.0 } else { big_n as f64 };
        let ratio = if k < 2 {
            format!("{:.2}", t.as_secs_f64() / best[0].0.as_secs_f64())
        } else {
            "-".into()
        };
        println!(
            "| {label} | {:.3} s | {:.1} MB | {:.1} | {ratio} |",
            t.as_secs_f64(),
            peak as f64 / 1e6,
            peak as f64 / agents,
        );
    }
}
