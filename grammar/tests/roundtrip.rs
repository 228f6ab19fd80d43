//! Pretty-printing a parsed rules file and parsing the text again gives the same tree:
//! for every rules file under examples/ and for generated rules of every kind.

use bumpalo::Bump;
use latticesim_grammar::{parse_agents, parse_rules, FileId};
use proptest::prelude::*;

fn roundtrip(src: &str, hint: Option<u8>) -> Result<(), TestCaseError> {
    let a1 = Bump::new();
    let (f1, d1) = parse_rules(src, FileId(0), &a1, hint);
    prop_assert!(
        d1.is_empty(),
        "generated text has diagnostics:\n{src}\n{d1:#?}"
    );
    let printed = f1.to_string();
    let a2 = Bump::new();
    let (f2, d2) = parse_rules(&printed, FileId(0), &a2, hint);
    prop_assert!(
        d2.is_empty(),
        "printed text has diagnostics:\n{printed}\n{d2:#?}"
    );
    prop_assert_eq!(&f1, &f2, "\n{}\n---\n{}", src, printed);
    prop_assert_eq!(printed.clone(), f2.to_string());
    Ok(())
}

#[test]
fn examples_roundtrip() {
    let root = concat!(env!("CARGO_MANIFEST_DIR"), "/../examples");
    let mut n = 0;
    for entry in walk(std::path::Path::new(root)) {
        let text = std::fs::read_to_string(&entry).unwrap();
        let name = entry.file_name().unwrap().to_string_lossy();
        if entry.components().any(|c| c.as_os_str() == "mistakes") {
            continue;
        }
        if name.starts_with("rules") {
            roundtrip(&text, None).unwrap();
            n += 1;
        } else if name.ends_with(".txt") && name.contains("agents") {
            let (f, d) = parse_agents(&text, FileId(0));
            assert!(d.is_empty(), "{}: {d:?}", entry.display());
            let printed = f.to_string();
            let (g, d2) = parse_agents(&printed, FileId(0));
            assert!(d2.is_empty());
            assert!(
                f == g,
                "{}: the printed agents file reads differently",
                entry.display()
            );
            n += 1;
        }
    }
    assert!(n >= 4, "expected example files under examples/, found {n}");
}

fn walk(dir: &std::path::Path) -> Vec<std::path::PathBuf> {
    let mut out = Vec::new();
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if p.is_dir() {
            out.extend(walk(&p));
        } else {
            out.push(p);
        }
    }
    out.sort();
    out
}

/// Text of 5 printable characters (no blank; `*` only where `star`; no `//`).
fn text5(star: bool) -> impl Strategy<Value = String> {
    proptest::collection::vec(proptest::char::range('!', '~'), 5).prop_map(move |cs| {
        let mut s: String = cs
            .into_iter()
            .map(|c| if c == '*' && !star { 'x' } else { c })
            .collect();
        while s.contains("//") {
            s = s.replacen("//", "/x", 1);
        }
        s
    })
}

fn pat(len: usize, alphabet: &'static str) -> impl Strategy<Value = String> {
    let cs: Vec<char> = alphabet.chars().collect();
    proptest::collection::vec(proptest::sample::select(cs), len)
        .prop_map(|v| v.into_iter().collect())
}

fn comp() -> impl Strategy<Value = String> {
    prop_oneof![
        (-40i64..40).prop_map(|n| n.to_string()),
        (0u8..45).prop_map(|c| format!("C{c:02}")),
    ]
}

fn offset(d: usize) -> impl Strategy<Value = String> {
    proptest::collection::vec(comp(), d).prop_map(|v| v.join(","))
}

fn value() -> impl Strategy<Value = String> {
    prop_oneof![
        (-32767i64..=32767).prop_map(|n| if n < 0 {
            format!("-{:04}", -n)
        } else {
            format!("{n:04}")
        }),
        (0u8..45).prop_map(|c| format!("C{c:02}")),
        (
            proptest::sample::select(vec!['N', 'W', 'E', 'S', 'A', 'B', '*']),
            1u8..9
        )
            .prop_map(|(d, k)| format!("#{d}{k:02}")),
    ]
}

