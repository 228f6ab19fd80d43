//! The user's whole path, for docs/performance.md ("From file to file"): B1F
//! (shared/bench/WORKLOADS.md) through `latticesim run RULES AGENTS --max-steps S --out OUT`
//! as a process, beside the plain hand-written file-to-file program `b1f_native` (this
//! crate's `src/bin/b1f_native.rs`) run on the same file in the same run. Each figure is the
//! fastest of three runs of the whole process (alternating the two programs), with its peak
//! resident memory; each run writes a new output file (its last output removed, and the
//! disk's dirty pages written out with `sync`, before it starts); both outputs must be byte-identical and give the same checksum (and the
//! reference checksum where WORKLOADS.md has one).
//!
//! Also measured: reading alone on one core (`run --threads 1 --max-steps 0`, its `--stats`
//! read time), `check --agents` (peak memory), and the `.zst` form of the largest file.
//!
//! `cargo bench -p latticesim-benches --bench file_to_file` builds the release binary,
//! writes the agents files under target/b1f/ (once), and writes
//! docs/data/performance-file.csv and docs/img/performance-file-{time,memory}.svg.
//! Environment: `FILE_BIG=1` adds L = 10000 (10^8 agents, a 1.9 GB file and its .zst form;
//! about 10 GB of disk and a few minutes); `FILE_QUICK=1` runs L <= 316 only.

use latticesim_benches::plot::*;
use latticesim_benches::process::{b1f_file, fresh, latticesim, measure, root, same_files};
use plotters::prelude::*;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Duration;

const RULES: &str = "flood\n1\nS*****\nC00 A C00 #N01 C00 A C00 #W01 C00 A C00 #E01 C00 A C00 #S01 #*01 + C00 0000\n";

/// The sum of C00 of an agents.txt text written by either program, read a line at a time
/// (this process stays small: a child's peak memory as `wait4` reports it can include the
/// parent's memory at the time it was started).
fn checksum(p: &Path) -> u64 {
    use std::io::BufRead;
    let f = std::io::BufReader::with_capacity(1 << 20, std::fs::File::open(p).unwrap());
    f.split(b'\n')
        .filter_map(|l| {
            let l = l.unwrap();
            let i = l.windows(5).position(|w| w == b" C00 ")?;
            std::str::from_utf8(&l[i + 5..]).ok()?.parse::<u64>().ok()
        })
        .sum()
}

struct Row {
    l: u64,
    n: u64,
    steps: u64,
    bytes: u64,
    ls: (Duration, u64),
    native: (Duration, u64),
}

fn main() {
    if std::env::args()
        .skip(1)
        .any(|a| !a.starts_with("--") && a != "file_to_file")
    {
        return;
    }
    let quick = std::env::var_os("FILE_QUICK").is_some();
    let big = std::env::var_os("FILE_BIG").is_some();
    let exes = (
        latticesim(),
        PathBuf::from(env!("CARGO_BIN_EXE_b1f_native")),
    );
    let dir = root().join("target/b1f");
    std::fs::create_dir_all(&dir).unwrap();
    let rules = dir.join("rules.txt");
    std::fs::write(&rules, RULES).unwrap();
    let mut sizes: Vec<(u64, u64)> = vec![(100, 50), (316, 50)];
    if !quick {
        sizes.extend([(1000, 50), (3162, 20)]);
    }
    if big {
        sizes.push((10000, 5));
    }
    let reps = 3;
    let rows: Vec<Row> = (sizes.iter())
        .map(|&(l, steps)| one_size(&exes, (&dir, &rules), (l, steps), reps))
        .collect();
    // Reading alone on one core, and check --agents, on the largest file but the big one.
    let (l, _) = *sizes.iter().rev().find(|s| s.0 < 10000).unwrap();
    let (read_rate, check_per) = read_and_check(&exes.0, (&dir, &rules), l, reps);
    // The .zst form of the biggest file, in and out.
    let (zl, zs) = *sizes.last().unwrap();
    let z = compressed(&exes.0, (&dir, &rules), zl, zs);
    report(&rows);
    println!("\nreading on one core: {read_rate:.0} MB/s; check --agents at n = {}: {check_per:.1} B/agent; L = {zl} .zst to .zst: {:.3} s, {:.1} B/agent", l * l, z.0.as_secs_f64(), z.1 as f64 / (zl * zl) as f64);
}

