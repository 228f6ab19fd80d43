//! The streaming reader of agents files (`agents_file::load`: the fast reader, warnings
//! found as it reads, the checker only when it declines) against the checker alone
//! (`compiler::check` on the whole pair): the same diagnostics, rendered and as JSON, the
//! same counts and the same agents, on files with warnings (states no rule tests, agents
//! without a state, comments, CRLF, a `U` line, 3D), on files with errors, agents on one
//! cell and one-sided bonds (which stream too, in bounded memory), with lint levels and few
//! diagnostics shown, and on mutated files; never a panic.

use latticesim::agents_file::Loaded;
use latticesim::fuzzing::{agents_of, seen, streamed, streamed_with, whole};
use latticesim_compiler::diagnostics::render_plain;
use latticesim_compiler::lints::Lints;
use latticesim_compiler::Checked;
use latticesim_grammar::Code;
use latticesim_runtime::Lattice;
use proptest::prelude::*;

const RULES: &[&str] = &[
    // Walkers: the walls' state is tested by nothing (W603, near `WALK0`).
    "walk\n1\nSWALK0 N**0* >C01 0000\nP1,0 C01 - C01 0001\n",
    // A state tested far from every start state, and one set.
    "a\n1\nSA0000 T1,0,B0000\nSB0000\n\nz\n1\nSZZZZ9\nSZZZZ8\n",
    // Every state accepted (no W603).
    "fall\n1\nN***0\nP0,-1\n",
    // 3D.
    "up\n1\nSUP000 U***0**\nP0,0,1\n",
    // Warnings of the rules file: W502, and W503 three times when agents start in WALK0
    // (then capped with the rules' others when few are shown).
    "a\n1\nSWALK0 SWALK1\nSWALK2\n\nb\n1\nSWALK3\nSWALK0\n\nc\n1\nSWALK4\nSWALK0\n",
    // 32-bit counters: `C01 40000` is in range.
    "// latticesim: counters 32\nwalk\n1\nSWALK0 N**0* >C01 0000\nP1,0 C01 - C01 0001\n",
];

fn same(rules: &str, agents: &[u8]) -> Result<(), TestCaseError> {
    agree(
        &streamed(rules.as_bytes(), agents),
        &whole(rules.as_bytes(), agents),
    )
}

/// The same diagnostics, counts and agents.
fn agree(l: &Loaded, whole: &Checked) -> Result<(), TestCaseError> {
    prop_assert_eq!(seen(&l.checked), seen(whole));
    let whole_lat = whole.config.as_ref().map(Lattice::new);
    prop_assert_eq!(
        l.lattice.as_ref().map(agents_of),
        whole_lat.as_ref().map(agents_of)
    );
    Ok(())
}

/// An agents file: walls, walkers, agents of other states, some without a state, bonds
/// declared on both sides, comments, blank lines, CRLF, a `U` line, 2D or 3D.
fn agents_file() -> impl Strategy<Value = Vec<u8>> {
    (
        prop::collection::vec((0..7usize, 0..3usize), 1..60),
        any::<bool>(),
        any::<bool>(),
        any::<bool>(),
        any::<bool>(),
    )
        .prop_map(|(agents, crlf, comments, universe, d3)| {
            let states = [
                "SWALL0",
                "SWALK0 C01 3",
                "",
                "SA0000",
                "SZZZZ9",
                "SUP000",
                "SINTI0",
            ];
            let end = if crlf { "\r\n" } else { "\n" };
            let mut s = String::new();
            if comments {
                s += &format!("// a file{end}{end}");
            }
            if universe {
                s += &format!("U{}{end}", if d3 { "40,40,40" } else { "40,40" });
            }
            for (k, &(st, extra)) in agents.iter().enumerate() {
                let (x, y) = (k % 10, k / 10);
                let pos = if d3 {
                    format!("{x},{y},1")
                } else {
                    format!("{x},{y}")
                };
                let mut line = format!("{pos} {}", states[st]);
                if extra == 1 && comments {
                    line += " // note";
                }
                s += line.trim_end();
                s += end;
                if extra == 2 && comments {
                    s += end;
                }
            }
            s.into_bytes()
        })
}

