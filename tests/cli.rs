//! The command-line program on real files: exit codes, output formats, flags.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn bin() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_latticesim"));
    c.current_dir(env!("CARGO_MANIFEST_DIR"));
    c.env_remove("NO_COLOR");
    c
}

fn tmp(name: &str, text: &[u8]) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("latticesim-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

fn run(args: &[&str]) -> Output {
    bin().args(args).output().unwrap()
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

#[test]
fn examples_check_clean() {
    for ex in ["maxflood", "gravity", "tour"] {
        let rules = format!("examples/{ex}/rules.txt");
        let agents = format!("examples/{ex}/agents.txt");
        let o = run(&["check", &rules, "--agents", &agents]);
        assert_eq!(o.status.code(), Some(0), "{ex}: {}", stderr(&o));
        let e = stderr(&o);
        assert!(e.contains("0 errors, 0 warnings"), "{ex}: {e}");
        assert!(
            !e.contains('\u{1b}'),
            "no colour when stderr is not a terminal"
        );
    }
}

#[test]
fn errors_exit_1_with_file_line_column() {
    let rules = tmp("bad-rules.txt", b"r\n1\nN1*0*1*\nS*****\n");
    let agents = tmp("bad-agents.txt", b"U0,4,0,4\n1,1\n1,1\n");
    let o = run(&[
        "check",
        rules.to_str().unwrap(),
        "--agents",
        agents.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(1));
    let e = stderr(&o);
    assert!(e.contains("error[E302]"), "{e}");
    assert!(e.contains("bad-rules.txt:3:2"), "{e}");
    assert!(e.contains("error[E402]"), "{e}");
    assert!(e.contains("bad-agents.txt:3:1"), "{e}");
    assert!(e.contains("2 errors, 0 warnings"), "{e}");
}

#[test]
fn warnings_alone_exit_0() {
    let rules = tmp("warn-rules.txt", b"r\n1\nN1*** N0***\nS*****\n");
    let o = run(&["check", rules.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(stderr(&o).contains("warning[W502]"));
}

#[test]
fn json_output() {
    let rules = tmp("json-rules.txt", b"r\n1\nN1*0* E1,0,0\nS*****\n");
    let o = run(&[
        "check",
        rules.to_str().unwrap(),
        "--format",
        "json",
        "--dim",
        "2",
    ]);
    assert_eq!(o.status.code(), Some(1));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).expect("stdout is JSON");
    assert_eq!(v["dimension"], "2D");
    assert_eq!(v["errors"], 1);
    let d = &v["diagnostics"][0];
    assert_eq!(d["code"], "E316");
    assert_eq!(d["severity"], "error");
    assert_eq!(d["line"], 3);
    assert_eq!(d["column"], 8);
    assert_eq!(d["end_line"], 3);
    assert_eq!(d["end_column"], 13);
    assert!(d["file"].as_str().unwrap().ends_with("json-rules.txt"));
    assert_eq!(d["labels"][0]["primary"], true);
    assert!(d["help"].as_str().unwrap().contains("E1,0"));
    assert!(d["message"].as_str().unwrap().contains("3 coordinates"));
}

#[test]
fn colour_on_request() {
    let rules = tmp("colour-rules.txt", b"r\n1\nSAB\nS*****\n");
    let o = run(&["check", rules.to_str().unwrap(), "--color", "always"]);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains('\u{1b}'), "ANSI escapes expected");
}

#[test]
fn usage_and_io_failures_exit_2() {
    let o = run(&["check", "does/not/exist.txt"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr(&o).contains("cannot read `does/not/exist.txt`"),
        "{}",
        stderr(&o)
    );
    let o = run(&["check"]);
    assert_eq!(o.status.code(), Some(2));
    let o = run(&["check", "examples/tour/rules.txt", "--dim", "4"]);
    assert_eq!(o.status.code(), Some(2));
    let o = run(&["frobnicate"]);
    assert_eq!(o.status.code(), Some(2));
    let dir = Path::new("examples");
    let o = run(&["check", dir.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2), "a folder is not a rules file");
}

#[test]
fn dim_flag_against_agents_file() {
    let rules = tmp("dim-rules.txt", b"r\n1\nS*****\nS*****\n");
    let agents = tmp("dim-agents.txt", b"0,0,0\n");
    let o = run(&[
        "check",
        rules.to_str().unwrap(),
        "--agents",
        agents.to_str().unwrap(),
        "--dim",
        "2",
    ]);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("error[E301]"), "{}", stderr(&o));
}
