//! No input makes the parsers or the checker panic, and every reported span lies inside its
//! file: random bytes, random token sequences, and mutated valid files.

mod common;

use latticesim_compiler::{Checked, Dim};
use proptest::prelude::*;

fn run(rules: &[u8], agents: Option<&[u8]>, dim: Option<Dim>) -> Checked {
    let c = common::run_bytes(rules, agents, dim);
    for d in &c.diags {
        for l in std::iter::once(&d.primary).chain(&d.secondary) {
            let text = c.sources.text(l.file);
            assert!(
                l.span.start <= l.span.end && (l.span.end as usize) <= text.len(),
                "{:?} span {:?} outside its file of {} bytes",
                d.code,
                l.span,
                text.len()
            );
            assert!(
                text.is_char_boundary(l.span.start as usize)
                    && text.is_char_boundary(l.span.end as usize)
            );
        }
        assert!(d.help.is_some(), "{:?} has no help", d.code);
    }
    // A program that passed the checks lowers to bytecode that verifies.
    if let Some(p) = &c.rules {
        assert_eq!(latticesim_compiler::lower(p).verify(), Ok(()));
    }
    // Rendering must not fail either.
    let _ = latticesim_compiler::diagnostics::render_plain(&c.diags, &c.sources);
    let _ = latticesim_compiler::diagnostics::to_json(&c.diags, &c.sources);
    c
}

/// A blank after a pattern's letter, before a character of two bytes (found by
/// `random_token_lines`): the pattern's span is counted from its end, so the character's
/// label is the character.
#[test]
fn a_blank_after_the_letter_keeps_the_pattern_span() {
    let c = run(
        "N \nN \nS \u{e9}Q1,1 \nN \n".as_bytes(),
        None,
        Some(Dim::Two),
    );
    let e304 = c
        .diags
        .iter()
        .find(|d| d.code.as_str() == "E304")
        .expect("E304");
    let text = c.sources.text(e304.primary.file);
    let span = e304.primary.span;
    assert_eq!(&text[span.start as usize..span.end as usize], "\u{e9}");
}

/// `latticesim fmt` on any input: no panic; what it formats, it formats to a fixed point
/// that reads without errors.
fn fmt_holds(bytes: &[u8]) {
    let text = String::from_utf8_lossy(bytes);
    if let Ok(once) = latticesim_compiler::format_rules(&text, None) {
        let twice = latticesim_compiler::format_rules(&once, None);
        assert_eq!(twice.as_deref(), Ok(once.as_str()), "{text:?}");
    }
}

const FRAGMENTS: &[&str] = &[
    "N",
    "N1*0*",
    "N1*0*1*",
    "A",
    "A1*+*",
    "P",
    "P<=**",
    "P1,0",
    "S",
    "SAB)CD",
    "S*****",
    "M",
    "M*",
    "MNhello",
    "MAx",
    "E",
    "E1,0",
    "E-1,C03",
    "F0,1,0",
    "L",
    "Q1,1",
    "T1,0,ABCDE",
    "T1,0,0,",
    "T",
    "V1,0,C03",
    "W",
    "X",
    "XN",
    "XZZ",
    "C",
    "C00",
    "C5",
    "C99",
    "#",
    "#N01",
    "#*01",
    "#Q9",
    "0010",
    "-0005",
    "99999999999999999999",
    "+",
    "-",
    "*",
    "/",
    "I",
    "<",
    ">",
    "=",
    "!",
    "(",
    ")",
    ",",
    ",,",
    "?",
    "é",
    "\t",
    "//",
    "\r",
];

fn token_line() -> impl Strategy<Value = String> {
    proptest::collection::vec(
        (proptest::sample::select(FRAGMENTS), proptest::bool::ANY),
        0..12,
    )
    .prop_map(|v| {
        v.into_iter()
            .map(|(t, glue)| if glue { t.to_string() } else { format!("{t} ") })
            .collect()
    })
}

fn seeds() -> Vec<Vec<u8>> {
    let root = concat!(env!("CARGO_MANIFEST_DIR"), "/..");
    let mut out = Vec::new();
    for dir in ["examples/maxflood", "examples/gravity", "examples/tour"] {
        for f in ["rules.txt", "agents.txt"] {
            if let Ok(b) = std::fs::read(format!("{root}/{dir}/{f}")) {
                out.push(b);
            }
        }
    }
    assert!(out.len() >= 4, "example files are missing");
    out
}

#[derive(Debug, Clone)]
enum Edit {
    Delete(usize),
    Insert(usize, u8),
    Replace(usize, u8),
    Duplicate(usize, usize),
}

fn apply(mut b: Vec<u8>, edits: &[Edit]) -> Vec<u8> {
    for e in edits {
        if b.is_empty() {
            break;
        }
        match *e {
            Edit::Delete(i) => {
                b.remove(i % b.len());
            }
            Edit::Insert(i, c) => b.insert(i % (b.len() + 1), c),
            Edit::Replace(i, c) => {
                let n = b.len();
                b[i % n] = c;
            }
            Edit::Duplicate(i, n) => {
                let s = i % b.len();
                let e = (s + n).min(b.len());
                let piece = b[s..e].to_vec();
                b.splice(s..s, piece);
            }
        }
    }
    b
}