/// A file mutated: bytes changed, inserted or taken out.
fn mutated() -> impl Strategy<Value = Vec<u8>> {
    (
        agents_file(),
        prop::collection::vec((any::<prop::sample::Index>(), 0..3u8, any::<u8>()), 1..4),
    )
        .prop_map(|(mut f, edits)| {
            for (at, kind, b) in edits {
                if f.is_empty() {
                    break;
                }
                let i = at.index(f.len());
                let b = b" ,-SCAU0123456789\n\r/*\x01\xff"[b as usize % 23];
                match kind {
                    0 => f[i] = b,
                    1 => f.insert(i, b),
                    _ => {
                        f.remove(i);
                    }
                }
            }
            f
        })
}

/// An agents file of `n` lines (after a clean first, or not): errors of every kind an
/// agent line can have, agents on one cell, bonds declared on one side (or towards no
/// agent), among good lines.
fn faulty_file(n: usize) -> impl Strategy<Value = Vec<u8>> {
    (
        prop::collection::vec((0..16usize, 0..6i32, 0..4i32, 0..16u8), n),
        any::<bool>(),
        0..4u8,
    )
        .prop_map(|(lines, universe, first)| {
            let mut s = String::from(if universe { "U-1,8,-1,8\n" } else { "" });
            // A clean first agent, or none; or no line that parses as an agent at all,
            // but perhaps the last (3D).
            let unparsed = first >= 2;
            if first == 0 {
                s += "0,0 SWALK0\n";
            }
            for (kind, x, y, bits) in lines {
                let kind = if unparsed {
                    [10, 12, 14][kind % 3]
                } else {
                    kind
                };
                let a = format!("A{bits:04b}");
                s += &match kind {
                    0..=5 => format!("{x},{y} SWALK0 {a}"),
                    6 => format!("{x},{y} {a} C01 5"),
                    7 => format!("{x},{y} SBAD"),
                    8 => format!("{x},{y} C01 40000"),
                    9 => format!("{x},{y},1"),
                    10 => format!("{x},{y} X"),
                    11 => format!("{x},{y} SWALK0 SWALK0 C99 1"),
                    12 => "U0,1,0,1".to_string(),
                    13 => format!("{},{y}", x + 20),
                    14 => format!("{x} ,{y}"),
                    _ => format!("  {x},{y}  // ok"),
                };
                s += "\n";
            }
            if first == 3 {
                s += "1,1,1\n";
            }
            s.into_bytes()
        })
}

/// Lint levels for W601, W602 and W603 (allowed, warned of, denied), and how many
/// diagnostics of a file are shown.
fn levels() -> impl Strategy<Value = Lints> {
    (
        0..3usize,
        0..3usize,
        0..3usize,
        prop::sample::select(vec![1usize, 2, 3, 7, 200]),
    )
        .prop_map(|(w601, w602, w603, shown)| {
            let (mut allow, mut warn, mut deny) = (Vec::new(), Vec::new(), Vec::new());
            for (level, code) in [(w601, "W601"), (w602, "W602"), (w603, "W603")] {
                [&mut allow, &mut warn, &mut deny][level].push(code.to_string());
            }
            let mut l = Lints::from_flags(&allow, &warn, &deny).expect("known codes");
            l.set_shown(shown);
            l
        })
}