/// B1 on an L x L block for `steps` steps from file to file, by latticesim and by the
/// plain program, each the best of `reps` runs; both outputs equal.
fn one_size(
    (exe, native): &(PathBuf, PathBuf),
    (dir, rules): (&Path, &Path),
    (l, steps): (u64, u64),
    reps: usize,
) -> Row {
    let input = b1f_file(dir, l, 1);
    let (o1, o2) = (dir.join("out-latticesim.txt"), dir.join("out-native.txt"));
    let s = steps.to_string();
    let mut best_ls = (Duration::MAX, 0);
    let mut best_native = (Duration::MAX, 0);
    let reps = if l >= 10000 { 1 } else { reps };
    for _ in 0..reps {
        // Each run writes a new file on a quiet disk (see `fresh`), so that neither
        // program pays for the other's writing (or for replacing a file of gigabytes).
        fresh(&o1);
        let a = measure(
            Command::new(exe)
                .args(["run", "-q", "--max-steps", &s, "--out"])
                .arg(&o1)
                .arg(rules)
                .arg(&input),
        );
        fresh(&o2);
        let b = measure(Command::new(native).arg(&input).arg(&s).arg(&o2));
        best_ls = (best_ls.0.min(a.0), best_ls.1.max(a.1));
        best_native = (best_native.0.min(b.0), best_native.1.max(b.1));
    }
    let same = same_files(&o1, &o2);
    assert!(
        same,
        "L = {l}: latticesim and the native program wrote different files"
    );
    let sum = checksum(&o1);
    if (l, steps) == (1000, 50) {
        assert_eq!(
            sum, 32744877892,
            "WORKLOADS.md's checksum of B1 L=1000 S=50"
        );
    }
    let row = Row {
        l,
        n: l * l,
        steps,
        bytes: std::fs::metadata(&input).unwrap().len(),
        ls: best_ls,
        native: best_native,
    };
    eprintln!(
        "L = {l}, S = {steps}: latticesim {:.3} s {:.1} B/agent, native {:.3} s {:.1} B/agent, ratio {:.2}, checksum {sum}",
        row.ls.0.as_secs_f64(),
        row.ls.1 as f64 / row.n as f64,
        row.native.0.as_secs_f64(),
        row.native.1 as f64 / row.n as f64,
        row.ls.0.as_secs_f64() / row.native.0.as_secs_f64()
    );
    row
}

/// The rate of reading on one core (MB/s) and the peak memory of `check --agents` per
/// agent, on the L x L file.
fn read_and_check(exe: &Path, (dir, rules): (&Path, &Path), l: u64, reps: usize) -> (f64, f64) {
    let input = b1f_file(dir, l, 1);
    let stats = dir.join("read-stats.json");
    let mut read_best = f64::MAX;
    for _ in 0..reps {
        measure(
            Command::new(exe)
                .args([
                    "run",
                    "-q",
                    "--threads",
                    "1",
                    "--max-steps",
                    "0",
                    "--out",
                    "/dev/null",
                    "--stats",
                ])
                .arg(&stats)
                .arg(rules)
                .arg(&input),
        );
        let v: serde_json::Value = serde_json::from_slice(&std::fs::read(&stats).unwrap()).unwrap();
        read_best = read_best.min(v["times"]["read_s"].as_f64().unwrap());
    }
    let mb = std::fs::metadata(&input).unwrap().len() as f64 / 1e6;
    let read_rate = mb / read_best;
    let check = measure(
        Command::new(exe)
            .args(["check", "--color", "never"])
            .arg(rules)
            .arg("--agents")
            .arg(&input),
    );
    let check_per = check.1 as f64 / (l * l) as f64;
    eprintln!("reading on one core: {read_rate:.0} MB/s ({mb:.1} MB in {read_best:.3} s); check --agents: {check_per:.1} B/agent");
    (read_rate, check_per)
}

