//! The single-slip corpus: every case under `tests/slips/` is an example of `examples/`
//! with one mistake (written by `tests/slips/make.py`). Each must give exactly one
//! diagnostic, with the code and on the line its `slip` file names; where a fix is
//! expected, applying it must give files that check clean (and, for most, give back the
//! example as it was); where none is, none is offered. `expected.txt` holds the rendered output
//! (`UPDATE_GOLDEN=1 cargo test -p latticesim-compiler --test slips` rewrites it).

mod common;

use common::{dim_of, run_bytes};
use latticesim_compiler::diagnostics::{render_plain, to_json};
use std::fs;
use std::path::{Path, PathBuf};

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn cases() -> Vec<PathBuf> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/slips");
    let mut v: Vec<PathBuf> = fs::read_dir(&dir)
        .expect("tests/slips exists")
        .map(|e| e.unwrap().path())
        .filter(|p| p.is_dir())
        .collect();
    v.sort();
    v
}

struct Slip {
    file: String,
    line: usize,
    code: String,
    fix: String,
    base: String,
}

fn slip(case: &Path) -> Slip {
    let text = fs::read_to_string(case.join("slip")).expect("every case has a slip file");
    let field = |k: &str| {
        text.lines()
            .find_map(|l| l.strip_prefix(k).map(|v| v.trim().to_string()))
            .unwrap_or_else(|| panic!("{}: no `{k}` in slip", case.display()))
    };
    Slip {
        file: field("file "),
        line: field("line ").parse().expect("a line number"),
        code: field("code "),
        fix: field("fix "),
        base: field("base "),
    }
}

#[test]
fn every_slip_gives_one_diagnostic_on_its_line_with_its_fix() {
    let update = std::env::var_os("UPDATE_GOLDEN").is_some();
    let cases = cases();
    assert!(cases.len() >= 60, "the corpus has {} cases", cases.len());
    let mut failures = Vec::new();
    for case in &cases {
        let name = case.file_name().unwrap().to_string_lossy().to_string();
        let s = slip(case);
        let rules = fs::read(case.join("rules.txt")).unwrap();
        let agents = fs::read(case.join("agents.txt")).unwrap();
        let dim = dim_of(case);
        let c = run_bytes(&rules, Some(&agents), dim);
        let rendered = render_plain(&c.diags, &c.sources);
        if c.diags.len() != 1 || c.errors() + c.warnings() != 1 {
            failures.push(format!(
                "{name}: {} diagnostics, not 1:\n{rendered}",
                c.diags.len()
            ));
            continue;
        }
        let d = &c.diags[0];
        let json = &to_json(&c.diags, &c.sources)[0];
        if d.code.as_str() != s.code || json.file != s.file || json.line != s.line {
            failures.push(format!(
                "{name}: {} at {}:{}, expected {} at {}:{}\n{rendered}",
                d.code.as_str(),
                json.file,
                json.line,
                s.code,
                s.file,
                s.line
            ));
            continue;
        }
        match s.fix.as_str() {
            "restores" | "clean" => {
                let Some(fix) = d.fixes.first() else {
                    failures.push(format!("{name}: no fix offered\n{rendered}"));
                    continue;
                };
                let file = d.primary.file;
                let fixed = fix.apply(c.sources.text(file), file);
                let base = fs::read_to_string(root().join(&s.base)).unwrap();
                if s.fix == "restores" && fixed != base {
                    failures.push(format!("{name}: the fix does not give back {}", s.base));
                    continue;
                }
                let (r, a) = if s.file == "rules.txt" {
                    (fixed.into_bytes(), agents.clone())
                } else {
                    (rules.clone(), fixed.into_bytes())
                };
                let again = run_bytes(&r, Some(&a), dim);
                if !again.diags.is_empty() {
                    failures.push(format!("{name}: the fixed files do not check clean"));
                    continue;
                }
                // The JSON carries the same edit.
                let e = &json.fixes[0].edits[0];
                assert_eq!(e.replacement, fix.edits[0].replacement, "{name}");
            }
            "none" => {
                if !d.fixes.is_empty() {
                    failures.push(format!(
                        "{name}: a fix offered where none is right\n{rendered}"
                    ));
                    continue;
                }
            }
            other => panic!("{name}: unknown fix expectation `{other}`"),
        }
        let expected_path = case.join("expected.txt");
        if update {
            fs::write(&expected_path, &rendered).unwrap();
        } else if fs::read_to_string(&expected_path).unwrap_or_default() != rendered {
            failures.push(format!(
                "{name}: output differs from expected.txt (UPDATE_GOLDEN=1 rewrites it):\n{rendered}"
            ));
        }
    }
    assert!(
        failures.is_empty(),
        "{} of {} cases fail:\n\n{}",
        failures.len(),
        cases.len(),
        failures.join("\n\n")
    );
}