fn edit() -> impl Strategy<Value = Edit> {
    let byte = prop_oneof![
        proptest::sample::select(b" \n,*()!#-0123456789CNAPSMTXEFLQVW<>=+/".to_vec()),
        any::<u8>()
    ];
    prop_oneof![
        any::<usize>().prop_map(Edit::Delete),
        (any::<usize>(), byte.clone()).prop_map(|(i, c)| Edit::Insert(i, c)),
        (any::<usize>(), byte).prop_map(|(i, c)| Edit::Replace(i, c)),
        (any::<usize>(), 1usize..40).prop_map(|(i, n)| Edit::Duplicate(i, n)),
    ]
}

proptest! {
    // PROPTEST_CASES=100000 for a longer run (see docs/testing.md).
    #![proptest_config(ProptestConfig {
        cases: std::env::var("PROPTEST_CASES").ok().and_then(|s| s.parse().ok()).unwrap_or(256),
        failure_persistence: None,
        ..ProptestConfig::default()
    })]

    #[test]
    fn random_bytes(rules in proptest::collection::vec(any::<u8>(), 0..400),
                    agents in proptest::collection::vec(any::<u8>(), 0..400),
                    dim in proptest::option::of(prop_oneof![Just(Dim::Two), Just(Dim::Three)])) {
        run(&rules, Some(&agents), dim);
        run(&rules, None, dim);
        fmt_holds(&rules);
    }

    #[test]
    fn random_token_lines(lines in proptest::collection::vec(token_line(), 0..12)) {
        let text = lines.join("\n");
        run(text.as_bytes(), None, None);
        run(text.as_bytes(), Some(text.as_bytes()), None);
        fmt_holds(text.as_bytes());
    }

    #[test]
    fn mutated_examples(which in any::<usize>(), edits in proptest::collection::vec(edit(), 1..8)) {
        let seeds = seeds();
        let base = seeds[which % seeds.len()].clone();
        let mutated = apply(base, &edits);
        run(&mutated, None, None);
        run(&seeds[0], Some(&mutated), None);
        fmt_holds(&mutated);
    }
}

/// Checks and renders an input on a thread with a small stack (the viewer's server checks on
/// threads of 2 MiB), within a time a linear implementation meets easily even unoptimised.
fn run_bounded(rules: Vec<u8>, agents: Vec<u8>) {
    let started = std::time::Instant::now();
    let size = rules.len() + agents.len();
    std::thread::Builder::new()
        .stack_size(1 << 20)
        .spawn(move || {
            let c = run(&rules, Some(&agents), None);
            let text = c.render(false);
            // Each line is the primary place of at most SHOWN_PER_LINE diagnostics, each
            // quoting it with its primary and at most one secondary label there.
            let per_line = 2 * latticesim_compiler::SHOWN_PER_LINE;
            assert!(
                text.len() < per_line * size + 200_000,
                "{} bytes of diagnostics for {size} bytes of input",
                text.len()
            );
            assert!(!text.contains('\x1b') && !text.contains('\0'));
        })
        .unwrap()
        .join()
        .expect("no panic and no stack overflow");
    let took = started.elapsed();
    assert!(
        took < std::time::Duration::from_secs(20),
        "{size} bytes took {took:?}"
    );
}

/// A control character or a character that reorders text.
fn control() -> impl Strategy<Value = char> {
    prop_oneof![
        (0u32..32).prop_map(|c| char::from_u32(c).unwrap()),
        Just('\x7f'),
        Just('\u{85}'),
        Just('\u{202e}'),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig {
        cases: std::env::var("PROPTEST_CASES").ok().and_then(|s| s.parse().ok()).unwrap_or(8).min(64),
        failure_persistence: None,
        ..ProptestConfig::default()
    })]

    /// Deep nesting, very long lines, many terms, many bad fields and control characters.
    #[test]
    fn huge_and_deep_inputs(
        bangs in 0usize..20_000,
        opens in 0usize..15_000,
        closes in 0usize..15_000,
        term in proptest::sample::select(FRAGMENTS),
        repeat_pre in any::<bool>(),
        copies in 1usize..30_000,
        ctrl in proptest::collection::vec((any::<usize>(), control()), 0..20),
        bad_fields in 0usize..50_000,
    ) {
        let (bangs, opens, closes) = if repeat_pre { (0, 0, 0) } else { (bangs, opens, closes) };
        let mut pre = "!".repeat(bangs) + &"(".repeat(opens);
        pre += &vec![term; copies].join(" ");
        pre += &")".repeat(closes);
        let mut rules: Vec<char> = format!("r\n1\n{pre}\nC00 + C00 1\n").chars().collect();
        for (at, c) in ctrl {
            let n = rules.len();
            rules.insert(at % n, c);
        }
        let rules: String = rules.into_iter().collect();
        let agents = format!("U-9,9,-9,9\n0,0{}\n99999999999999999999,-2147483649\n", " Q".repeat(bad_fields));
        run_bounded(rules.into_bytes(), agents.into_bytes());
    }
}
