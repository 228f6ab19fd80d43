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
    // Every rules file of every example, with every agents file of the same dimension in its
    // folder: no error and no warning.
    let mut checked = 0;
    let mut dirs: Vec<PathBuf> =
        std::fs::read_dir(Path::new(env!("CARGO_MANIFEST_DIR")).join("examples"))
            .unwrap()
            .map(|e| e.unwrap().path())
            .filter(|p| p.is_dir() && !p.ends_with("mistakes"))
            .collect();
    dirs.sort();
    for dir in dirs {
        let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
            .unwrap()
            .map(|e| e.unwrap().path())
            .collect();
        files.sort();
        let name = |p: &PathBuf| p.file_name().unwrap().to_string_lossy().to_string();
        let is_3d = |p: &PathBuf| name(p).contains("3d");
        for rules in files.iter().filter(|p| name(p).starts_with("rules")) {
            let agents: Vec<&PathBuf> = files
                .iter()
                .filter(|p| name(p).starts_with("agents") && is_3d(p) == is_3d(rules))
                .collect();
            assert!(
                !agents.is_empty(),
                "{}: no agents file for {}",
                dir.display(),
                name(rules)
            );
            for a in agents {
                let o = run(&[
                    "check",
                    rules.to_str().unwrap(),
                    "--agents",
                    a.to_str().unwrap(),
                ]);
                assert_eq!(
                    o.status.code(),
                    Some(0),
                    "{}: {}",
                    rules.display(),
                    stderr(&o)
                );
                let e = stderr(&o);
                assert!(
                    e.contains("0 errors, 0 warnings"),
                    "{} with {}: {e}",
                    rules.display(),
                    a.display()
                );
                assert!(
                    !e.contains('\u{1b}'),
                    "no colour when stderr is not a terminal"
                );
                checked += 1;
            }
        }
    }
    assert!(checked >= 20, "only {checked} example pairs");
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

fn run_files(rules: &str, agents: &str, tag: &str, extra: &[&str]) -> (Output, PathBuf) {
    let r = tmp(&format!("{tag}-rules.txt"), rules.as_bytes());
    let a = tmp(&format!("{tag}-agents.txt"), agents.as_bytes());
    let dir = r.parent().unwrap().join(tag);
    std::fs::create_dir_all(&dir).unwrap();
    let mut args: Vec<String> = vec![
        "run".into(),
        r.display().to_string(),
        a.display().to_string(),
    ];
    args.extend(
        ["--out", "--stats", "--trace"]
            .iter()
            .zip(["out.txt", "stats.json", "trace.jsonl"])
            .flat_map(|(flag, name)| [flag.to_string(), dir.join(name).display().to_string()]),
    );
    args.extend(extra.iter().map(|s| s.to_string()));
    let o = bin().args(&args).output().unwrap();
    (o, dir)
}

const MOVERS: &str = "east\n2\nSE**** E1,0\nP1,0 A**+* C00 + C00 0001 #*01 + C00 0000\nstop\n1\nSE**** F1,0\nSSTOP0 MNhello\n";
const MOVERS_AGENTS: &str = "U0,9,0,3\n0,0 SE0000 A0010\n1,0 A0100\n0,2 SE0000\n5,2\n";

#[test]
fn run_is_deterministic_and_writes_everything() {
    let (o1, d1) = run_files(MOVERS, MOVERS_AGENTS, "det1", &["--no-timing"]);
    let (o2, d2) = run_files(MOVERS, MOVERS_AGENTS, "det2", &["--no-timing"]);
    assert_eq!(o1.status.code(), Some(0), "{}", stderr(&o1));
    assert_eq!(o2.status.code(), Some(0));
    for f in ["out.txt", "stats.json", "trace.jsonl"] {
        let a = std::fs::read(d1.join(f)).unwrap();
        let b = std::fs::read(d2.join(f)).unwrap();
        assert!(!a.is_empty(), "{f} is empty");
        assert_eq!(a, b, "{f} differs between two runs");
    }
    let stats: serde_json::Value =
        serde_json::from_slice(&std::fs::read(d1.join("stats.json")).unwrap()).unwrap();
    assert_eq!(stats["stopped_by"], "quiescence");
    assert!(stats.get("wall_time_s").is_none());
    assert_eq!(stats["firings"][0]["rule"], "east");
    for line in std::fs::read_to_string(d1.join("trace.jsonl"))
        .unwrap()
        .lines()
    {
        let v: serde_json::Value = serde_json::from_str(line).expect("each trace line is JSON");
        assert!(v["step"].as_u64().unwrap() >= 1);
        assert!(v["event"].is_string());
    }
    assert!(stderr(&o1).contains("quiescent"), "{}", stderr(&o1));
}

#[test]
fn zero_steps_write_back_the_agents_and_reload_unchanged() {
    let agents = "// comment\nU-5,5,-5,5\n1,1 SLEAD0 A0010 C03 -7 C00 5\n2,1 A0100\n-3,4\n";
    let (o, d) = run_files(
        "r\n1\nS*****\nS*****\n",
        agents,
        "zero",
        &["--max-steps", "0"],
    );
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let out = std::fs::read_to_string(d.join("out.txt")).unwrap();
    assert_eq!(
        out,
        "U-5,5,-5,5\n1,1 SLEAD0 A0010 C00 5 C03 -7\n2,1 A0100\n-3,4\n"
    );
    let (o2, d2) = run_files(
        "r\n1\nS*****\nS*****\n",
        &out,
        "zero2",
        &["--max-steps", "0"],
    );
    assert_eq!(o2.status.code(), Some(0));
    assert_eq!(std::fs::read_to_string(d2.join("out.txt")).unwrap(), out);
}

#[test]
fn run_refuses_rules_with_errors() {
    let (o, _) = run_files("r\n1\nN1*0*1*\nS*****\n", "0,0\n", "bad", &[]);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("error[E302]"), "{}", stderr(&o));
    assert!(stderr(&o).contains("nothing was run"));
}

#[test]
fn strict_stops_before_the_step_with_an_error() {
    // Step 1 moves agent 0 east; step 2 would divide by zero: --strict keeps the state after
    // step 1 and exits 3.
    let rules = "a\n1\nS0****\nP1,0 SA****\nb\n1\nSA****\nC00 / C00 0000\n";
    let (o, d) = run_files(rules, "0,0\n", "strict", &["--strict"]);
    assert_eq!(o.status.code(), Some(3), "{}", stderr(&o));
    assert_eq!(
        std::fs::read_to_string(d.join("out.txt")).unwrap(),
        "1,0 SA0000\n"
    );
    let stats: serde_json::Value =
        serde_json::from_slice(&std::fs::read(d.join("stats.json")).unwrap()).unwrap();
    assert_eq!(stats["stopped_by"], "strict");
    assert_eq!(stats["steps"], 1);
    // Without --strict the run goes on and counts the records.
    let (o, d) = run_files(rules, "0,0\n", "lenient", &["--max-steps", "3"]);
    assert_eq!(o.status.code(), Some(0));
    let stats: serde_json::Value =
        serde_json::from_slice(&std::fs::read(d.join("stats.json")).unwrap()).unwrap();
    assert_eq!(stats["records"]["by_kind"]["division-by-zero"], 2);
    assert!(
        stderr(&o).contains("error[division-by-zero] step 2"),
        "{}",
        stderr(&o)
    );
}

#[test]
fn a_flood_of_records_is_summarised() {
    let rules = "d\n1\nS*****\nC00 / C00 0000\n";
    let (o, _) = run_files(rules, "0,0\n", "flood", &["--max-steps", "50"]);
    assert_eq!(o.status.code(), Some(0));
    let e = stderr(&o);
    assert_eq!(e.matches("error[division-by-zero]").count(), 5, "{e}");
    assert!(
        e.contains("... and 45 more division-by-zero records"),
        "{e}"
    );
}

/// Without `--trace` a run keeps only the records it shows (the rest are counted, their
/// sentences never made): what it prints, its stats and its series are those of a run
/// that keeps every record (with `--trace`, which writes them all).
#[test]
fn records_not_shown_are_counted_alike() {
    let rules = "d\n1\nS*****\nC00 / C00 0000\n";
    let agents: String = (0..40).map(|i| format!("{i},0\n")).collect();
    let (traced, d) = run_files(rules, &agents, "flood-traced", &["--max-steps", "10"]);
    let r = tmp("flood-traced-rules.txt", rules.as_bytes());
    let a = tmp("flood-traced-agents.txt", agents.as_bytes());
    let path = |name: &str| d.join(name).display().to_string();
    let (r, a) = (r.display().to_string(), a.display().to_string());
    let mut args: Vec<String> = ["run", &r, &a, "--max-steps", "10", "--no-timing"]
        .map(String::from)
        .to_vec();
    args.extend(["--stats".into(), path("stats-untraced.json")]);
    args.extend(["--series".into(), path("series-untraced.csv")]);
    args.extend(["--out".into(), path("out-untraced.txt")]);
    let plain = bin().args(&args).output().unwrap();
    assert_eq!(plain.status.code(), Some(0), "{}", stderr(&plain));
    // (The summary's last line has times.)
    let shown = |o: &Output| {
        stderr(o)
            .split("40 agents, 10 steps")
            .next()
            .unwrap()
            .to_string()
    };
    assert_eq!(shown(&plain), shown(&traced));
    let e = stderr(&plain);
    assert_eq!(e.matches("error[division-by-zero]").count(), 5, "{e}");
    assert!(
        e.contains("... and 395 more division-by-zero records"),
        "{e}"
    );
    let stats = |name: &str| -> serde_json::Value {
        serde_json::from_slice(&std::fs::read(d.join(name)).unwrap()).unwrap()
    };
    let (s, t) = (stats("stats-untraced.json"), stats("stats.json"));
    assert_eq!(s["records"], t["records"]);
    assert_eq!(s["records"]["by_kind"]["division-by-zero"], 400);
    let trace = std::fs::read_to_string(d.join("trace.jsonl")).unwrap();
    assert_eq!(trace.matches("\"division-by-zero\"").count(), 400);
    let series = std::fs::read_to_string(d.join("series-untraced.csv")).unwrap();
    let rows: Vec<&str> = series.lines().collect();
    assert_eq!(rows.len(), 11, "{series}");
    let head: Vec<&str> = rows[0].split(',').collect();
    let col = head
        .iter()
        .position(|&c| c == "records:division-by-zero")
        .unwrap();
    assert!(
        rows[1..]
            .iter()
            .all(|r| r.split(',').nth(col) == Some("40")),
        "{series}"
    );
}

#[test]
fn ctrl_c_stops_after_the_step_and_still_writes() {
    let r = tmp("int-rules.txt", b"spin\n1\nS*****\nC00 + C00 0001\n");
    let a = tmp("int-agents.txt", b"0,0\n");
    let dir = r.parent().unwrap().join("int");
    std::fs::create_dir_all(&dir).unwrap();
    let mut child = bin()
        .args([
            "run",
            r.to_str().unwrap(),
            a.to_str().unwrap(),
            "--max-steps",
            "1000000000",
        ])
        .arg("--out")
        .arg(dir.join("out.txt"))
        .arg("--stats")
        .arg(dir.join("stats.json"))
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    std::thread::sleep(std::time::Duration::from_millis(500));
    let ok = Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(ok.success());
    let status = child.wait().unwrap();
    assert_eq!(status.code(), Some(130));
    let stats: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.join("stats.json")).unwrap()).unwrap();
    assert_eq!(stats["stopped_by"], "interrupted");
    let steps = stats["steps"].as_u64().unwrap();
    assert!(steps > 0);
    let out = std::fs::read_to_string(dir.join("out.txt")).unwrap();
    let want = (steps as i64).min(32767);
    assert_eq!(
        out,
        format!("0,0 C00 {want}\n"),
        "the state after the last full step"
    );
}

