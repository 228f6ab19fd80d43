//! Golden files for rendered diagnostics: one folder per case under `tests/golden/`, named
//! after the code it shows (`E302-pattern-length`), holding `rules.txt`, optionally
//! `agents.txt` and `args` (`dim=3`), and `expected.txt`, the exact plain output.
//!
//! Regenerate with `UPDATE_GOLDEN=1 cargo test -p latticesim-compiler --test golden`.

mod common;

use common::{dim_of, run, run_bytes};
use latticesim_compiler::diagnostics::render_plain;
use latticesim_grammar::Code;
use std::fs;
use std::path::{Path, PathBuf};

const HEADER: &str =
    "// Rendered by `latticesim check`; regenerate with UPDATE_GOLDEN=1 cargo test -p latticesim-compiler --test golden\n";

fn cases() -> Vec<PathBuf> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/golden");
    let mut v: Vec<PathBuf> = fs::read_dir(&dir)
        .expect("tests/golden exists")
        .map(|e| e.unwrap().path())
        .filter(|p| p.is_dir())
        .collect();
    v.sort();
    v
}

fn render(case: &Path) -> (String, Vec<Code>) {
    let rules = fs::read(case.join("rules.txt")).expect("every case has rules.txt");
    let agents = fs::read(case.join("agents.txt")).ok();
    let c = run_bytes(&rules, agents.as_deref(), dim_of(case));
    for d in &c.diags {
        assert!(
            d.help.is_some(),
            "{}: {:?} has no help line",
            case.display(),
            d.code
        );
        for l in std::iter::once(&d.primary).chain(&d.secondary) {
            let len = c.sources.text(l.file).len() as u32;
            assert!(
                l.span.start <= l.span.end && l.span.end <= len,
                "{}: span outside its file",
                case.display()
            );
        }
    }
    let mut out = String::from(HEADER);
    out += &render_plain(&c.diags, &c.sources);
    out += &format!("errors: {}, warnings: {}\n", c.errors(), c.warnings());
    (out, c.diags.iter().map(|d| d.code).collect())
}

#[test]
fn golden_files_match() {
    let update = std::env::var_os("UPDATE_GOLDEN").is_some();
    let mut failures = Vec::new();
    for case in cases() {
        let (got, codes) = render(&case);
        let name = case.file_name().unwrap().to_string_lossy().to_string();
        let code = Code::parse(&name[..4])
            .unwrap_or_else(|| panic!("{name}: folder must start with a code"));
        assert!(
            codes.contains(&code),
            "{name}: the case does not produce {code:?}, only {codes:?}"
        );
        let path = case.join("expected.txt");
        if update {
            fs::write(&path, &got).unwrap();
            continue;
        }
        match fs::read_to_string(&path) {
            Ok(want) if want == got => {}
            Ok(want) => failures.push(format!("{name}:\n--- expected\n{want}\n--- got\n{got}")),
            Err(_) => failures.push(format!("{name}: no expected.txt; run with UPDATE_GOLDEN=1")),
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn every_code_has_a_golden_case() {
    let names: Vec<String> = cases()
        .iter()
        .map(|p| p.file_name().unwrap().to_string_lossy().to_string())
        .collect();
    let missing: Vec<&str> = Code::ALL
        .iter()
        .map(|c| c.as_str())
        .filter(|c| !names.iter().any(|n| n.starts_with(c)))
        .collect();
    assert!(
        missing.is_empty(),
        "codes without a golden case: {missing:?}"
    );
}

/// The diagnostics section of docs/language.md is generated from the explanations
/// (`compiler/src/explain.md`, also shown by `latticesim explain`), with the output each
/// wrong example really gives. Regenerate with UPDATE_GOLDEN=1.
#[test]
fn language_reference_lists_every_code() {
    let doc_path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../docs/language.md");
    let doc = fs::read_to_string(&doc_path).expect("docs/language.md exists");
    let (begin, end) = ("<!-- BEGIN DIAGNOSTICS -->\n", "<!-- END DIAGNOSTICS -->");
    let a = doc.find(begin).expect("begin marker") + begin.len();
    let b = doc.find(end).expect("end marker");
    let mut section = String::new();
    for e in latticesim_compiler::explain::all() {
        section += &latticesim_compiler::explain::markdown(&e);
    }
    if std::env::var_os("UPDATE_GOLDEN").is_some() {
        let new = format!("{}{}{}", &doc[..a], section, &doc[b..]);
        fs::write(&doc_path, new).unwrap();
        return;
    }
    assert!(doc[a..b] == section, "docs/language.md is out of date: run UPDATE_GOLDEN=1 cargo test -p latticesim-compiler --test golden");
}

/// Every fix of every diagnostic of every golden case, applied alone, gives files with
/// fewer diagnostics of that code and no more errors than before (a fix never makes a file
/// worse; where a case shows one slip, it checks clean after its fix).
#[test]
fn every_fix_of_every_case_applies() {
    let mut applied = 0;
    let mut failures = Vec::new();
    for case in cases() {
        let name = case.file_name().unwrap().to_string_lossy().to_string();
        let Ok(rules) = fs::read_to_string(case.join("rules.txt")) else {
            continue; // not UTF-8: no fix edits it
        };
        let agents = fs::read_to_string(case.join("agents.txt")).ok();
        let dim = dim_of(&case);
        let run = |rules: &str, agents: Option<&str>| run(rules, agents, dim);
        let before = run(&rules, agents.as_deref());
        let count = |c: &latticesim_compiler::Checked, code: Code| {
            let shown = c.diags.iter().filter(|d| d.code == code).count();
            let hidden: usize = (c.not_shown.iter())
                .flat_map(|n| n.codes.iter())
                .filter(|(k, _)| *k == code)
                .map(|(_, n)| *n)
                .sum();
            shown + hidden
        };
        for d in &before.diags {
            for f in &d.fixes {
                let r = f.apply(&rules, latticesim_grammar::FileId(0));
                let a = agents
                    .as_deref()
                    .map(|a| f.apply(a, latticesim_grammar::FileId(1)));
                let after = run(&r, a.as_deref());
                applied += 1;
                if count(&after, d.code) >= count(&before, d.code)
                    || after.errors() > before.errors()
                {
                    failures.push(format!(
                        "{name}: the fix `{}` of {:?} leaves:\n{}",
                        f.message,
                        d.code,
                        after.render(false)
                    ));
                }
            }
        }
    }
    assert!(applied >= 8, "only {applied} fixes applied");
    assert!(failures.is_empty(), "{}", failures.join("\n\n"));
}
