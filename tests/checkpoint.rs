//! Checkpoints through the command line: a run resumed from a checkpoint ends byte-identical
//! to the run without a stop (--out, --stats --no-timing, and the trace of the remaining
//! steps); checkpoints that cannot be resumed are refused with their reason, and nothing is
//! overwritten.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn bin() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_latticesim"));
    c.current_dir(env!("CARGO_MANIFEST_DIR"));
    c
}

fn dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("latticesim-ckpt-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn run(args: &[&str]) -> Output {
    let o = bin().args(args).output().unwrap();
    o
}

fn ok(args: &[&str]) {
    let o = run(args);
    assert!(
        o.status.success(),
        "{args:?}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// The trace lines of steps after `after`.
fn trace_after(p: &Path, after: u64) -> Vec<String> {
    std::fs::read_to_string(p)
        .unwrap()
        .lines()
        .filter(|l| {
            let v: serde_json::Value = serde_json::from_str(l).unwrap();
            v["step"].as_u64().unwrap() > after
        })
        .map(String::from)
        .collect()
}

/// Runs `rules` on `agents` for `steps` steps straight, and again stopped after each of
/// `stops` (checkpoint), resumed to the end; compares the outputs.
fn same_as_straight(rules: &Path, agents: &Path, steps: u64, stops: &[u64], extra: &[&str]) {
    static CASE: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);
    let d = dir(&format!(
        "case-{}",
        CASE.fetch_add(1, std::sync::atomic::Ordering::SeqCst)
    ));
    let (out, stats, trace) = (
        d.join("out.txt"),
        d.join("stats.json"),
        d.join("trace.jsonl"),
    );
    let max = steps.to_string();
    let mut args = vec![
        "run",
        s(rules),
        s(agents),
        "-q",
        "--no-timing",
        "--max-steps",
        &max,
    ];
    args.extend(extra);
    let mut straight = args.clone();
    straight.extend(["--out", s(&out), "--stats", s(&stats), "--trace", s(&trace)]);
    ok(&straight);
    for &stop in stops {
        let ck = d.join(format!("at-{stop}.ckpt"));
        let stop_s = stop.to_string();
        let mut first = vec!["run", s(rules), s(agents), "-q", "--max-steps", &stop_s];
        first.extend(extra);
        first.extend(["--checkpoint", s(&ck), "--out", "/dev/null"]);
        ok(&first);
        let (o2, s2, t2) = (d.join("o2.txt"), d.join("s2.json"), d.join("t2.jsonl"));
        let mut second = vec!["run", s(rules), "--resume", s(&ck), "-q", "--no-timing"];
        second.extend(["--max-steps", &max]);
        second.extend(extra);
        second.extend(["--out", s(&o2), "--stats", s(&s2), "--trace", s(&t2)]);
        ok(&second);
        let what = format!("{} stopped at {stop} {extra:?}", s(agents));
        assert_eq!(
            std::fs::read(&out).unwrap(),
            std::fs::read(&o2).unwrap(),
            "--out, {what}"
        );
        assert_eq!(
            std::fs::read(&stats).unwrap(),
            std::fs::read(&s2).unwrap(),
            "--stats, {what}"
        );
        assert_eq!(
            trace_after(&trace, stop),
            trace_after(&t2, 0),
            "--trace, {what}"
        );
    }
}

/// Runs `steps` steps and writes a checkpoint at the end (`extra`: more options).
fn make_checkpoint(rules: &Path, agents: &Path, steps: u64, ck: &Path, extra: &[&str]) {
    let steps = steps.to_string();
    let mut args = vec!["run", s(rules), s(agents), "-q", "--max-steps", &steps];
    args.extend(["--checkpoint", s(ck), "--out", "/dev/null"]);
    args.extend(extra);
    ok(&args);
}

fn example(p: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("examples")
        .join(p)
}

#[test]
fn resumed_examples_end_as_the_run_without_a_stop() {
    // Moves and carried groups, messages in flight, 3D, under both orders and static-first.
    let cases: &[(&str, &str, u64)] = &[
        (
            "reconfigure-line/rules.txt",
            "reconfigure-line/agents-30.txt",
            60,
        ),
        ("tour/rules.txt", "tour/agents.txt", 40),
        ("maxflood/rules.txt", "maxflood/agents.txt", 12),
        (
            "spanning-tree/rules-3d.txt",
            "spanning-tree/agents-3d.txt",
            30,
        ),
        ("gravity-3d/rules.txt", "gravity-3d/agents.txt", 30),
        ("bouncing/rules.txt", "bouncing/agents.txt", 30),
    ];
    for &(r, a, steps) in cases {
        for extra in [
            &[][..],
            &["--order", "messages-first"][..],
            &["--static-first"][..],
        ] {
            same_as_straight(
                &example(r),
                &example(a),
                steps,
                &[1, steps / 3, steps - 1],
                extra,
            );
        }
    }
}

#[test]
fn resumed_swaps_and_text_messages_go_on_exactly() {
    let d = dir("swaps");
    // Agents swap east in turn and send texts that the next step reads.
    let rules = d.join("rules.txt");
    std::fs::write(
        &rules,
        "swap\n2\nSA**** F1,0\nXE MEhello\n\
         hear\n1\nSB**** MWh****\nSC0000 M*hi000\n\
         again\n1\nSC**** M*hi***\nSB0000\n",
    )
    .unwrap();
    let agents = d.join("agents.txt");
    let mut text = String::new();
    for x in 0..12 {
        for y in 0..3 {
            let st = if (x + y) % 3 == 0 { "SA0000" } else { "SB0000" };
            text += &format!("{x},{y} {st} C01 {}\n", x * 3 + y);
        }
    }
    std::fs::write(&agents, text).unwrap();
    for extra in [
        &[][..],
        &["--order", "messages-first"][..],
        &["--static-first"][..],
    ] {
        same_as_straight(&rules, &agents, 9, &[1, 2, 5, 8], extra);
    }
}

#[test]
fn checkpoints_that_cannot_be_resumed_are_refused() {
    let d = dir("refused");
    let rules = example("maxflood/rules.txt");
    let agents = example("maxflood/agents.txt");
    let ck = d.join("run.ckpt");
    make_checkpoint(&rules, &agents, 3, &ck, &[]);
    let good = std::fs::read(&ck).unwrap();
    let out = d.join("out.txt");
    std::fs::write(&out, "keep me\n").unwrap();
    let refuse = |bytes: &[u8], rules: &Path, extra: &[&str], why: &str| {
        let bad = d.join("bad.ckpt");
        std::fs::write(&bad, bytes).unwrap();
        let mut args = vec!["run", s(rules), "--resume", s(&bad), "--out", s(&out)];
        args.extend(extra);
        let o = run(&args);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{why}: {err}");
        assert!(
            err.contains(&format!("cannot resume from `{}`", s(&bad))),
            "{err}"
        );
        assert!(err.contains(why), "expected `{why}` in: {err}");
        assert_eq!(std::fs::read_to_string(&out).unwrap(), "keep me\n", "{why}");
    };
    let mut body = good.clone();
    let mid = body.len() / 2;
    body[mid] ^= 0x40;
    refuse(&body, &rules, &[], "corrupted");
    let mut head = good.clone();
    head[20] ^= 1;
    refuse(&head, &rules, &[], "corrupted");
    refuse(&good[..good.len() - 3], &rules, &[], "truncated");
    refuse(&good[..100], &rules, &[], "truncated");
    let mut version = good.clone();
    version[8] = 9;
    refuse(&version, &rules, &[], "format version 9");
    // A forged agent count with the header's checksum made again: refused as short, in
    // bounded memory (it allocated for 2^31 agents and aborted).
    for forged in [1u64 << 31, (1 << 32) - 3] {
        let mut f = good.clone();
        f[48..56].copy_from_slice(&forged.to_le_bytes());
        let sum = crc32(&f[..57]);
        f[57..61].copy_from_slice(&sum.to_le_bytes());
        refuse(&f, &rules, &[], "truncated");
    }
    // A universe with its bounds out of order, a flag of 2, bounds after a flag of 0, each
    // with the checksums made again (the first made a grid of negative size: a panic).
    let forge = |at: usize, bytes: &[u8]| {
        let mut f = good.clone();
        f[at..at + bytes.len()].copy_from_slice(bytes);
        let sum = crc32(&f[..57]);
        f[57..61].copy_from_slice(&sum.to_le_bytes());
        let end = f.len() - 4;
        let sum = crc32(&f[..end]);
        f[end..].copy_from_slice(&sum.to_le_bytes());
        f
    };
    let mut inverted = vec![1u8];
    for (lo, hi) in [(5i32, -5i32), (0, 9), (0, 0)] {
        inverted.extend_from_slice(&lo.to_le_bytes());
        inverted.extend_from_slice(&hi.to_le_bytes());
    }
    refuse(&forge(23, &inverted), &rules, &[], "a universe of");
    refuse(&forge(23, &[2]), &rules, &[], "a universe of");
    refuse(&forge(24, &[7]), &rules, &[], "a universe of");
    refuse(&forge(21, &[3]), &rules, &[], "static-first 3");
    refuse(b"0,0 S00000\n", &rules, &[], "not a latticesim checkpoint");
    refuse(b"", &rules, &[], "not a latticesim checkpoint");
    let other = d.join("other.txt");
    std::fs::write(&other, "flood\n1\nS*****\n#*01 + C00 0001\n").unwrap();
    refuse(&good, &other, &[], "other rules");
    refuse(
        &good,
        &rules,
        &["--order", "messages-first"],
        "--order actions-first",
    );
    refuse(&good, &rules, &["--static-first"], "no --static-first");
    // The good one still resumes, and a compressed one too.
    ok(&["run", s(&rules), "--resume", s(&ck), "-q", "--out", s(&out)]);
    let zst = d.join("run.ckpt.zst");
    make_checkpoint(&rules, &agents, 3, &zst, &[]);
    let o2 = d.join("out2.txt");
    ok(&["run", s(&rules), "--resume", s(&zst), "-q", "--out", s(&o2)]);
    assert_eq!(std::fs::read(&out).unwrap(), std::fs::read(&o2).unwrap());
}

#[test]
fn checkpoint_every_n_steps_and_at_the_end() {
    let d = dir("every");
    let rules = example("maxflood/rules.txt");
    let agents = example("maxflood/agents.txt");
    let ck = d.join("run.ckpt");
    // Stopped by --max-steps 7 with a checkpoint every 3: the last one written is the end's.
    make_checkpoint(&rules, &agents, 7, &ck, &["--checkpoint-every", "3"]);
    let stats = d.join("stats.json");
    ok(&[
        "run",
        s(&rules),
        "--resume",
        s(&ck),
        "-q",
        "--max-steps",
        "7",
        "--no-timing",
        "--stats",
        s(&stats),
        "--out",
        "/dev/null",
    ]);
    let v: serde_json::Value = serde_json::from_slice(&std::fs::read(&stats).unwrap()).unwrap();
    assert_eq!(v["steps"], 7);
    // Both an agents file and --resume: refused by the argument parser.
    let o = run(&["run", s(&rules), s(&agents), "--resume", s(&ck)]);
    assert_eq!(o.status.code(), Some(2));
}

#[test]
fn ctrl_c_writes_a_checkpoint_that_resumes() {
    let d = dir("ctrl-c");
    let rules = d.join("rules.txt");
    // Counters that climb by one a step (and stay at 32767, with a saturation warning).
    std::fs::write(&rules, "climb\n1\nS*****\nC00 + C00 0001\n").unwrap();
    let agents = d.join("agents.txt");
    std::fs::write(&agents, "0,0\n1,0 C00 100\n").unwrap();
    let (ck, stats) = (d.join("run.ckpt"), d.join("stats.json"));
    // Far more steps than it takes before the interrupt, however fast a step is.
    let max = "1000000000";
    let mut child = bin()
        .args(["run", s(&rules), s(&agents), "-q", "--checkpoint", s(&ck)])
        .args(["--stats", s(&stats), "--max-steps", max, "--out"])
        .arg(d.join("stopped.txt"))
        .spawn()
        .unwrap();
    std::thread::sleep(std::time::Duration::from_millis(200));
    let killed = Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(killed.success());
    assert_eq!(child.wait().unwrap().code(), Some(130));
    let v: serde_json::Value = serde_json::from_slice(&std::fs::read(&stats).unwrap()).unwrap();
    assert_eq!(v["stopped_by"], "interrupted");
    let at = v["steps"].as_u64().unwrap();
    assert!(at > 0 && at < 1_000_000_000, "interrupted at step {at}");
    let (straight, resumed) = (d.join("straight.txt"), d.join("resumed.txt"));
    let (s1, s2) = (d.join("s1.json"), d.join("s2.json"));
    // Both go on to a thousand steps past the interrupt.
    let end = (at + 1000).to_string();
    let max = end.as_str();
    ok(&[
        "run",
        s(&rules),
        s(&agents),
        "-q",
        "--no-timing",
        "--max-steps",
        max,
        "--out",
        s(&straight),
        "--stats",
        s(&s1),
    ]);
    ok(&[
        "run",
        s(&rules),
        "--resume",
        s(&ck),
        "-q",
        "--no-timing",
        "--max-steps",
        max,
        "--out",
        s(&resumed),
        "--stats",
        s(&s2),
    ]);
    assert_eq!(
        std::fs::read(&straight).unwrap(),
        std::fs::read(&resumed).unwrap()
    );
    assert_eq!(std::fs::read(&s1).unwrap(), std::fs::read(&s2).unwrap());
}

/// A checkpoint written while quiet agents are skipped (walkers passing over resting
/// agents that hear them, most agents quiet at every step) resumes to the end of the run
/// without a stop, with skipping and without.
#[test]
fn a_checkpoint_of_a_skipping_run_resumes_to_the_same_end() {
    let d = dir("skipping");
    let rules = d.join("rules.txt");
    std::fs::write(
        &rules,
        "walk\n1\nSWALK0 >C01 0000 N**0*\nP1,0 C01 - C01 0001 #S01 + C01 0000\n\n\
         hear\n1\nSREST0 >#N01 0000\nC02 + C02 #N01 SHEARD\n",
    )
    .unwrap();
    let agents = d.join("agents.txt");
    let mut text = String::new();
    for x in 0..40 {
        for y in 0..10 {
            text += &format!("{x},{y} SREST0\n");
        }
    }
    for i in 0..5 {
        text += &format!("{},10 SWALK0 C01 {}\n", -3 * i, 20 + i);
    }
    std::fs::write(&agents, text).unwrap();
    for extra in [&[][..], &["--no-skip"][..], &["--threads", "2"][..]] {
        same_as_straight(&rules, &agents, 30, &[1, 7, 16, 24], extra);
    }
}

/// CRC-32 (IEEE), as the checkpoint's header checksum.
fn crc32(bytes: &[u8]) -> u32 {
    let mut c = !0u32;
    for &b in bytes {
        c ^= b as u32;
        for _ in 0..8 {
            c = if c & 1 != 0 {
                (c >> 1) ^ 0xEDB8_8320
            } else {
                c >> 1
            };
        }
    }
    !c
}
