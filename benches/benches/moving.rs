//! Agents that move, for docs/performance.md ("Agents that move"), through the command a
//! user runs (`latticesim run RULES AGENTS --out OUT --stats STATS`), each figure the
//! fastest of three runs (five for B2F, nine for the walkers beside at most 10^5 agents),
//! alternating the programs:
//!
//! - **B2F** (shared/bench/WORKLOADS.md): gravity from file to file, whole process, by
//!   `latticesim run` on one and on two threads and by the plain hand-written program
//!   `b2f_native` (this crate's `src/bin/b2f_native.rs`) on the same file in the same run;
//!   the outputs must be byte-identical, with the steps and checksum of WORKLOADS.md.
//! - **B4 walkers** beside resting agents (WORKLOADS.md): 1,000 walkers alone, beside 100,
//!   10^5 and 10^7 resting agents, and beside 10^7 obstacles (agents in a state no rule
//!   tests), one and two threads; the figure is the stepping time
//!   (`--stats`' `steps_s`); every walker must end 1,000 cells east, every resting agent
//!   where it was.
//! - **Walkers with no grid around them**: 1,000 walkers scattered over 10^6 x 37,000
//!   cells, and 1,000 in a row 10^6 cells from a block of 10^5 at rest, one and two
//!   threads, against the walkers alone; every walker must end 1,000 cells east.
//! - **Walkers that turn** every 20 steps (two rules per state), alone and beside 10^5
//!   agents at rest, 1,000 steps, one and two threads; every walker must end 7 cells
//!   east of where it started, every resting agent where it was.
//! - **3D walkers** that leave the box of a block of 100^3 agents at rest (1,000 in a slab
//!   beside it walking east), one and two threads; every walker must end 1,000 cells
//!   east, every resting agent where it was.
//! - **Threads**: stepping time on one and two threads for B1F (L = 1000, 50 steps), B2F
//!   and the walkers (2D and 3D), and a gravity cloud of 10^6 agents listed at random (`gen cloud`,
//!   1,340 steps; the outputs of both runs must be the same), and the actions of the
//!   general way: B2's gravity with a rule per state (the agents' positions at the end
//!   must be B2's, by WORKLOADS.md's checksum), the bouncing example's rules on 200,000
//!   dots, rigid bars carried, lines sorted by swaps (`general_files`; the outputs of both
//!   runs must be the same).
//!
//! Before and after B2F it measures the cores' round trip (a counter passed between two
//! threads and back), which on a virtual machine changes with where the host runs its
//! cores, and with it what a second thread gains.
//!
//! `cargo bench -p latticesim-benches --bench moving` writes the files under
//! target/moving/ (once), docs/data/performance-moving.csv and
//! docs/img/performance-moving-{b2f,walkers}.svg, and prints the tables of
//! docs/performance.md. `MOVING_QUICK=1` leaves out the largest sizes and the cloud.

use latticesim_benches::plot::*;
use latticesim_benches::process::{
    b1f_file, core_round_trip, fresh, latticesim, measure, once, root, same_files,
};
use plotters::prelude::*;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Duration;

const B1_RULES: &str = latticesim_benches::workloads::B1_RULES;
const B2_RULES: &str = latticesim_benches::workloads::B2_RULES;
const WALK_RULES: &str = "walk\n1\nSWALK0 N**0* >C01 0000\nP1,0 C01 - C01 0001\n\nrest\n1\nSREST0 >C00 0000\nC00 - C00 0001\n";

/// B2F's input of side `w`: `x,y C00 y` (`x,y` when y = 0), x-major.
fn b2f_file(dir: &Path, w: u64) -> PathBuf {
    once(&dir.join(format!("b2f_{w}.txt")), |out| {
        for (x, y) in latticesim_benches::workloads::b2_cells(w, w) {
            if y == 0 {
                writeln!(out, "{x},{y}").unwrap();
            } else {
                writeln!(out, "{x},{y} C00 {y}").unwrap();
            }
        }
    })
}

/// Walkers that turn: east 20 steps, a step to turn, west 20 steps, a step to turn, and
/// so on (two rules per state, as rule authors write them; beside agents at rest, the
/// agents woken are evaluated in windows of each state's rules).
const TURN_RULES: &str = "east\n1\nSWALK0 N**0* >C01 0000\nP1,0 C01 - C01 0001\n\n\
turnw\n1\nSWALK0 =C01 0000\nSBACK0 C01 + C01 0020\n\n\
west\n1\nSBACK0 N*0** >C01 0000\nP-1,0 C01 - C01 0001\n\n\
turne\n1\nSBACK0 =C01 0000\nSWALK0 C01 + C01 0020\n\n\
rest\n1\nSREST0 >C00 0000\nC00 - C00 0001\n";

