//! The fast path of agents files against the diagnostic path: on every input it either
//! declines (and the diagnostic path speaks), or reads exactly the lattice the diagnostic
//! path reads from a file it has nothing to say of; and what a lattice writes reads back
//! to the same lattice.

use latticesim_compiler::checked::Width;
use latticesim_compiler::fast_agents::{read_head, read_lines};
use latticesim_compiler::Columns;
use latticesim_runtime::{Lattice, Mends};
use proptest::prelude::*;

/// The fast path as the command line takes it, with the lines after the head cut into
/// pieces at the given line ends (as chunks and threads cut them).
fn fast(src: &[u8], cuts: &[usize], width: Width) -> Option<Lattice> {
    let mut head = read_head(src)?;
    head.width = width;
    let rest = &src[head.agents_at..];
    let mut ends: Vec<usize> = cuts
        .iter()
        .map(|&c| c % (rest.len() + 1))
        .map(|c| {
            rest[c..]
                .iter()
                .position(|&b| b == b'\n')
                .map_or(rest.len(), |p| c + p + 1)
        })
        .collect();
    ends.push(rest.len());
    ends.sort_unstable();
    let mut cols = Columns::new(width);
    let mut from = 0;
    for end in ends {
        let mut part = Columns::new(width);
        if read_lines(&rest[from..end], &head, &mut part).is_err() {
            return None;
        }
        cols.append(part);
        from = end;
    }
    cols.fill();
    // Agents on one cell or a bond declared on one side: the fast path has something to say.
    let (lat, mends) = Lattice::from_columns_mended(head.dim, head.universe, cols, 0);
    (mends == Mends::default()).then_some(lat)
}

/// The diagnostic path (with counters of `width`): the lattice when it has nothing to say
/// of the file, and whether it said nothing.
fn slow(src: &[u8], width: Width) -> (Option<Lattice>, bool) {
    let rules = match width {
        Width::W16 => "r\n1\nS*****\nS*****\n",
        Width::W32 => "// latticesim: counters 32\nr\n1\nS*****\nS*****\n",
    };
    let c = latticesim_compiler::check(
        latticesim_compiler::Input {
            name: "rules.txt",
            bytes: rules.as_bytes(),
        },
        Some(latticesim_compiler::Input {
            name: "agents.txt",
            bytes: src,
        }),
        None,
    );
    let silent = c.diags.is_empty() && c.not_shown.is_empty();
    (c.config.as_ref().map(Lattice::new), silent)
}

/// Everything a lattice holds that a file sets: its text, positions and counter columns.
type Seen = (String, Vec<[i32; 3]>, Vec<(u8, Vec<i32>)>);

/// What [`Seen`] says of a lattice, to compare.
fn seen(l: &Lattice) -> Seen {
    let counters = l
        .counter_numbers()
        .into_iter()
        .map(|c| (c, (0..l.len() as u32).map(|a| l.counter(a, c)).collect()))
        .collect();
    (l.to_agents_text(), l.pos.clone(), counters)
}

/// [`agrees_in`] with 16-bit counters and with 32-bit ones.
fn agrees(src: &[u8], cuts: &[usize]) -> Result<(), TestCaseError> {
    agrees_in(src, cuts, Width::W16)?;
    agrees_in(src, cuts, Width::W32)
}

fn agrees_in(src: &[u8], cuts: &[usize], width: Width) -> Result<(), TestCaseError> {
    let (lat, silent) = slow(src, width);
    match fast(src, cuts, width) {
        Some(f) => {
            prop_assert!(
                silent,
                "the fast path read a file the diagnostic path speaks of:\n{}",
                String::from_utf8_lossy(src)
            );
            let s = lat.expect("no errors");
            prop_assert_eq!(seen(&f), seen(&s), "{}", String::from_utf8_lossy(src));
        }
        None => {
            // It declines only what the diagnostic path speaks of, or a file without agents.
            let empty = lat.as_ref().is_some_and(|l| l.is_empty());
            prop_assert!(
                !silent || empty,
                "the fast path declined a clean file:\n{}",
                String::from_utf8_lossy(src)
            );
        }
    }
    Ok(())
}