/// The streaming reader against the checker, both with these levels.
fn same_with(rules: &str, agents: &[u8], levels: &Lints) -> Result<(), TestCaseError> {
    let l = streamed_with(rules.as_bytes(), agents, levels);
    let input = |name, bytes| latticesim_compiler::Input { name, bytes };
    let whole = latticesim_compiler::check_with(
        input("rules.txt", rules.as_bytes()),
        Some(input("agents.txt", agents)),
        None,
        levels,
    );
    // Read to its end while streaming, but where a line that parses as an agent comes
    // after lines that do not (the dimension is then the checker's to find), or the
    // rules are not of the agents' dimension.
    let late = agents.ends_with(b"1,1,1\n");
    let e301 = whole.diags.iter().any(|d| d.code == Code::E301);
    // A `U` line with an error (the head's) leaves the file to the checker too.
    let text = String::from_utf8_lossy(agents);
    let first = latticesim_grammar::lines::significant_lines(&text).next();
    let bad_universe = first.is_some_and(|l| {
        l.text.starts_with('U')
            && !latticesim_grammar::parse_agents(l.text, latticesim_grammar::FileId(1))
                .1
                .is_empty()
    });
    prop_assert!(
        l.streamed || late || e301 || bad_universe,
        "the checker read the file"
    );
    agree(&l, &whole)
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 400, ..ProptestConfig::default() })]

    #[test]
    fn the_streaming_reader_says_what_the_checker_says(r in 0..RULES.len(), a in agents_file()) {
        same(RULES[r], &a)?;
    }

    #[test]
    fn the_streaming_reader_says_what_the_checker_says_with_lint_levels(
        r in 0..RULES.len(),
        a in agents_file(),
        levels in levels(),
    ) {
        same_with(RULES[r], &a, &levels)?;
    }

    #[test]
    fn the_streaming_reader_says_what_the_checker_says_of_mutated_files(r in 0..RULES.len(), a in mutated()) {
        same(RULES[r], &a)?;
    }

    /// Errors streamed (the first shown, the rest counted: compaction with 1 to 7 shown),
    /// agents on one cell and one-sided bonds mended from the lattice, lint levels.
    #[test]
    fn the_streaming_reader_finds_errors_and_mends_as_the_checker(
        r in 0..RULES.len(),
        a in (1..400usize).prop_flat_map(faulty_file),
        levels in levels(),
    ) {
        same_with(RULES[r], &a, &levels)?;
    }

    #[test]
    fn the_streaming_reader_never_panics_on_bytes(r in 0..RULES.len(), a in prop::collection::vec(any::<u8>(), 0..200)) {
        same(RULES[r], &a)?;
    }
}

/// [`same_with`] with each number of diagnostics shown.
fn same_showing(rules: &str, agents: &[u8], shown: &[usize]) {
    for &n in shown {
        let mut levels = Lints::new();
        levels.set_shown(n);
        same_with(rules, agents, &levels).unwrap();
    }
}

/// A 3D file of 10^5 agents (read in two parts) with one-sided bonds up (`A`), states given
/// twice and counters past their range, beside 3D rules: as the checker says it.
#[test]
fn a_3d_file_with_errors_and_bonds_is_said_as_the_checker_says_it() {
    let mut text = String::new();
    for k in 0..100_000u32 {
        let (x, y, z) = (k / 1000, k / 10 % 100, k % 10);
        text += &format!("{x},{y},{z} SUP000");
        for (m, field) in [(97, " A000010"), (101, " SBAD"), (103, " C44 40000")] {
            if k % m == 0 {
                text += field;
            }
        }
        text += "\n";
    }
    same_showing(RULES[3], text.as_bytes(), &[5, 200]);
}

/// The rules' warnings that follow from the start states (W503) are capped with the
/// rules' other diagnostics, as the checker caps them, when few are shown.
#[test]
fn the_rules_warnings_found_late_are_capped_with_the_others() {
    same_showing(RULES[4], b"0,0 SWALK0\n1,0 SWALK0\n", &[1, 2, 200]);
}