#[test]
fn gen_writes_agents_files_that_check() {
    let o = run(&[
        "gen",
        "connected",
        "--n",
        "30",
        "--seed",
        "5",
        "--ids",
        "C00",
        "--first-state",
        "ROOT0",
        "--state",
        "WAIT0",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let text = String::from_utf8(o.stdout).unwrap();
    assert_eq!(text.lines().count(), 30);
    assert!(text.starts_with("0,0 SROOT0 C00 "));
    let p = tmp("gen-agents.txt", text.as_bytes());
    let c = run(&[
        "check",
        "examples/leader-election/rules.txt",
        "--agents",
        p.to_str().unwrap(),
    ]);
    assert_eq!(c.status.code(), Some(0), "{}", stderr(&c));
    let o = run(&[
        "gen",
        "block",
        "--width",
        "2",
        "--height",
        "3",
        "--depth",
        "2",
        "--dim",
        "3",
        "--universe",
    ]);
    assert_eq!(
        String::from_utf8(o.stdout).unwrap().lines().next(),
        Some("U0,1,0,2,0,1")
    );
    let o = run(&["gen", "cloud", "--n", "5"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("needs --width"));
    let o = run(&["gen", "line", "--n", "3", "--state", "AB"]);
    assert_eq!(o.status.code(), Some(2));
    let o = run(&["gen", "line", "--n", "3", "--ids", "C99"]);
    assert_eq!(o.status.code(), Some(2));
}

/// `sweep` of leader election on polyominoes of 5 and 20 agents, two seeds each, into
/// `csv`, with `extra` arguments.
fn sweep_leader_election(csv: &Path, extra: &[&str]) -> Output {
    let mut args = vec![
        "sweep",
        "examples/leader-election/rules.txt",
        "--sizes",
        "5,20",
        "--seeds",
        "2",
        "--state",
        "INIT0",
        "--ids",
        "C00",
        "--out",
        csv.to_str().unwrap(),
    ];
    args.extend(extra);
    run(&args)
}

/// `sweep --plot` as PNG and as PDF (with reference slopes and chosen metrics) into
/// `dir`: the PNG decodes at the size of two rows of two panels, the PDF is whole.
fn plots_decode(dir: &Path, csv: &Path) {
    for (ext, refs) in [("png", "n,n^0.5"), ("pdf", "n log n")] {
        let file = dir.join(format!("r.{ext}"));
        let plot = [
            "--plot",
            file.to_str().unwrap(),
            "--metrics",
            "steps,messages,firings",
        ];
        let o = sweep_leader_election(csv, &[&plot[..], &["--reference", refs]].concat());
        assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
        let bytes = std::fs::read(&file).unwrap();
        if ext == "png" {
            let d = png::Decoder::new(std::io::Cursor::new(&bytes))
                .read_info()
                .unwrap();
            let (w, h) = (d.info().width, d.info().height);
            assert!(
                w >= 1000 && h >= 800,
                "two columns, two rows of panels: {w} x {h}"
            );
        } else {
            assert!(bytes.starts_with(b"%PDF-"), "a PDF");
            assert!(
                bytes.windows(5).rev().take(64).any(|w| w == b"%%EOF"),
                "a whole PDF"
            );
        }
    }
}

#[test]
fn sweep_writes_csv_and_plot() {
    let dir = std::env::temp_dir().join(format!("latticesim-sweep-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let (csv, svg) = (dir.join("r.csv"), dir.join("r.svg"));
    let o = sweep_leader_election(&csv, &["--plot", svg.to_str().unwrap(), "--threads", "2"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let text = std::fs::read_to_string(&csv).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    assert!(
        lines[0]
            .starts_with("run,n,seed,input,steps,stopped_by,firings,firings:start,firings:adopt,"),
        "{}",
        lines[0]
    );
    for c in [
        ",executing,moves,carried,swaps,sent,delivered,dropped,records,records:move-conflict,",
        ",wall_time_s",
    ] {
        assert!(lines[0].contains(c), "{c} in {}", lines[0]);
    }
    assert_eq!(lines.len(), 5);
    assert!(lines[1].starts_with("1,5,1,"), "{}", lines[1]);
    assert!(lines.iter().skip(1).all(|l| l.contains(",quiescence,")));
    assert!(std::fs::read_to_string(&svg).unwrap().starts_with("<svg"));
    assert!(stderr(&o).contains("steps ~ n^"), "{}", stderr(&o));
    assert!(stderr(&o).contains("messages ~ n^"), "{}", stderr(&o));
    assert!(
        !stderr(&o).contains("moves ~"),
        "no moves to fit: {}",
        stderr(&o)
    );
    // PNG and PDF too, by the name, with reference slopes; each file decodes.
    plots_decode(&dir, &csv);
    let svg_text = std::fs::read_to_string(&svg).unwrap();
    resvg::usvg::Tree::from_str(&svg_text, &resvg::usvg::Options::default())
        .expect("the SVG parses");
    assert!(
        svg_text.contains("fit: n<tspan baseline-shift=\"super\""),
        "the fit and its exponent (a superscript) are labelled"
    );
    assert!(svg_text.contains("agents n"), "the axis is labelled");
    // Another name is refused before any run.
    let o = run(&[
        "sweep",
        "examples/leader-election/rules.txt",
        "--sizes",
        "5",
        "--out",
        csv.to_str().unwrap(),
        "--plot",
        dir.join("r.jpg").to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr(&o).contains("a plot is written as SVG, PNG or PDF"),
        "{}",
        stderr(&o)
    );
    // Rules that do not fit the generated agents: exit 1.
    let o = run(&[
        "sweep",
        "examples/leader-election/rules-3d.txt",
        "--sizes",
        "5",
        "--out",
        csv.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(1));
}

/// The documented colours of states (docs/running.md): the first eight of the palette,
/// Okabe and Ito's seven and Tol's indigo, handed out in order of first appearance, in
/// agent order at step 0 and after each step up to `steps` (written here from the
/// document, not taken from the program). The states in that order, with their colours.
fn documented_colours(rules: &str, agents: &str, steps: u64) -> Vec<(String, [u8; 3])> {
    const FIRST: [[u8; 3]; 8] = [
        [0xe6, 0x9f, 0x00],
        [0x56, 0xb4, 0xe9],
        [0x00, 0x9e, 0x73],
        [0xf0, 0xe4, 0x42],
        [0x00, 0x72, 0xb2],
        [0xd5, 0x5e, 0x00],
        [0xcc, 0x79, 0xa7],
        [0x33, 0x22, 0x88],
    ];
    let mut order: Vec<String> = Vec::new();
    for step in 0..=steps {
        for (_, _, st) in agents_after(rules, agents, &step.to_string()) {
            if !order.contains(&st) {
                order.push(st);
            }
        }
    }
    assert!(
        order.len() <= 8,
        "more states than the test knows colours of"
    );
    order.into_iter().zip(FIRST).collect()
}

/// Runs `latticesim render RULES AGENTS ARGS --out <tmp file named NAME>`, which must
/// succeed; the image's path.
fn render_ok(rules: &str, agents: &str, args: &[&str], name: &str) -> PathBuf {
    let out = tmp(name, b"");
    let mut a = vec!["render", rules, agents];
    a.extend(args);
    a.extend(["--out", out.to_str().unwrap()]);
    let o = run(&a);
    assert!(o.status.success(), "{a:?}: {}", stderr(&o));
    out
}

/// The agents after `steps` steps, from `latticesim run`: (x, y, state) of each.
fn agents_after(rules: &str, agents: &str, steps: &str) -> Vec<(i64, i64, String)> {
    let o = run(&[
        "run",
        rules,
        agents,
        "--max-steps",
        steps,
        "--quiet",
        "--no-timing",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    String::from_utf8_lossy(&o.stdout)
        .lines()
        .map(|l| {
            let mut w = l.split_whitespace();
            let p: Vec<i64> = w
                .next()
                .unwrap()
                .split(',')
                .map(|v| v.parse().unwrap())
                .collect();
            // The default state is left out of the text.
            let state = w
                .next()
                .and_then(|s| s.strip_prefix('S'))
                .unwrap_or("00000");
            (p[0], p[1], state.to_string())
        })
        .collect()
}

#[test]
fn render_png_shows_each_agent_in_its_state_colour() {
    let (rules, agents) = ("examples/gravity/rules.txt", "examples/gravity/agents.txt");
    let png_path = render_ok(
        rules,
        agents,
        &["--step", "3", "--cell", "10"],
        "render.png",
    );
    // Where the agents stand after three steps, from `latticesim run`.
    let cells = agents_after(rules, agents, "3");
    let decoder = png::Decoder::new(std::io::BufReader::new(
        std::fs::File::open(&png_path).unwrap(),
    ));
    let mut reader = decoder.read_info().unwrap();
    let mut buf = vec![0; reader.output_buffer_size().unwrap()];
    let info = reader.next_frame(&mut buf).unwrap();
    let (w, h) = (info.width as i64, info.height as i64);
    let (x0, x1) = (
        cells.iter().map(|c| c.0).min().unwrap(),
        cells.iter().map(|c| c.0).max().unwrap(),
    );
    let (y0, y1) = (
        cells.iter().map(|c| c.1).min().unwrap(),
        cells.iter().map(|c| c.1).max().unwrap(),
    );
    // Ten pixels a cell and a margin of one cell, north up; the legend (140 pixels wide,
    // 24 + 18 per state high) on the right, its states in order of first appearance.
    let colours = documented_colours(rules, agents, 3);
    let colour = |st: &str| colours.iter().find(|c| c.0 == st).unwrap().1;
    let states: Vec<&str> = (colours.iter())
        .map(|c| c.0.as_str())
        .filter(|st| cells.iter().any(|c| c.2 == *st))
        .collect();
    let view_w = (x1 - x0 + 3) * 10;
    let legend_h = 24 + 18 * states.len() as i64;
    assert_eq!((w, h), (view_w + 140, ((y1 - y0 + 3) * 10).max(legend_h)));
    for (i, st) in states.iter().enumerate() {
        let (px, py) = (view_w + 17, 24 + 18 * i as i64 + 7);
        let k = ((py * w + px) * 3) as usize;
        assert_eq!(
            [buf[k], buf[k + 1], buf[k + 2]],
            colour(st),
            "the legend's swatch of {st}"
        );
    }
    // The step's line of text above the swatches: dark pixels in the legend's first rows.
    let dark = (4..20).flat_map(|y| (view_w + 10..view_w + 60).map(move |x| (x, y)));
    let dark = dark
        .filter(|&(x, y)| buf[((y * w + x) * 3) as usize] < 100)
        .count();
    assert!(
        dark > 10,
        "the step is written in the legend ({dark} dark pixels)"
    );
    let pixel = |x: i64, y: i64| {
        let (px, py) = ((x - x0 + 1) * 10 + 5, (y1 - y + 1) * 10 + 5);
        let i = ((py * w + px) * 3) as usize;
        [buf[i], buf[i + 1], buf[i + 2]]
    };
    for (x, y, state) in &cells {
        assert_eq!(pixel(*x, *y), colour(state), "agent at {x},{y}");
    }
    let taken: std::collections::HashSet<(i64, i64)> = cells.iter().map(|c| (c.0, c.1)).collect();
    let empty = (x0..=x1)
        .flat_map(|x| (y0..=y1).map(move |y| (x, y)))
        .find(|c| !taken.contains(c))
        .unwrap();
    assert_eq!(pixel(empty.0, empty.1), [255, 255, 255]);
}

#[test]
fn render_takes_a_user_palette() {
    let (rules, agents) = ("examples/gravity/rules.txt", "examples/gravity/agents.txt");
    let states: Vec<String> = documented_colours(rules, agents, 0)
        .into_iter()
        .map(|c| c.0)
        .collect();
    let pal = tmp(
        "palette.txt",
        format!("// mine\n#102030\n{} #ff0000 // pinned\n", states[0]).as_bytes(),
    );
    let svg = render_ok(
        rules,
        agents,
        &["--step", "0", "--palette", pal.to_str().unwrap()],
        "palette.svg",
    );
    let svg = std::fs::read_to_string(svg).unwrap();
    assert!(svg.contains("#ff0000"), "the pinned state's colour");
    if states.len() > 1 {
        assert!(svg.contains("#102030"), "the sequence's first colour");
    }
    let bad = tmp("bad-palette.txt", b"#102030\nLEAD #ff0000\n");
    let out = tmp("bad-palette.svg", b"");
    let o = run(&[
        "render",
        rules,
        agents,
        "--step",
        "0",
        "--palette",
        bad.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr(&o).contains("bad-palette.txt:2:1: `LEAD` is not a state"),
        "{}",
        stderr(&o)
    );
}

#[test]
fn render_gif_has_a_frame_per_step_and_svg_a_legend() {
    let (rules, agents) = (
        "examples/spanning-tree/rules.txt",
        "examples/spanning-tree/agents-40.txt",
    );
    let gif_path = render_ok(rules, agents, &["--steps", "2..9"], "render.gif");
    let mut opts = gif::DecodeOptions::new();
    opts.set_color_output(gif::ColorOutput::RGBA);
    let mut d = opts
        .read_info(std::fs::File::open(&gif_path).unwrap())
        .unwrap();
    let mut frames = 0;
    while d.read_next_frame().unwrap().is_some() {
        frames += 1;
    }
    // The run is quiescent after step 8: the animation ends there.
    assert_eq!(frames, 7);
    let svg_path = render_ok(rules, agents, &["--step", "10"], "render.svg");
    let svg = std::fs::read_to_string(&svg_path).unwrap();
    // Two squares per agent (border and face), a legend entry per state.
    assert_eq!(svg.matches("<polygon").count(), 2 * 40);
    let states: std::collections::BTreeSet<String> = agents_after(rules, agents, "10")
        .into_iter()
        .map(|a| a.2)
        .collect();
    for s in &states {
        assert!(svg.contains(&format!(">{s}</text>")), "legend lacks {s}");
    }
    assert!(svg.contains(">step 10</text>"));
    // 3D: three faces per cube.
    let (rules3, agents3) = (
        "examples/gravity-3d/rules.txt",
        "examples/gravity-3d/agents.txt",
    );
    let svg3 = render_ok(rules3, agents3, &["--step", "2"], "render3.svg");
    let svg3 = std::fs::read_to_string(&svg3).unwrap();
    let n = std::fs::read_to_string(agents3)
        .unwrap()
        .lines()
        .filter(|l| l.starts_with(|c: char| c.is_ascii_digit() || c == '-'))
        .count();
    assert_eq!(svg3.matches("<polygon").count(), 3 * n);
}

#[test]
fn render_refuses_bad_requests() {
    let (rules, agents) = ("examples/gravity/rules.txt", "examples/gravity/agents.txt");
    let out = tmp("bad.png", b"");
    let out = out.to_str().unwrap();
    for (args, want) in [
        (
            vec!["--step", "1", "--out", "/tmp/x.bmp"],
            "must end in .png, .svg or .gif",
        ),
        (vec!["--steps", "5..2", "--out", out], "expected A..B"),
        (vec!["--steps", "0..3", "--out", out], "is written as .gif"),
        (
            vec!["--steps", "0..99999", "--out", "/tmp/x.gif"],
            "at most 2000 frames",
        ),
    ] {
        let mut a = vec!["render", rules, agents];
        a.extend(args);
        let o = run(&a);
        assert_eq!(o.status.code(), Some(2), "{a:?}");
        assert!(stderr(&o).contains(want), "{a:?}: {}", stderr(&o));
    }
    // Agents too far apart for any picture: refused, not drawn.
    let far = tmp("far.txt", b"0,0\n0,1000000\n");
    let o = run(&["render", rules, far.to_str().unwrap(), "--out", out]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr(&o).contains("far.txt`: the agents spread over 1 x 1000001 cells"),
        "{}",
        stderr(&o)
    );
    let bad = tmp("bad-rules.txt", b"r\n1\nQQ\nS*****\n");
    let o = run(&["render", bad.to_str().unwrap(), agents, "--out", out]);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("bad-rules.txt:3:"), "{}", stderr(&o));
}

// ------------------------------------------------------------------ reliability (issue 14)

/// Runs the program with standard output into a pipe whose reader takes one line and
/// closes it: the exit status and standard error.
fn closed_pipe(args: &[&str]) -> (Option<i32>, String) {
    use std::io::{BufRead, Read};
    let mut child = bin()
        .args(args)
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let mut line = String::new();
    std::io::BufReader::new(child.stdout.take().unwrap())
        .read_line(&mut line)
        .unwrap();
    // The reader is gone now.
    let mut err = String::new();
    child
        .stderr
        .take()
        .unwrap()
        .read_to_string(&mut err)
        .unwrap();
    (child.wait().unwrap().code(), err)
}

#[test]
fn a_closed_pipe_ends_quietly_and_files_are_still_written() {
    let (code, err) = closed_pipe(&["gen", "block", "--width", "300", "--height", "300"]);
    assert_eq!((code, err.as_str()), (Some(0), ""));
    let (code, err) = closed_pipe(&[
        "check",
        "examples/mistakes/rules.txt",
        "--agents",
        "examples/tour/agents.txt",
        "--format",
        "json",
    ]);
    assert_eq!((code, err.as_str()), (Some(1), ""));
    let stats = tmp("pipe-stats.json", b"");
    std::fs::remove_file(&stats).unwrap();
    let agents = tmp("pipe-agents.txt", b"");
    assert!(run(&[
        "gen",
        "block",
        "--width",
        "120",
        "--height",
        "120",
        "--out",
        agents.to_str().unwrap()
    ])
    .status
    .success());
    let (code, err) = closed_pipe(&[
        "run",
        "examples/maxflood/rules.txt",
        agents.to_str().unwrap(),
        "--max-steps",
        "3",
        "--stats",
        stats.to_str().unwrap(),
    ]);
    assert_eq!(code, Some(0), "{err}");
    assert!(!err.contains("panicked"), "{err}");
    let v: serde_json::Value = serde_json::from_slice(&std::fs::read(&stats).unwrap()).unwrap();
    assert_eq!(v["steps"], 3);
    // Standard error into the same pipe: its summary line meets the closed pipe too.
    std::fs::remove_file(&stats).unwrap();
    let line = format!(
        "set -o pipefail; '{}' run examples/maxflood/rules.txt '{}' --max-steps 3 --stats '{}' 2>&1 | head -1 > /dev/null",
        env!("CARGO_BIN_EXE_latticesim"),
        agents.display(),
        stats.display()
    );
    let o = std::process::Command::new("bash")
        .args(["-c", &line])
        .output()
        .unwrap();
    assert_eq!(
        o.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&std::fs::read(&stats).unwrap()).unwrap();
    assert_eq!(v["steps"], 3);
}

#[cfg(target_os = "linux")]
#[test]
fn a_full_disk_is_exit_2_with_a_message() {
    let full = || std::fs::File::create("/dev/full").unwrap();
    let stats = tmp("full-stats.json", b"");
    std::fs::remove_file(&stats).unwrap();
    let o = bin()
        .args([
            "run",
            "examples/gravity/rules.txt",
            "examples/gravity/agents.txt",
            "--stats",
            stats.to_str().unwrap(),
        ])
        .stdout(full())
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("cannot write to standard output: No space left"),
        "{}",
        stderr(&o)
    );
    assert!(stats.exists(), "the statistics asked for are still written");
    for args in [
        &[
            "check",
            "examples/mistakes/rules.txt",
            "--agents",
            "examples/tour/agents.txt",
        ][..],
        &["gen", "line", "--n", "3", "--nonsense"][..],
    ] {
        let o = bin().args(args).stderr(full()).output().unwrap();
        assert_eq!(o.status.code(), Some(2), "{args:?}");
    }
    let o = bin()
        .args(["check", "examples/tour/rules.txt", "--format", "json"])
        .stdout(full())
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
}

#[test]
fn output_paths_are_checked_before_anything_runs() {
    // The files that are fine are not started either (the trace was written while stepping).
    let stats = tmp("early-stats.json", b"");
    std::fs::remove_file(&stats).unwrap();
    let trace = tmp("early-trace.jsonl", b"");
    std::fs::remove_file(&trace).unwrap();
    for flag in ["--out", "--stats"] {
        let mut args = vec![
            "run",
            "examples/gravity/rules.txt",
            "examples/gravity/agents.txt",
            flag,
            "/nonexistent/folder/file.txt",
            "--trace",
            trace.to_str().unwrap(),
        ];
        if flag != "--stats" {
            args.extend(["--stats", stats.to_str().unwrap()]);
        }
        let o = run(&args);
        assert_eq!(o.status.code(), Some(2), "{flag}");
        let err = stderr(&o);
        assert!(
            err.contains("cannot write `/nonexistent/folder/file.txt`"),
            "{err}"
        );
        assert!(!err.contains("steps"), "nothing ran: {err}");
        assert!(!stats.exists(), "{flag}: nothing is written");
        assert!(!trace.exists(), "{flag}: nothing is written");
    }
    for args in [
        &["gen", "line", "--n", "3", "--out", "/nonexistent/a.txt"][..],
        &[
            "render",
            "examples/gravity/rules.txt",
            "examples/gravity/agents.txt",
            "--out",
            "/nonexistent/a.png",
        ][..],
        &[
            "sweep",
            "examples/gravity/rules.txt",
            "--shape",
            "line",
            "--sizes",
            "3",
            "--out",
            "/nonexistent/a.csv",
        ][..],
    ] {
        let o = run(args);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {}", stderr(&o));
        assert!(stderr(&o).contains("/nonexistent/"), "{}", stderr(&o));
    }
}

/// Files of `dir` whose names end in `.tmp`.
fn temporary_files(dir: &Path) -> Vec<String> {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".tmp"))
        .collect()
}

#[cfg(unix)]
#[test]
fn a_killed_write_leaves_the_old_file_whole() {
    // The process is killed (SIGXFSZ, as by a crash) once it has written 4 KB of a file:
    // the file asked for keeps its old text instead of a cut one.
    let dir = std::env::temp_dir().join(format!("latticesim-atomic-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let agents = dir.join("agents.txt");
    assert!(run(&[
        "gen",
        "block",
        "--width",
        "60",
        "--height",
        "60",
        "--out",
        agents.to_str().unwrap()
    ])
    .status
    .success());
    let out = dir.join("final.txt");
    std::fs::write(&out, "0,0 SOLD00\n").unwrap();
    let cmd = format!(
        "ulimit -f 4; exec '{}' run examples/gravity/rules.txt '{}' --out '{}'",
        env!("CARGO_BIN_EXE_latticesim"),
        agents.display(),
        out.display()
    );
    let o = Command::new("sh")
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .args(["-c", &cmd])
        .output()
        .unwrap();
    assert!(!o.status.success(), "the write was to be cut");
    assert_eq!(std::fs::read_to_string(&out).unwrap(), "0,0 SOLD00\n");
    // A run that fails on its input leaves no temporary file either.
    let bad = dir.join("bad.txt");
    std::fs::write(&bad, "x\n").unwrap();
    let o = run(&[
        "run",
        bad.to_str().unwrap(),
        agents.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(1));
    assert_eq!(std::fs::read_to_string(&out).unwrap(), "0,0 SOLD00\n");
    // Only the killed run's temporary file may stay.
    assert!(
        temporary_files(&dir).len() <= 1,
        "{:?}",
        temporary_files(&dir)
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn ctrl_c_while_loading_stops_at_once_with_a_message() {
    let agents = tmp("load-agents.txt", b"");
    assert!(run(&[
        "gen",
        "block",
        "--width",
        "700",
        "--height",
        "700",
        "--out",
        agents.to_str().unwrap()
    ])
    .status
    .success());
    let out = tmp("load-out.txt", b"");
    std::fs::remove_file(&out).unwrap();
    let child = bin()
        .args(["run", "examples/maxflood/rules.txt"])
        .arg(&agents)
        .arg("--out")
        .arg(&out)
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    std::thread::sleep(std::time::Duration::from_millis(100));
    let ok = Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(ok.success());
    let o = child.wait_with_output().unwrap();
    assert_eq!(o.status.code(), Some(130), "{}", stderr(&o));
    let err = stderr(&o);
    assert!(err.contains("interrupted"), "{err}");
    if err.contains("nothing was written") {
        assert!(!out.exists());
    }
    assert!(temporary_files(out.parent().unwrap()).is_empty());
}

#[test]
fn more_threads_than_can_work_are_capped_with_a_note() {
    let o = run(&[
        "run",
        "examples/gravity/rules.txt",
        "examples/gravity/agents.txt",
        "--threads",
        "5000",
        "--quiet",
    ]);
    assert!(o.status.success());
    let err = stderr(&o);
    assert!(
        err.contains("note: --threads 5000: using 1, because 45 agents keep at most 1 busy"),
        "{err}"
    );
}

#[test]
fn render_stops_at_quiescence_and_says_where() {
    let path = render_ok(
        "examples/gravity/rules.txt",
        "examples/gravity/agents.txt",
        &["--step", "18446744073709551615"],
        "quiet.png",
    );
    assert!(std::fs::metadata(path).unwrap().len() > 0);
    let o = run(&[
        "render",
        "examples/gravity/rules.txt",
        "examples/gravity/agents.txt",
        "--steps",
        "5..40",
        "--out",
        tmp("quiet.gif", b"").to_str().unwrap(),
    ]);
    assert!(o.status.success());
    assert!(
        stderr(&o).contains("quiescent after step 10"),
        "{}",
        stderr(&o)
    );
}

#[test]
fn deep_nesting_is_an_error_not_a_crash() {
    for (what, pre) in [
        ("bangs", "!".repeat(14_000) + "S0****"),
        (
            "groups",
            "(".repeat(11_500) + "S0****" + &")".repeat(11_500),
        ),
        ("unclosed", "(".repeat(10_000) + "S0****"),
    ] {
        let rules = tmp(
            &format!("deep-{what}.txt"),
            format!("r\n1\n{pre}\nS1****\n").as_bytes(),
        );
        for cmd in ["check", "run"] {
            let mut args = vec![cmd, rules.to_str().unwrap()];
            if cmd == "check" {
                args.push("--agents");
            }
            args.push("examples/tour/agents.txt");
            let o = run(&args);
            assert_eq!(o.status.code(), Some(1), "{what} {cmd}: {}", stderr(&o));
            let err = stderr(&o);
            assert!(err.contains("error[E206]"), "{err}");
            assert!(err.contains(":3:101"), "{err}");
            assert!(err.len() < 100_000, "{what}: {} bytes", err.len());
        }
    }
}

#[test]
fn diagnostics_are_capped_per_line_and_file() {
    let rules = tmp(
        "many-x.txt",
        format!("r\n1\nS0****\nC00 + C00 1{}\n", " x".repeat(4000)).as_bytes(),
    );
    let check = |more: &[&str]| {
        let mut args = vec!["check", rules.to_str().unwrap(), "--dim", "2"];
        args.extend(more);
        let o = run(&args);
        assert_eq!(o.status.code(), Some(1));
        o
    };
    let err = stderr(&check(&[]));
    assert_eq!(err.matches("error[E102]").count(), 10);
    assert!(
        err.contains("note: not shown in ")
            && err.contains(": 3990 more errors and 0 more warnings: 3990 E102 ("),
        "{err}"
    );
    assert!(err.contains("4000 errors"), "{err}");
    let json = |o: Output| -> serde_json::Value { serde_json::from_slice(&o.stdout).unwrap() };
    let v = json(check(&["--format", "json"]));
    assert_eq!(v["errors"], 4000);
    assert_eq!(v["diagnostics"].as_array().unwrap().len(), 10);
    assert_eq!(v["not_shown"][0]["errors"], 3990);
    // Fewer shown when asked; the rest counted per code, in JSON too.
    let err = stderr(&check(&["--max-diagnostics", "3"]));
    assert_eq!(err.matches("error[E102]").count(), 3, "{err}");
    assert!(
        err.contains(": 3997 more errors and 0 more warnings: 3997 E102 ("),
        "{err}"
    );
    let v = json(check(&["--max-diagnostics", "0", "--format", "json"]));
    assert_eq!(v["diagnostics"].as_array().unwrap().len(), 0);
    assert_eq!(v["not_shown"][0]["codes"]["E102"], 4000);
}

#[test]
fn control_characters_are_shown_escaped() {
    let rules = tmp("escapes.txt", b"r\n1\nS\x1b[2J12 \r N1***\nS1****\n");
    let o = run(&["check", rules.to_str().unwrap(), "--dim", "2"]);
    assert_eq!(o.status.code(), Some(1));
    let err = stderr(&o);
    assert!(!err.contains('\x1b') && !err.contains('\r'), "{err:?}");
    assert!(err.contains("`\\u{1b}[2J12`"), "{err}");
    assert!(
        err.contains("S\u{241b}[2J12"),
        "the excerpt shows ESC as a picture: {err}"
    );
    assert!(err.contains("a lone carriage return (CR, `\\r`)"), "{err}");
}

/// A canonical B1 agents file of `l` x `l` agents (as `run --out` writes it).
fn b1_text(l: u64) -> String {
    let mut s = String::with_capacity((l * l * 20) as usize);
    for x in 0..l {
        for y in 0..l {
            s += &format!("{x},{y} C00 {}\n", ((x * l + y) * 7919) % 32749 + 1);
        }
    }
    s
}

#[test]
fn large_files_stream_through_chunks_and_threads_unchanged() {
    // 1,100 x 1,100 agents: 22 MB, more than one chunk of the reader, cut among threads.
    let text = b1_text(1100);
    assert!(text.len() > 17 << 20);
    let input = tmp("large-b1.txt", text.as_bytes());
    let rules = tmp("large-rules.txt", b"flood\n1\nS*****\nC00 A C00 #N01 C00 A C00 #W01 C00 A C00 #E01 C00 A C00 #S01 #*01 + C00 0000\n");
    for threads in ["1", "2"] {
        let out = tmp(&format!("large-out-{threads}.txt"), b"");
        let o = run(&[
            "run",
            rules.to_str().unwrap(),
            input.to_str().unwrap(),
            "--max-steps",
            "0",
            "--threads",
            threads,
            "--out",
            out.to_str().unwrap(),
            "-q",
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
        assert!(
            std::fs::read(&out).unwrap() == text.as_bytes(),
            "0 steps write back what was read ({threads} threads)"
        );
    }
    // A defect on the last line: the diagnostic path names it.
    let mut bad = text.clone();
    bad += "5,5 C00 7\n";
    let input = tmp("large-bad.txt", bad.as_bytes());
    let o = run(&[
        "check",
        rules.to_str().unwrap(),
        "--agents",
        input.to_str().unwrap(),
        "--color",
        "never",
    ]);
    assert_eq!(o.status.code(), Some(1));
    let err = stderr(&o);
    assert!(
        err.contains("error[E402]: two agents on the cell 5,5"),
        "{err}"
    );
    assert!(
        err.contains(&format!("{}:1210001:1", input.display())),
        "{err}"
    );
}

#[test]
fn compressed_agents_files_read_and_write() {
    let text = b1_text(40);
    let plain = tmp("packed.txt", text.as_bytes());
    let rules = "examples/maxflood/rules.txt";
    let p = |p: &PathBuf| p.to_str().unwrap().to_string();
    let mut outs = Vec::new();
    for ext in ["txt", "zst", "gz"] {
        let out = tmp(&format!("packed-out.{ext}"), b"");
        let o = run(&[
            "run",
            rules,
            &p(&plain),
            "--max-steps",
            "5",
            "--out",
            &p(&out),
            "-q",
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
        outs.push(out);
    }
    let raw = std::fs::read(&outs[0]).unwrap();
    assert_eq!(
        &std::fs::read(&outs[1]).unwrap()[..4],
        &[0x28, 0xb5, 0x2f, 0xfd],
        "zstd magic"
    );
    assert_eq!(
        &std::fs::read(&outs[2]).unwrap()[..2],
        &[0x1f, 0x8b],
        "gzip magic"
    );
    // Each compressed output read back (0 steps) gives the plain text.
    for out in &outs[1..] {
        let again = tmp("packed-again.txt", b"");
        let o = run(&[
            "run",
            rules,
            &p(out),
            "--max-steps",
            "0",
            "--out",
            &p(&again),
            "-q",
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
        assert_eq!(std::fs::read(&again).unwrap(), raw);
        let o = run(&["check", rules, "--agents", &p(out)]);
        assert!(o.status.success(), "{}", stderr(&o));
        assert!(stderr(&o).contains("1600 agents"), "{}", stderr(&o));
    }
    // A damaged compressed file is an I/O error with the file's name.
    let mut z = std::fs::read(&outs[1]).unwrap();
    z.truncate(z.len() / 2);
    let broken = tmp("broken.txt.zst", &z);
    let o = run(&["run", rules, &p(&broken), "-q"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr(&o).contains(&format!("cannot read `{}`", broken.display())),
        "{}",
        stderr(&o)
    );
}

#[test]
fn the_summary_gives_each_part_of_the_time_and_the_peak_memory() {
    let stats = tmp("timing-stats.json", b"");
    let o = run(&[
        "run",
        "examples/maxflood/rules.txt",
        "examples/maxflood/agents.txt",
        "--out",
        "/dev/null",
        "--stats",
        stats.to_str().unwrap(),
    ]);
    assert!(o.status.success());
    let err = stderr(&o);
    for part in ["read ", "check ", "steps ", "write ", "peak memory "] {
        assert!(err.contains(part), "{part} in {err}");
    }
    let v: serde_json::Value = serde_json::from_slice(&std::fs::read(&stats).unwrap()).unwrap();
    for k in ["read_s", "check_s", "steps_s", "write_s"] {
        assert!(v["times"][k].as_f64().unwrap() >= 0.0, "{k}");
    }
    assert!(v["peak_memory_bytes"].as_u64().unwrap() > 1_000_000);
}

#[test]
fn an_output_that_is_a_device_is_written_not_replaced() {
    use std::os::unix::fs::FileTypeExt;
    let o = run(&[
        "run",
        "examples/maxflood/rules.txt",
        "examples/maxflood/agents.txt",
        "-q",
        "--out",
        "/dev/null",
        "--stats",
        "/dev/null",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let meta = std::fs::metadata("/dev/null").unwrap();
    assert!(meta.file_type().is_char_device(), "/dev/null was replaced");
    assert!(temporary_files(Path::new("/dev")).is_empty());
}

/// Errors and agents on one cell are found by the streaming reader, which needs no more
/// memory for them than for a clean file: with the checker's memory capped
/// (LATTICESIM_CHECK_MEMORY) below what these files need, they are said in full, as the
/// checker says them. A line the streaming reader leaves to the checker of the whole file
/// (not UTF-8) still gets the checker's verdict on the file's first part.
#[test]
fn a_file_too_large_for_the_checker_is_streamed_to_its_end() {
    let rules = "examples/maxflood/rules.txt";
    let mut text = b1_text(200);
    let good_len = text.len();
    text += "1,2 C77 5\n";
    text += &b1_text(100).replace('\n', " C01 3\n");
    text += "1,2 C78 5\n";
    let bad = tmp("too-large-bad.txt", text.as_bytes());
    let check = |path: &Path| {
        bin()
            .args(["check", rules, "--agents", path.to_str().unwrap()])
            .args(["--color", "never"])
            .env("LATTICESIM_CHECK_MEMORY", "100000")
            .output()
            .unwrap()
    };
    let o = check(&bad);
    assert_eq!(o.status.code(), Some(1));
    let err = stderr(&o);
    assert!(err.contains(&format!("{}:40001:5", bad.display())), "{err}");
    assert!(
        err.contains("error[E404]: `C77` is not a counter of 2D"),
        "{err}"
    );
    // The other 100 x 100 agents stand on the first ones' cells; the last line's error
    // is counted.
    assert!(
        err.contains("9802 more errors and 0 more warnings: 9801 E402, 1 E404"),
        "{err}"
    );
    assert!(err.contains("50002 agents; 10002 errors"), "{err}");
    assert!(!err.contains("too large"), "{err}");
    assert!(good_len < 1 << 20);
    // Two agents on a cell: said with both lines, in `run` too.
    let mut text = b1_text(200);
    text += "// a comment line\n3,4\n";
    let dup = tmp("too-large-dup.txt", text.as_bytes());
    let o = bin()
        .args(["run", rules, dup.to_str().unwrap(), "--color", "never"])
        .env("LATTICESIM_CHECK_MEMORY", "100000")
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(1));
    let err = stderr(&o);
    let d = dup.display();
    assert!(
        err.contains("error[E402]: two agents on the cell 3,4"),
        "{err}"
    );
    assert!(err.contains(&format!("{d}:40002:1")), "{err}");
    assert!(err.contains("agent 40000 would stand here"), "{err}");
    assert!(err.contains("605 │ 3,4"), "{err}");
    assert!(err.contains("agent 604 stands here already"), "{err}");
    assert!(err.contains("nothing was run"), "{err}");
    // A line that is not UTF-8: the checker reads the file's first part.
    let mut bytes = text.into_bytes();
    bytes.extend_from_slice(b"5,5 S\xff0000\n");
    let odd = tmp("too-large-odd.txt", &bytes);
    let o = check(&odd);
    assert_eq!(o.status.code(), Some(1));
    let err = stderr(&o);
    assert!(err.contains("note: only its first"), "{err}");
    assert!(
        err.contains("is too large to be checked whole here"),
        "{err}"
    );
}

/// A line of A and B agents: each A swaps with a B east of it until the Bs stand west.
const SWAPS: &str = "east\n1\nSA**** T1,0,B****\nXE\n";
const SWAPS_AGENTS: &str = "0,0 SAAAAA\n1,0 SBBBBB\n2,0 SAAAAA\n3,0 SBBBBB\n4,0 SBBBBB\n";

/// The rows of a CSV series as (column names, rows of numbers).
fn csv_series(path: &Path) -> (Vec<String>, Vec<Vec<f64>>) {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let names = lines.next().unwrap().split(',').map(String::from).collect();
    let rows = lines
        .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
        .collect();
    (names, rows)
}

/// The rows of a Parquet series, read with the parquet crate's own reader.
fn parquet_series(path: &Path) -> (Vec<String>, Vec<Vec<f64>>) {
    use parquet::file::reader::{FileReader, SerializedFileReader};
    use parquet::record::Field;
    let r = SerializedFileReader::new(std::fs::File::open(path).unwrap()).unwrap();
    let names = (r.metadata().file_metadata().schema_descr().columns().iter())
        .map(|c| c.name().to_string())
        .collect();
    let rows = (r.get_row_iter(None).unwrap())
        .map(|row| {
            (row.unwrap().get_column_iter())
                .map(|(_, f)| match f {
                    Field::Long(v) => *v as f64,
                    Field::Double(v) => *v,
                    other => panic!("unexpected field {other:?}"),
                })
                .collect()
        })
        .collect();
    (names, rows)
}

/// Each row of a series against the events of the same step in the trace `trace`.
fn trace_agrees(name: &str, trace: &Path, names: &[String], rows: &[Vec<f64>]) {
    let col = |c: &str| {
        names
            .iter()
            .position(|n| n == c)
            .unwrap_or_else(|| panic!("{c}"))
    };
    let trace = std::fs::read_to_string(trace).unwrap();
    let mut events: std::collections::BTreeMap<(u64, String), f64> = Default::default();
    for line in trace.lines() {
        let v: serde_json::Value = serde_json::from_str(line).unwrap();
        let mut key = v["event"].as_str().unwrap().to_string();
        if key == "record" {
            key = format!("records:{}", v["kind"].as_str().unwrap());
        }
        *events
            .entry((v["step"].as_u64().unwrap(), key))
            .or_default() += 1.0;
    }
    for row in rows {
        let step = row[col("step")] as u64;
        let ev = |k: &str| events.get(&(step, k.to_string())).copied().unwrap_or(0.0);
        for (c, e) in [
            ("executing", "fire"),
            ("moves", "move"),
            ("swaps", "swap"),
            ("sent", "message"),
        ] {
            assert_eq!(
                row[col(c)],
                ev(e),
                "{name}, step {step}: {c} against the trace's {e} events"
            );
        }
        for n in names.iter().filter(|n| n.starts_with("records:")) {
            assert_eq!(row[col(n)], ev(n), "{name}, step {step}: {n}");
        }
    }
}

/// `run --series` as CSV and Parquet: every column summed over the steps equals the
/// `--stats` total, and step by step the counts agree with the trace's events (fire events
/// = agents executing, move events = moves, swap events = swaps, message events = sent,
/// record lines by kind); the Parquet file holds the CSV's rows.
#[test]
fn series_sum_to_the_stats_and_follow_the_trace() {
    let examples = [
        (
            "reconfigure-line/rules.txt",
            "reconfigure-line/agents-30.txt",
        ),
        ("leader-election/rules.txt", "leader-election/agents-30.txt"),
        ("tour/rules.txt", "tour/agents.txt"),
        ("bouncing/rules.txt", "bouncing/agents.txt"),
    ];
    let mut cases: Vec<(String, String, String)> = examples
        .iter()
        .map(|(r, a)| {
            let read = |f: &str| std::fs::read_to_string(format!("examples/{f}")).unwrap();
            (r.to_string(), read(r), read(a))
        })
        .collect();
    cases.push(("swaps".into(), SWAPS.into(), SWAPS_AGENTS.into()));
    let mut carried = 0;
    for (i, (name, rules, agents)) in cases.iter().enumerate() {
        let tag = format!("series{i}");
        let dir = std::env::temp_dir().join(format!("latticesim-cli-{}", std::process::id()));
        let (csv, pq) = (
            dir.join(format!("{tag}.csv")),
            dir.join(format!("{tag}.parquet")),
        );
        let extra = ["--max-steps", "300", "--series"];
        let (o, d) = run_files(
            rules,
            agents,
            &tag,
            &[&extra[..], &[csv.to_str().unwrap()]].concat(),
        );
        assert_eq!(o.status.code(), Some(0), "{name}: {}", stderr(&o));
        let (o2, _) = run_files(
            rules,
            agents,
            &format!("{tag}p"),
            &[&extra[..], &[pq.to_str().unwrap()]].concat(),
        );
        assert_eq!(o2.status.code(), Some(0), "{name}: {}", stderr(&o2));
        let (names, rows) = csv_series(&csv);
        let (pnames, prows) = parquet_series(&pq);
        assert_eq!(names, pnames, "{name}: the same columns in CSV and Parquet");
        let counts = names.len() - 1; // the last is the step time
        assert_eq!(names[counts], "step_s");
        let strip = |rows: &[Vec<f64>]| -> Vec<Vec<f64>> {
            rows.iter().map(|r| r[..counts].to_vec()).collect()
        };
        assert_eq!(
            strip(&rows),
            strip(&prows),
            "{name}: the same rows in CSV and Parquet"
        );
        let col = |c: &str| {
            names
                .iter()
                .position(|n| n == c)
                .unwrap_or_else(|| panic!("{c}"))
        };
        let total = |c: &str| rows.iter().map(|r| r[col(c)]).sum::<f64>() as u64;
        let stats: serde_json::Value =
            serde_json::from_slice(&std::fs::read(d.join("stats.json")).unwrap()).unwrap();
        assert_eq!(
            rows.len() as u64,
            stats["steps"].as_u64().unwrap(),
            "{name}: a row per step"
        );
        for f in stats["firings"].as_array().unwrap() {
            let rule = f["rule"].as_str().unwrap();
            assert_eq!(
                total(&format!("firings:{rule}")),
                f["firings"].as_u64().unwrap(),
                "{name}: {rule}"
            );
        }
        for (c, v) in [
            ("moves", &stats["moves"]),
            ("carried", &stats["carried"]),
            ("swaps", &stats["swaps"]),
            ("sent", &stats["messages"]["sent"]),
            ("delivered", &stats["messages"]["delivered"]),
            ("dropped", &stats["messages"]["dropped"]),
        ] {
            assert_eq!(total(c), v.as_u64().unwrap(), "{name}: {c}");
        }
        let by_kind = stats["records"]["by_kind"].as_object().unwrap();
        for n in names.iter().filter_map(|n| n.strip_prefix("records:")) {
            let want = by_kind.get(n).map_or(0, |v| v.as_u64().unwrap());
            assert_eq!(
                total(&format!("records:{n}")),
                want,
                "{name}: records of {n}"
            );
        }
        // Step by step against the trace.
        trace_agrees(name, &d.join("trace.jsonl"), &names, &rows);
        carried += total("carried");
        if name == "swaps" {
            assert_eq!(total("swaps"), 5, "the swaps of the A-B line");
        }
    }
    assert!(carried > 0, "some example carries agents");
}

/// A series file's name says its format; any other name is refused before the run.
#[test]
fn a_series_is_csv_or_parquet() {
    let out = tmp("series-bad-out.txt", b"untouched");
    let o = run(&[
        "run",
        "examples/gravity/rules.txt",
        "examples/gravity/agents.txt",
        "--out",
        out.to_str().unwrap(),
        "--series",
        tmp("series.xlsx", b"").to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr(&o)
            .contains("a series is written as CSV (a name ending in .csv) or Parquet (.parquet)"),
        "{}",
        stderr(&o)
    );
    assert_eq!(
        std::fs::read(&out).unwrap(),
        b"untouched",
        "nothing was run"
    );
}

/// `sweep --order` reaches the engine: the first agent of a line moves north and sends
/// east; with actions first its message goes to an empty cell (dropped every step), with
/// messages first the first one reaches its neighbour (derived by hand: 0 and 1 delivered
/// in 3 steps).
/// The CSV lines of a sweep table without its last column (the wall time).
fn without_wall_time(text: &str) -> Vec<String> {
    text.lines()
        .map(|l| l.rsplit_once(',').unwrap().0.to_string())
        .collect()
}

#[test]
fn sweep_shards_merged_equal_the_whole_sweep() {
    let dir = std::env::temp_dir().join(format!("latticesim-shard-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let whole = dir.join("whole.csv");
    let o = sweep_leader_election(&whole, &[]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    // Three parts, one of them Parquet, given to merge in another order.
    let parts = ["p1.csv", "p2.parquet", "p3.csv"].map(|p| dir.join(p));
    for (i, p) in parts.iter().enumerate() {
        let shard = format!("{}/3", i + 1);
        let o = sweep_leader_election(p, &["--shard", &shard]);
        assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    }
    let p1 = std::fs::read_to_string(&parts[0]).unwrap();
    let runs: Vec<&str> = p1
        .lines()
        .skip(1)
        .map(|l| l.split(',').next().unwrap())
        .collect();
    assert_eq!(runs, ["1", "4"], "part 1 of 3 holds runs 1, 4 of 4");
    for out in ["merged.csv", "merged.parquet"] {
        let merged = dir.join(out);
        let o = run(&[
            "merge",
            parts[2].to_str().unwrap(),
            parts[0].to_str().unwrap(),
            parts[1].to_str().unwrap(),
            "--out",
            merged.to_str().unwrap(),
        ]);
        assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
        assert!(stderr(&o).contains("4 runs from 3 parts"), "{}", stderr(&o));
        let back = dir.join("back.csv");
        let o = run(&[
            "merge",
            merged.to_str().unwrap(),
            "--out",
            back.to_str().unwrap(),
        ]);
        assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
        assert_eq!(
            without_wall_time(&std::fs::read_to_string(&back).unwrap()),
            without_wall_time(&std::fs::read_to_string(&whole).unwrap()),
            "{out}"
        );
    }
    // A part given twice, a missing part, a file that is no part, a bad --shard.
    let o = run(&[
        "merge",
        parts[0].to_str().unwrap(),
        parts[0].to_str().unwrap(),
        "--out",
        dir.join("x.csv").to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("run 1 is in"), "{}", stderr(&o));
    let o = run(&[
        "merge",
        parts[0].to_str().unwrap(),
        parts[2].to_str().unwrap(),
        "--out",
        dir.join("x.csv").to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(0));
    assert!(
        stderr(&o).contains("1 run is missing below the last (2)"),
        "{}",
        stderr(&o)
    );
    let o = run(&[
        "merge",
        "examples/tour/rules.txt",
        "--out",
        dir.join("x.csv").to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr(&o).contains("examples/tour/rules.txt"),
        "{}",
        stderr(&o)
    );
    let o = sweep_leader_election(&dir.join("x.csv"), &["--shard", "0/3"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr(&o).contains("from 1 to the number of parts"),
        "{}",
        stderr(&o)
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn sweep_and_render_take_the_order_of_a_step() {
    let rules = tmp("order-rules.txt", b"m\n1\nSM****\nP0,1 #E01 + 0001 0000\n");
    let dir = std::env::temp_dir().join(format!("latticesim-order-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    for (order, delivered) in [("actions-first", "0"), ("messages-first", "1")] {
        let csv = dir.join(format!("{order}.csv"));
        let o = run(&[
            "sweep",
            rules.to_str().unwrap(),
            "--shape",
            "line",
            "--sizes",
            "3",
            "--seeds",
            "1",
            "--state",
            "S0000",
            "--first-state",
            "M0000",
            "--max-steps",
            "3",
            "--order",
            order,
            "--out",
            csv.to_str().unwrap(),
        ]);
        assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
        let text = std::fs::read_to_string(&csv).unwrap();
        let mut lines = text.lines();
        let head: Vec<&str> = lines.next().unwrap().split(',').collect();
        let row: Vec<&str> = lines.next().unwrap().split(',').collect();
        let at = |c: &str| row[head.iter().position(|h| *h == c).unwrap()];
        assert_eq!((at("steps"), at("stopped_by")), ("3", "max-steps"));
        assert_eq!((at("sent"), at("delivered")), ("3", delivered), "{order}");
    }
    let agents = tmp("order-agents.txt", b"0,0 SM0000\n1,0 SS0000\n");
    for order in ["actions-first", "messages-first"] {
        let png = dir.join(format!("{order}.svg"));
        let o = run(&[
            "render",
            rules.to_str().unwrap(),
            agents.to_str().unwrap(),
            "--step",
            "1",
            "--order",
            order,
            "--static-first",
            "--out",
            png.to_str().unwrap(),
        ]);
        assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    }
}

/// The fields of a CSV line (RFC 4180 quotes).
fn csv_fields(line: &str) -> Vec<String> {
    let (mut fields, mut cur, mut quoted, mut chars) =
        (Vec::new(), String::new(), false, line.chars().peekable());
    while let Some(c) = chars.next() {
        match (c, quoted) {
            ('"', true) if chars.peek() == Some(&'"') => {
                cur.push('"');
                chars.next();
            }
            ('"', _) => quoted = !quoted,
            (',', false) => fields.push(std::mem::take(&mut cur)),
            _ => cur.push(c),
        }
    }
    fields.push(cur);
    fields
}

/// `sweep` over agents files (a folder, a pattern), over a generator command's output, and
/// with counters set by expressions: leader election on a line whose ids grow eastwards
/// (`--set C00=id+1`) takes n + 1 steps (e + 2, e = n - 1); each input is named in the
/// CSV; bad settings, failing commands and empty patterns are clear errors.
#[test]
fn sweep_runs_files_commands_and_set_counters() {
    let dir = std::env::temp_dir().join(format!("latticesim-sweep-in-{}", std::process::id()));
    let inputs = dir.join("in");
    std::fs::create_dir_all(&inputs).unwrap();
    for n in [6, 15] {
        let line: String = (0..n).map(|i| format!("{i},0 SINIT0\n")).collect();
        std::fs::write(inputs.join(format!("line-{n}.txt")), line).unwrap();
    }
    let rules = "examples/leader-election/rules.txt";
    let csv = dir.join("out.csv");
    let rows = |csv: &Path| -> Vec<(String, String, String)> {
        let text = std::fs::read_to_string(csv).unwrap();
        let mut lines = text.lines();
        let head = csv_fields(lines.next().unwrap());
        let at = |row: &[String], c: &str| row[head.iter().position(|h| h == c).unwrap()].clone();
        lines
            .map(|l| {
                let row = csv_fields(l);
                (at(&row, "n"), at(&row, "input"), at(&row, "steps"))
            })
            .collect()
    };
    let sweep = |extra: &[&str]| {
        let mut args = vec!["sweep", rules, "--out", csv.to_str().unwrap()];
        args.extend(extra);
        run(&args)
    };
    let folder = inputs.to_str().unwrap().to_string();
    let o = sweep(&["--agents", &folder, "--set", "C00=id+1"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let got = rows(&csv);
    assert_eq!(got.len(), 2);
    for (n, input, steps) in &got {
        assert!(input.ends_with(&format!("line-{n}.txt")), "{input}");
        assert_eq!(
            steps.parse::<u64>().unwrap(),
            n.parse::<u64>().unwrap() + 1,
            "{input}"
        );
    }
    let pattern = format!("{folder}/line-1*.txt");
    let o = sweep(&["--agents", &pattern, "--set", "C00 = n - id"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert_eq!(rows(&csv).len(), 1, "the pattern picks one file");
    // A command writes each run's agents: a line of {n} (or {size}) agents.
    for size in ["{n}", "{size}"] {
        let cmd =
            format!("i=0; while [ $i -lt {size} ]; do echo \"$i,0 SINIT0\"; i=$((i+1)); done");
        let o = sweep(&[
            "--agents-cmd",
            &cmd,
            "--sizes",
            "4,9",
            "--seeds",
            "2",
            "--set",
            "C00=id+seed",
        ]);
        assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    }
    let got = rows(&csv);
    assert_eq!(got.len(), 4);
    for (n, input, steps) in &got {
        assert!(
            input.contains(&format!("-lt {n} ]")),
            "the command run: {input}"
        );
        assert_eq!(
            steps,
            &(n.parse::<u64>().unwrap() + 1).to_string(),
            "{input}"
        );
    }
    // Errors.
    let o = sweep(&["--agents", &folder, "--set", "C0=id"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr(&o).contains("`C0` is not a counter"),
        "{}",
        stderr(&o)
    );
    // The rules choose 32-bit counters; `--counters 16` the paper's, and the message says
    // how to have the others.
    let o = sweep(&[
        "--agents",
        &folder,
        "--set",
        "C00=id*10000",
        "--counters",
        "16",
    ]);
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stderr(&o).contains(
            "agent 4 gets 40000, outside a counter's -32767..32767 (32-bit counters hold it"
        ),
        "{}",
        stderr(&o)
    );
    let o = sweep(&["--agents", &folder, "--set", "C00=id*1000000000"]);
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stderr(&o).contains("agent 3 gets 3000000000, outside a counter's -2147483647..2147483647"),
        "{}",
        stderr(&o)
    );
    // A run that fails does not take the others with it: here only the line of 15
    // (agent 11 gets 2200000000) fails, and the CSV holds the line of 6.
    let o = sweep(&["--agents", &folder, "--set", "C00=id*200000000"]);
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stderr(&o).contains("agent 11 gets 2200000000"),
        "{}",
        stderr(&o)
    );
    assert!(stderr(&o).contains("1 of 2 runs failed"), "{}", stderr(&o));
    let got = rows(&csv);
    assert_eq!(got.len(), 1, "{got:?}");
    assert_eq!((got[0].0.as_str(), got[0].2.as_str()), ("6", "7"));
    let o = sweep(&["--agents-cmd", "echo oops >&2; exit 3", "--sizes", "4"]);
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stderr(&o).contains("failed (exit status: 3): oops"),
        "{}",
        stderr(&o)
    );
    let o = sweep(&["--agents", &format!("{folder}/none-*.txt")]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr(&o).contains("no agents files there"),
        "{}",
        stderr(&o)
    );
}

/// `render --color-by C01`: the agents with the smallest and the largest value after three
/// steps of leader election (from `latticesim run`) are drawn in the scale's two ends
/// (viridis: #440154 and #fde725, docs/running.md), and the legend names the counter and
/// both values.
#[test]
fn render_colours_agents_by_a_counter() {
    let (rules, agents) = (
        "examples/leader-election/rules.txt",
        "examples/leader-election/agents-30.txt",
    );
    let o = run(&["run", rules, agents, "--max-steps", "3", "--quiet"]);
    let cells: Vec<(i64, i64, i64)> = String::from_utf8_lossy(&o.stdout)
        .lines()
        .map(|l| {
            let f: Vec<&str> = l.split_whitespace().collect();
            let p: Vec<i64> = f[0].split(',').map(|v| v.parse().unwrap()).collect();
            let c01 = f
                .iter()
                .position(|w| *w == "C01")
                .map_or(0, |k| f[k + 1].parse().unwrap());
            (p[0], p[1], c01)
        })
        .collect();
    let (lo, hi) = (
        cells.iter().map(|c| c.2).min().unwrap(),
        cells.iter().map(|c| c.2).max().unwrap(),
    );
    assert!(lo < hi);
    let png_path = render_ok(
        rules,
        agents,
        &["--step", "3", "--cell", "10", "--color-by", "C01"],
        "by-counter.png",
    );
    let mut reader = png::Decoder::new(std::io::BufReader::new(
        std::fs::File::open(&png_path).unwrap(),
    ))
    .read_info()
    .unwrap();
    let mut buf = vec![0; reader.output_buffer_size().unwrap()];
    let w = reader.next_frame(&mut buf).unwrap().width as i64;
    let (x0, y1) = (
        cells.iter().map(|c| c.0).min().unwrap(),
        cells.iter().map(|c| c.1).max().unwrap(),
    );
    let pixel = |x: i64, y: i64| {
        let (px, py) = ((x - x0 + 1) * 10 + 5, (y1 - y + 1) * 10 + 5);
        let i = ((py * w + px) * 3) as usize;
        [buf[i], buf[i + 1], buf[i + 2]]
    };
    for (x, y, v) in &cells {
        if *v == lo {
            assert_eq!(pixel(*x, *y), [68, 1, 84], "the smallest value, at {x},{y}");
        }
        if *v == hi {
            assert_eq!(
                pixel(*x, *y),
                [253, 231, 37],
                "the largest value, at {x},{y}"
            );
        }
    }
    let svg = render_ok(
        rules,
        agents,
        &["--step", "3", "--color-by", "C01"],
        "by-counter.svg",
    );
    let svg = std::fs::read_to_string(svg).unwrap();
    for label in [
        ">C01</text>".to_string(),
        format!(">{lo}</text>"),
        format!(">{hi}</text>"),
    ] {
        assert!(svg.contains(&label), "the legend has {label}");
    }
    let o = run(&[
        "render",
        rules,
        agents,
        "--color-by",
        "C25",
        "--out",
        tmp("x.png", b"").to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("C00 to C24"), "{}", stderr(&o));
}

/// Agents that start in a state no rule accepts, reads or sets (a typo) get W603 in
/// `check` and in `run` (whose fast reader finds them from the states it reads), on the first
/// such agent's line, with the state meant; a run whose first step fires no rule, and a
/// sweep without `--state`, say so.
#[test]
fn idle_start_states_and_runs_that_fire_nothing_are_warned_of() {
    let rules = tmp("idle-rules.txt", b"go\n1\nSINIT0\nSDONE0\n");
    let agents = tmp("idle-agents.txt", b"0,0 SINIT0\n1,0 SINTI0\n2,0 SINTI0\n");
    let (r, a) = (rules.to_str().unwrap(), agents.to_str().unwrap());
    for args in [
        vec!["check", r, "--agents", a, "--color", "never"],
        vec!["run", r, a, "--out", "/dev/null", "--color", "never"],
    ] {
        let o = run(&args);
        assert_eq!(o.status.code(), Some(0), "a warning only: {}", stderr(&o));
        let e = stderr(&o);
        assert!(
            e.contains("warning[W603]: 2 agents start in state `INTI0`"),
            "{args:?}: {e}"
        );
        assert!(e.contains("idle-agents.txt:2:5"), "{e}");
        assert!(e.contains("did you mean `SINIT0`?"), "{e}");
    }
    let quiet = tmp("quiet-rules.txt", b"go\n1\nSINIT0 N1***\nSDONE0\n");
    let o = run(&["run", quiet.to_str().unwrap(), a, "--out", "/dev/null"]);
    assert_eq!(o.status.code(), Some(0));
    assert!(
        stderr(&o).contains("warning: no rule fired in the first step"),
        "{}",
        stderr(&o)
    );
    let csv = tmp("idle-sweep.csv", b"");
    let o = run(&[
        "sweep",
        "examples/leader-election/rules.txt",
        "--sizes",
        "5,10",
        "--seeds",
        "1",
        "--out",
        csv.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(0));
    assert!(
        stderr(&o).contains("2 of 2 runs fired no rule at all"),
        "{}",
        stderr(&o)
    );
}

/// `latticesim explain`: a code's text with its wrong example's real diagnostic; the list
/// without a code; an unknown code is exit 2.
#[test]
fn explain_codes() {
    let o = run(&["explain", "e104", "--color", "never"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(out.starts_with("E104 rule-missing-line: "), "{out}");
    assert!(
        out.contains("error[E104]: the rule `grow` lacks a line"),
        "{out}"
    );
    assert!(out.contains("Right:"), "{out}");
    let o = run(&["explain"]);
    let list = String::from_utf8_lossy(&o.stdout);
    assert_eq!(
        list.lines().count(),
        1 + latticesim_grammar::Code::ALL.len()
    );
    let o = run(&["explain", "E999"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("`E999` is not a latticesim diagnostic code"));
}

/// `latticesim fmt`: `--check` names what differs (exit 1) and changes nothing; without it
/// the file is rewritten and then passes `--check`; `-` is a filter; a file with a syntax
/// error is left alone (exit 1, its errors shown).
#[test]
fn fmt_rewrites_checks_and_filters() {
    let messy = b"// keep me\r\ngrow\r\n1\r\n  N1***   E0,1 // and me\r\nC00 + C00 1\r\n\r\n\r\nstop\n2\nSDONE*\nS*****\n";
    let want =
        "// keep me\ngrow\n1\nN1*** E0,1 // and me\nC00 + C00 0001\n\nstop\n2\nSDONE*\nS*****\n";
    let p = tmp("fmt-rules.txt", messy);
    let path = p.to_str().unwrap();
    let o = run(&["fmt", "--check", path]);
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stderr(&o).contains(":1: not in the canonical layout"),
        "{}",
        stderr(&o)
    );
    assert_eq!(std::fs::read(&p).unwrap(), messy);
    let o = run(&["fmt", path]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(std::fs::read_to_string(&p).unwrap(), want);
    assert!(run(&["fmt", "--check", path]).status.success());
    let mut child = bin()
        .args(["fmt", "-"])
        .stdin(std::process::Stdio::piped())
        .stdout(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    use std::io::Write;
    child.stdin.take().unwrap().write_all(messy).unwrap();
    let o = child.wait_with_output().unwrap();
    assert_eq!(String::from_utf8_lossy(&o.stdout), want);
    let broken = tmp("fmt-broken.txt", b"r\n1\nE1,\nS*****\n");
    let o = run(&["fmt", broken.to_str().unwrap(), "--color", "never"]);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("error[E202]"), "{}", stderr(&o));
    assert_eq!(std::fs::read(&broken).unwrap(), b"r\n1\nE1,\nS*****\n");
}

/// Lint levels (docs/language.md, "Lint levels"): `--allow`, `--warn`, `--deny` on
/// `check`, `run`, `sweep`, `render` and `serve`, and directives in the rules file; a
/// denied warning fails the command (exit 1) and says where it was denied; a level for an
/// error or an unknown code is a usage error (exit 2); a directive that cannot be read is
/// E106.
#[test]
fn lint_levels_allow_warn_and_deny_warnings() {
    let rules = tmp(
        "lint-rules.txt",
        b"walk\n1\nSWALK0 N**0* >C01 0000\nP1,0 C01 - C01 0001\n",
    );
    let mut walls = String::new();
    for x in 0..30 {
        for y in 0..30 {
            walls += &format!("{x},{y} SWALL0\n");
        }
    }
    walls += "0,31 SWALK0 C01 5\n";
    let agents = tmp("lint-walls.txt", walls.as_bytes());
    let (r, a) = (rules.to_str().unwrap(), agents.to_str().unwrap());
    let png = std::env::temp_dir().join(format!("lint-{}.png", std::process::id()));
    let png = png.to_str().unwrap();
    let check = |extra: &[&str]| {
        let mut args = vec!["check", r, "--agents", a, "--color", "never"];
        args.extend(extra);
        run(&args)
    };
    let o = check(&[]);
    assert_eq!(o.status.code(), Some(0));
    assert!(
        stderr(&o).contains("warning[W603]: 900 agents"),
        "{}",
        stderr(&o)
    );
    // 900 walls beside one walker are not a slip of `WALK0`: no "did you mean".
    assert!(!stderr(&o).contains("did you mean"), "{}", stderr(&o));
    let o = check(&["--deny", "W603"]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    let e = stderr(&o);
    assert!(e.contains("error[W603]: 900 agents"), "{e}");
    assert!(
        e.contains("= note: a warning made an error by `--deny W603`"),
        "{e}"
    );
    assert!(e.contains("1 error, 0 warnings"), "{e}");
    for allow in ["W603", "idle-start-state", "warnings"] {
        let o = check(&["--allow", allow]);
        assert_eq!(o.status.code(), Some(0));
        assert!(
            !stderr(&o).contains("W603"),
            "--allow {allow}: {}",
            stderr(&o)
        );
    }
    // A code's level wins over `warnings`'; --deny over --warn over --allow for one code.
    let o = check(&["--deny", "warnings", "--allow", "W603"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let o = check(&["--allow", "W603", "--deny", "W603"]);
    assert_eq!(o.status.code(), Some(1));
    for (cmd, extra) in [
        ("run", vec![r, a, "--out", "/dev/null"]),
        ("render", vec![r, a, "--out", png]),
    ] {
        let mut args = vec![cmd];
        args.extend(extra.iter().copied());
        let ok = run(&args);
        assert_eq!(ok.status.code(), Some(0), "{cmd}: {}", stderr(&ok));
        args.extend(["--deny", "warnings"]);
        let o = run(&args);
        assert_eq!(
            o.status.code(),
            Some(1),
            "{cmd} --deny warnings: {}",
            stderr(&o)
        );
        assert!(stderr(&o).contains("error[W603]"), "{cmd}: {}", stderr(&o));
    }
    let csv = std::env::temp_dir().join(format!("lint-{}.csv", std::process::id()));
    let sweep = |extra: &[&str]| {
        let mut args = vec![
            "sweep", r, "--shape", "line", "--sizes", "5", "--seeds", "1",
        ];
        args.extend(["--out", csv.to_str().unwrap()]);
        args.extend(extra);
        run(&args)
    };
    assert_eq!(sweep(&[]).status.code(), Some(0));
    let o = sweep(&["--deny", "idle-start-state"]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(stderr(&o).contains("error[W603]"), "{}", stderr(&o));
    // Levels for errors and unknown codes: usage errors, on every command.
    for args in [
        vec!["check", r, "--deny", "E302"],
        vec!["run", r, a, "--allow", "W999"],
        vec!["serve", "--warn", "nonsense"],
    ] {
        let o = run(&args);
        assert_eq!(o.status.code(), Some(2), "{args:?}");
        assert!(
            stderr(&o).starts_with("error: --"),
            "{args:?}: {}",
            stderr(&o)
        );
    }
    // Directives in the rules file; the command line comes after them.
    let said = tmp(
        "lint-said.txt",
        b"// latticesim: allow W603\nwalk\n1\nSWALK0 N**0* >C01 0000\nP1,0 C01 - C01 0001\n",
    );
    let s = said.to_str().unwrap();
    let o = run(&["check", s, "--agents", a]);
    assert_eq!(o.status.code(), Some(0));
    assert!(!stderr(&o).contains("W603"), "{}", stderr(&o));
    let o = run(&["check", s, "--agents", a, "--deny", "W603"]);
    assert_eq!(o.status.code(), Some(1));
    let bad = tmp(
        "lint-bad.txt",
        b"// latticesim: forbid W603\nwalk\n1\nSWALK0 N**0* >C01 0000\nP1,0 C01 - C01 0001\n",
    );
    let o = run(&[
        "check",
        bad.to_str().unwrap(),
        "--agents",
        a,
        "--color",
        "never",
    ]);
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stderr(&o).contains("error[E106]: `forbid` is not a lint level"),
        "{}",
        stderr(&o)
    );
}

/// 32-bit counters: ids past 32,767 from `gen`, which the rules file's directive (or
/// `--counters 32`) runs, and which without it are E404 naming the extension; checkpoints
/// record the width.
#[test]
fn counters_of_32_bits_elect_a_leader_past_32767_agents() {
    let dir = std::env::temp_dir().join(format!("latticesim-wide-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let p = |f: &str| dir.join(f).to_str().unwrap().to_string();
    let (agents, out, ckpt) = (p("ids.txt"), p("out.txt"), p("run.ckpt"));
    let o = run(&[
        "gen",
        "connected",
        "--n",
        "40000",
        "--seed",
        "5",
        "--state",
        "INIT0",
        "--ids",
        "C00",
        "--out",
        &agents,
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("need 32-bit counters"),
        "{}",
        stderr(&o)
    );
    let le = "examples/leader-election/rules.txt";
    let o = run(&["run", le, &agents, "--out", &out, "--checkpoint", &ckpt]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let text = std::fs::read_to_string(&out).unwrap();
    let leaders: Vec<&str> = text.lines().filter(|l| l.contains("SLEAD0")).collect();
    assert_eq!(leaders.len(), 1, "{leaders:?}");
    assert!(
        leaders[0].ends_with("C00 40000 C01 40000"),
        "{}",
        leaders[0]
    );
    // The paper's width: E404, which names the extension.
    let o = run(&[
        "check",
        le,
        "--agents",
        &agents,
        "--counters",
        "16",
        "--color",
        "never",
    ]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(stderr(&o).contains("error[E404]"), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("`// latticesim: counters 32`"),
        "{}",
        stderr(&o)
    );
    // Rules without the directive, and the flag instead.
    let plain = tmp(
        "wide-plain.txt",
        std::fs::read_to_string(le)
            .unwrap()
            .replace("// latticesim: counters 32", "")
            .as_bytes(),
    );
    let plain = plain.to_str().unwrap();
    let o = run(&["check", plain, "--agents", &agents, "--color", "never"]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    let o = run(&["check", plain, "--agents", &agents, "--counters", "32"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    // The checkpoint says its width: resumed as it was made, refused in another.
    let o = run(&[
        "run",
        le,
        "--resume",
        &ckpt,
        "--max-steps",
        "1",
        "--out",
        &out,
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(std::fs::read_to_string(&out)
        .unwrap()
        .contains("C00 40000 C01 40000"));
    let o = run(&["run", le, "--resume", &ckpt, "--counters", "16"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("32-bit counters"), "{}", stderr(&o));
    // More ids than a counter holds: refused before anything is written.
    let o = run(&["gen", "line", "--n", "3000000000", "--ids", "C00"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let _ = std::fs::remove_dir_all(&dir);
}

/// Every help text shows what its source says: no code span cut in two (clap turns `{n}`
/// into a line break), no line that is only the end of a parenthesis cut off.
#[test]
fn help_texts_are_whole() {
    let o = run(&["--help"]);
    let top = String::from_utf8_lossy(&o.stdout).to_string();
    let mut commands: Vec<String> = top
        .lines()
        .skip_while(|l| !l.starts_with("Commands:"))
        .skip(1)
        .take_while(|l| l.starts_with("  "))
        .filter_map(|l| l.split_whitespace().next().map(str::to_string))
        .filter(|c| c != "help")
        .collect();
    assert!(commands.len() >= 10, "{top}");
    commands.push(String::new());
    for c in &commands {
        let args: Vec<&str> = [c.as_str(), "--help"]
            .into_iter()
            .filter(|a| !a.is_empty())
            .collect();
        let o = run(&args);
        assert_eq!(o.status.code(), Some(0), "{c}");
        let help = String::from_utf8_lossy(&o.stdout).to_string();
        for line in help.lines() {
            assert_eq!(
                line.matches('`').count() % 2,
                0,
                "`latticesim {c} --help`: a code span cut: {line:?}"
            );
            assert_ne!(
                line.trim(),
                ")",
                "`latticesim {c} --help`: a line cut: {line:?}"
            );
        }
    }
}

/// examples/mistakes: each comment names its mistakes; each gives its diagnostic.
#[test]
fn the_mistakes_example_gives_what_its_comments_promise() {
    let o = run(&[
        "check",
        "examples/mistakes/rules.txt",
        "--agents",
        "examples/tour/agents.txt",
    ]);
    assert_eq!(o.status.code(), Some(1));
    let err = stderr(&o);
    for code in [
        "error[E302]",
        "error[E204]",
        "error[E315]",
        "error[E309]",
        "error[E312]",
        "error[E303]",
        "warning[W502]",
    ] {
        assert!(err.contains(code), "{code} missing:\n{err}");
    }
    assert!(err.ends_with("6 errors, 1 warning\n"), "{err}");
}

/// Runs the program with a deadline: its status and standard error, or a panic when it
/// does not end in `secs`.
fn run_within(args: &[&str], secs: u64) -> (Option<i32>, String) {
    use std::io::Read;
    let mut child = bin()
        .args(args)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let mut err = child.stderr.take().unwrap();
    let reader = std::thread::spawn(move || {
        let mut s = String::new();
        let _ = err.read_to_string(&mut s);
        s
    });
    let deadline = std::time::Instant::now() + std::time::Duration::from_secs(secs);
    loop {
        if let Some(status) = child.try_wait().unwrap() {
            return (status.code(), reader.join().unwrap());
        }
        if std::time::Instant::now() > deadline {
            let _ = child.kill();
            panic!("`latticesim {}` did not end in {secs} s", args.join(" "));
        }
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
}

/// A full disk (`/dev/full`) under `--out`: a clear message and exit 2, in bounded time,
/// with the output written by two threads (it hung: the formatting thread waited forever
/// on a writer that had failed).
#[test]
fn a_full_disk_ends_the_run_with_a_message() {
    if !std::path::Path::new("/dev/full").exists() {
        return;
    }
    let agents = tmp("full-disk-agents.txt", b"");
    let a = agents.to_str().unwrap();
    let o = run(&[
        "gen", "block", "--width", "300", "--height", "300", "--out", a,
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    for threads in ["1", "2"] {
        let (code, err) = run_within(
            &[
                "run",
                "examples/gravity/rules.txt",
                a,
                "--max-steps",
                "1",
                "--threads",
                threads,
                "--out",
                "/dev/full",
            ],
            60,
        );
        assert_eq!(code, Some(2), "{err}");
        assert!(
            err.contains("cannot write `/dev/full`") && err.contains("No space left"),
            "{err}"
        );
    }
}

/// The summary line gives the time to write checkpoints, and a resumed run's own counts
/// before its totals since step 0.
#[test]
fn the_summary_says_checkpoint_time_and_what_a_resumed_run_did() {
    let ckpt = tmp("summary.ckpt", b"");
    let c = ckpt.to_str().unwrap();
    let g = ["examples/gravity/rules.txt", "examples/gravity/agents.txt"];
    let o = run(&["run", g[0], g[1], "--max-steps", "3", "--checkpoint", c]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let err = stderr(&o);
    assert!(
        err.contains("45 agents, 3 steps, stopped at --max-steps 3: 90 rule firings"),
        "{err}"
    );
    assert!(err.contains(", checkpoint 0."), "{err}");
    let o = run(&["run", g[0], "--resume", c]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let err = stderr(&o);
    assert!(
        err.contains(
            "45 agents, resumed at step 3, 7 steps, quiescent: 103 rule firings, 103 moves"
        ) && err.contains("; since step 0: 10 steps, 193 rule firings, 193 moves"),
        "{err}"
    );
    assert!(
        !err.contains("checkpoint 0."),
        "no checkpoint asked for: {err}"
    );
}

/// `sweep` draws its progress bar only on a terminal: with standard error a pipe (or
/// with `-q`), no bar.
#[test]
fn sweep_shows_no_progress_bar_off_a_terminal() {
    let out = tmp("sweep-quiet.csv", b"");
    for q in [&[][..], &["-q"][..]] {
        let mut args = vec![
            "sweep",
            "examples/leader-election/rules.txt",
            "--sizes",
            "5,10",
            "--seeds",
            "2",
            "--state",
            "INIT0",
            "--ids",
            "C00",
            "--out",
            out.to_str().unwrap(),
        ];
        args.extend(q);
        let o = run(&args);
        assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
        assert!(!stderr(&o).contains("runs ["), "{}", stderr(&o));
    }
}

/// A temporary file left by a killed run (`.NAME.PID.N.tmp`, its process gone) is removed,
/// and said, by the next write of that name; one of a process that runs is kept.
#[test]
fn temporary_files_of_killed_runs_are_removed_by_the_next_write() {
    let dir = std::env::temp_dir().join(format!("latticesim-stale-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let out = dir.join("out.txt");
    let stale = dir.join(".out.txt.999999999.0.tmp");
    let live = dir.join(format!(".out.txt.{}.0.tmp", std::process::id()));
    let other = dir.join(".other.txt.999999999.0.tmp");
    for f in [&stale, &live, &other] {
        std::fs::write(f, b"half").unwrap();
    }
    let o = run(&["gen", "line", "--n", "3", "--out", out.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(!stale.exists(), "the killed run's file is removed");
    assert!(stderr(&o).contains("process 999999999"), "{}", stderr(&o));
    assert!(
        live.exists() && other.exists(),
        "a live run's and another name's are kept"
    );
    assert_eq!(std::fs::read_to_string(&out).unwrap().lines().count(), 3);
}

/// `gen --depth` without `--dim 3` is refused (it wrote a 2D file); a saturation record
/// with 32-bit counters names their range.
#[test]
fn depth_needs_3d_and_saturation_names_the_width() {
    let o = run(&[
        "gen", "block", "--width", "3", "--height", "3", "--depth", "3",
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr(&o).contains("--depth 3 is for 3D shapes: add --dim 3"),
        "{}",
        stderr(&o)
    );
    let o = run(&[
        "gen", "block", "--width", "3", "--height", "3", "--depth", "3", "--dim", "3",
    ]);
    assert_eq!(o.status.code(), Some(0));
    assert_eq!(
        String::from_utf8_lossy(&o.stdout).lines().next(),
        Some("0,0,0")
    );
    let rules = tmp(
        "near-range.txt",
        b"inc\n1\n<C00 2147483647\nC00 + C00 1000000000\n\n// latticesim: counters 32\n",
    );
    let agents = tmp("near-range-agents.txt", b"0,0 C00 2147483000\n");
    let o = run(&[
        "run",
        rules.to_str().unwrap(),
        agents.to_str().unwrap(),
        "--max-steps",
        "3",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("the result 3147483000 is saturated to the 32-bit range"),
        "{}",
        stderr(&o)
    );
    assert_eq!(String::from_utf8_lossy(&o.stdout), "0,0 C00 2147483647\n");
}

/// docs/running.md's example of agents kept in space order, run as a script as a user
/// runs it (bash, `latticesim` on the PATH, the repository's `examples/` beside it), with
/// the cloud made smaller (70,000 agents in 483 x 483 for 10^6 in 1825 x 1825, still above
/// the 65,536 agents from which the order is kept): the run says it kept the agents in
/// space order, and its final configuration is the file-order run's, byte for byte (the
/// script's own `grep` and `cmp`); the agents fell.
#[test]
fn the_space_order_example_of_the_docs_runs_as_a_script() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let doc = std::fs::read_to_string(root.join("docs/running.md")).unwrap();
    let block = (doc.split("```sh\n").skip(1))
        .filter_map(|b| b.split("```").next())
        .find(|b| b.contains("--file-order"))
        .expect("docs/running.md has the space-order example");
    let big = "--n 1000000 --width 1825 --height 1825";
    assert!(block.contains(big), "the example's sizes changed:\n{block}");
    let script = block.replace(big, "--n 70000 --width 483 --height 483");
    let dir = std::env::temp_dir().join(format!("latticesim-space-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    std::os::unix::fs::symlink(root.join("examples"), dir.join("examples")).unwrap();
    std::fs::write(dir.join("example.sh"), &script).unwrap();
    let bin_dir = Path::new(env!("CARGO_BIN_EXE_latticesim"))
        .parent()
        .unwrap();
    let path = format!(
        "{}:{}",
        bin_dir.display(),
        std::env::var("PATH").unwrap_or_default()
    );
    let o = Command::new("bash")
        .args(["-e", "-o", "pipefail", "example.sh"])
        .current_dir(&dir)
        .env("PATH", path)
        .output()
        .unwrap();
    assert!(o.status.success(), "{script}\n{}", stderr(&o));
    let read = |name: &str| std::fs::read_to_string(dir.join(name)).unwrap();
    let (cloud, end) = (read("cloud.txt"), read("end.txt"));
    assert_eq!(cloud.lines().count(), 70_000);
    assert_eq!(end, read("end-file-order.txt"));
    assert_ne!(cloud, end, "the agents fell");
    std::fs::remove_dir_all(&dir).unwrap();
}
