//! The benchmark workloads of ../shared/bench/WORKLOADS.md through the command line, at the
//! small sizes: the checksum computed from --out matches the reference.

use latticesim_benches::workloads::*;
use std::path::PathBuf;
use std::process::Command;

fn dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("latticesim-wl-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Runs the CLI and returns the --out text and the --stats JSON.
fn run(name: &str, rules: &str, agents: &str, extra: &[&str]) -> (String, serde_json::Value) {
    let d = dir(name);
    std::fs::write(d.join("rules.txt"), rules).unwrap();
    std::fs::write(d.join("agents.txt"), agents).unwrap();
    let o = Command::new(env!("CARGO_BIN_EXE_latticesim"))
        .arg("run")
        .arg(d.join("rules.txt"))
        .arg(d.join("agents.txt"))
        .arg("--out")
        .arg(d.join("out.txt"))
        .arg("--stats")
        .arg(d.join("stats.json"))
        .args(extra)
        .output()
        .unwrap();
    assert!(
        o.status.success(),
        "{name}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    let out = std::fs::read_to_string(d.join("out.txt")).unwrap();
    let stats =
        serde_json::from_str(&std::fs::read_to_string(d.join("stats.json")).unwrap()).unwrap();
    (out, stats)
}

fn fields(line: &str) -> (i64, i64, &str, i64) {
    let mut w = line.split_whitespace();
    let pos: Vec<i64> = w
        .next()
        .unwrap()
        .split(',')
        .map(|v| v.parse().unwrap())
        .collect();
    let mut state = "00000";
    let mut c00 = 0;
    while let Some(f) = w.next() {
        if let Some(s) = f.strip_prefix('S') {
            state = s;
        } else if f == "C00" {
            c00 = w.next().unwrap().parse().unwrap();
        } else if f.starts_with('C') {
            w.next();
        }
    }
    (pos[0], pos[1], state, c00)
}

#[test]
fn b1_maxflood() {
    for (l, s, want) in [
        (30u64, 10u64, 28364701u64),
        (30, 20, 29318341),
        (100, 10, 325162305),
    ] {
        let (out, stats) = run(
            &format!("b1-{l}-{s}"),
            B1_RULES,
            &b1_agents(l),
            &["--max-steps", &s.to_string()],
        );
        let sum: u64 = out.lines().map(|l| fields(l).3 as u64).sum();
        assert_eq!(sum, want, "B1 L={l} S={s}");
        assert_eq!(stats["steps"], s);
        assert_eq!(stats["stopped_by"], "max-steps");
    }
}

#[test]
fn b2_gravity() {
    for (w, n, steps, want) in [
        (30u64, 283u64, 26u64, 411013639u64),
        (40, 489, 37, 958231766),
        (60, 1074, 52, 3129303495),
    ] {
        let (out, stats) = run(&format!("b2-{w}"), B2_RULES, &b2_agents(w, w), &[]);
        let sum: u64 = out
            .lines()
            .map(|l| {
                let (x, y, _, _) = fields(l);
                (x * 100003 + y) as u64
            })
            .sum();
        assert_eq!(out.lines().count() as u64, n);
        assert_eq!(sum, want, "B2 W=H={w}");
        assert_eq!(stats["steps"], steps, "B2 W=H={w}");
        assert_eq!(stats["stopped_by"], "quiescence");
    }
}

#[test]
fn b3_rule_count() {
    for (l, k, s, want) in [
        (30u64, 7u64, 10u64, 2704u64),
        (30, 1, 5, 0),
        (30, 16, 5, 6728),
        (100, 16, 5, 75008),
    ] {
        let (out, _) = run(
            &format!("b3-{l}-{k}-{s}"),
            &b3_rules(k),
            &b3_agents(l, k),
            &["--max-steps", &s.to_string()],
        );
        let sum: u64 = out
            .lines()
            .map(|l| fields(l).2[1..].parse::<u64>().unwrap())
            .sum();
        assert_eq!(sum, want, "B3 L={l} k={k} S={s}");
    }
}