/// A clean agents file: `U` line or not, 2D or 3D, states, symmetric bonds, counters,
/// and comments, CRLF and blank lines between.
fn clean_file() -> impl Strategy<Value = String> {
    (
        any::<bool>(),
        any::<bool>(),
        proptest::collection::vec(
            (
                0i32..6,
                0i32..6,
                0i32..3,
                proptest::option::of("[!-)+-.0-~]{5}"),
                proptest::collection::vec(
                    (
                        0u8..25,
                        prop_oneof![
                            -32767i32..=32767,
                            -2_147_483_647i32..=2_147_483_647,
                            Just(-32768),
                            Just(32768),
                        ],
                    ),
                    0..4,
                ),
                0u8..4,
                any::<u8>(),
            ),
            1..40,
        ),
    )
        .prop_map(|(three, universe, agents)| {
            let mut cells = std::collections::BTreeMap::new();
            for (x, y, z, state, counters, ws, deco) in agents {
                let z = if three { z } else { 0 };
                cells
                    .entry([x, y, z])
                    .or_insert((state, counters, ws, deco));
            }
            let all = latticesim_compiler::checked::Dir::ALL.map(|d| d.offset());
            let dirs = &all[..if three { 6 } else { 4 }];
            let mut s = String::new();
            if universe {
                s += if three {
                    "U -1,7,-1,7,-1,4\r\n"
                } else {
                    "U-1,7,-1,7\n"
                };
            }
            s += "// generated\n\n";
            for (p, (state, counters, ws, deco)) in &cells {
                let pos = if three {
                    format!("{},{},{}", p[0], p[1], p[2])
                } else {
                    format!("{},{}", p[0], p[1])
                };
                let mut fields = vec![pos];
                if let Some(st) = state {
                    fields.push(format!("S{st}"));
                }
                // Bonds to every neighbour present, when the decoration says so (both
                // sides then declare them: the rule is a property of the pair).
                if deco & 1 == 1 {
                    let bonds: String = dirs
                        .iter()
                        .map(|d| {
                            let q = [p[0] + d[0], p[1] + d[1], p[2] + d[2]];
                            let both = cells.get(&q).is_some_and(|o| o.3 & 1 == 1);
                            if both {
                                '1'
                            } else {
                                '0'
                            }
                        })
                        .collect();
                    fields.push(format!("A{bonds}"));
                }
                let mut used = std::collections::BTreeSet::new();
                for (c, v) in counters {
                    if used.insert(*c) {
                        fields.push(format!("C{c:02} {v}"));
                    }
                }
                let sep = [" ", "\t", "  ", " \t "][*ws as usize];
                let mut line = fields.join(sep);
                if deco & 2 == 2 {
                    line = format!("  {line} // note");
                }
                s += &line;
                s += if deco & 4 == 4 { "\r\n" } else { "\n" };
                if deco & 8 == 8 {
                    s += "\n   \n";
                }
            }
            s
        })
}

/// A file made of agents-file-like pieces, many of them wrong.
fn noisy_file() -> impl Strategy<Value = String> {
    let piece = prop_oneof![
        Just("1,2".to_string()),
        Just("-3,4,5".to_string()),
        Just("S".to_string()),
        Just("SAB*DE".to_string()),
        Just("S00000".to_string()),
        Just("A1000".to_string()),
        Just("A010010".to_string()),
        Just("C03".to_string()),
        Just("C3".to_string()),
        Just("C99".to_string()),
        Just("-7".to_string()),
        Just("32768".to_string()),
        Just("2147483647".to_string()),
        Just("-2147483648".to_string()),
        Just("99999999999999999999".to_string()),
        Just("U0,5,0,5".to_string()),
        Just("U 0,5,0,5,0,5".to_string()),
        Just("//".to_string()),
        Just(" ".to_string()),
        Just("\t".to_string()),
        Just("\n".to_string()),
        Just("\r\n".to_string()),
        Just("\r".to_string()),
        Just(",".to_string()),
        Just("\u{1}".to_string()),
        Just("é".to_string()),
        "[0-9]{1,3},[0-9]{1,3}".prop_map(|s| s),
    ];
    proptest::collection::vec(piece, 0..40).prop_map(|v| v.concat())
}

proptest! {
    #![proptest_config(ProptestConfig {
        cases: std::env::var("PROPTEST_CASES").ok().and_then(|s| s.parse().ok()).unwrap_or(500),
        failure_persistence: None,
        ..ProptestConfig::default()
    })]

    #[test]
    fn clean_files_read_the_same_on_both_paths(src in clean_file(), cuts in proptest::collection::vec(any::<usize>(), 0..4)) {
        // Clean with 32-bit counters (values past 16 bits are generated too).
        let w = Width::W32;
        let (lat, silent) = slow(src.as_bytes(), w);
        prop_assert!(silent, "the generated file is not clean:\n{}", src);
        prop_assert!(fast(src.as_bytes(), &cuts, w).is_some(), "declined:\n{}", src);
        agrees(src.as_bytes(), &cuts)?;
        // Written and read again: the same lattice, on both paths.
        let lat = lat.unwrap();
        let text = lat.to_agents_text();
        let again = fast(text.as_bytes(), &cuts, w).expect("what a lattice writes is clean");
        prop_assert_eq!(seen(&again), seen(&lat));
        prop_assert_eq!(seen(&slow(text.as_bytes(), w).0.unwrap()), seen(&lat));
    }

    #[test]
    fn mutated_files_agree(src in clean_file(), at in any::<usize>(), with in any::<u8>(), kind in 0u8..3) {
        let mut b = src.into_bytes();
        let i = at % b.len();
        match kind {
            0 => b[i] = with,
            1 => { b.remove(i); }
            _ => b.insert(i, with),
        }
        agrees(&b, &[at])?;
    }

    #[test]
    fn noisy_files_agree(src in noisy_file(), cuts in proptest::collection::vec(any::<usize>(), 0..3)) {
        agrees(src.as_bytes(), &cuts)?;
    }

    #[test]
    fn random_bytes_agree(b in proptest::collection::vec(any::<u8>(), 0..200)) {
        agrees(&b, &[])?;
    }
}

/// Two agents on a cell and bonds on one side only are found by the lattice; a bond
/// towards an empty cell too.
#[test]
fn what_lies_beyond_a_line_is_left_to_the_diagnostic_path() {
    for src in [
        "0,0\n1,0\n0,0\n",
        "0,0 A0010\n1,0\n",
        "0,0 A0010\n",
        "0,0 A0010\n1,0 A0100\n5,5 A1000\n",
    ] {
        assert!(fast(src.as_bytes(), &[], Width::W16).is_none(), "{src:?}");
        assert!(!slow(src.as_bytes(), Width::W16).1, "{src:?}");
    }
    assert!(fast(b"0,0 A0010\n1,0 A0100\n", &[], Width::W16).is_some());
}