/// 1,000 walkers of [`TURN_RULES`] (at (2i, r + 1), as [`walkers_file`]'s, C01 = 20)
/// above an `r` x `r` block at rest.
fn turning_file(dir: &Path, r: u64) -> PathBuf {
    block_and_walkers(&dir.join(format!("turning_{r}.txt")), (r, "SREST0"), 20)
}

/// B4's input: an `r` x `r` block of resting agents and 1,000 walkers above it. The
/// agents at rest are in `SREST0` (whose rule never applies) or, with `walls`, in
/// `SWALL0`, a state no rule tests (obstacles).
fn walkers_file(dir: &Path, r: u64, walls: bool) -> PathBuf {
    let (name, state) = if walls {
        ("walls", "SWALL0")
    } else {
        ("walkers", "SREST0")
    };
    block_and_walkers(&dir.join(format!("{name}_{r}.txt")), (r, state), 1000)
}

/// An `r` x `r` block of agents in `state` and 1,000 `SWALK0` agents at (2i, r + 1) with
/// C01 = `c01`, written to `p` once.
fn block_and_walkers(p: &Path, (r, state): (u64, &str), c01: u32) -> PathBuf {
    once(p, |out| {
        for x in 0..r {
            for y in 0..r {
                writeln!(out, "{x},{y} {state}").unwrap();
            }
        }
        for i in 0..1000 {
            writeln!(out, "{},{} SWALK0 C01 {c01}", 2 * i, r + 1).unwrap();
        }
    })
}

/// 1,000 walkers with no grid around them: scattered 1,000 cells apart over 10^6 x
/// 37,000 cells (no grid at all), or in a row 10^6 cells north of a 316 x 316 block of
/// resting agents (`beside_block`: the block in a grid, the row not).
fn scattered_file(dir: &Path, beside_block: bool) -> PathBuf {
    let name = if beside_block {
        "far_316.txt"
    } else {
        "scattered.txt"
    };
    once(&dir.join(name), |out| {
        for x in (0..316).filter(|_| beside_block) {
            for y in 0..316 {
                writeln!(out, "{x},{y} SREST0").unwrap();
            }
        }
        for (x, y) in scattered_walkers(beside_block) {
            writeln!(out, "{x},{y} SWALK0 C01 1000").unwrap();
        }
    })
}

/// The checksum of an `r` x `r` block of agents from the origin (the sum of
/// `x * 100003 + y`).
fn block_sum(r: u64) -> u64 {
    (0..r)
        .flat_map(|x| (0..r).map(move |y| x * 100003 + y))
        .sum()
}

/// Where [`scattered_file`]'s walkers start.
fn scattered_walkers(beside_block: bool) -> impl Iterator<Item = (u64, u64)> {
    (0..1000).map(move |i| match beside_block {
        true => (2 * i, 1_000_000),
        false => (1000 * i, 37 * i),
    })
}

/// An `r`^3 block of resting agents and 1,000 walkers in a slab beside it (100 along x by
/// 10 along z, at y = r + 1), which walk east out of the block's box.
fn walkers_3d_file(dir: &Path, r: u64) -> PathBuf {
    once(&dir.join(format!("walkers3d_{r}.txt")), |out| {
        for x in 0..r {
            for y in 0..r {
                for z in 0..r {
                    writeln!(out, "{x},{y},{z} SREST0").unwrap();
                }
            }
        }
        for i in 0..1000 {
            let (x, z) = (2 * (i % 100), 2 * (i / 100));
            writeln!(out, "{x},{},{z} SWALK0 C01 1000", r + 1).unwrap();
        }
    })
}

/// The walkers' rules in 3D.
const WALK3D_RULES: &str = "walk\n1\nSWALK0 N**0*** >C01 0000\nP1,0,0 C01 - C01 0001\n\n\
                            rest\n1\nSREST0 >C00 0000\nC00 - C00 0001\n";

/// B2's gravity with a rule per state: `fall_a` turns A to B as it falls, `fall_b` B to A.
const TOGGLE_RULES: &str = "fall_a\n1\nSA**** N***0 >C00 0000\nP0,-1 SB0000 C00 - C00 0001\n\n\
                            fall_b\n1\nSB**** N***0 >C00 0000\nP0,-1 SA0000 C00 - C00 0001\n";

/// Rigid bars of four agents, bonded north-south, each carried east by its bottom agent.
const BARS_RULES: &str = "push\n1\nSB****\nP1,0 A+***\n\nhold\n1\nSC****\nA+**+\n";

