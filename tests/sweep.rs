//! A sweep keeps what it finished: Ctrl-C writes the table of the runs finished (exit 130),
//! a kill leaves them in the journal, and `--resume` runs only the others and ends with the
//! table of the whole sweep.

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::time::{Duration, Instant};

const BIN: &str = env!("CARGO_BIN_EXE_latticesim");

fn dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("latticesim-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// `sweep` of leader election on lines of 3, 4, 5 and 9 agents (made by `--agents-cmd`) into
/// `out`, one run at a time; with `slow`, the command of the run of 9 agents sleeps first,
/// so that a signal finds three runs finished and one running.
fn sweep(out: &Path, slow: bool, extra: &[&str]) -> Command {
    let mut c = Command::new(BIN);
    c.current_dir(env!("CARGO_MANIFEST_DIR"));
    let make = format!(
        "if [ -n \"$SWEEP_SLOW\" ] && [ {{size}} -ge 9 ]; then sleep 60; fi; {BIN} gen line --n {{size}} --state INIT0 --ids C00 --seed {{seed}}"
    );
    c.args([
        "sweep",
        "examples/leader-election/rules.txt",
        "--sizes",
        "3,4,5,9",
        "--seeds",
        "1",
        "--threads",
        "1",
        "--agents-cmd",
        &make,
        "--out",
    ]);
    c.arg(out).args(extra);
    if slow {
        c.env("SWEEP_SLOW", "1");
    } else {
        c.env_remove("SWEEP_SLOW");
    }
    c
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// The lines of a CSV table without its last column (the wall time).
fn without_wall_time(path: &Path) -> Vec<String> {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .map(|l| l.rsplit_once(',').unwrap().0.to_string())
        .collect()
}

/// Starts the slow sweep and waits until its journal holds the three quick runs.
fn started_until_three_finished(out: &Path) -> Child {
    let child = sweep(out, true, &[])
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let journal = journal_of(out);
    let t = Instant::now();
    loop {
        let lines = std::fs::read_to_string(&journal).map_or(0, |t| t.lines().count());
        if lines == 4 {
            break;
        }
        assert!(
            t.elapsed() < Duration::from_secs(60),
            "the journal never held 3 runs"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
    child
}

fn journal_of(out: &Path) -> PathBuf {
    let mut name = out.file_name().unwrap().to_os_string();
    name.push(".partial.csv");
    out.with_file_name(name)
}

fn signal(child: &Child, sig: &str) {
    let ok = Command::new("kill")
        .args([sig, &child.id().to_string()])
        .status()
        .unwrap();
    assert!(ok.success());
}

#[test]
fn ctrl_c_keeps_the_finished_runs_and_resume_ends_as_the_whole_sweep() {
    let d = dir("sweep-int");
    let whole = d.join("whole.csv");
    let o = sweep(&whole, false, &[]).output().unwrap();
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert_eq!(without_wall_time(&whole).len(), 5, "a header and 4 runs");
    assert!(
        !journal_of(&whole).exists(),
        "no journal after a whole sweep"
    );

    let out = d.join("t.csv");
    let child = started_until_three_finished(&out);
    let t = Instant::now();
    signal(&child, "-INT");
    let o = child.wait_with_output().unwrap();
    assert!(
        t.elapsed() < Duration::from_secs(10),
        "Ctrl-C ends the sweep at once (the command running is killed)"
    );
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(130), "{err}");
    assert!(
        err.contains("interrupted: 3 of 4 runs finished")
            && err.contains("the same command with --resume runs the other 1"),
        "{err}"
    );
    assert_eq!(
        without_wall_time(&out),
        without_wall_time(&whole)[..4],
        "a valid table of the three runs finished"
    );
    assert!(!journal_of(&out).exists(), "the table holds them all");

    let o = sweep(&out, false, &["--resume"]).output().unwrap();
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(0), "{err}");
    assert!(
        err.contains("resuming: 3 of 4 runs are done; running the other 1"),
        "{err}"
    );
    assert_eq!(without_wall_time(&out), without_wall_time(&whole));
    assert!(!journal_of(&out).exists());

    // Resumed again, nothing is left to run and the table stays as it is.
    let o = sweep(&out, false, &["--resume"]).output().unwrap();
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(stderr(&o).contains("4 of 4 runs are done; running the other 0"));
    assert_eq!(without_wall_time(&out), without_wall_time(&whole));
    std::fs::remove_dir_all(&d).unwrap();
}

#[test]
fn a_killed_sweep_leaves_its_journal_and_resume_goes_on_from_it() {
    let d = dir("sweep-kill");
    let whole = d.join("whole.csv");
    let o = sweep(&whole, false, &[]).output().unwrap();
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));

    for ext in ["csv", "parquet"] {
        let out = d.join(format!("t.{ext}"));
        let child = started_until_three_finished(&out);
        signal(&child, "-KILL");
        let o = child.wait_with_output().unwrap();
        assert_eq!(o.status.code(), None, "killed");
        assert!(!out.exists(), "the table is written at the end");
        assert!(journal_of(&out).exists(), "the journal keeps the runs");

        // Resumed as another sweep: refused, and the journal stays.
        let o = Command::new(BIN)
            .current_dir(env!("CARGO_MANIFEST_DIR"))
            .args([
                "sweep",
                "examples/leader-election/rules.txt",
                "--sizes",
                "3,4",
                "--seeds",
                "1",
                "--shape",
                "line",
                "--resume",
                "--out",
            ])
            .arg(&out)
            .output()
            .unwrap();
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{err}");
        assert!(err.contains("cannot resume from it"), "{err}");
        assert!(journal_of(&out).exists());

        let o = sweep(&out, false, &["--resume"]).output().unwrap();
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(0), "{err}");
        assert!(err.contains("resuming: 3 of 4 runs are done"), "{err}");
        assert!(!journal_of(&out).exists());
        let back = d.join("back.csv");
        let o = Command::new(BIN)
            .args(["merge"])
            .arg(&out)
            .arg("--out")
            .arg(&back)
            .output()
            .unwrap();
        assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
        assert_eq!(without_wall_time(&back), without_wall_time(&whole), "{ext}");
    }

    // A journal left behind and a sweep started afresh (no --resume): a note says it is
    // dropped, and the sweep runs all.
    let out = d.join("fresh.csv");
    let child = started_until_three_finished(&out);
    signal(&child, "-KILL");
    child.wait_with_output().unwrap();
    let o = sweep(&out, false, &[]).output().unwrap();
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(0), "{err}");
    assert!(
        err.contains("they are dropped (--resume keeps them)"),
        "{err}"
    );
    assert_eq!(without_wall_time(&out), without_wall_time(&whole));
    std::fs::remove_dir_all(&d).unwrap();
}