/// A file of several megabytes, read in parts on two threads: errors, agents on one cell
/// and one-sided bonds in every part, some of each shown, the others counted, as the
/// checker says them; with few diagnostics shown and with many.
#[test]
fn errors_in_every_part_of_a_large_file_are_said_as_the_checker_says_them() {
    let mut text = String::new();
    for k in 0..240_000u32 {
        let (x, y) = (k % 500, k / 500);
        text += &match k % 997 {
            17 => format!("{x},{y} SBAD\n"),
            29 => format!("{x},{y} C01 99999\n"),
            31 => "0,0 SWALK0\n".to_string(),
            37 => format!("{x},{y} SWALK0 A0010\n"),
            41 => format!("{x} ,{y}\n"),
            _ => format!("{x},{y} SWALK0\n"),
        };
    }
    assert!(text.len() > 3 << 20);
    same_showing(RULES[0], text.as_bytes(), &[3, 200]);
}

/// A warning deep in a large file is quoted with its own line number, as the checker
/// quotes it, though only the file's head and that line are held.
#[test]
fn a_warning_far_down_is_quoted_with_its_line() {
    let mut a = String::from("// walls and walkers\n");
    for x in 0..200 {
        for y in 0..100 {
            a += &format!("{x},{y} SWALK0 C01 1\n");
        }
    }
    a += "500,500 SWALL0\r\n7,-3\n";
    same(RULES[0], a.as_bytes()).unwrap();
    let l = streamed(RULES[0].as_bytes(), a.as_bytes());
    let text = render_plain(&l.checked.diags, &l.checked.sources);
    assert!(text.contains("agents.txt:20002:9"), "{text}");
    assert!(text.contains("20003 │ 7,-3"), "{text}");
    assert!(
        l.checked.sources.text(latticesim_grammar::FileId(1)).len() < 100,
        "only the head and the quoted lines are held"
    );
    // The first agent in a state far from every pattern (its W603 is given alone, and
    // the walkers' pattern is matched later in the file).
    let b = format!("0,-5 SQQQQ0\n{a}");
    same(RULES[0], b.as_bytes()).unwrap();
    let l = streamed(RULES[0].as_bytes(), b.as_bytes());
    let text = render_plain(&l.checked.diags, &l.checked.sources);
    assert!(text.contains("agents.txt:1:6"), "{text}");
    let held = l.checked.sources.text(latticesim_grammar::FileId(1));
    assert!(held.len() < 100, "read on the fast path: {text}");
}

/// A typo in a few agents' state, one of them far down: the fix edits each of them in the
/// agents file, quoted from their lines (the fast path holds only those), the same as the
/// checker's; applied to the whole file, it checks clean.
#[test]
fn a_typo_in_a_few_agents_is_fixed_in_the_agents_file() {
    let mut a = String::from("// walkers\n");
    for x in 0..200 {
        for y in 0..100 {
            let s = if (x, y) == (3, 4) || (x, y) == (150, 7) {
                "SWALX0"
            } else {
                "SWALK0"
            };
            a += &format!("{x},{y} {s} C01 1\n");
        }
    }
    a += "500,500 SWALX0\r\n";
    same(RULES[0], a.as_bytes()).unwrap();
    let l = streamed(RULES[0].as_bytes(), a.as_bytes());
    let held = l.checked.sources.text(latticesim_grammar::FileId(1));
    assert!(held.len() < 200, "read on the fast path: {held}");
    let d = &l.checked.diags;
    assert_eq!(d.len(), 1, "{d:?}");
    let text = render_plain(d, &l.checked.sources);
    assert!(text.contains("20002 | 500,500 SWALK0"), "{text}");
    assert!(text.contains("15009 | 150,7 SWALK0 C01 1"), "{text}");
    let fix = &d[0].fixes[0];
    assert_eq!(fix.edits.len(), 3);
    let mut fixed = a.clone().into_bytes();
    let mut edits = fix.edits.clone();
    edits.sort_by_key(|e| std::cmp::Reverse(e.span.start));
    for e in edits {
        let (s, t) = (e.span.start as usize, e.span.end as usize);
        fixed.splice(s..t, e.replacement.bytes());
    }
    assert_eq!(fixed, a.replace("SWALX0", "SWALK0").into_bytes());
    assert!(streamed(RULES[0].as_bytes(), &fixed)
        .checked
        .diags
        .is_empty());
}
