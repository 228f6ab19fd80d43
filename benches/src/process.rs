//! Running `latticesim` and the plain hand-written programs as processes, as a user does:
//! the release binary built once, a command timed from start to end with its peak
//! resident memory, outputs compared byte for byte. Used by the benchmarks that measure
//! the user's whole path (`file_to_file`, `moving`, `counters`), and their input files,
//! written once.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

/// The workspace's root.
pub fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// Builds the release `latticesim` and gives its path.
pub fn latticesim() -> PathBuf {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let ok = Command::new(cargo)
        .args([
            "build",
            "--release",
            "--quiet",
            "-p",
            "latticesim",
            "--bin",
            "latticesim",
        ])
        .current_dir(root())
        .status()
        .expect("run cargo build")
        .success();
    assert!(ok, "cargo build --release of latticesim failed");
    root().join("target/release/latticesim")
}

/// Runs a command to its end: wall time and peak resident bytes of the child (reaped by
/// `wait4`, which gives its own peak, rather than by `Child::wait`).
pub fn measure(cmd: &mut Command) -> (Duration, u64) {
    measure_exit(cmd, 0)
}

/// As [`measure`], for a command that must end with the exit status `code`.
#[allow(clippy::zombie_processes)]
pub fn measure_exit(cmd: &mut Command, code: i32) -> (Duration, u64) {
    let t = Instant::now();
    let child = cmd
        .stdout(std::process::Stdio::null())
        .spawn()
        .expect("start the command");
    let mut status = 0;
    // SAFETY: wait4 writes the status and the usage of the child it reaps.
    let mut ru: libc::rusage = unsafe { std::mem::zeroed() };
    let r = unsafe { libc::wait4(child.id() as i32, &mut status, 0, &mut ru) };
    let wall = t.elapsed();
    assert!(
        r > 0 && libc::WIFEXITED(status) && libc::WEXITSTATUS(status) == code,
        "{cmd:?} failed"
    );
    (wall, ru.ru_maxrss as u64 * 1024)
}

/// The time two threads take to pass a counter to each other and back (the median of
/// five runs of 100,000 round trips, each thread spinning on a load without a pause): how
/// far apart the machine's cores are now. On a
/// virtual machine it changes from hour to hour with where the host runs the two cores
/// (120-350 ns on the machine of docs/performance.md), and with it what a second thread
/// gains: phases that hand over data between threads wait on it.
pub fn core_round_trip() -> Duration {
    use std::sync::atomic::{AtomicU64, Ordering::*};
    const TRIPS: u64 = 100_000;
    let mut runs: Vec<Duration> = (0..5)
        .map(|_| {
            let ball = AtomicU64::new(0);
            std::thread::scope(|s| {
                s.spawn(|| {
                    for i in 0..TRIPS {
                        while ball.load(Acquire) != 2 * i + 1 {}
                        ball.store(2 * i + 2, Release);
                    }
                });
                let t = Instant::now();
                for i in 0..TRIPS {
                    ball.store(2 * i + 1, Release);
                    while ball.load(Acquire) != 2 * i + 2 {}
                }
                t.elapsed() / TRIPS as u32
            })
        })
        .collect();
    runs.sort();
    runs[2]
}

/// Removes `out` (a program's output of the last run) and writes every dirty page out, so
/// that the next program timed neither pays for another's writing nor replaces a file.
pub fn fresh(out: &Path) {
    let _ = std::fs::remove_file(out);
    // SAFETY: sync takes no arguments and cannot fail.
    unsafe { libc::sync() };
}

/// Whether two files hold the same bytes, read a block at a time.
pub fn same_files(a: &Path, b: &Path) -> bool {
    let (mut fa, mut fb) = (
        std::fs::File::open(a).unwrap(),
        std::fs::File::open(b).unwrap(),
    );
    let (mut ba, mut bb) = (vec![0u8; 1 << 20], vec![0u8; 1 << 20]);
    loop {
        let na = read_full(&mut fa, &mut ba);
        let nb = read_full(&mut fb, &mut bb);
        if na != nb || ba[..na] != bb[..nb] {
            return false;
        }
        if na == 0 {
            return true;
        }
    }
}

fn read_full(f: &mut std::fs::File, buf: &mut [u8]) -> usize {
    use std::io::Read;
    let mut n = 0;
    while n < buf.len() {
        match f.read(&mut buf[n..]).unwrap() {
            0 => break,
            k => n += k,
        }
    }
    n
}

/// Writes `p` once (through a part file renamed at the end), with `fill` writing its text.
pub fn once(p: &Path, fill: impl FnOnce(&mut dyn Write)) -> PathBuf {
    if !p.exists() {
        let part = p.with_extension("part");
        let mut w =
            std::io::BufWriter::with_capacity(1 << 20, std::fs::File::create(&part).unwrap());
        fill(&mut w);
        w.flush().unwrap();
        drop(w);
        std::fs::rename(&part, p).unwrap();
    }
    p.to_path_buf()
}

/// B1F's input (shared/bench/WORKLOADS.md) of side `l`, `x,y C00 v` x-major, its values
/// times `scale` (1: the workload's own).
pub fn b1f_file(dir: &Path, l: u64, scale: u64) -> PathBuf {
    let name = match scale {
        1 => format!("b1f_{l}.txt"),
        s => format!("b1f_{l}_x{s}.txt"),
    };
    once(&dir.join(name), |out| {
        for x in 0..l {
            for y in 0..l {
                let v = (((x * l + y) * 7919) % 32749 + 1) * scale;
                writeln!(out, "{x},{y} C00 {v}").unwrap();
            }
        }
    })
}