/// docs/scale-out.md's example with GNU parallel, run as a user runs it: the block as a
/// script in a folder of its own (with the repository's `examples/`), `latticesim` on the
/// PATH. Eight parallel shards of 30 runs, merged into one Parquet table of every run.
/// Without GNU parallel on the machine the test says so and passes, but not in CI
/// (`.ci/run` installs it).
#[test]
fn the_gnu_parallel_example_of_the_docs_runs_as_a_script() {
    let has_parallel = Command::new("parallel")
        .arg("--version")
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|s| s.success());
    if !has_parallel {
        assert!(
            std::env::var_os("CI").is_none(),
            "GNU parallel is needed in CI (.ci/run installs it)"
        );
        eprintln!("skipped: GNU parallel is not installed");
        return;
    }
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let doc = std::fs::read_to_string(root.join("docs/scale-out.md")).unwrap();
    let block = doc
        .split("```sh\n")
        .skip(1)
        .filter_map(|b| b.split("```").next())
        .find(|b| b.contains("parallel latticesim sweep"))
        .expect("docs/scale-out.md has the GNU parallel example");
    let d = dir("parallel-example");
    std::os::unix::fs::symlink(root.join("examples"), d.join("examples")).unwrap();
    std::fs::write(d.join("example.sh"), block).unwrap();
    let bin_dir = Path::new(BIN).parent().unwrap();
    let path = format!(
        "{}:{}",
        bin_dir.display(),
        std::env::var("PATH").unwrap_or_default()
    );
    let mut child = Command::new("bash")
        .args(["-e", "example.sh"])
        .current_dir(&d)
        .env("PATH", path)
        .stdin(Stdio::null())
        .stdout(std::fs::File::create(d.join("out.txt")).unwrap())
        .stderr(std::fs::File::create(d.join("err.txt")).unwrap())
        .spawn()
        .unwrap();
    let start = Instant::now();
    let status = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break s;
        }
        if start.elapsed() > Duration::from_secs(600) {
            let _ = child.kill();
            panic!("the example ran for 10 minutes");
        }
        std::thread::sleep(Duration::from_millis(100));
    };
    let err = std::fs::read_to_string(d.join("err.txt")).unwrap();
    assert!(status.success(), "{block}\n{err}");
    // Every run of the sweep is in the merged table, each once.
    let csv = d.join("all.csv");
    let o = Command::new(BIN)
        .args(["merge", "leader-election.parquet", "--out"])
        .arg(&csv)
        .current_dir(&d)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("30 runs from 1 part;"),
        "{}",
        stderr(&o)
    );
    let rows = without_wall_time(&csv);
    assert_eq!(rows.len(), 1 + 3 * 10, "{rows:?}");
    let _ = std::fs::remove_dir_all(&d);
}