/// The inputs of the actions of the general way (moves in several directions and state
/// changes, carried groups, swaps): B2's gravity with a rule per state turning its agents
/// to the other state; the bouncing example's rules on 200,000 dots at random
/// in its 1,000 x 1,000 universe, heading every way; 25,000 bars of four (100 rows of 250);
/// the odd-even sort example's rules on 100 lines of 1,000 agents in reverse order. With
/// their rules and the steps each runs.
fn general_files(dir: &Path) -> Vec<(&'static str, PathBuf, PathBuf, u64)> {
    let dots = once(&dir.join("bounce.txt"), |out| {
        writeln!(out, "U0,999,0,999").unwrap();
        let mut taken = vec![false; 1_000_000];
        let mut s: u64 = 12345;
        let mut left = 200_000;
        while left > 0 {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            let c = (s >> 33) as usize % 1_000_000;
            if !taken[c] {
                taken[c] = true;
                let dir = ["NE", "NW", "SE", "SW"][(s >> 20) as usize % 4];
                writeln!(out, "{},{} S{dir}000", c / 1000, c % 1000).unwrap();
                left -= 1;
            }
        }
    });
    let bars = once(&dir.join("bars.txt"), |out| {
        for row in 0..100 {
            for b in 0..250 {
                let (x, y) = (2 * b, 5 * row);
                writeln!(out, "{x},{y} SB0000 A1000").unwrap();
                writeln!(out, "{x},{} SC0000 A1001", y + 1).unwrap();
                writeln!(out, "{x},{} SC0000 A1001", y + 2).unwrap();
                writeln!(out, "{x},{} SC0000 A0001", y + 3).unwrap();
            }
        }
    });
    let bars_rules = dir.join("bars-rules.txt");
    std::fs::write(&bars_rules, BARS_RULES).unwrap();
    let lines = once(&dir.join("sort.txt"), |out| {
        for y in 0..100 {
            for x in 0..1000 {
                writeln!(
                    out,
                    "{x},{} S0SORT C00 {} C01 {} C03 1000",
                    2 * y,
                    1000 - x,
                    x % 2
                )
                .unwrap();
            }
        }
    });
    // B2's gravity with a rule per state, each turning its agents to the other state as
    // they fall: B2F W = 1000's agents, each in state A or B at random.
    let toggle_rules = dir.join("toggle-rules.txt");
    std::fs::write(&toggle_rules, TOGGLE_RULES).unwrap();
    let toggle = once(&dir.join("toggle.txt"), |out| {
        let mut s: u64 = 777;
        for (x, y) in latticesim_benches::workloads::b2_cells(1000, 1000) {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            let state = ["A", "B"][(s >> 40) as usize % 2];
            writeln!(out, "{x},{y} S{state}0000 C00 {y}").unwrap();
        }
    });
    let ex = root().join("examples");
    vec![
        (
            "gravity, a rule per state turning A to B and back, 299,501 agents, 754 steps",
            toggle_rules,
            toggle,
            754,
        ),
        (
            "bouncing example, 200,000 dots, 200 steps",
            ex.join("bouncing/rules.txt"),
            dots,
            200,
        ),
        (
            "25,000 rigid bars of four carried, 100 steps",
            bars_rules,
            bars,
            100,
        ),
        (
            "odd-even sort by swaps, 100 x 1,000 agents, 100 steps",
            ex.join("odd-even-sort/rules.txt"),
            lines,
            100,
        ),
    ]
}

/// A gravity cloud: 10^6 cells at random in a 1825 x 1825 box (`latticesim gen cloud`,
/// listed as drawn), `C00 = y`.
fn cloud_file(exe: &Path, dir: &Path) -> PathBuf {
    let p = dir.join("cloud.txt");
    if !p.exists() {
        let out = Command::new(exe)
            .args([
                "gen", "cloud", "--n", "1000000", "--width", "1825", "--height", "1825",
            ])
            .args(["--seed", "1"])
            .output()
            .expect("latticesim gen");
        assert!(out.status.success());
        let text = String::from_utf8(out.stdout).unwrap();
        once(&p, |w| {
            for l in text.lines() {
                let y = l.split(',').nth(1).unwrap();
                writeln!(w, "{l} C00 {y}").unwrap();
            }
        });
    }
    p
}

/// The sum of x * 100003 + y over the agents of an agents.txt text (B2's checksum), and
/// the number of agents.
fn positions_checksum(p: &Path) -> (u64, u64) {
    use std::io::BufRead;
    let f = std::io::BufReader::with_capacity(1 << 20, std::fs::File::open(p).unwrap());
    let (mut sum, mut n) = (0u64, 0u64);
    for l in f.split(b'\n') {
        let l = l.unwrap();
        let Some(sp) = l.iter().position(|&c| c == b' ').or(Some(l.len())) else {
            continue;
        };
        let xy = std::str::from_utf8(&l[..sp]).unwrap();
        if xy.contains(',') {
            // (x * 100003 + y) in 2D, as WORKLOADS.md's; ((x * 100003 + y) * 100003 + z)
            // in 3D.
            let c = xy.split(',').map(|c| c.parse::<i64>().unwrap());
            let key = c.fold(0i64, |k, c| k.wrapping_mul(100003).wrapping_add(c));
            sum = sum.wrapping_add(key as u64);
            n += 1;
        }
    }
    (sum, n)
}

