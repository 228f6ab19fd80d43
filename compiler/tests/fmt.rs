//! `latticesim fmt` round-trips every rules file of the repository: formatting, then
//! checking, gives the same checked program (the same bytecode, names and priorities), and
//! formatting twice gives the same text. Generated rules are covered by the differential
//! tests (runtime/tests/differential.rs), the fuzz tests by tests/robust.rs.

use latticesim_compiler::{check, format_rules, lower, Input};
use std::path::{Path, PathBuf};

fn rules_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if p.is_dir() {
            rules_files(&p, out);
        } else if p
            .file_name()
            .is_some_and(|n| n.to_string_lossy().starts_with("rules"))
        {
            out.push(p);
        }
    }
}

fn program(text: &str) -> Option<String> {
    let c = check(
        Input {
            name: "rules.txt",
            bytes: text.as_bytes(),
        },
        None,
        None,
    );
    c.rules.as_ref().map(|r| lower(r).disassemble())
}

#[test]
fn formatting_keeps_the_program_and_is_idempotent() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let mut files = Vec::new();
    for d in ["examples", "compiler/tests/golden", "compiler/tests/slips"] {
        rules_files(&root.join(d), &mut files);
    }
    let mut formatted_count = 0;
    for f in &files {
        let Ok(text) = std::fs::read_to_string(f) else {
            continue;
        };
        let Ok(once) = format_rules(&text, None) else {
            continue;
        };
        formatted_count += 1;
        let twice = format_rules(&once, None).expect("a formatted file reads");
        assert_eq!(once, twice, "{}: formatting twice changes it", f.display());
        assert_eq!(
            program(&text),
            program(&once),
            "{}: formatting changed the checked program",
            f.display()
        );
    }
    assert!(
        formatted_count >= 80,
        "only {formatted_count} files were formatted"
    );
}