/// L x L for `zs` steps from a .zst file to a .zst file: the time and peak memory.
fn compressed(exe: &Path, (dir, rules): (&Path, &Path), zl: u64, zs: u64) -> (Duration, u64) {
    let zin = dir.join(format!("b1_{zl}.txt.zst"));
    if !zin.exists() {
        let ok = Command::new(exe)
            .args(["run", "-q", "--max-steps", "0", "--out"])
            .arg(&zin)
            .arg(rules)
            .arg(b1f_file(dir, zl, 1))
            .status()
            .unwrap()
            .success();
        assert!(ok);
    }
    let zout = dir.join("out-latticesim.txt.zst");
    fresh(&zout);
    let z = measure(
        Command::new(exe)
            .args(["run", "-q", "--max-steps", &zs.to_string(), "--out"])
            .arg(&zout)
            .arg(rules)
            .arg(&zin),
    );
    eprintln!(
        "L = {zl} from .zst to .zst: {:.3} s, {:.1} B/agent ({:.1} MB in)",
        z.0.as_secs_f64(),
        z.1 as f64 / (zl * zl) as f64,
        std::fs::metadata(&zin).unwrap().len() as f64 / 1e6
    );
    z
}

/// The CSV in docs/data, the plots in docs/img, and the table of docs/performance.md.
fn report(rows: &[Row]) {
    let data = root().join("docs/data");
    let img = root().join("docs/img");
    std::fs::create_dir_all(&data).unwrap();
    std::fs::create_dir_all(&img).unwrap();
    let mut csv = String::from(
        "l,n,steps,file_bytes,latticesim_s,latticesim_peak_bytes,native_s,native_peak_bytes\n",
    );
    for r in rows {
        csv += &format!(
            "{},{},{},{},{:.4},{},{:.4},{}\n",
            r.l,
            r.n,
            r.steps,
            r.bytes,
            r.ls.0.as_secs_f64(),
            r.ls.1,
            r.native.0.as_secs_f64(),
            r.native.1
        );
    }
    std::fs::write(data.join("performance-file.csv"), csv).unwrap();
    let series = |f: &dyn Fn(&Row) -> (f64, f64)| -> Vec<(f64, f64)> {
        rows.iter()
            .map(|r| (r.n as f64, f(r).0))
            .collect::<Vec<_>>()
    };
    let time: Vec<Series> = vec![
        (
            "latticesim run (whole process)",
            series(&|r| (r.ls.0.as_secs_f64(), 0.0)),
            RED,
        ),
        (
            "plain hand-written program",
            series(&|r| (r.native.0.as_secs_f64(), 0.0)),
            BLUE,
        ),
    ];
    plot_lines(
        &img.join("performance-file-time.svg"),
        "B1F from file to file: wall time of the whole process",
        ("agents", "seconds"),
        (power_of_ten, plain),
        &time,
    )
    .expect("plot");
    let memory: Vec<Series> = vec![
        (
            "latticesim run",
            series(&|r| (r.ls.1 as f64 / r.n as f64, 0.0)),
            RED,
        ),
        (
            "plain hand-written program",
            series(&|r| (r.native.1 as f64 / r.n as f64, 0.0)),
            BLUE,
        ),
    ];
    plot_lines(
        &img.join("performance-file-memory.svg"),
        "B1F from file to file: peak resident bytes per agent",
        ("agents", "bytes per agent"),
        (power_of_ten, plain),
        &memory,
    )
    .expect("plot");
    println!("| n | steps | file | latticesim | native | latticesim / native | latticesim peak per agent | native peak per agent |");
    println!("|---:|---:|---:|---:|---:|---:|---:|---:|");
    for r in rows {
        println!(
            "| {} | {} | {:.1} MB | {:.3} s | {:.3} s | {:.2} | {:.1} B | {:.1} B |",
            r.n,
            r.steps,
            r.bytes as f64 / 1e6,
            r.ls.0.as_secs_f64(),
            r.native.0.as_secs_f64(),
            r.ls.0.as_secs_f64() / r.native.0.as_secs_f64(),
            r.ls.1 as f64 / r.n as f64,
            r.native.1 as f64 / r.n as f64
        );
    }
}