/// One run of `latticesim run` to its end: wall time, peak memory, and the stepping time
/// and steps of its statistics.
struct Run {
    wall: Duration,
    peak: u64,
    steps_s: f64,
    steps: u64,
}

fn run_latticesim(
    exe: &Path,
    (rules, agents): (&Path, &Path),
    threads: u32,
    out: &Path,
    extra: &[&str],
) -> Run {
    let stats = out.with_extension("stats.json");
    fresh(out);
    let (wall, peak) = measure(
        Command::new(exe)
            .args(["run", "-q", "--threads", &threads.to_string(), "--out"])
            .arg(out)
            .arg("--stats")
            .arg(&stats)
            .args(extra)
            .arg(rules)
            .arg(agents),
    );
    let v: serde_json::Value = serde_json::from_slice(&std::fs::read(&stats).unwrap()).unwrap();
    Run {
        wall,
        peak,
        steps_s: v["times"]["steps_s"].as_f64().unwrap(),
        steps: v["steps"].as_u64().unwrap(),
    }
}

/// The fastest of `reps` runs each of `latticesim run` on one and on two threads (taken in
/// turn, compared by `key`), writing `outs`.
fn one_and_two(
    (exe, files): (&Path, (&Path, &Path)),
    (outs, args): ((&Path, &Path), &[&str]),
    reps: usize,
    key: fn(&Run) -> f64,
) -> (Run, Run) {
    let mut one = || run_latticesim(exe, files, 1, outs.0, args);
    let mut two = || run_latticesim(exe, files, 2, outs.1, args);
    let mut runs = best_of(reps, &mut [&mut one, &mut two], key);
    let two = runs.pop().unwrap();
    (runs.pop().unwrap(), two)
}

/// The checks of a run of the walkers: the positions' checksum and count of `outs.0` as
/// computed apart (`want`), the same output on two threads, and the steps to the end
/// (1,001 for walkers that stop after 1,000 moves).
fn walkers_ran(outs: (&Path, &Path), want: (u64, u64), (one, steps): (&Run, u64), name: &str) {
    assert_eq!(positions_checksum(outs.0), want, "{name}");
    assert!(
        same_files(outs.0, outs.1),
        "{name}: one and two threads differ"
    );
    assert_eq!(one.steps, steps, "{name}");
}

/// A row of walkers beside `resting` agents at rest, its runs on one and two threads
/// said as they end.
fn named(name: &'static str, resting: u64, (one, two): (Run, Run)) -> Named {
    eprintln!(
        "{name}: stepping {:.3} s one thread, {:.3} s two",
        one.steps_s, two.steps_s
    );
    (name, WalkRow { resting, one, two })
}

/// The fastest of `reps` runs of each of `jobs` (run in turn, `reps` rounds).
fn best_of<T>(reps: usize, jobs: &mut [&mut dyn FnMut() -> T], key: impl Fn(&T) -> f64) -> Vec<T> {
    let mut best: Vec<Option<T>> = jobs.iter().map(|_| None).collect();
    for _ in 0..reps {
        for (b, job) in best.iter_mut().zip(jobs.iter_mut()) {
            let r = job();
            if b.as_ref().is_none_or(|x| key(&r) < key(x)) {
                *b = Some(r);
            }
        }
    }
    best.into_iter()
        .map(|b| b.expect("at least one run"))
        .collect()
}

struct B2fRow {
    w: u64,
    n: u64,
    steps: u64,
    native: (Duration, u64),
    one: Run,
    two: Run,
}

struct WalkRow {
    resting: u64,
    one: Run,
    two: Run,
}