fn dir() -> impl Strategy<Value = char> {
    proptest::sample::select(vec!['N', 'W', 'E', 'S', 'A', 'B', '*'])
}

fn pre_leaf(d: usize) -> impl Strategy<Value = String> {
    let n = if d == 2 { 4 } else { 6 };
    prop_oneof![
        pat(n, "01*").prop_map(|p| format!("N{p}")),
        pat(n, "01*").prop_map(|p| format!("A{p}")),
        pat(n, "<=*").prop_map(|p| format!("P{p}")),
        text5(true).prop_map(|t| format!("S{t}")),
        (dir(), text5(true)).prop_map(|(d, t)| format!("M{d}{t}")),
        (
            proptest::sample::select(vec!['E', 'F', 'L', 'Q']),
            offset(d)
        )
            .prop_map(|(l, o)| format!("{l}{o}")),
        (offset(d), text5(true)).prop_map(|(o, t)| format!("T{o},{t}")),
        (
            proptest::sample::select(vec!['<', '>', '=']),
            value(),
            value()
        )
            .prop_map(|(o, a, b)| format!("{o}{a} {b}")),
        (
            proptest::sample::select(vec!['V', 'W']),
            offset(2),
            0u8..25,
            value()
        )
            .prop_map(|(l, o, c, v)| format!("{l}{o},C{c:02} {v}")),
    ]
}

fn pre_term(d: usize) -> impl Strategy<Value = String> {
    pre_leaf(d).prop_recursive(3, 12, 3, |inner| {
        prop_oneof![
            inner.clone().prop_map(|t| format!("!{t}")),
            proptest::collection::vec(inner, 1..4).prop_map(|ts| format!("({})", ts.join(" "))),
        ]
    })
}

fn operand() -> impl Strategy<Value = String> {
    prop_oneof![
        3 => value(),
        1 => (comp(), comp(), 0u8..25).prop_map(|(x, y, c)| format!("{x},{y},C{c:02}")),
    ]
}

fn post_term(d: usize) -> impl Strategy<Value = String> {
    let n = if d == 2 { 4 } else { 6 };
    prop_oneof![
        pat(n, "01*+").prop_map(|p| format!("A{p}")),
        text5(true).prop_map(|t| format!("S{t}")),
        (dir(), text5(false)).prop_map(|(d, t)| format!("M{d}{t}")),
        offset(d).prop_map(|o| format!("P{o}")),
        dir().prop_map(|c| format!("X{c}")),
        (
            prop_oneof![
                (0u8..45).prop_map(|c| format!("C{c:02}")),
                (dir(), 1u8..9).prop_map(|(d, k)| format!("#{d}{k:02}"))
            ],
            proptest::sample::select(vec!['+', '-', '*', '/', 'M', 'A', 'I']),
            operand(),
            operand()
        )
            .prop_map(|(t, o, a, b)| format!("{t} {o} {a} {b}")),
    ]
}

fn rules_file() -> impl Strategy<Value = (String, u8)> {
    (2usize..=3).prop_flat_map(|d| {
        let rule = (
            "[a-zA-Z][a-zA-Z0-9_ .-]{0,10}[a-zA-Z0-9]",
            1i64..32768,
            proptest::collection::vec(pre_term(d), 1..6),
            proptest::collection::vec(post_term(d), 1..6),
        )
            .prop_map(|(name, p, pre, post)| {
                format!("{name}\n{p}\n{}\n{}\n", pre.join(" "), post.join(" "))
            });
        (proptest::collection::vec(rule, 1..6), Just(d as u8))
            .prop_map(|(rs, d)| (rs.join("\n// a comment\n"), d))
    })
}

proptest! {
    // PROPTEST_CASES=100000 for a longer run (see docs/testing.md).
    #![proptest_config(ProptestConfig {
        cases: std::env::var("PROPTEST_CASES").ok().and_then(|s| s.parse().ok()).unwrap_or(512),
        failure_persistence: None,
        ..ProptestConfig::default()
    })]

    #[test]
    fn generated_rules_roundtrip((src, d) in rules_file()) {
        roundtrip(&src, Some(d))?;
    }
}