/// A row of walkers with its name in the tables.
type Named = (&'static str, WalkRow);

fn main() {
    if std::env::args()
        .skip(1)
        .any(|a| !a.starts_with("--") && a != "moving")
    {
        return;
    }
    let quick = std::env::var_os("MOVING_QUICK").is_some();
    let exe = latticesim();
    let native = PathBuf::from(env!("CARGO_BIN_EXE_b2f_native"));
    let dir = root().join("target/moving");
    std::fs::create_dir_all(&dir).unwrap();
    let rules = |name: &str, text: &str| {
        let p = dir.join(name);
        std::fs::write(&p, text).unwrap();
        p
    };
    let (b1r, b2r, walkr) = (
        rules("b1.txt", B1_RULES),
        rules("b2.txt", B2_RULES),
        rules("walk.txt", WALK_RULES),
    );
    let reps = 3;

    // B2F beside the plain program, with how far apart the two cores were before and
    // after (what the second thread gains depends on it).
    let sizes: &[u64] = if quick { &[316] } else { &[316, 1000] };
    let mut b2f = Vec::new();
    let mut trips = vec![core_round_trip()];
    for &w in sizes {
        let input = b2f_file(&dir, w);
        let (o0, o1, o2) = (
            dir.join("b2f-native.txt"),
            dir.join("b2f-1.txt"),
            dir.join("b2f-2.txt"),
        );
        let files = (b2r.as_path(), input.as_path());
        let mut nat = || {
            fresh(&o0);
            let (wall, peak) = measure(Command::new(&native).arg(&input).arg(&o0));
            Run {
                wall,
                peak,
                steps_s: 0.0,
                steps: 0,
            }
        };
        let mut one = || run_latticesim(&exe, files, 1, &o1, &[]);
        let mut two = || run_latticesim(&exe, files, 2, &o2, &[]);
        // The plain program and latticesim on one and two threads in turn, in each of five
        // rounds, the fastest of each kept: the machine's speed drifts over a minute by
        // more than the margins measured here.
        let mut runs = best_of(5, &mut [&mut nat, &mut one, &mut two], |r| {
            r.wall.as_secs_f64()
        });
        let (two, one) = (runs.pop().unwrap(), runs.pop().unwrap());
        let nat = runs.pop().map(|r| (r.wall, r.peak)).unwrap();
        assert!(
            same_files(&o0, &o1) && same_files(&o0, &o2),
            "B2F W = {w}: the outputs differ"
        );
        let (sum, n) = positions_checksum(&o1);
        let expected = match w {
            316 => Some((238, 473921339434)),
            1000 => Some((754, 14959134065689)),
            _ => None,
        };
        if let Some(e) = expected {
            assert_eq!(
                (one.steps, sum),
                e,
                "WORKLOADS.md's steps and checksum of B2 W = {w}"
            );
        }
        eprintln!(
            "B2F W = {w}: native {:.3} s, latticesim {:.3} s ({:.2}x) one thread, {:.3} s ({:.2}x) two",
            nat.0.as_secs_f64(),
            one.wall.as_secs_f64(),
            one.wall.as_secs_f64() / nat.0.as_secs_f64(),
            two.wall.as_secs_f64(),
            two.wall.as_secs_f64() / nat.0.as_secs_f64()
        );
        b2f.push(B2fRow {
            w,
            n,
            steps: one.steps,
            native: nat,
            one,
            two,
        });
    }
    trips.push(core_round_trip());
    eprintln!("the cores' round trip: {trips:?} before and after B2F");

    // Walkers beside resting agents (and beside 100, whose box of 24 cells per agent was
    // once over the grid's budget: all in the hash map, 20x the walkers alone).
    let rs: &[u64] = if quick {
        &[0, 10, 316]
    } else {
        &[0, 10, 316, 3162]
    };
    // The walkers' rules on `input` on one and two threads, the outputs' positions
    // checked against `want` (their checksum and count, computed apart), `resting` agents
    // beside them. (Nine runs each, where a run takes a few hundredths of a second: the
    // fastest of three of the walkers alone, 6 ms of stepping, was once 9 ms.)
    let run_walkers = |input: &Path, want: (u64, u64), name: &str, resting: u64| {
        let (o1, o2) = (dir.join("walk-1.txt"), dir.join("walk-2.txt"));
        let (one, two) = one_and_two(
            (&exe, (walkr.as_path(), input)),
            ((o1.as_path(), o2.as_path()), &[]),
            if resting > 1_000_000 { reps } else { 3 * reps },
            |r| r.steps_s,
        );
        walkers_ran((&o1, &o2), want, (&one, 1001), name);
        (one, two)
    };
    let walkers = |r: u64, walls: bool| {
        let input = walkers_file(&dir, r, walls);
        // Every walker 1,000 cells east, every resting agent in place.
        let walkers: u64 = (0..1000).map(|i| (2 * i + 1000) * 100003 + r + 1).sum();
        let (one, two) = run_walkers(
            &input,
            (block_sum(r) + walkers, r * r + 1000),
            &format!("walkers R = {r}, walls {walls}"),
            r * r,
        );
        eprintln!(
            "walkers beside {} {}: stepping {:.3} s one thread, {:.3} s two; whole {:.3} s, {:.1} MB",
            r * r,
            if walls { "obstacles" } else { "resting" },
            one.steps_s,
            two.steps_s,
            one.wall.as_secs_f64(),
            one.peak as f64 / 1e6
        );
        WalkRow {
            resting: r * r,
            one,
            two,
        }
    };
    let walk: Vec<WalkRow> = rs.iter().map(|&r| walkers(r, false)).collect();
    // Beside as many obstacles, agents in a state no rule tests (their lists were read
    // where those of agents whose rule never applies were not: 1.4x their time).
    let walls = walkers(*rs.last().expect("sizes"), true);
    // Walkers with no grid around them (once a hash map of cells, 18x and 20x the
    // walkers alone; now tiles of cells).
    let scattered: Vec<Named> = [false, true]
        .into_iter()
        .map(|beside_block| {
            let input = scattered_file(&dir, beside_block);
            let r: u64 = if beside_block { 316 } else { 0 };
            let walkers: u64 = scattered_walkers(beside_block)
                .map(|(x, y)| (x + 1000) * 100003 + y)
                .sum();
            let name = match beside_block {
                true => "1,000 walkers 10^6 cells from a block of 316^2 at rest",
                false => "1,000 walkers scattered over 10^6 x 37,000 cells",
            };
            let want = (block_sum(r) + walkers, r * r + 1000);
            named(name, r * r, run_walkers(&input, want, name, r * r))
        })
        .collect();

    // Walkers that turn, alone and beside 10^5 agents at rest, for 1,000 steps: a period
    // of 42 steps (20 east, a turn, 20 west, a turn), so each ends 7 cells east of where
    // it started (966 steps back where it was, then 20 east, a turn and 13 west).
    let turnr = rules("turn.txt", TURN_RULES);
    let turning: Vec<Named> = [0, 316]
        .into_iter()
        .map(|r: u64| {
            let input = turning_file(&dir, r);
            let (o1, o2) = (dir.join("turn-1.txt"), dir.join("turn-2.txt"));
            let (one, two) = one_and_two(
                (&exe, (turnr.as_path(), input.as_path())),
                ((o1.as_path(), o2.as_path()), &["--max-steps", "1000"]),
                3 * reps,
                |r| r.steps_s,
            );
            let walkers: u64 = (0..1000).map(|i| (2 * i + 7) * 100003 + r + 1).sum();
            let name = match r {
                0 => "1,000 walkers that turn, alone",
                _ => "1,000 walkers that turn, beside 316^2 at rest",
            };
            let want = (block_sum(r) + walkers, r * r + 1000);
            walkers_ran((&o1, &o2), want, (&one, 1000), name);
            named(name, r * r, (one, two))
        })
        .collect();

    // Walkers that leave the box of a 3D block: the grid is not made again over the
    // block's whole cross-section every few dozen steps (it was: 0.25 s against 0.065 s
    // beside 10^6 agents, 1.6-1.8 s against 0.054 s beside 10^7).
    let walk3d = {
        let r: u64 = if quick { 46 } else { 100 };
        let (input, walk3r) = (walkers_3d_file(&dir, r), rules("walk3d.txt", WALK3D_RULES));
        let (o1, o2) = (dir.join("walk3d-1.txt"), dir.join("walk3d-2.txt"));
        let files = (walk3r.as_path(), input.as_path());
        let (one, two) = one_and_two(
            (&exe, files),
            ((o1.as_path(), o2.as_path()), &[]),
            reps,
            |r| r.steps_s,
        );
        // Every walker 1,000 cells east, every resting agent in place: computed apart.
        let key = |x: u64, y: u64, z: u64| (x * 100003 + y) * 100003 + z;
        let rest: u64 = (0..r * r * r)
            .map(|i| key(i / (r * r), i / r % r, i % r))
            .fold(0, u64::wrapping_add);
        let walkers: u64 = (0..1000)
            .map(|i| key(2 * (i % 100) + 1000, r + 1, 2 * (i / 100)))
            .fold(0, u64::wrapping_add);
        let want = (rest.wrapping_add(walkers), r * r * r + 1000);
        walkers_ran(
            (&o1, &o2),
            want,
            (&one, 1001),
            &format!("3D walkers, r = {r}"),
        );
        eprintln!(
            "3D walkers beside {} resting: stepping {:.3} s one thread, {:.3} s two; {:.1} MB",
            r * r * r,
            one.steps_s,
            two.steps_s,
            one.peak as f64 / 1e6
        );
        (
            format!("3D walkers leaving the box of {r}^3 agents at rest"),
            one,
            two,
        )
    };

    // Threads on B1F and the cloud (B2F and the walkers above).
    let mut threads: Vec<(String, f64, f64)> = Vec::new();
    for row in &b2f {
        threads.push((
            format!("B2F W = {}", row.w),
            row.one.steps_s,
            row.two.steps_s,
        ));
    }
    for row in &walk {
        threads.push((
            format!("walkers beside {}", row.resting),
            row.one.steps_s,
            row.two.steps_s,
        ));
    }
    threads.push((
        format!(
            "walkers beside {} obstacles (a state no rule tests)",
            walls.resting
        ),
        walls.one.steps_s,
        walls.two.steps_s,
    ));
    threads.push((walk3d.0, walk3d.1.steps_s, walk3d.2.steps_s));
    for (name, row) in &scattered {
        threads.push((name.to_string(), row.one.steps_s, row.two.steps_s));
    }
    {
        let l = if quick { 316 } else { 1000 };
        let input = b1f_file(&dir, l, 1);
        let (o1, o2) = (dir.join("b1f-1.txt"), dir.join("b1f-2.txt"));
        let files = (b1r.as_path(), input.as_path());
        let (one, two) = one_and_two(
            (&exe, files),
            ((o1.as_path(), o2.as_path()), &["--max-steps", "50"]),
            reps,
            |r| r.steps_s,
        );
        assert!(same_files(&o1, &o2), "B1F: one and two threads differ");
        threads.push((format!("B1F L = {l}, 50 steps"), one.steps_s, two.steps_s));
    }
    // The actions of the general way, on one and two threads.
    for (name, rules, input, steps) in general_files(&dir) {
        let (o1, o2) = (dir.join("general-1.txt"), dir.join("general-2.txt"));
        let max = ["--max-steps".to_string(), steps.to_string()];
        let max: Vec<&str> = max.iter().map(String::as_str).collect();
        let files = (rules.as_path(), input.as_path());
        let (one, two) = one_and_two(
            (&exe, files),
            ((o1.as_path(), o2.as_path()), &max),
            reps,
            |r| r.steps_s,
        );
        assert!(same_files(&o1, &o2), "{name}: one and two threads differ");
        if rules.ends_with("toggle-rules.txt") {
            // The same moves as B2's: WORKLOADS.md's checksum of the positions.
            assert_eq!(
                positions_checksum(&o1),
                (14959134065689, 299501),
                "{name}: the positions"
            );
        }
        eprintln!(
            "{name}: {:.3} s one thread, {:.3} s two",
            one.steps_s, two.steps_s
        );
        threads.push((name.into(), one.steps_s, two.steps_s));
    }
    if !quick {
        let input = cloud_file(&exe, &dir);
        let (o1, o2) = (dir.join("cloud-1.txt"), dir.join("cloud-2.txt"));
        // The fastest of three each, taken in turn, as the other figures.
        let files = (b2r.as_path(), input.as_path());
        let (one, two) = one_and_two(
            (&exe, files),
            ((o1.as_path(), o2.as_path()), &[]),
            reps,
            |r| r.steps_s,
        );
        assert!(
            same_files(&o1, &o2),
            "the cloud: one and two threads differ"
        );
        eprintln!(
            "gravity cloud: {} steps, {:.3} s one thread, {:.3} s two",
            one.steps, one.steps_s, two.steps_s
        );
        threads.push((
            "gravity cloud of 10^6, listed at random".into(),
            one.steps_s,
            two.steps_s,
        ));
    }
    report(
        (&b2f, &trips),
        (&walk, &walls, &scattered, &turning),
        &threads,
    );
}

/// The CSV in docs/data, the plots in docs/img, and the tables of docs/performance.md.
fn report(
    (b2f, trips): (&[B2fRow], &[Duration]),
    (walk, walls, scattered, turning): (&[WalkRow], &WalkRow, &[Named], &[Named]),
    threads: &[(String, f64, f64)],
) {
    let (data, img) = (root().join("docs/data"), root().join("docs/img"));
    std::fs::create_dir_all(&data).unwrap();
    std::fs::create_dir_all(&img).unwrap();
    let mut csv = String::from("workload,size,agents,steps,native_s,latticesim_1_s,latticesim_2_s,steps_1_s,steps_2_s,peak_1_bytes\n");
    for r in b2f {
        csv += &format!(
            "b2f,{},{},{},{:.4},{:.4},{:.4},{:.4},{:.4},{}\n",
            r.w,
            r.n,
            r.steps,
            r.native.0.as_secs_f64(),
            r.one.wall.as_secs_f64(),
            r.two.wall.as_secs_f64(),
            r.one.steps_s,
            r.two.steps_s,
            r.one.peak
        );
    }
    // (`walls`: the walkers beside obstacles, agents in a state no rule tests;
    // `scattered` and `far`: the walkers with no grid around them; `turning`: the walkers
    // that turn.)
    for (name, r) in walk
        .iter()
        .map(|r| ("walkers", r))
        .chain([("walls", walls)])
        .chain(
            ["scattered", "far"]
                .into_iter()
                .zip(scattered.iter().map(|s| &s.1)),
        )
        .chain(turning.iter().map(|t| ("turning", &t.1)))
    {
        csv += &format!(
            "{name},{},{},{},,{:.4},{:.4},{:.4},{:.4},{}\n",
            r.resting,
            r.resting + 1000,
            r.one.steps,
            r.one.wall.as_secs_f64(),
            r.two.wall.as_secs_f64(),
            r.one.steps_s,
            r.two.steps_s,
            r.one.peak
        );
    }
    std::fs::write(data.join("performance-moving.csv"), csv).unwrap();
    let b2f_series: Vec<Series> = vec![
        (
            "latticesim run, one thread (whole process)",
            b2f.iter()
                .map(|r| (r.n as f64, r.one.wall.as_secs_f64()))
                .collect(),
            RED,
        ),
        (
            "latticesim run, two threads",
            b2f.iter()
                .map(|r| (r.n as f64, r.two.wall.as_secs_f64()))
                .collect(),
            MAGENTA,
        ),
        (
            "plain hand-written program",
            b2f.iter()
                .map(|r| (r.n as f64, r.native.0.as_secs_f64()))
                .collect(),
            BLUE,
        ),
    ];
    plot_lines(
        &img.join("performance-moving-b2f.svg"),
        "B2F gravity from file to file: wall time of the whole process",
        ("agents", "seconds"),
        (power_of_ten, plain),
        &b2f_series,
    )
    .expect("plot");
    let walk_series: Vec<Series> = vec![
        (
            "one thread",
            walk.iter()
                .map(|r| ((r.resting + 1000) as f64, r.one.steps_s))
                .collect(),
            RED,
        ),
        (
            "two threads",
            walk.iter()
                .map(|r| ((r.resting + 1000) as f64, r.two.steps_s))
                .collect(),
            MAGENTA,
        ),
    ];
    plot_lines(
        &img.join("performance-moving-walkers.svg"),
        "1,000 walkers for 1,000 steps beside resting agents: stepping time",
        ("agents in all (1,000 walking)", "seconds"),
        (power_of_ten, plain),
        &walk_series,
    )
    .expect("plot");
    println!("| B2F W | agents | steps | plain program | latticesim, 1 thread | / plain | latticesim, 2 threads | / plain |");
    println!("|---:|---:|---:|---:|---:|---:|---:|---:|");
    for r in b2f {
        let nat = r.native.0.as_secs_f64();
        println!(
            "| {} | {} | {} | {:.3} s | {:.3} s | {:.2} | {:.3} s | {:.2} |",
            r.w,
            r.n,
            r.steps,
            nat,
            r.one.wall.as_secs_f64(),
            r.one.wall.as_secs_f64() / nat,
            r.two.wall.as_secs_f64(),
            r.two.wall.as_secs_f64() / nat
        );
    }
    let ns: Vec<String> = (trips.iter())
        .map(|t| format!("{:.0} ns", t.as_secs_f64() * 1e9))
        .collect();
    println!(
        "\nThe cores' round trip (a counter passed between two threads and back): {} before B2F, {} after.",
        ns[0],
        ns[ns.len() - 1]
    );
    println!("\n| resting agents | stepping, 1 thread | / walkers alone | stepping, 2 threads | whole process, 1 thread | peak |");
    println!("|---:|---:|---:|---:|---:|---:|");
    let alone = walk.first().map_or(1.0, |r| r.one.steps_s);
    for r in walk {
        println!(
            "| {} | {:.3} s | {:.2} | {:.3} s | {:.3} s | {:.1} MB |",
            r.resting,
            r.one.steps_s,
            r.one.steps_s / alone,
            r.two.steps_s,
            r.one.wall.as_secs_f64(),
            r.one.peak as f64 / 1e6
        );
    }
    let turning_alone = turning.first().map_or(1.0, |r| r.1.one.steps_s);
    let tables = [
        (
            "walkers with no grid around them",
            "walkers alone",
            scattered,
            alone,
        ),
        (
            "walkers that turn every 20 steps (two rules per state)",
            "turning alone",
            turning,
            turning_alone,
        ),
    ];
    for (title, against, rows, base) in tables {
        println!("\n| {title} | stepping, 1 thread | / {against} | stepping, 2 threads | peak |");
        println!("|---|---:|---:|---:|---:|");
        for (name, r) in rows {
            println!(
                "| {name} | {:.3} s | {:.2} | {:.3} s | {:.1} MB |",
                r.one.steps_s,
                r.one.steps_s / base,
                r.two.steps_s,
                r.one.peak as f64 / 1e6
            );
        }
    }
    println!("\n| workload | stepping, 1 thread | 2 threads | 1 / 2 |");
    println!("|---|---:|---:|---:|");
    for (name, one, two) in threads {
        println!("| {name} | {one:.3} s | {two:.3} s | {:.2} |", one / two);
    }
}
