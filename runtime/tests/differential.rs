//! The engine (bytecode VM, flat lattice) against the reference evaluator (condition trees,
//! a plain list of agents): random rule sets using every kind of term and action, on random
//! configurations, several steps; both must agree on the configuration after every step,
//! the records and the statistics.
//!
//! `PROPTEST_CASES` sets the number of cases (default 200); see docs/testing.md.

#![allow(clippy::needless_range_loop)]

mod common;
mod reference;

use latticesim_compiler::compile;
use latticesim_grammar::Code;
use latticesim_runtime::{
    Engine, Lattice, Options, Order, RecordKind, Skip, SpaceOrder, TraceEvent,
};
use proptest::prelude::*;
use reference::{Rec, World};

const STATES: [&str; 3] = ["A0000", "B0000", "A1000"];

fn pick<T: Clone + std::fmt::Debug + 'static>(v: Vec<T>) -> impl Strategy<Value = T> {
    proptest::sample::select(v)
}

fn dirs(d3: bool) -> Vec<char> {
    if d3 {
        vec!['N', 'W', 'E', 'S', 'A', 'B']
    } else {
        vec!['N', 'W', 'E', 'S']
    }
}

fn pat(len: usize, alphabet: &'static str) -> impl Strategy<Value = String> {
    proptest::collection::vec(pick(alphabet.chars().collect()), len)
        .prop_map(|v| v.into_iter().collect())
}

fn coord() -> impl Strategy<Value = String> {
    prop_oneof![4 => (-1i32..=1).prop_map(|v| v.to_string()), 1 => (0u8..3).prop_map(|c| format!("C{c:02}"))]
}

fn offset(d3: bool) -> impl Strategy<Value = String> {
    proptest::collection::vec(coord(), if d3 { 3 } else { 2 }).prop_map(|v| v.join(","))
}

fn value(d3: bool, any: bool) -> BoxedStrategy<String> {
    let mut ds = dirs(d3);
    if any {
        ds.push('*');
    }
    prop_oneof![
        (-2i32..=2).prop_map(|v| if v < 0 {
            format!("-{:04}", -v)
        } else {
            format!("{v:04}")
        }),
        (0u8..3).prop_map(|c| format!("C{c:02}")),
        (pick(ds), 1u8..3).prop_map(|(d, k)| format!("#{d}{k:02}")),
    ]
    .boxed()
}

fn state_pat() -> impl Strategy<Value = String> {
    (pick(vec!["A", "B", "*"]), pick(vec!["0", "1", "*"])).prop_map(|(a, b)| format!("{a}{b}***"))
}

fn pre_leaf(d3: bool) -> BoxedStrategy<String> {
    let n = if d3 { 6 } else { 4 };
    let mut all: Vec<BoxedStrategy<String>> = vec![
        pat(n, "01**").prop_map(|p| format!("N{p}")).boxed(),
        pat(n, "01***").prop_map(|p| format!("A{p}")).boxed(),
        pat(n, "<=**").prop_map(|p| format!("P{p}")).boxed(),
        state_pat().prop_map(|p| format!("S{p}")).boxed(),
        (
            pick({
                let mut d = dirs(d3);
                d.push('*');
                d
            }),
            pick(vec!["hi***", "h****"]),
        )
            .prop_map(|(d, t)| format!("M{d}{t}"))
            .boxed(),
        (pick(vec!['E', 'F', 'L', 'Q']), offset(d3))
            .prop_map(|(l, o)| format!("{l}{o}"))
            .boxed(),
        (offset(d3), state_pat())
            .prop_map(|(o, s)| format!("T{o},{s}"))
            .boxed(),
        (pick(vec!['<', '>', '=']), value(d3, true), value(d3, false))
            .prop_map(|(o, a, b)| format!("{o}{a} {b}"))
            .boxed(),
    ];
    if !d3 {
        all.push(
            (
                pick(vec!['V', 'W']),
                offset(false),
                0u8..3,
                value(false, true),
            )
                .prop_map(|(l, o, c, v)| format!("{l}{o},C{c:02} {v}"))
                .boxed(),
        );
    }
    proptest::strategy::Union::new(all).boxed()
}

fn pre(d3: bool) -> BoxedStrategy<String> {
    let term = pre_leaf(d3).prop_recursive(2, 6, 3, |inner| {
        prop_oneof![
            inner.clone().prop_map(|t| format!("!{t}")),
            proptest::collection::vec(inner, 1..3).prop_map(|v| format!("({})", v.join(" "))),
        ]
    });
    proptest::collection::vec(term, 1..4)
        .prop_map(|v| v.join(" "))
        .boxed()
}

fn operand(d3: bool) -> BoxedStrategy<String> {
    if d3 {
        value(true, false)
    } else {
        prop_oneof![3 => value(false, false), 1 => (coord(), coord(), 0u8..3).prop_map(|(x, y, c)| format!("{x},{y},C{c:02}"))].boxed()
    }
}

fn post(d3: bool) -> BoxedStrategy<String> {
    let n = if d3 { 6 } else { 4 };
    let ds = dirs(d3);
    let mut tds = ds.clone();
    tds.push('*');
    let calc = (
        prop_oneof![
            (0u8..3).prop_map(|c| format!("C{c:02}")),
            (pick(tds.clone()), 1u8..3).prop_map(|(d, k)| format!("#{d}{k:02}"))
        ],
        pick(vec!['+', '-', '*', '/', 'M', 'A', 'I']),
        // At most one external counter per calculation, on either side.
        prop_oneof![
            (operand(d3), value(d3, false)),
            (value(d3, false), operand(d3))
        ],
    )
        .prop_map(|(t, o, (a, b))| format!("{t} {o} {a} {b}"));
    (
        proptest::option::of(prop_oneof![
            offset(d3).prop_map(|o| format!("P{o}")),
            pick(ds).prop_map(|d| format!("X{d}"))
        ]),
        proptest::option::of(pat(n, "01*+*").prop_map(|p| format!("A{p}"))),
        proptest::option::of(state_pat().prop_map(|p| format!("S{p}"))),
        proptest::option::of(
            (pick(tds), pick(vec!["hi000", "hello"])).prop_map(|(d, t)| format!("M{d}{t}")),
        ),
        proptest::collection::vec(calc, 0..3),
    )
        .prop_map(|(m, a, s, msg, calcs)| {
            let mut v: Vec<String> = [m, a, s, msg].into_iter().flatten().collect();
            v.extend(calcs);
            if v.is_empty() {
                v.push("S*****".into());
            }
            v.join(" ")
        })
        .boxed()
}

fn rules(d3: bool) -> impl Strategy<Value = String> {
    proptest::collection::vec((1u16..4, pre(d3), post(d3)), 1..5).prop_map(|rs| {
        rs.iter()
            .enumerate()
            .map(|(i, (p, pre, post))| format!("r{i}\n{p}\n{pre}\n{post}\n"))
            .collect::<Vec<_>>()
            .join("\n")
    })
}

fn agents(d3: bool) -> impl Strategy<Value = String> {
    agents_in(d3, if d3 { 3 } else { 4 }, 9)
}

/// Fewer than `most` agents in a box of `side` cells a side.
fn agents_in(d3: bool, side: i32, most: usize) -> impl Strategy<Value = String> {
    let cell = if d3 {
        (0i32..side, 0i32..side, 0i32..side).boxed()
    } else {
        (0i32..side, 0i32..side, Just(0)).boxed()
    };
    (
        proptest::collection::btree_set(cell, 1..most),
        proptest::collection::vec((pick(STATES.to_vec()), -3i16..4, -3i16..4, 0u8..64), most),
        proptest::bool::ANY,
    )
        .prop_map(move |(cells, attrs, bounded)| {
            let cells: Vec<(i32, i32, i32)> = cells.into_iter().collect();
            let n = if d3 { 6 } else { 4 };
            let at = |p: (i32, i32, i32)| cells.iter().position(|&c| c == p);
            let mut text = String::new();
            if bounded {
                let m = side - 1;
                text += &if d3 {
                    format!("U0,{m},0,{m},0,{m}\n")
                } else {
                    format!("U0,{m},0,{m}\n")
                };
            }
            for (i, &(x, y, z)) in cells.iter().enumerate() {
                let (st, c0, c1, bits) = attrs[i];
                // Attach only where a neighbour stands and both ends agree.
                let mut a = String::new();
                for d in 0..n {
                    let o = latticesim_compiler::checked::Dir::ALL[d].offset();
                    let nb = at((x + o[0], y + o[1], z + o[2]));
                    let on = nb.is_some_and(|j| {
                        let pair = (i.min(j) * 7 + i.max(j) * 3) as u8;
                        (bits ^ attrs[j].3) & 1 == 0 && !pair.is_multiple_of(3)
                    });
                    a.push(if on { '1' } else { '0' });
                }
                let pos = if d3 {
                    format!("{x},{y},{z}")
                } else {
                    format!("{x},{y}")
                };
                text += &format!("{pos} S{st} A{a} C00 {c0} C01 {c1}\n");
            }
            text
        })
}

fn compare(e: &Engine, w: &World, step: u64) -> Result<(), TestCaseError> {
    let nd = w.dim.dirs();
    let ns = w.dim.slots();
    for (id, a) in w.agents.iter().enumerate() {
        // The agent of the engine with this id in the agents file (kept in space order or
        // not).
        let i = e.lat.agent_of(id as u32) as usize;
        prop_assert_eq!(e.lat.label(i as u32), id as u32);
        prop_assert_eq!(
            e.lat.pos[i],
            a.pos,
            "step {}: position of agent {}",
            step,
            i
        );
        prop_assert_eq!(
            e.lat.state[i],
            a.state,
            "step {}: state of agent {}",
            step,
            i
        );
        prop_assert_eq!(
            e.lat.attach[i],
            a.attach,
            "step {}: attachments of agent {}",
            step,
            i
        );
        prop_assert_eq!(
            (0..a.counters.len())
                .map(|c| e.lat.counter(i as u32, c as u8))
                .collect::<Vec<_>>(),
            a.counters.clone(),
            "step {}: counters of agent {}",
            step,
            i
        );
        for d in 0..nd {
            for s in 0..ns {
                prop_assert_eq!(
                    e.lat.inbox(i as u32, d as u8, s as u8),
                    a.inbox_num[d][s],
                    "step {}: inbox of {}",
                    step,
                    i
                );
            }
            let t = e.lat.inbox_text(i as u32, d as u8);
            prop_assert_eq!(t, a.inbox_text[d], "step {}: text inbox of {}", step, i);
        }
    }
    Ok(())
}

/// Runs the rules with quiet agents skipped whenever they can be (`Skip::Eager`), as by
/// default (`Skip::Auto`) and without skipping.
fn differential(
    rules: &str,
    agents: &str,
    order: Order,
    static_first: bool,
) -> Result<(), TestCaseError> {
    for skip in [Skip::Eager, Skip::Auto, Skip::Off] {
        differential_on(rules, agents, (order, static_first, skip), 1)
            .map_err(|e| TestCaseError::fail(format!("{skip:?}: {e}")))?;
    }
    Ok(())
}

/// Runs the rules under all four combinations of `--order` and `--static-first`, with
/// quiet agents skipped whenever they can be; and without skipping under two of them.
fn every_option(rules: &str, agents: &str, threads: usize) -> Result<(), TestCaseError> {
    for order in [Order::ActionsFirst, Order::MessagesFirst] {
        for static_first in [false, true] {
            let mut skips = vec![Skip::Eager];
            if static_first == (order == Order::MessagesFirst) {
                skips.push(Skip::Off);
            }
            for skip in skips {
                differential_on(rules, agents, (order, static_first, skip), threads).map_err(
                    |e| {
                        TestCaseError::fail(format!(
                            "{order:?}, static-first {static_first}, {skip:?}: {e}"
                        ))
                    },
                )?;
            }
        }
    }
    Ok(())
}

fn differential_on(
    rules: &str,
    agents: &str,
    (order, static_first, skip): (Order, bool, Skip),
    threads: usize,
) -> Result<(), TestCaseError> {
    let c = common::checked(rules, agents);
    prop_assert_eq!(
        c.errors(),
        0,
        "generated files have errors: {:?}\n{}\n{}",
        c.diags.first(),
        rules,
        agents
    );
    let program = c.rules.clone().unwrap();
    let config = c.config.clone().unwrap();
    let prog = compile(&program);
    prop_assert!(prog.is_ok());
    let prog = prog.unwrap();
    let mut e = Engine::new(
        prog,
        Lattice::new(&config),
        Options {
            order,
            static_first,
            // Tracing only reports; half the cases run with it to show that it changes nothing.
            trace: static_first,
            threads,
            skip,
            // Agents kept in space order whatever the lattice, but when every agent is
            // evaluated at every step (and when tracing, which keeps the file's order).
            space_order: match skip {
                Skip::Off => SpaceOrder::Off,
                _ => SpaceOrder::Always,
            },
            records_per_step: None,
        },
    );
    let mut w = World::new(
        program,
        &config,
        order == Order::MessagesFirst,
        static_first,
    );
    // A case may say how many steps it runs (`// steps N` first), else six.
    let steps = (rules.strip_prefix("// steps "))
        .and_then(|r| r.split_whitespace().next()?.parse().ok())
        .unwrap_or(6);
    for step in 1..=steps {
        let rep = e.step();
        let (quiet, recs) = w.step();
        prop_assert_eq!(
            rep.quiescent,
            quiet,
            "step {}: quiescence\n{}\n{}",
            step,
            rules,
            agents
        );
        let mut mine: Vec<Rec> = rep
            .records
            .iter()
            .map(|r| {
                let mut ids: Vec<u32> = r.agents.iter().map(|a| a.0).collect();
                ids.sort();
                Rec {
                    step: r.step,
                    kind: r.kind.name(),
                    agents: ids,
                }
            })
            .collect();
        let mut theirs: Vec<Rec> = recs
            .into_iter()
            .map(|mut r| {
                r.agents.sort();
                r
            })
            .collect();
        mine.sort();
        theirs.sort();
        prop_assert_eq!(
            mine,
            theirs,
            "step {}: records\n{}\n{}",
            step,
            rules,
            agents
        );
        compare(&e, &w, step)
            .map_err(|err| TestCaseError::fail(format!("{err}\n{rules}\n{agents}")))?;
        if quiet {
            break;
        }
    }
    let s = &e.stats;
    let r = &w.stats;
    prop_assert_eq!(s.steps, r.steps);
    prop_assert_eq!(&s.firings, &r.firings);
    prop_assert_eq!((s.moves, s.carried, s.swaps), (r.moves, r.carried, r.swaps));
    prop_assert_eq!(
        (s.sent, s.delivered, s.dropped),
        (r.sent, r.delivered, r.dropped)
    );
    let by_kind: std::collections::BTreeMap<&str, u64> =
        s.records.iter().map(|(k, n)| (k.name(), *n)).collect();
    prop_assert_eq!(by_kind, r.records.clone());
    Ok(())
}

/// Goes to each target in a history of `rules` on `agents`, and past the furthest step,
/// checking each step against a straight run.
fn history_matches(
    rules: &str,
    agents: &str,
    targets: &[u64],
    budget: usize,
) -> Result<(), TestCaseError> {
    let c = common::checked(rules, agents);
    if c.errors() > 0 {
        return Ok(());
    }
    let prog = compile(c.rules.as_ref().unwrap()).unwrap();
    let lat = Lattice::new(c.config.as_ref().unwrap());
    let mut straight = Engine::new(prog.clone(), lat.clone(), Options::default());
    let mut seen = vec![(common::picture(&straight), straight.stats.clone(), None)];
    for _ in 0..40 {
        let rep = straight.step();
        seen.push((
            common::picture(&straight),
            straight.stats.clone(),
            Some(rep),
        ));
    }
    let mut h = latticesim_runtime::History::new(prog, lat, Options::default(), 4, 4);
    h.set_delta_budget(budget);
    for &t in targets.iter().chain(&[40, 17, 3]) {
        h.goto(t);
        let (pic, stats, rep) = &seen[t as usize];
        prop_assert_eq!(h.steps(), t);
        prop_assert_eq!(
            &common::picture(h.engine()),
            pic,
            "step {} ({:?})",
            t,
            h.jump()
        );
        prop_assert_eq!(&h.engine().stats, stats, "statistics at step {}", t);
        prop_assert_eq!(h.last_report(), rep.as_ref(), "report of step {}", t);
    }
    Ok(())
}

/// The same files with 32-bit counters (the extension): the directive added, the
/// literals 1 and 2 (and -1, -2) made large (2 and -2 the bounds, less one for 2), and
/// every counter of the agents multiplied by `scale`, so that sums, products and messages
/// cross 16 bits and saturate at both 32-bit bounds.
fn widened(rules: &str, agents: &str, scale: i64) -> (String, String) {
    let big = |t: &str| match t {
        "0001" => Some("1073741824"),
        "-0001" => Some("-1073741824"),
        "0002" => Some("2147483646"),
        "-0002" => Some("-2147483647"),
        _ => None,
    };
    let word = |w: &str| {
        let (op, rest) = match w.strip_prefix(['<', '>', '=']) {
            Some(r) => (&w[..1], r),
            None => ("", w),
        };
        big(rest).map_or(w.to_string(), |b| format!("{op}{b}"))
    };
    let mut r: String = (rules.lines())
        .map(|l| {
            if l.starts_with("//") {
                l.to_string()
            } else {
                l.split(' ').map(word).collect::<Vec<_>>().join(" ")
            }
        })
        .map(|l| l + "\n")
        .collect();
    r += "\n// latticesim: counters 32\n";
    let a: String = (agents.lines())
        .map(|l| {
            let mut out: Vec<String> = Vec::new();
            for w in l.split(' ') {
                let after_counter = out.last().is_some_and(|p| {
                    p.len() == 3 && p.starts_with('C') && p[1..].bytes().all(|b| b.is_ascii_digit())
                });
                match w.parse::<i64>() {
                    Ok(v) if after_counter => out.push((v * scale).to_string()),
                    _ => out.push(w.to_string()),
                }
            }
            out.join(" ") + "\n"
        })
        .collect();
    (r, a)
}

proptest! {
    #![proptest_config(ProptestConfig {
        cases: std::env::var("PROPTEST_CASES").ok().and_then(|s| s.parse().ok()).unwrap_or(200),
        failure_persistence: None,
        ..ProptestConfig::default()
    })]

    #[test]
    fn engine_agrees_with_reference_2d(r in rules(false), a in agents(false)) {
        every_option(&r, &a, 1)?;
    }

    /// A history reaches any step, by its deltas, its keyframes or stepping, exactly as a
    /// straight run has it (agents, inboxes, statistics, the step's report), 2D and 3D,
    /// with deltas kept for every step, for a few, or none.
    #[test]
    fn history_reaches_each_step_as_a_straight_run(
        (r, a) in proptest::bool::ANY.prop_flat_map(|d3| (rules(d3), agents_in(d3, if d3 { 5 } else { 9 }, 60))),
        targets in proptest::collection::vec(0u64..30, 1..12),
        budget in pick(vec![0usize, 3_000, usize::MAX]),
    ) {
        history_matches(&r, &a, &targets, budget)?;
    }

    /// With 32-bit counters: values past 16 bits, saturation at both bounds, division and
    /// messages, against the reference in the same width.
    #[test]
    fn engine_agrees_with_reference_wide_2d(r in rules(false), a in agents(false)) {
        let (r, a) = widened(&r, &a, 715_827_882);
        every_option(&r, &a, 1)?;
    }

    #[test]
    fn engine_agrees_with_reference_wide_3d(r in rules(true), a in agents(true)) {
        let (r, a) = widened(&r, &a, 715_827_882);
        every_option(&r, &a, 1)?;
    }

    #[test]
    fn engine_agrees_with_reference_3d(r in rules(true), a in agents(true)) {
        every_option(&r, &a, 1)?;
    }

    /// Several swap requests around one agent, and static and moving rules of one agent
    /// touching the same state characters and attachment directions.
    #[test]
    fn themes_agree_with_reference_2d(r in themes(false), a in agents(false)) {
        every_option(&r, &a, 1)?;
    }

    #[test]
    fn themes_agree_with_reference_3d(r in themes(true), a in agents(true)) {
        every_option(&r, &a, 1)?;
    }

    /// The checker's claims that a rule never fires hold in runs: a rule with a
    /// contradictory precondition (W502) or always outranked (W506) fires in no step, and
    /// of two rules that always conflict (W505) neither fires without a conflict record.
    #[test]
    fn rules_said_never_to_fire_never_fire(
        (_, r, a) in proptest::bool::ANY.prop_flat_map(|d3| (Just(d3), rules(d3), agents(d3)))
    ) {
        let c = common::checked(&r, &a);
        prop_assume!(c.errors() == 0);
        // The rule of a diagnostic: rules are blocks between blank lines.
        let rule_of = |d: &latticesim_grammar::Diagnostic| {
            r[..d.primary.span.start as usize].matches("\n\n").count()
        };
        let never: Vec<usize> = (c.diags.iter())
            .filter(|d| matches!(d.code, Code::W502 | Code::W506))
            .map(rule_of)
            .collect();
        let conflicting: Vec<usize> = (c.diags.iter())
            .filter(|d| d.code == Code::W505)
            .map(rule_of)
            .collect();
        let (prog, lat) = common::compile(&r, &a);
        let mut e = Engine::new(prog, lat, Options::default());
        let mut conflicts = 0;
        for _ in 0..6 {
            let rep = e.step();
            conflicts += (rep.records.iter())
                .filter(|x| matches!(x.kind, RecordKind::StateConflict | RecordKind::MoveConflict))
                .count();
        }
        for &i in &never {
            prop_assert_eq!(e.stats.firings[i], 0, "rule {} fired\n{}\n{}", i, r, a);
        }
        for &i in &conflicting {
            prop_assert!(e.stats.firings[i] == 0 || conflicts > 0, "rule {} fired without a conflict\n{}\n{}", i, r, a);
        }
    }

    /// What the viewer's inspector asks, the rules an agent executes next
    /// (`Engine::next_rules`, the selection alone), is what a traced step fires for it.
    #[test]
    fn next_rules_are_the_traced_firings(
        (_, r, a) in proptest::bool::ANY.prop_flat_map(|d3| (Just(d3), rules(d3), agents(d3)))
    ) {
        let (prog, lat) = common::compile(&r, &a);
        let traced = Options { trace: true, ..Options::default() };
        let mut e = Engine::new(prog.clone(), lat.clone(), traced);
        let rep = e.step();
        for agent in 0..lat.len() as u32 {
            let fired = rep.trace.iter().find_map(|ev| match ev {
                TraceEvent::Fire { agent: x, rules, priority } if *x == agent => Some((rules.clone(), *priority)),
                _ => None,
            });
            let next = Engine::new(prog.clone(), lat.clone(), Options::default()).next_rules(agent);
            prop_assert_eq!(next, fired, "agent {}\n{}\n{}", agent, r, a);
        }
    }

    /// `latticesim fmt` on generated rules: the formatted file runs exactly as the original
    /// (same configuration, records and statistics after every step) and formatting it
    /// again changes nothing.
    #[test]
    fn formatted_rules_run_the_same(
        (d3, r, a) in proptest::bool::ANY.prop_flat_map(|d3| (Just(d3), rules(d3), agents(d3)))
    ) {
        let hint = Some(if d3 { 3 } else { 2 });
        let once = latticesim_compiler::format_rules(&r, hint).expect("generated rules read");
        let twice = latticesim_compiler::format_rules(&once, hint).expect("formatted rules read");
        prop_assert_eq!(&once, &twice);
        let engine = |rules: &str| {
            let (prog, lat) = common::compile(rules, &a);
            Engine::new(prog, lat, Options::default())
        };
        let (mut original, mut formatted) = (engine(&r), engine(&once));
        for _ in 0..4 {
            prop_assert_eq!(original.step(), formatted.step(), "{}\n--\n{}", r, once);
            prop_assert!(original.lat == formatted.lat, "{}\n--\n{}", r, once);
        }
        prop_assert_eq!(&original.stats, &formatted.stats);
    }
}

proptest! {
    // Large instances (more than 2,500 agents) reach every batch, chunk and thread path of
    // the engine; PROPTEST_LARGE_CASES sets how many (default: 2 in an optimised build, none
    // in an unoptimised one, where the reference evaluator takes minutes a case; .ci/run
    // runs them with --release).
    #![proptest_config(ProptestConfig {
        cases: std::env::var("PROPTEST_LARGE_CASES").ok().and_then(|s| s.parse().ok()).unwrap_or(if cfg!(debug_assertions) { 0 } else { 2 }),
        failure_persistence: None,
        ..ProptestConfig::default()
    })]

    #[test]
    fn large_instances_agree_with_reference_2d(r in prop_oneof![rules(false), themes(false)], a in large_agents(false)) {
        every_option(&r, &a, 2)?;
    }

    #[test]
    fn large_instances_agree_with_reference_3d(r in prop_oneof![rules(true), themes(true)], a in large_agents(true)) {
        every_option(&r, &a, 2)?;
    }
}

/// Rules of the two themes: swaps around agents (several `X` rules of one priority, so an
/// agent may be asked for several swaps and its neighbours for swaps towards it), and pairs
/// of rules with one precondition and priority, one static and one moving, whose states
/// and letters overlap.
fn themes(d3: bool) -> BoxedStrategy<String> {
    let n = if d3 { 6 } else { 4 };
    let swaps = proptest::collection::vec(
        (
            1u16..3,
            state_pat(),
            pick(dirs(d3)),
            proptest::option::of(state_pat()),
        ),
        2..6,
    )
    .prop_map(|rs| {
        rs.iter()
            .enumerate()
            .map(|(i, (p, pre, d, st))| {
                let st = st.as_ref().map_or(String::new(), |s| format!(" S{s}"));
                format!("x{i}\n{p}\nS{pre}\nX{d}{st}\n")
            })
            .collect::<String>()
    });
    let letters = move || pat(n, "01*+");
    let split = proptest::collection::vec(
        (
            1u16..3,
            pre(d3),
            state_pat(),
            proptest::option::of(letters()),
            prop_oneof![
                offset(d3).prop_map(|o| format!("P{o}")),
                pick(dirs(d3)).prop_map(|d| format!("X{d}"))
            ],
            proptest::option::of(state_pat()),
            proptest::option::of(letters()),
        ),
        1..3,
    )
    .prop_map(|rs| {
        rs.iter()
            .enumerate()
            .map(|(i, (p, pre, s1, a1, mv, s2, a2))| {
                let a1 = a1.as_ref().map_or(String::new(), |a| format!(" A{a}"));
                let s2 = s2.as_ref().map_or(String::new(), |s| format!(" S{s}"));
                let a2 = a2.as_ref().map_or(String::new(), |a| format!(" A{a}"));
                format!("st{i}\n{p}\n{pre}\nS{s1}{a1}\nmv{i}\n{p}\n{pre}\n{mv}{s2}{a2}\n")
            })
            .collect::<String>()
    });
    prop_oneof![swaps, split].boxed()
}

/// A full block of more than 2,500 agents (52 x 50, or 14 x 14 x 14) with random states,
/// counters and bonds.
fn large_agents(d3: bool) -> impl Strategy<Value = String> {
    let (w, h, d) = if d3 { (14, 14, 14) } else { (52, 50, 1) };
    let n = (w * h * d) as usize;
    (
        proptest::collection::vec((0usize..3, -3i16..4, 0u8..4), n),
        proptest::bool::ANY,
    )
        .prop_map(move |(attrs, bounded)| {
            let mut text = String::new();
            if bounded {
                text += &if d3 {
                    format!("U0,{},0,{},0,{}\n", w - 1, h - 1, d - 1)
                } else {
                    format!("U0,{},0,{}\n", w - 1, h - 1)
                };
            }
            let mut k = 0;
            for z in 0..d {
                for y in 0..h {
                    for x in 0..w {
                        let (st, c0, bond) = attrs[k];
                        k += 1;
                        // Bonds east, made by both ends (the next agent's west), on a few.
                        let east = bond == 0 && x + 1 < w;
                        let west = x > 0 && attrs[k - 2].2 == 0;
                        let mut a = vec!['0'; if d3 { 6 } else { 4 }];
                        a[2] = if east { '1' } else { '0' };
                        a[1] = if west { '1' } else { '0' };
                        let a: String = a.into_iter().collect();
                        let pos = if d3 {
                            format!("{x},{y},{z}")
                        } else {
                            format!("{x},{y}")
                        };
                        text += &format!("{pos} S{} A{a} C00 {c0}\n", STATES[st]);
                    }
                }
            }
            text
        })
}

/// The generators reach every kind of record, moves, swaps and deliveries: the comparison
/// above is not vacuous.
#[test]
fn generators_reach_every_record_kind() {
    use proptest::strategy::ValueTree;
    let mut runner = fixed_runner(7);
    let mut kinds = std::collections::BTreeSet::new();
    let (mut moves, mut swaps, mut delivered) = (0, 0, 0);
    for i in 0..3000 {
        let d3 = i % 4 == 3;
        let r = rules(d3).new_tree(&mut runner).unwrap().current();
        let a = agents(d3).new_tree(&mut runner).unwrap().current();
        let (prog, lat) = common::compile(&r, &a);
        let mut e = Engine::new(prog, lat, Options::default());
        for _ in 0..6 {
            if e.step().quiescent {
                break;
            }
        }
        kinds.extend(e.stats.records.keys().copied());
        moves += e.stats.moves;
        swaps += e.stats.swaps;
        delivered += e.stats.delivered;
    }
    let missing: Vec<&str> = latticesim_runtime::RecordKind::ALL
        .iter()
        .filter(|k| !kinds.contains(k))
        .map(|k| k.name())
        .collect();
    assert!(missing.is_empty(), "never produced: {missing:?}");
    assert!(
        moves > 100 && swaps > 10 && delivered > 100,
        "{moves} moves, {swaps} swaps, {delivered} delivered"
    );
}

/// A proptest runner drawing the same cases on every machine (`seed`).
fn fixed_runner(seed: u64) -> proptest::test_runner::TestRunner {
    use proptest::test_runner::{Config, RngSeed, TestRunner};
    TestRunner::new(Config {
        rng_seed: RngSeed::Fixed(seed),
        ..Config::default()
    })
}

/// The agents of a generated shape with the generators' states and some counters.
fn with_states(base: &str) -> String {
    (base.lines().enumerate())
        .map(|(k, l)| {
            format!(
                "{l} S{} C00 {} C01 {}\n",
                STATES[k % 3],
                (k % 7) as i32 - 3,
                (k % 5) as i32 - 2
            )
        })
        .collect()
}

/// Threads and skipping change nothing: random rule sets on configurations large enough
/// to be split into chunks, run on 1 thread evaluating every agent and on 2, 3 and 8
/// threads skipping quiet agents (by default, whenever possible, or not at all), agree on
/// everything after every step.
#[test]
fn threads_give_the_same_results() {
    use latticesim_runtime::shapes::{agents_text, GenOptions, Shape};
    use proptest::strategy::ValueTree;
    let mut runner = fixed_runner(11);
    for i in 0..24u64 {
        let d3 = i % 3 == 2;
        let r = rules(d3).new_tree(&mut runner).unwrap().current();
        let o = GenOptions {
            three_d: d3,
            seed: i,
            ..Default::default()
        };
        let base = agents_text(&Shape::Connected { n: 2500 }, &o).unwrap();
        let (prog, lat) = common::compile(&r, &with_states(&base));
        let order = if i % 2 == 0 {
            Order::ActionsFirst
        } else {
            Order::MessagesFirst
        };
        let mk = |threads, skip| {
            Engine::new(
                prog.clone(),
                lat.clone(),
                Options {
                    order,
                    threads,
                    skip,
                    // Half the cases with agents kept in space order, in every engine.
                    space_order: match i % 4 < 2 {
                        true => SpaceOrder::Always,
                        false => SpaceOrder::Off,
                    },
                    ..Options::default()
                },
            )
        };
        // One thread without skipping, against 2, 3 and 8 threads skipping by default,
        // always, and not at all.
        let skip = [Skip::Auto, Skip::Eager, Skip::Off][i as usize % 3];
        let mut one = mk(1, Skip::Off);
        let mut more = [mk(2, skip), mk(3, skip), mk(8, skip)];
        for step in 0..6 {
            let a = one.step();
            for (t, e) in more.iter_mut().enumerate() {
                assert_eq!(a, e.step(), "case {i}, step {step}, engine {t}: reports");
                assert!(
                    one.lat == e.lat,
                    "case {i}, step {step}, engine {t}: lattices differ\n{r}"
                );
                assert_eq!(one.stats, e.stats, "case {i}, step {step}: statistics");
            }
        }
    }
}

/// Threads change nothing where the chunks' results must be joined in order: messages
/// left with their senders (the plan of senders is made in chunks), records of every
/// chunk (divisions by zero, saturations), runs of agents evaluated over chunks' ends, the
/// agents woken for the next step (found in chunks), and the actions collected, moves
/// made, groups carried, collisions cancelled, bonds made and swaps of chunks of agents;
/// 1, 2, 3 and 8 threads for eight steps (the thread tuner's first trial included).
#[test]
fn threads_join_chunks_in_order() {
    let hash = |x: i32, y: i32| ((x * 31 + y * 17) % 23) as i64;
    let cases = [
        (
            "flood\n1\nS*****\nC00 A C00 #N01 C00 A C00 #W01 C00 A C00 #E01 C00 A C00 #S01 #*01 + C00 0000\n",
            block(64, 64, |x, y, _| format!(" C00 {}", hash(x, y) * 100 + x as i64)),
        ),
        (
            "r\n1\n<C00 0009\nC00 / C00 C01 C02 * C02 C03 C00 + C00 0001 #*01 + C02 0000\n\nq\n1\n>C00 0008\nC01 I C01 #N01 C01 + C01 #S01\n",
            block(64, 64, |x, y, _| {
                format!(" C00 {} C01 {} C02 300 C03 {}", (x + y) % 12, (x * y) % 3, 100 + x)
            }),
        ),
    ];
    // Gravity (moves at once) on a block with gaps, listed in order and scrambled.
    let fall = "fall\n1\nN***0 >C00 0000\nP0,-1 C00 - C00 0001\n";
    let cloud: Vec<String> = block(80, 80, |_, y, _| format!(" C00 {y}"))
        .lines()
        .enumerate()
        .filter(|(k, _)| (k * 7919) % 10 < 4)
        .map(|(_, l)| format!("{l}\n"))
        .collect();
    let mut scrambled = cloud.clone();
    for k in (1..scrambled.len()).rev() {
        scrambled.swap(k, (k * 7919 + 13) % (k + 1));
    }
    // States set at once beside moves (the selection decided by states alone: agents
    // take their state's hop, counted per chunk), with the moves of the general way.
    let hops = "go\n1\nSA****\nP1,0 SB****\n\nturn\n1\nSB****\nSC****\n\nback\n1\nSC****\nSA****\n";
    let states = block(64, 64, |x, y, _| {
        format!(" S{}0000", ["A", "B", "C"][hash(x, y) as usize % 3])
    });
    // Rigid bars of four carried east into a wall (groups, collisions cancelled round
    // after round as the bars close up), and lines sorted by swaps (odd-even sort).
    let bars = "push\n1\nSB****\nP1,0 A+***\n\nhold\n1\nSC****\nA+**+\n";
    let barred = bar_rows(40, 10, 24);
    // The same bars listed in no order: groups whose members lie in different chunks.
    let mut bars_scrambled: Vec<&str> = barred.lines().collect();
    for k in (1..bars_scrambled.len()).rev() {
        bars_scrambled.swap(k, (k * 7919 + 13) % (k + 1));
    }
    let bars_scrambled = bars_scrambled.join("\n") + "\n";
    let sort = include_str!("../../examples/odd-even-sort/rules.txt");
    let lines: String = (0..4)
        .flat_map(|y| {
            (0..300).map(move |x| {
                format!(
                    "{x},{} S0SORT C00 {} C01 {} C03 300\n",
                    2 * y,
                    (x * 7919 + y) % 300,
                    x % 2
                )
            })
        })
        .collect();
    // The bouncing example's dots, 35,000 in a 400 x 400 universe: moves of several
    // offsets, more than 8,192 a step (the moves alone on the pool), and turns.
    let bounce = include_str!("../../examples/bouncing/rules.txt");
    let mut dots = String::from("U0,399,0,399\n");
    for k in 0..160_000u64 {
        let h = k.wrapping_mul(0x9E37_79B9_7F4A_7C15) >> 40;
        if h % 9 < 2 {
            let heading = ["NE", "NW", "SE", "SW"][(h / 9 % 4) as usize];
            dots += &format!("{},{} S{heading}000\n", k / 400, k % 400);
        }
    }
    // 40,000 agents heading east, west or north (or staying) in a 250 x 250 square,
    // unbounded: collisions (cancelled round after round), agents leaving the grid, more
    // than 8,192 moves asked for a step.
    let mut field = String::new();
    for k in 0..62_500u64 {
        let h = k.wrapping_mul(0x9E37_79B9_7F4A_7C15) >> 40;
        if h % 25 < 16 {
            let state = ["E", "W", "N", "S"][(h / 25 % 4) as usize];
            field += &format!("{},{} S{state}0000\n", k / 250, k % 250);
        }
    }
    // Swaps in every direction on a 120 x 120 block (more than 4,096 asked a step: the
    // swaps on the pool), agents asked for two swaps (in none), swaps sharing an agent,
    // and bonded pairs (their swaps made one at a time, dropping their neighbours' bonds).
    let swap = "e\n1\nSE****\nXE\n\nw\n1\nSW****\nXW\n\nn\n1\nSN****\nXN\n\ns\n1\nSS****\nXS\n\nd1\n1\nSD****\nXE\n\nd2\n1\nSD****\nXN\n";
    let swapping = block(120, 120, |x, y, _| {
        let bond = match x % 4 {
            0 if x < 119 => "A0010",
            1 => "A0100",
            _ => "A0000",
        };
        let state = ["E", "W", "N", "S", "D", "R"][((x * 13 + y * 7) % 29 % 6) as usize];
        format!(" S{state}0000 {bond}")
    });
    // Gravity with a rule per state, each turning its agents to the other state as they
    // fall (more than 4,096 states set a step: on the pool, each chunk its own agents; the
    // moves at once from the actions' list; runs across the two states' lists).
    let toggle = "fall_a\n1\nSA**** N***0 >C00 0000\nP0,-1 SB0000 C00 - C00 0001\n\n\
                  fall_b\n1\nSB**** N***0 >C00 0000\nP0,-1 SA0000 C00 - C00 0001\n";
    let toggling = sparse_block(150, 150, |x, y, k| {
        let state = ["A", "B"][((k * 7919) >> 3) % 2];
        ((k * 7919) % 10 < 4).then(|| format!(" S{state}0000 C00 {}", y + x % 3))
    });
    // Bars as above, 280,000 agents, more than 2^18 of them moving every step (the groups'
    // moves on the pool), against walls from the second step.
    let many_bars = bar_rows(280, 250, 500);
    // The scrambled bars pulled apart, bottom east and top west: every group's members
    // disagree (a record naming them, in order), members in other chunks than their
    // roots'.
    let apart = "push\n1\nSB****\nP1,0 A+***\n\nhold\n1\nSC****\nA+**+\n\n\
                 pull\n1\nSD****\nP-1,0 A***+\n";
    let bars_apart = bars_scrambled.replace("SC0000 A0001", "SD0000 A0001");
    // Bonds made by one side, read by the other: agents in state L attach west, those in
    // state R, which change nothing themselves, then see the bond (every agent among the
    // bonds' agents: the bonds written per chunk, the agents whose bonds changed woken).
    let linking = "link\n1\nSL****\nSM0000 A*1**\n\nseen\n1\nSR**** A**1*\nSD0000\n";
    let columns = block(64, 64, |x, _, _| {
        [" SR0000", " SL0000"][x as usize % 2].into()
    });
    let cases = [
        cases[0].clone(),
        cases[1].clone(),
        (fall, cloud.concat()),
        (fall, scrambled.concat()),
        (hops, states),
        (bars, barred),
        (sort, lines),
        (bounce, dots),
        (PLAIN, field),
        (swap, swapping),
        (bars, bars_scrambled),
        (toggle, toggling),
        (bars, many_bars),
        (apart, bars_apart),
        (linking, columns),
    ];
    for (i, (rules, agents)) in cases.iter().enumerate() {
        // Unoptimised (`cargo test`), the four largest cases are left out (this test took
        // 14 s with three of them, 1.4 s without); `.ci/run` runs this file optimised,
        // with all.
        if cfg!(debug_assertions) && ((7..=9).contains(&i) || i == 12) {
            continue;
        }
        let (prog, lat) = common::compile(rules, agents);
        let mk = |threads, skip| {
            Engine::new(
                prog.clone(),
                lat.clone(),
                Options {
                    threads,
                    skip,
                    ..Options::default()
                },
            )
        };
        // Skipping always, the agents woken are found on the pool too (more than a
        // thread takes alone move in gravity's first steps).
        let mut one = mk(1, Skip::Off);
        let mut more = [
            mk(2, Skip::Auto),
            mk(3, Skip::Auto),
            mk(8, Skip::Auto),
            mk(2, Skip::Eager),
            mk(3, Skip::Eager),
        ];
        let mut collided = false;
        let mut kinds = std::collections::BTreeSet::new();
        for step in 0..8 {
            let a = one.step();
            kinds.extend(a.records.iter().map(|r| r.kind.name()));
            assert!(
                step < 2 || !a.records.is_empty() || i != 1,
                "case {i} makes records"
            );
            collided |= a.records.iter().any(|r| r.kind.name() == "move-collision");
            for e in &mut more {
                assert_eq!(a, e.step(), "case {i}, step {step}: reports");
                assert!(one.lat == e.lat, "case {i}, step {step}: lattices differ");
                assert_eq!(one.stats, e.stats, "case {i}, step {step}: statistics");
            }
        }
        // The bars are carried and collide; the lines swap.
        assert!(
            (i != 5 && i != 10) || (one.stats.carried > 0 && collided),
            "case {i}"
        );
        assert!(i != 6 || one.stats.swaps > 1000, "case {i}");
        assert!(
            i != 7 || one.stats.moves > 8 * 8192,
            "case {i}: {}",
            one.stats.moves
        );
        assert!(
            i != 9
                || (one.stats.swaps > 2000
                    && kinds.contains("swap-shared")
                    && kinds.contains("swap-target")),
            "case {i}: {} swaps, records {kinds:?}",
            one.stats.swaps
        );
        // (More than 4,096 states set a step.)
        assert!(
            i != 11 || one.stats.moves > 8 * 4096,
            "case {i}: {} moves",
            one.stats.moves
        );
        assert!(
            i != 14 || one.stats.firings == [2048, 2048],
            "case {i}: {:?}",
            one.stats.firings
        );
        assert!(
            i != 13 || (kinds.contains("group-conflict") && one.stats.moves == 0),
            "case {i}: {kinds:?}"
        );
        assert!(
            i != 12 || (one.stats.moves > 8 << 18 && collided),
            "case {i}: {} moves",
            one.stats.moves
        );
        // (Firings of `east`, `west` and `north`: moves asked for.)
        let asked: u64 = one.stats.firings.iter().take(3).sum();
        assert!(
            i != 8 || (asked > 8 * 8192 && one.stats.moves > 8192 && collided),
            "case {i}: {asked} moves asked, {} made, collisions {collided}",
            one.stats.moves
        );
    }
}

/// Agents on every cell of a W x H block, x-major (the order in which the engine finds
/// runs of agents on consecutive cells), with extra fields per agent.
fn block(w: i32, h: i32, extra: impl Fn(i32, i32, usize) -> String) -> String {
    let mut s = String::new();
    let mut k = 0;
    for x in 0..w {
        for y in 0..h {
            s += &format!("{x},{y}{}\n", extra(x, y, k));
            k += 1;
        }
    }
    s
}

/// `rows` rows of `per_row` rigid bars of four (bonded north-south, a bar every second
/// column, a row every five cells: B at the bottom, C above), each row ending at a wall of
/// `SW0000` agents in column `wall`.
fn bar_rows(rows: i32, per_row: i32, wall: i32) -> String {
    let mut s = String::new();
    for row in 0..rows {
        for b in 0..per_row {
            let (x, y) = (2 * b, 5 * row);
            s += &format!("{x},{y} SB0000 A1000\n{x},{} SC0000 A1001\n", y + 1);
            s += &format!("{x},{} SC0000 A1001\n{x},{} SC0000 A0001\n", y + 2, y + 3);
        }
        for y in 5 * row..5 * row + 5 {
            s += &format!("{wall},{y} SW0000\n");
        }
    }
    s
}

/// The cells of a `w` x `h` block (x, then y) where `agent` (given x, y and the cell's
/// index) gives an agent's line after its position; the others empty.
fn sparse_block(w: i32, h: i32, agent: impl Fn(i32, i32, usize) -> Option<String>) -> String {
    let mut s = String::new();
    for (k, (x, y)) in (0..w).flat_map(|x| (0..h).map(move |y| (x, y))).enumerate() {
        if let Some(rest) = agent(x, y, k) {
            s += &format!("{x},{y}{rest}\n");
        }
    }
    s
}

const FLOOD: &str = "flood\n1\nS*****\nC00 A C00 #N01 C00 A C00 #W01 C00 A C00 #E01 C00 A C00 #S01 #*01 + C00 0000\n";
const FALL: &str = "fall\n1\nN***0 >C00 0000\nP0,-1 C00 - C00 0001\n";
const CHAIN: &str = "even\n2\nP**<*\nC00 + C00 0001\n\nodd\n1\nS*****\nC01 + C01 0001\n";
const MIXED: &str = "grow\n2\nSA****\nC00 I C00 #N01 C01 * C00 C00 C02 / C01 C03 #*01 + C00 0000 SB****\n\nshrink\n1\nSB****\nC00 I C00 #S01 C02 M C00 C03 #E02 + C02 0000 SA****\n";
const PLAIN: &str = "east\n1\nSE****\nP1,0\n\nwest\n1\nSW****\nP-1,0\n\nnorth\n1\nSN****\nP0,1\n\nbehind\n1\nN*1**\nC01 + C01 0001\n";

/// `k` rules stepping states R0000, R0001, ... round a cycle.
fn cycle(k: usize) -> String {
    (0..k)
        .map(|i| format!("r{i}\n1\nSR{i:04}\nSR{:04}\n\n", (i + 1) % k))
        .collect()
}

fn hash(x: i32, y: i32) -> i64 {
    ((x * 31 + y * 17) % 23) as i64
}

/// The plain moves, and a jump by a counter.
fn crowd() -> String {
    format!("{PLAIN}\njump\n1\nSJ****\nPC00,0 C00 * C00 -0001\n")
}

/// Agents in rows of letters (`.` leaves a cell empty), each row repeated with gaps.
fn rows(rows: &[&str]) -> String {
    let mut s = String::new();
    for (y, row) in rows.iter().cycle().take(12).enumerate() {
        for (x, c) in row.chars().enumerate().filter(|c| c.1 != '.') {
            s += &format!("{},{} S{c}AAAA\n", x + (y % 3) * 2, y * 2);
        }
    }
    s
}

/// A block of movers of `kinds` kinds (of E, W, N, S, E, W, J), with gaps.
fn crowd_agents(kinds: usize) -> String {
    block(14, 14, |x, y, _| {
        let h = hash(x, y);
        let s = ["E", "W", "N", "S", "E", "W", "J"][h as usize % kinds];
        format!(" S{s}AAAA C00 {}", 25 + h)
    })
    .lines()
    .enumerate()
    .filter(|(k, _)| (k * 7919) % 10 < 6)
    .map(|(_, l)| format!("{l}\n"))
    .collect()
}

/// The engine's optimisations, each on a configuration shaped to trigger it, against the
/// reference in both orders, with and without static-first (which also switches tracing,
/// which turns the in-place state updates off): runs of agents executing one rule
/// (calculations one instruction at a time, the in-place max/min and plain sends), the
/// post office's runs of neighbours read from the grid and copied whole, preconditions
/// evaluated over runs, the selection kept across state changes, the candidate cache
/// growing past a thousand states, single-agent moves, priority chains (worklist),
/// saturation and division by zero inside runs.
#[test]
fn optimisations_agree_with_reference() {
    let cases = [
        counter_and_message_cases(),
        move_cases(),
        state_and_calc_cases(),
    ]
    .concat();
    for (i, (rules, agents)) in cases.iter().enumerate() {
        // Each case also with 32-bit counters, its values past 16 bits.
        let (wide_rules, wide_agents) = widened(rules, agents, 65_537);
        for (w, rules, agents) in [(16, rules, agents), (32, &wide_rules, &wide_agents)] {
            for order in [Order::ActionsFirst, Order::MessagesFirst] {
                for static_first in [false, true] {
                    // Unoptimised (`cargo test`), the 32-bit cases and the case of 1,200
                    // rules in one combination of the options (all took 70 s); `.ci/run`
                    // runs this file optimised, with all of them.
                    let heavy = w == 32 || rules.len() > 10_000;
                    let first = (order, static_first) == (Order::ActionsFirst, false);
                    if cfg!(debug_assertions) && heavy && !first {
                        continue;
                    }
                    if let Err(e) = differential(rules, agents, order, static_first) {
                        panic!("case {i}, {w}-bit, {order:?}, static-first {static_first}: {e}");
                    }
                }
            }
        }
    }
}

/// Quiet agents (no valid rule) that something wakes later, each case for one cause of
/// waking (see the engine's `activity.rs`): a message arriving, an inbox emptied a step
/// after a message, a state read at an offset, a counter read at an offset (`V`), a bond
/// made, agents swapped under a reader, groups carried past readers, walkers leaving the
/// box in every direction and far, a rule whose offset depends on a counter. Each runs
/// with skipping (whenever possible, and as by default) and without, against the
/// reference, in every order.
#[test]
fn skipping_agrees_with_reference() {
    let cases = skipping_cases();
    for (i, (rules, agents)) in cases.iter().enumerate() {
        for order in [Order::ActionsFirst, Order::MessagesFirst] {
            for static_first in [false, true] {
                if let Err(e) = differential(rules, agents, order, static_first) {
                    panic!("skipping case {i}, {order:?}, static-first {static_first}: {e}");
                }
            }
        }
    }
}

/// A few walkers that leave the grid beside agents at rest that read the cells they leave:
/// the grid is made again during a step's moves (the walkers' work outside it adds up), and
/// the readers of the cells they left are found on the new grid (the cells' codes noted
/// before the moves were the old grid's: an index out of bounds, found by the random cases,
/// before `Changes::grid`).
#[test]
fn readers_are_woken_across_a_grid_made_again() {
    // A row of readers, each under a walker; the walkers go west while the west cell is
    // free (the first at once, the others one by one), and a reader changes state when
    // the cell above it empties. The walkers leave the grid westwards as others still
    // leave the cells above readers, and the grid made again is shifted (room to the west):
    // a reader found through the old grid's code would be another cell's.
    let mut agents = String::new();
    for x in 0..60 {
        agents.push_str(&format!("{x},0 SREST0\n{x},1 SWALK0 C01 100\n"));
    }
    let rules = "// steps 130\nwalk\n1\nSWALK0 N*0** >C01 0000\nP-1,0 C01 - C01 0001\n\n\
                 done\n1\nSREST0 E0,1\nSDONE0\n";
    for order in [Order::ActionsFirst, Order::MessagesFirst] {
        for static_first in [false, true] {
            if let Err(e) = differential(rules, &agents, order, static_first) {
                panic!("{order:?}, static-first {static_first}: {e}");
            }
        }
    }
}

/// The cell index as agents move (see `cells.rs`): clusters far apart (a hash map with a
/// neighbour table, changed where agents move), a block walking out of its grid (made
/// again over where the agents are), agents jumping far in every direction, and a
/// bounded universe with a grid over all of it, or over the agents' box clipped to it.
#[test]
fn the_cell_index_follows_the_agents() {
    // Walkers east (E must be empty), falling agents (S empty), and agents that watch
    // the cell north of them fill and empty (they count in C02).
    let rules = "// steps 14\nwalk\n1\nSE0000 >C01 0000 N**0*\nP1,0 C01 - C01 0001\n\nfall\n1\nSF0000 >C01 0000 N***0\nP0,-1 C01 - C01 0001\n\njump\n1\nSJ0000 >C01 0000\nP-3000,2500 C01 - C01 0001\n\nwatch\n1\nSR0000 N1*** <C02 0003\nC02 + C02 0001 SR0000\n\nlook\n1\nSR0000 N0*** >C02 0000\nC02 - C02 0001\n";
    let block = |x0: i32, y0: i32, w: i32, h: i32, st: &str, c01: i32| -> String {
        (0..w)
            .flat_map(|x| (0..h).map(move |y| (x, y)))
            .map(|(x, y)| format!("{},{} S{st} C01 {c01}\n", x0 + x, y0 + y))
            .collect()
    };
    let row = |x0: i32, y: i32, w: i32, st: &str| -> String {
        (0..w).map(|x| format!("{},{y} S{st}\n", x0 + x)).collect()
    };
    let cases = [
        // Three clusters far apart: no grid.
        [
            block(0, 0, 3, 3, "E0000", 6),
            row(0, -1, 10, "R0000"),
            // A lone walker that comes up against an agent.
            block(20, 0, 1, 1, "E0000", 9),
            row(25, 0, 1, "R0000"),
            block(100_000, 50_000, 2, 4, "F0000", 5),
            row(100_000, 44_000, 2, "R0000"),
            block(-90_000, 7, 3, 2, "J0000", 2),
            row(-93_000, 2510, 4, "R0000"),
        ]
        .concat(),
        // A block walking out of its grid, over a row of watchers, past a wall.
        [
            block(0, 0, 12, 10, "E0000", 12),
            row(0, -1, 30, "R0000"),
            block(20, 0, 1, 3, "R0000", 0),
        ]
        .concat(),
        // A falling block that leaves its grid downwards, and jumpers.
        [
            block(0, 0, 10, 10, "F0000", 12),
            row(-2, -14, 14, "R0000"),
            block(30, 0, 2, 2, "J0000", 1),
        ]
        .concat(),
        // Clusters far apart at the ends of i32's range (tiles of cells whose
        // neighbours lie past it): walkers that reach the end, fallers and jumpers.
        [
            block(i32::MAX - 8, 0, 3, 3, "E0000", 12),
            row(i32::MAX - 9, -1, 10, "R0000"),
            block(i32::MIN, 5, 2, 2, "F0000", 6),
            row(i32::MIN, -2, 3, "R0000"),
            block(i32::MIN + 2000, i32::MAX - 3000, 2, 2, "J0000", 3),
            block(-7, i32::MIN + 1, 3, 1, "F0000", 4),
        ]
        .concat(),
    ];
    let bounded = [
        // A universe small enough for a grid over all of it.
        format!(
            "U-3,20,-14,12\n{}",
            [
                block(0, 0, 6, 5, "E0000", 9),
                row(0, -1, 18, "R0000"),
                block(3, 8, 2, 3, "F0000", 30)
            ]
            .concat()
        ),
        // A universe too large for that: the grid over the agents' box clipped to it.
        format!(
            "U-1,100000,-14,100000\n{}",
            [
                block(0, 0, 6, 5, "E0000", 9),
                row(-1, -1, 18, "R0000"),
                block(3, 8, 2, 3, "F0000", 30)
            ]
            .concat()
        ),
    ];
    for (i, agents) in cases.iter().chain(&bounded).enumerate() {
        for order in [Order::ActionsFirst, Order::MessagesFirst] {
            for static_first in [false, true] {
                if let Err(e) = differential(rules, agents, order, static_first) {
                    panic!("index case {i}, {order:?}, static-first {static_first}: {e}");
                }
            }
        }
    }
}

/// `agents` laid out three times, about 10^6 cells apart along x and 7 x 10^5 along y
/// (and 5 x 10^5 along z): a box over any grid's budget with no dense core, so that
/// every agent stands in tiles of cells and keeps a table of neighbours. `None` for a
/// file with a bounded universe (the copies would fall outside it).
fn far_apart(agents: &str) -> Option<String> {
    if agents.lines().any(|l| l.trim_start().starts_with('U')) {
        return None;
    }
    let mut out = String::new();
    for k in 0..3i64 {
        for l in agents.lines().map(str::trim) {
            if l.is_empty() || l.starts_with("//") {
                continue;
            }
            let (coords, rest) = l.split_once(' ').unwrap_or((l, ""));
            let shifted: Vec<String> = (coords.split(','))
                .zip([1_000_003, -700_001, 500_009])
                .map(|(c, d)| (c.parse::<i64>().expect("a coordinate") + k * d).to_string())
                .collect();
            out += &format!("{} {rest}\n", shifted.join(","));
        }
    }
    Some(out)
}

/// The shaped cases of moves, of waking quiet agents (swaps, bonds, carried groups,
/// walkers leaving in every direction) and of counters and messages, each laid out three
/// times far apart ([`far_apart`]: no grid, every agent in tiles of cells), against the
/// reference evaluator under both orders and `--static-first`.
#[test]
fn cases_far_apart_agree_with_reference() {
    let cases = [move_cases(), skipping_cases(), counter_and_message_cases()].concat();
    let mut ran = 0;
    for (i, (rules, agents)) in cases.iter().enumerate() {
        let Some(agents) = far_apart(agents) else {
            continue;
        };
        ran += 1;
        for order in [Order::ActionsFirst, Order::MessagesFirst] {
            for static_first in [false, true] {
                // (Unoptimised, one combination of the options: `.ci/run` runs this file
                // optimised, with all of them.)
                let first = (order, static_first) == (Order::ActionsFirst, false);
                if cfg!(debug_assertions) && !first {
                    continue;
                }
                if let Err(e) = differential(rules, &agents, order, static_first) {
                    panic!("far case {i}, {order:?}, static-first {static_first}: {e}");
                }
            }
        }
    }
    assert!(
        ran * 2 > cases.len(),
        "most cases run ({ran} of {})",
        cases.len()
    );
}

/// Moves made at once (every acting rule moves one step east, `plain_step`): a row that
/// moves as a chain, listed west to east and east to west (made in place only when each
/// target is empty when its mover comes to it; else undone and made the general way), a
/// row running into an agent that stays (in the second step, while the pool of threads
/// is tried first), a bonded mover among free ones, movers on the grid's rim; on one
/// thread and on three.
#[test]
fn moves_at_once_agree_with_reference() {
    let rules = "// steps 8\ngo\n1\nSE0000 >C01 0000\nP1,0 C01 - C01 0001\n\nhold\n1\nSH0000 N1***\nC02 + C02 0001\n\nfree\n1\nSF0000 N0***\nC02 + C02 0001\n";
    let row = |xs: &mut dyn Iterator<Item = i32>, y: i32, st: &str, c: i32| -> String {
        xs.map(|x| format!("{x},{y} S{st} C01 {c}\n")).collect()
    };
    let spaced = |y: i32, c: i32| row(&mut (0..4).map(|k| k * 2), y, "E0000", c);
    let cases = [
        row(&mut (0..12), 0, "E0000", 5),
        row(&mut (0..12).rev(), 0, "E0000", 5),
        // The third step's front mover runs into the holder after the others moved.
        [spaced(0, 6), "9,0 SH0000\n".into(), spaced(1, 2)].concat(),
        // The bonded mover (to the holder north of it) makes the second step go the
        // general way.
        [
            spaced(0, 3),
            "3,1 SE0000 A1000 C01 3\n".into(),
            row(&mut (0..5), 2, "H0000", 0),
        ]
        .concat(),
        [
            row(&mut (0..40).map(|k| k * 2), 0, "E0000", 4),
            row(&mut (0..40).map(|k| k * 2), 9, "E0000", 4),
        ]
        .concat(),
        // A jam: most movers stand behind the holder (blocked, and left to the general
        // way); the few free ones walk on, at once again after a pause.
        [
            row(&mut (0..12), 0, "E0000", 9),
            "12,0 SH0000\n".into(),
            spaced(2, 9),
        ]
        .concat(),
        // Movers onto the universe's wall (the grid's rim there) wake the holders below
        // it; one leaving the rim frees the agent below its first cell.
        [
            "U0,19,-100000,100000\n".into(),
            row(&mut (0..7).map(|k| 5 + k * 2), 3, "E0000", 9),
            "0,3 SE0000 C01 9\n19,2 SH0000\n17,2 SH0000\n0,2 SF0000\n".into(),
        ]
        .concat(),
    ];
    // Every case also as copies one above the other, for the pool of threads: twice as
    // many agents as a thread takes alone, so that the pool splits them into chunks (300
    // copies, up to 24,000 agents, took minutes against the reference evaluator).
    for (i, case) in cases.iter().enumerate() {
        let copies =
            (2 * latticesim_runtime::AGENTS_PER_THREAD).div_ceil(case.lines().count()) as i32;
        // (A universe line stays first, once.)
        let (universe, agents) = match case.split_once('\n') {
            Some((u, rest)) if u.starts_with('U') => (format!("{u}\n"), rest),
            _ => (String::new(), &case[..]),
        };
        let ys = || {
            agents
                .lines()
                .map(|l| l.split([',', ' ']).nth(1).unwrap().parse::<i32>().unwrap())
        };
        let stride = ys().max().unwrap() + 2;
        let many: String = universe
            + &(0..copies)
                .map(|k| {
                    agents
                        .lines()
                        .map(|l| {
                            let (xy, rest) = l.split_once(' ').unwrap();
                            let (x, y) = xy.split_once(',').unwrap();
                            let y: i32 = y.parse().unwrap();
                            format!("{x},{} {rest}\n", y + stride * k)
                        })
                        .collect::<String>()
                })
                .collect::<String>();
        for (text, threads) in [(case, 1), (&many, 3)] {
            for skip in [Skip::Eager, Skip::Off] {
                for order in [Order::ActionsFirst, Order::MessagesFirst] {
                    if let Err(e) = differential_on(rules, text, (order, false, skip), threads) {
                        panic!("case {i}, {threads} threads, {skip:?}, {order:?}: {e}");
                    }
                }
            }
        }
    }
}

/// Movers that reach the grid's rim find room made ahead of them (the grid made again,
/// longer in their direction of travel) instead of leaving the grid one by one for the
/// hash map: blocks of movers (every other cell along their way, so that every target is
/// empty) beside agents that stay, in every direction in 2D and 3D, far past the grid they
/// started in. The same as the reference evaluator on one thread and on three (blocks of
/// more than two threads' share of agents), and no agent of the large blocks is ever off
/// the grid (a grid made again for a score of movers would cost more than their moves
/// the slow way: some go there).
/// An engine of `rules` on `agents` with the default options on `threads` threads.
fn engine_on(rules: &str, agents: &str, threads: usize) -> Engine {
    let (prog, lat) = common::compile(rules, agents);
    let opts = Options {
        threads,
        ..Options::default()
    };
    Engine::new(prog, lat, opts)
}

#[test]
fn movers_at_the_rim_grow_the_grid() {
    let dirs: Vec<[i32; 3]> = (0..6)
        .map(|k| {
            let mut o = [0; 3];
            o[k / 2] = if k % 2 == 0 { 1 } else { -1 };
            o
        })
        .collect();
    for (d3, size) in [
        (false, [5, 4, 1]),
        (false, [48, 50, 1]),
        (true, [3, 3, 2]),
        (true, [13, 13, 13]),
    ] {
        for off in dirs.iter().filter(|o| d3 || o[2] == 0) {
            let k = off.iter().position(|&c| c != 0).unwrap();
            let text = |p: [i32; 3]| match d3 {
                true => format!("{},{},{}", p[0], p[1], p[2]),
                false => format!("{},{}", p[0], p[1]),
            };
            let mut agents = String::new();
            for x in 0..size[0] {
                for y in 0..size[1] {
                    for z in 0..size[2] {
                        let mut p = [x, y, z];
                        p[k] *= 2;
                        agents += &format!("{} SE0000 C01 30\n", text(p));
                    }
                }
            }
            // Agents that stay, beside the block (across its way).
            let mut side = [0; 3];
            side[(k + 1) % if d3 { 3 } else { 2 }] = -2;
            agents += &format!("{} SR0000\n", text(side));
            let rules = format!(
                "// steps 36\ngo\n1\nSE0000 >C01 0000\nP{} C01 - C01 0001\n",
                text(*off)
            );
            let large = size[0] > 10;
            // The large blocks against the reference only when optimised (.ci/run runs this
            // file so; unoptimised, the reference takes minutes on them): there, one thread
            // against three.
            if !large || !cfg!(debug_assertions) {
                for skip in [Skip::Eager, Skip::Off] {
                    let threads = if large { 3 } else { 1 };
                    let how = (Order::ActionsFirst, false, skip);
                    if let Err(e) = differential_on(&rules, &agents, how, threads) {
                        panic!("{size:?} moving {off:?}, {skip:?}: {e}");
                    }
                }
            }
            if !large {
                continue;
            }
            let engine = |threads| engine_on(&rules, &agents, threads);
            let (mut one, mut three) = (engine(1), engine(3));
            for step in 1..=36 {
                assert_eq!(
                    one.step(),
                    three.step(),
                    "{size:?} moving {off:?}, step {step}"
                );
                assert!(one.lat == three.lat, "{size:?} moving {off:?}, step {step}");
                assert_eq!(
                    three.lat.off_grid(),
                    0,
                    "{size:?} moving {off:?}, step {step}"
                );
            }
        }
    }
}

/// A cell as agents.txt writes it, in 3D or 2D.
fn cell_text(d3: bool, p: [i32; 3]) -> String {
    match d3 {
        true => format!("{},{},{}", p[0], p[1], p[2]),
        false => format!("{},{}", p[0], p[1]),
    }
}

/// A block of agents at rest (`SR0000`, C00 = 0) from the origin, 40^3 in 3D or 130^2 in
/// 2D: its lines, its size and its number of agents.
fn block_at_rest(d3: bool) -> (String, [i32; 3], usize) {
    let size = if d3 { [40, 40, 40] } else { [130, 130, 1] };
    let mut block = String::new();
    for x in 0..size[0] {
        for y in 0..size[1] {
            for z in 0..size[2] {
                block += &format!("{} SR0000 C00 0\n", cell_text(d3, [x, y, z]));
            }
        }
    }
    (block, size, (size[0] * size[1] * size[2]) as usize)
}

/// Walkers far from a block at rest (farther than a grid over both can span) get a grid
/// of their own, the block's agents beside it: in every direction of 2D and one of 3D,
/// against the reference (with skipping and without in 2D), and on three threads as on
/// one; in most steps every walker stands on the grid. (Only optimised, as .ci/run runs
/// this file: the walkers must be under one agent in a hundred, so that the first grid is
/// the block's, and the block large enough that their moves pay for a grid soon.)
#[test]
fn walkers_far_from_a_block_get_a_grid_of_their_own() {
    if cfg!(debug_assertions) {
        return;
    }
    let steps = 60;
    for d3 in [false, true] {
        let text = |p| cell_text(d3, p);
        let (block, _, agents_at_rest) = block_at_rest(d3);
        // (In 3D one direction, down, and the reference with skipping only:
        // it takes a minute a run there.)
        let ks: &[usize] = if d3 { &[5] } else { &[0, 1, 2, 3] };
        for &k in ks {
            let mut off = [0; 3];
            off[k / 2] = if k % 2 == 0 { 1 } else { -1 };
            // A row of walkers along their way, 10^6 cells out that way.
            let walkers = (agents_at_rest * 94 / 10_000) as i32;
            let mut agents = block.clone();
            for i in 0..walkers {
                let mut p = [0; 3];
                p[k / 2] = off[k / 2] * (1_000_000 + 2 * i);
                agents += &format!("{} SE0000 C01 {}\n", text(p), steps + 10);
            }
            let nd = if d3 { 6 } else { 4 };
            let ahead = (latticesim_compiler::checked::Dir::ALL.iter())
                .position(|d| d.offset() == off)
                .unwrap();
            let pattern: String = (0..nd)
                .map(|d| if d == ahead { '0' } else { '*' })
                .collect();
            let rules = format!(
                "// steps {steps}\ngo\n1\nSE0000 N{pattern} >C01 0000\nP{} C01 - C01 0001\n\n\
                 rest\n1\nSR0000 >C00 0000\nC00 - C00 0001\n",
                text(off)
            );
            let skips: &[Skip] = if d3 {
                &[Skip::Auto]
            } else {
                &[Skip::Auto, Skip::Off]
            };
            for &skip in skips {
                let how = (Order::ActionsFirst, false, skip);
                if let Err(e) = differential_on(&rules, &agents, how, 1) {
                    panic!("3D {d3}, moving {off:?}, {skip:?}: {e}");
                }
            }
            let engine = |threads| engine_on(&rules, &agents, threads);
            let (mut one, mut three) = (engine(1), engine(3));
            let mut own_grid = 0;
            for step in 1..=steps {
                assert_eq!(one.step(), three.step(), "moving {off:?}, step {step}");
                own_grid += (one.lat.off_grid() == agents_at_rest) as usize;
            }
            assert!(one.lat == three.lat, "moving {off:?}");
            assert!(
                own_grid > steps / 2,
                "3D {d3}, moving {off:?}: the walkers on a grid of their own in {own_grid} steps"
            );
        }
    }
}

/// Walkers in a row beside a block at rest (not far from it: a grid over both with room
/// ahead is within the budget) get a grid of their own when they reach the grid's rim
/// (made over them and their room, the block beside it: a grid over the block with room
/// ahead of them cost the 3D walkers twice the time); once they turn back and reach that
/// grid's other rim, the next grid is made over every agent (a grid of their own at every turn would cost a pass over
/// every agent per turn). The same results as the reference (in 2D, with and without
/// skipping) and on one and three threads.
#[test]
fn walkers_beside_a_block_get_a_grid_of_their_own_until_they_turn() {
    if cfg!(debug_assertions) {
        return;
    }
    // (In 3D the walkers go the slow way for a dozen steps before the grid pays.)
    let (out, back) = (40, 45);
    let steps = out + back + 5;
    for d3 in [false, true] {
        let text = |p| cell_text(d3, p);
        let (mut agents, size, agents_at_rest) = block_at_rest(d3);
        // Just above the block: in 2D a row along x from its west side to past its east
        // side, in 3D a slab of rows 20 long over it (as the bench's 3D walkers).
        let walkers = (agents_at_rest * 94 / 10_000) as i32;
        for i in 0..walkers {
            let p = match d3 {
                true => [2 * (i % 20), size[1] + 1, i / 20],
                false => [2 * i, size[1] + 1, 0],
            };
            agents += &format!("{} SE0000 C01 {out}\n", text(p));
        }
        let (east, west) = match d3 {
            true => ("N**0***", "N*0****"),
            false => ("N**0*", "N*0**"),
        };
        let rules = format!(
            "// steps {steps}\neast\n1\nSE0000 {east} >C01 0000\nP{} C01 - C01 0001\n\n\
             turn\n1\nSE0000 =C01 0000\nSW0000 C01 + C01 {back:04}\n\n\
             west\n1\nSW0000 {west} >C01 0000\nP{} C01 - C01 0001\n\n\
             rest\n1\nSR0000 >C00 0000\nC00 - C00 0001\n",
            text([1, 0, 0]),
            text([-1, 0, 0])
        );
        if !d3 {
            for skip in [Skip::Auto, Skip::Off] {
                let how = (Order::ActionsFirst, false, skip);
                if let Err(e) = differential_on(&rules, &agents, how, 1) {
                    panic!("{skip:?}: {e}");
                }
            }
        }
        let engine = |threads| engine_on(&rules, &agents, threads);
        let (mut one, mut three) = (engine(1), engine(3));
        let (mut own_grid, mut all_on_grid) = (0, 0);
        for step in 1..=steps {
            assert_eq!(one.step(), three.step(), "3D {d3}, step {step}");
            let off = one.lat.off_grid();
            match step <= out {
                // (The grid over the walkers takes in the block's top row.)
                true => own_grid += (off > agents_at_rest / 2) as usize,
                false => all_on_grid += (off == 0) as usize,
            }
        }
        assert!(one.lat == three.lat, "3D {d3}");
        assert!(
            own_grid > out as usize / 4,
            "3D {d3}: the walkers on a grid of their own in {own_grid} of {out} steps east"
        );
        // (Back west, they walk the grid of their own to its west rim first.)
        assert!(
            all_on_grid > 0 && one.lat.off_grid() == 0,
            "3D {d3}: every agent on the grid in {all_on_grid} steps after the turn, and not at the end"
        );
    }
}

/// The cases of [`skipping_agrees_with_reference`]: `// steps N` first says how many steps
/// each runs.
fn skipping_cases() -> Vec<(String, String)> {
    let countdown = "tick\n1\nSA0000 >C00 0000\nC00 - C00 0001\n\n";
    vec![
        // A message arriving wakes its quiet recipient.
        (
            "// steps 8\ntick\n1\nSA0000 >C00 0001\nC00 - C00 0001\n\nsend\n1\nSA0000 =C00 0001\n#E01 + 0005 0000 C00 - C00 0001\n\ngo\n1\nSWAIT0 >#W01 0000\nSDONE0\n".into(),
            "0,0 SA0000 C00 3\n1,0 SWAIT0\n5,5 SWAIT0\n".into(),
        ),
        // An inbox emptied a step after a message wakes its agent: the sender sends at
        // steps 3 and 4; its neighbour, woken by the first message (it changes state), is
        // quiet at step 5 with the second and must see its empty inbox at step 6 (an agent
        // counting down far away keeps the run going).
        (
            "// steps 10\ntick\n1\nSA0000 >C00 0002\nC00 - C00 0001\n\nsend\n1\nSA0000 <C00 0003 >C00 0000\n#E01 + 0005 0000 C00 - C00 0001\n\npre\n1\nSPRE00 =#W01 0005\nSWAIT0\n\ngo\n1\nSWAIT0 =#W01 0000\nSDONE0\n\nkeep\n1\nST0000 >C00 0000\nC00 - C00 0001\n".into(),
            "0,0 SA0000 C00 4\n1,0 SPRE00\n9,9 ST0000 C00 20\n".into(),
        ),
        // The same, with text messages.
        (
            "// steps 10\ntick\n1\nSA0000 >C00 0002\nC00 - C00 0001\n\nsend\n1\nSA0000 <C00 0003 >C00 0000\nMEHELLO C00 - C00 0001\n\npre\n1\nSPRE00 MWHELLO\nSWAIT0\n\ngo\n1\nSWAIT0 !MWH****\nSDONE0\n\nkeep\n1\nST0000 >C00 0000\nC00 - C00 0001\n".into(),
            "0,0 SA0000 C00 4\n1,0 SPRE00\n9,9 ST0000 C00 20\n".into(),
        ),
        // A state read at an offset.
        (
            format!("// steps 8\n{countdown}flip\n1\nSA0000 =C00 0000\nSGO000\n\ngo\n1\nSWAIT0 T-2,0,GO000\nSDONE0\n"),
            "0,0 SA0000 C00 3\n2,0 SWAIT0\n1,0 SWAIT0\n".into(),
        ),
        // A counter read at an offset.
        (
            format!("// steps 8\n{countdown}go\n1\nSWAIT0 V-1,0,C00 0001\nSDONE0\n"),
            "0,0 SA0000 C00 3\n1,0 SWAIT0\n".into(),
        ),
        // A bond made by a neighbour.
        (
            format!("// steps 8\n{countdown}bond\n1\nSA0000 =C00 0000 !A**1*\nA**1*\n\ngo\n1\nSWAIT0 A*1**\nSDONE0\n"),
            "0,0 SA0000 C00 3\n1,0 SWAIT0\n".into(),
        ),
        // Two agents swapped under a reader of one's state.
        (
            format!("// steps 8\n{countdown}swap\n1\nSA0000 =C00 0000\nXE SB0000\n\ngo\n1\nSWAIT0 T0,-1,C0000\nSDONE0\n"),
            "0,0 SA0000 C00 2\n1,0 SC0000\n1,1 SWAIT0\n0,1 SWAIT0\n".into(),
        ),
        // A group carried past readers of its cells: a rigid pair moving east under a row
        // of agents waiting for the cell below to fill, one waiting for it to empty, and
        // the carried agent waiting to pass over an agent.
        (
            "// steps 10\nmove\n1\nSM0000 >C00 0000\nP1,0 A**+* C00 - C00 0001\n\nfull\n1\nSWAIT0 N***1\nSDONE0\n\nempty\n1\nSEMPT0 N***0\nSDONE0\n\nland\n1\nSC0000 N***1\nSDONE0\n".into(),
            "0,0 SM0000 A0010 C00 4\n1,0 SC0000 A0100\n3,1 SWAIT0\n4,1 SWAIT0\n5,1 SWAIT0\n0,1 SEMPT0\n1,1 SEMPT0\n3,-1\n".into(),
        ),
        // Bonds changed by a few agents beside many resting ones (only the agents concerned
        // are visited): a rigid pair whose carried agent also has a plain bond to one at
        // rest (dropped as it moves on); a chain carried through an agent that holds a
        // rigid bond without moving, to one with a plain bond to an agent at rest; the
        // movers attaching with `1` to agents under them that have no rule; an agent
        // detaching with `0` from one at rest; bonded resting agents that keep their bonds.
        (
            "// steps 6\nmove\n1\nSM0000 >C00 0000\nP1,0 A**+1 C00 - C00 0001\n\nhold\n1\nSH0000\nA**+*\n\ncut\n1\nSD0000 A1***\nA0*** SE0000\n\nsee\n1\nSR0000 A***1\nC01 + C01 0001\n\ntop\n1\nSR0000 A1***\nC02 + C02 0001\n".into(),
            format!(
                "0,0 SM0000 A0010 C00 3\n1,0 SC0000 A1100\n1,1 SR0000 A0001\n1,-1 SR0000\n2,-1 SR0000\n3,-1\n0,10 SM0000 A0010 C00 3\n1,10 SH0000 A0110\n2,10 SC0000 A1100\n2,11 SR0000 A0001\n10,5 SD0000 A1000\n10,6 SR0000 A0001\n{}",
                (0..64)
                    .map(|k| {
                        let (x, y) = (20 + k % 4, k / 4);
                        let a = ["A0010", "A0100"][(x % 2) as usize];
                        let st = ["SR0000", "SQ0000"][(y % 3 == 0) as usize];
                        format!("{x},{y} {st} {a}\n")
                    })
                    .collect::<String>()
            ),
        ),
        // Walkers leaving the box in every direction, one far, beside resting agents that
        // watch their paths.
        (
            "// steps 12\nwalk\n1\nSE0000 >C01 0000\nP1,0 C01 - C01 0001\n\nwest\n1\nSW0000 >C01 0000\nP-1,0 C01 - C01 0001\n\nnorth\n1\nSN0000 >C01 0000\nP0,1 C01 - C01 0001\n\nsouth\n1\nSS0000 >C01 0000\nP0,-1 C01 - C01 0001\n\nfar\n1\nSF0000 >C01 0000\nP9999,-7777 C01 - C01 0001\n\nsee\n1\nSREST0 N1***\nSSEEN0\n".into(),
            "0,0 SREST0\n1,0 SREST0\n0,1 SREST0\n1,1 SREST0\n2,0 SE0000 C01 9\n-1,1 SW0000 C01 9\n0,-1 SS0000 C01 9\n1,-3 SN0000 C01 9\n5,5 SF0000 C01 3\n10004,-7771 SREST0\n10003,-7774 SREST0\n".into(),
        ),
        // Walkers passing over a row of resting agents, sending each step to the agent
        // below them (after their move): messages delivered while agents move, to agents
        // quiet before and after; one walker's messages fall off the row's end.
        (
            "// steps 14\nwalk\n1\nSWALK0 >C01 0000 N**0*\nP1,0 C01 - C01 0001 #S01 + C01 0000 #E02 + 0007 0000\n\nhear\n1\nSREST0 >#N01 0000\nC02 + C02 #N01\n\nnext\n1\nSWALK0 >#W02 0000\nC03 + C03 0001\n".into(),
            "0,1 SWALK0 C01 9\n-3,1 SWALK0 C01 12\n0,0 SREST0\n1,0 SREST0\n2,0 SREST0\n3,0 SREST0\n4,0 SREST0\n6,0 SREST0\n".into(),
        ),
        // External counters read while few agents calculate: one of an agent that
        // calculated before in the same phase (its value at the phase's start), one of an
        // agent at rest, one where nobody stands.
        (
            "// steps 8\ncnt\n1\nSCOUNT >C00 0000\nC00 - C00 0001 C01 + 1,0,C00 0000\n".into(),
            "1,0 SCOUNT C00 3\n0,0 SCOUNT C00 5\n5,0 SCOUNT C00 4\n6,0 SREST0 C00 7\n9,9 SREST0\n".into(),
        ),
        // A rule whose offset depends on a counter: its agents are evaluated every step.
        (
            format!("// steps 8\n{countdown}go\n1\nSWAIT0 FC01,0\nSDONE0\n\nmove\n1\nSM0000 >C00 0000\nP0,1 C00 - C00 0001\n"),
            "0,0 SWAIT0 C01 3\n3,-2 SM0000 C00 2\n".into(),
        ),
    ]
}

/// Flooding, falling, cycles of states, priority chains, messages left with their senders,
/// sends to all directions and to one, bounded and sparse universes.
fn counter_and_message_cases() -> Vec<(String, String)> {
    vec![
        (
            FLOOD.into(),
            block(24, 24, |x, y, _| format!(" C00 {}", hash(x, y) * 100)),
        ),
        (
            FLOOD.into(),
            // Holes break the runs.
            block(20, 20, |x, y, _| format!(" C00 {}", hash(x, y)))
                .lines()
                .filter(|l| !l.starts_with("7,") && !l.ends_with(",13 C00 8"))
                .map(|l| format!("{l}\n"))
                .collect(),
        ),
        (
            FALL.into(),
            block(18, 18, |_, y, _| format!(" C00 {y}"))
                .lines()
                .enumerate()
                .filter(|(k, _)| (k * 7919) % 10 < 4)
                .map(|(_, l)| format!("{l}\n"))
                .collect(),
        ),
        (
            cycle(7),
            block(16, 16, |x, y, _| format!(" SR{:04}", (x + y) % 7)),
        ),
        (
            cycle(1200),
            block(40, 40, |x, y, _| format!(" SR{:04}", (x * 40 + y) % 1200)),
        ),
        (CHAIN.into(), block(12, 12, |_, _, _| String::new())),
        // (Columns of 30 or more agents, so that the plan of senders is kept: a plan
        // of more than one segment per eight agents is given up for single reads.)
        // Messages left with their senders (rules without moves), sent every third step,
        // read by preconditions and calculations: nothing stale is read.
        (
            "a\n1\nSA****\nC00 + C00 0003 #*01 + C00 0000 SB****\n\nb\n1\nSB****\nC01 A C01 #N01 SC****\n\nhear\n2\nSB**** >#W01 0010\nC02 + #W01 0000 SC****\n\nc\n1\nSC****\nC01 A C01 #E01 SA****\n".into(),
            block(6, 30, |x, y, _| {
                format!(" S{}AAAA C00 {}", ["A", "B", "C"][((x * 2 + y) % 3) as usize], (x * 7 + y * 3) % 11)
            }),
        ),
        // Runs of readers (even columns) next to senders of which a third sent in each
        // step (odd columns, period three): a run's messages are picked one by one.
        (
            "read\n1\nSR****\nC01 A C01 #E01 C02 + C02 #W01\n\np0\n1\nSP0***\nC00 + C00 0001 #*01 + C00 0000 SP1***\n\np1\n1\nSP1***\nSP2***\n\np2\n1\nSP2***\nSP0***\n".into(),
            block(8, 30, |x, y, _| {
                if x % 2 == 0 {
                    " SRRRRR".to_string()
                } else {
                    format!(" SP{}AAA C00 {}", y % 3, 5 + y)
                }
            }),
        ),
        // Runs of readers whose senders all sent but the last few agents (in the last,
        // partial word of the outbox bits), which sent in other steps.
        (
            "a\n1\nSA****\n#*01 + C00 0000 C00 + C00 0001 SB****\n\nb\n1\nSB****\nC01 + C01 #N01 C02 + C02 #S01 SC****\n\nc\n1\nSC****\nC01 + C01 #E01 SA****\n".into(),
            block(6, 40, |_, _, k| {
                format!(" S{}AAAA C00 {}", if k >= 235 { "C" } else { "A" }, k + 1)
            }),
        ),
        // Sends to all directions and to one, in both orders, some not made (division by
        // zero), by whole columns and by single agents.
        (
            "first\n1\nSA****\n#S01 + C01 0000 #*01 + C00 0000 #N01 + C01 0000 C00 + C00 0001 SB****\n\nsecond\n1\nSB****\n#E01 + C00 0000 #*01 / C01 C02 C01 A C01 #S01 C03 + #S01 0000 C02 + C02 #N01 SA****\n".into(),
            block(6, 40, |x, y, _| {
                format!(
                    " S{}AAAA C00 {} C01 {} C02 {}",
                    ["A", "B"][(x % 2) as usize],
                    (x * 5 + y) % 9,
                    (x + y * 3) % 13 + 1,
                    (x * y) % 3
                )
            }),
        ),
        (
            "first\n1\nSA****\n#S01 + C01 0000 #*01 + C00 0000 #N01 + C01 0000 C00 + C00 0001 SB****\n\nsecond\n1\nSB****\n#E01 + C00 0000 #*01 / C01 C02 C01 A C01 #S01 C03 + #S01 0000 C02 + C02 #N01 SA****\n".into(),
            block(6, 40, |x, y, _| {
                format!(
                    " S{}AAAA C00 {} C01 {} C02 {}",
                    ["A", "B"][((x + y) % 2) as usize],
                    (x * 5 + y) % 9,
                    (x + y * 3) % 13 + 1,
                    (x * y) % 3
                )
            }),
        ),
        // In a bounded universe
        // with most cells empty, and in pairs far apart (a hash-indexed lattice).
        (
            FLOOD.into(),
            "U0,29,0,29\n".to_string()
                + &block(30, 30, |x, y, _| format!(" C00 {}", hash(x, y)))
                    .lines()
                    .enumerate()
                    .filter(|(k, _)| (k * 7919) % 10 < 4)
                    .map(|(_, l)| format!("{l}\n"))
                    .collect::<String>(),
        ),
        (
            FLOOD.into(),
            (0..40)
                .map(|k| {
                    let (x, y) = (k % 8 * 1000, k / 8 * 7);
                    format!("{x},{y} C00 {}\n{},{y} C00 {}\n", k * 3, x + 1, 100 - k)
                })
                .collect(),
        ),
    ]
}

/// Single agents moving every step, trains, targets claimed twice, plain moves.
fn move_cases() -> Vec<(String, String)> {
    vec![
        // Single agents moving every step: into the same cell, into cells of agents that
        // stay or that leave, in trains; then also out of the grid into the hash map and
        // back.
        (crowd(), crowd_agents(6)),
        (crowd(), crowd_agents(7)),
        // Only trains and free movers; only two movers targeting one cell (the rest move
        // freely); only movers into cells of agents that stay.
        (crowd(), rows(&["EEE", "N.EE", "W..WW", "NNE"])),
        (crowd(), rows(&["E.W", "EEE", "N..W", ".WW"])),
        (crowd(), rows(&["ES", "EEES", "SW..E", "N"])),
        // Only empty targets, two of them claimed twice by movers of different offsets.
        (crowd(), rows(&["E.W", "N", "E..W"])),
        // Movers all by one offset: into empty cells only; and in trains and into agents
        // that stay.
        (crowd(), rows(&["E.E", ".E", "E..E.S"])),
        (crowd(), rows(&["EEE", "E.ES", "..E"])),
        // Programs whose only actions are moves by literal offsets (collected in one loop).
        (PLAIN.into(), rows(&["EEE", "N.EE", "W..WW", "NNE"])),
        (PLAIN.into(), rows(&["E.E", ".E", "E..E.S"])),
    ]
}

/// States changed at once along chains, calculations over runs (division by zero,
/// saturation, comparisons, in-place steps and chains of min and max), runs longer than a
/// batch, 3D chains, falling in a crowd.
fn state_and_calc_cases() -> Vec<(String, String)> {
    vec![
        // Several states share a list of one rule with a precondition, their agents
        // interleaved (evaluated in one batch across states); other states have another
        // rule or none; states change as agents fall.
        (
            "fall\n1\nSG**** N***0 >C00 0000\nP0,-1 C00 - C00 0001 SG0000\n\nrise\n1\nSH**** N0*** <C00 0003\nP0,1 C00 + C00 0001\n".into(),
            block(9, 14, |x, y, k| {
                let st = ["GA000", "HB000", "GC000", "XX000", "HA000", "GB000"][(x as usize * 7 + y as usize * 3 + k) % 6];
                if (x * 5 + y * 11) % 7 == 0 {
                    String::new()
                } else {
                    format!(" S{st} C00 {}", (x + 2 * y) % 5)
                }
            }),
        ),
        // A rule per state that moves one step down, changes the state and counts down
        // (`fall_a` takes SA to SB, `fall_b` back; the same precondition but for the state):
        // their agents, mixed one by one, evaluated in runs across the two lists; the moves
        // made at once from the actions' list; the counters counted down in one masked pass
        // for both rules. In a universe bounded below (movers at its rim go the general
        // way), with holes, and agents in a state without rules.
        (
            "// steps 12\nfall_a\n1\nSA**** N***0 >C00 0000\nP0,-1 SB0000 C00 - C00 0001\n\n\
             fall_b\n1\nSB**** N***0 >C00 0000\nP0,-1 SA0000 C00 - C00 0001\n"
                .into(),
            format!(
                "U0,8,0,13\n{}",
                sparse_block(9, 14, |x, y, k| {
                    // (Runs of SA and SB alone in the first columns, and short ones among
                    // agents of a state without rules after.)
                    let st = match x {
                        0..=3 => ["A", "B", "B", "A"][(y as usize + k) % 4],
                        _ => ["A", "B", "B", "A", "X"][(x as usize * 3 + y as usize + k) % 5],
                    };
                    ((x * 5 + y * 11) % 4 != 0).then(|| format!(" S{st}0000 C00 {}", (x + 3 * y) % 6))
                })
            ),
        ),
        // The same walking east out of the input's box (the grid made again ahead of the
        // movers at its rim), counting up to saturation (32767: the masked pass declines,
        // the runs record it); beside rules of two states that test different cells,
        // their agents mixed one by one (short runs, evaluated in windows of lists).
        (
            "// steps 9\nwalk_a\n1\nSA**** N**0*\nP1,0 SB0000 C00 + C00 0001\n\n\
             walk_b\n1\nSB**** N**0*\nP1,0 SA0000 C00 + C00 0001\n\n\
             up\n1\nSC**** N0***\nSD0000\n\ndown\n1\nSD**** N***0\nSC0000\n"
                .into(),
            sparse_block(7, 9, |x, y, k| {
                let st = ["A", "C", "B", "D", "A", "B"][(x as usize + y as usize * 2 + k) % 6];
                let c = [0, 5, 32765, 32766, 32767][(x + y) as usize % 5];
                ((x * 3 + y * 5) % 4 != 0).then(|| format!(" S{st}0000 C00 {c}"))
            }),
        ),
        // States changed at once along chains of state-only rules: into a state without
        // rules, into one whose rule calculates, into one whose rule tests a neighbour (the
        // selection is then evaluated again).
        (
            "a\n1\nSA****\nSB****\n\nb\n1\nSB****\nSE****\n\ne\n1\nSE****\nSF****\n\ng\n1\nSG****\nSH****\n\nh\n1\nSH****\nC00 + C00 0001 SG****\n\nc\n2\nSC**** N1***\nSA****\n".into(),
            block(8, 8, |x, y, _| {
                let s = ["A", "B", "E", "F", "G", "H", "A", "C"][hash(x, y) as usize % 8];
                format!(" S{s}AAAA")
            }),
        ),
        (
            "a\n1\nSA****\nSB****\n\nb\n1\nSB****\nSE****\n\ne\n1\nSE****\nSF****\n".into(),
            block(6, 6, |x, y, _| {
                format!(" S{}AAAA", ["A", "B", "E", "F"][hash(x, y) as usize % 4])
            }),
        ),
        // `E` and `F` at offsets of one step (run as neighbour patterns over runs) beside
        // one at two steps (evaluated per agent), in a bounded universe (a cell outside
        // it is neither empty nor filled), in 2D and in 3D.
        (
            "fall\n1\nE0,-1 F1,0 >C00 0000\nP0,-1 C00 - C00 0001\n\nslide\n1\nE0,-1 E-1,0 E2,0 !F-1,0\nP-1,0\n".into(),
            format!(
                "U0,8,0,13\n{}",
                block(9, 14, |x, y, _| if (x * 7 + y * 3) % 5 < 2 {
                    " SXXXXX".to_string()
                } else {
                    format!(" C00 {}", (x + y) % 4)
                })
            ),
        ),
        (
            "fall\n1\nE0,0,-1 !F0,1,0\nP0,0,-1\n".into(),
            (0..6)
                .flat_map(|x| (0..6).flat_map(move |y| (0..6).map(move |z| (x, y, z))))
                .filter(|(x, y, z)| (x * 5 + y * 3 + z * 7) % 4 != 0)
                .fold("U0,5,0,5,0,5\n".to_string(), |t, (x, y, z)| {
                    t + &format!("{x},{y},{z}\n")
                }),
        ),
        // The bouncing example: four states of five rules each, of four priorities, mixed
        // in any order (evaluated list by list over windows of agents), with `E` and `F`
        // at diagonal and two-step offsets (one bit of the grid each), in a bounded
        // universe whose walls are neither empty nor filled.
        (
            include_str!("../../examples/bouncing/rules.txt").into(),
            (0..30)
                .flat_map(|x| (0..24).map(move |y| (x, y)))
                .filter(|&(x, y)| hash(x, y) % 3 == 0)
                .fold("U0,29,0,23\n".to_string(), |t, (x, y)| {
                    let d = ["NE", "NW", "SE", "SW"][hash(y, x) as usize % 4];
                    t + &format!("{x},{y} S{d}000\n")
                }),
        ),
        // Seventy states of two rules each, mixed: a window of agents ends when it meets
        // more lists than it looks up among (64).
        (
            (0..70)
                .map(|i| {
                    format!("a{i}\n2\nSK{i:02}AA E1,0\nC00 + C00 0001\n\nb{i}\n1\nSK{i:02}AA\nC01 + C01 0001\n\n")
                })
                .collect(),
            block(24, 24, |x, y, _| match (x * 5 + y * 11) % 7 {
                0 => String::new(),
                _ => format!(" SK{:02}AA", (x * 7 + y * 3) % 70),
            }),
        ),
        // In 3D, two rules of one priority true together (several rules for one agent)
        // beside a lower one, with cells two steps and a diagonal away.
        (
            "up\n2\nSA**** E0,0,2 !F1,1,0\nC00 + C00 0001\n\nside\n2\nSA**** E2,0,0\nC01 + C01 0001\n\nrest\n1\nSA****\nC02 + C02 0001\n".into(),
            (0..6)
                .flat_map(|x| (0..6).flat_map(move |y| (0..6).map(move |z| (x, y, z))))
                .filter(|(x, y, z)| (x * 5 + y * 3 + z * 7) % 3 != 0)
                .fold(String::new(), |t, (x, y, z)| t + &format!("{x},{y},{z} SAAAAA\n")),
        ),
        // One rule alone calculates, an add in place (made in one masked pass over each
        // chunk), its agents scattered among agents of a rule that does not calculate and
        // of none; some results saturate (the runs then make the records).
        (
            "down\n1\nSA**** N0***\nC00 - C00 0001\n\nturn\n1\nSB**** N1***\nSA****\n".into(),
            block(12, 30, |x, y, _| {
                let st = ["A", "B", "A", "C"][hash(x, y) as usize % 4];
                let c = if (x + y) % 9 == 0 { -32766 } else { (x * 3 + y) % 50 };
                if (x * 5 + y * 11) % 7 == 0 {
                    String::new()
                } else {
                    format!(" S{st}AAAA C00 {c}")
                }
            }),
        ),
        // The same add in place over 3,000 agents, the one that saturates first (at the
        // third step) the last of them: the pass adds nothing for any, and the runs
        // calculate (and make the record).
        (
            "up\n1\nSA****\nC00 + C00 0001\n".into(),
            block(50, 60, |x, y, _| match (x, y) {
                (49, 59) => " SAAAAA C00 32765".into(),
                (20, _) => format!(" SAAAAA C00 {}", 32760 - y),
                _ => format!(" SAAAAA C00 {}", (x * 7 + y) % 40),
            }),
        ),
        // A division by zero for some agents of a run, then a product that saturates for
        // the same agents: the second is saturated (and recorded) all the same.
        (
            "r\n1\nS*****\nC00 / C00 C01 C02 * C02 C03\n".into(),
            block(4, 40, |x, y, _| {
                format!(" C00 {} C01 {} C02 300 C03 {}", 7 + y, (x + y) % 3, 200 + x)
            }),
        ),
        // Counters compared with literals over runs (one rule per state).
        (
            "low\n1\nSL**** <C00 0005\nC00 + C00 0002\n\nsame\n1\nSQ**** =C01 0003\nC01 + C01 0001\n\nhigh\n1\nSH**** >C00 0004\nC00 - C00 0001\n".into(),
            block(9, 30, |x, y, _| {
                let s = ["L", "Q", "H"][(x % 3) as usize];
                format!(" S{s}AAAA C00 {} C01 {}", y % 7, (x + y) % 5)
            }),
        ),
        // Counters stepped in place over runs, some runs saturating (left to the
        // general path, which records them).
        (
            "up\n1\nS*****\nC00 + C00 0900 C01 - C01 0700\n".into(),
            block(10, 30, |x, y, _| {
                let c0 = if x % 3 == 0 { 30000 - y * 10 } else { y };
                let c1 = if x % 4 == 1 { -31000 } else { x };
                format!(" C00 {c0} C01 {c1}")
            }),
        ),
        (
            MIXED.into(),
            block(16, 16, |x, y, k| {
                format!(
                    " S{} C00 {} C03 {}",
                    if (k / 10) % 2 == 0 { "AAAAA" } else { "BBBBB" },
                    200 + hash(x, y) * 40,
                    hash(y, x) % 3
                )
            }),
        ),
        // Runs longer than one of the engine's batches (1024 agents): the calculations,
        // the post office and the preconditions go on to the next batch within one run
        // (with their working space as the last batch left it).
        (
            FLOOD.into(),
            block(34, 34, |x, y, _| format!(" C00 {}", hash(x, y) * 100 + x as i64))
                .lines()
                .filter(|l| !l.starts_with("31,"))
                .map(|l| format!("{l}\n"))
                .collect(),
        ),
        (
            "r\n1\nS*****\nC00 / C00 C01 C02 * C02 C03 #*01 + C02 0000\n".into(),
            block(34, 34, |x, y, _| {
                format!(" C00 {} C01 {} C02 300 C03 {}", 7 + y, (x + y) % 3, 100 + x)
            }),
        ),
        // Chains of in-place min and max with messages, run in one pass: of three (min),
        // of two (max, on another counter), a max and a min that do not chain, and sends
        // to single directions besides one to all (holes break the runs).
        (
            "r\n1\nS*****\nC01 I C01 #N01 C01 I C01 #E01 C01 I C01 #S02 C00 A C00 #W01 C00 A C00 #N02 C02 A C02 #W01 C02 I C02 #E01 #*01 + C00 0000 #N01 + C01 0000 #S02 + C02 0000\n".into(),
            block(34, 34, |x, y, _| {
                format!(" C00 {} C01 {} C02 {}", hash(x, y) * 10, 300 - hash(y, x), x - y)
            })
            .lines()
            .filter(|l| !l.starts_with("12,") && !l.ends_with("C02 0"))
            .map(|l| format!("{l}\n"))
            .collect(),
        ),
        // A chain of six (3D), then links that do not chain (another counter as the left
        // operand).
        (
            "r\n1\nS*****\nC00 A C00 #N01 C00 A C00 #W01 C00 A C00 #E01 C00 A C00 #S01 C00 A C00 #A01 C00 A C00 #B01 C01 I C01 #A01 C01 I C00 #B01 C01 I C01 #N01 #*01 + C00 0000\n".into(),
            (0..11)
                .flat_map(|x| (0..11).flat_map(move |y| (0..11).map(move |z| (x, y, z))))
                .map(|(x, y, z)| format!("{x},{y},{z} C00 {} C01 {}\n", hash(x + z, y) * 3, 50 + x))
                .collect(),
        ),
        (
            FALL.into(),
            block(36, 36, |x, y, _| format!(" C00 {}", (y + x) % 5))
                .lines()
                .enumerate()
                .filter(|(k, _)| (k * 7919) % 10 < 8)
                .map(|(_, l)| format!("{l}\n"))
                .collect(),
        ),
    ]
}

/// The trace's messages carry the values sent, also where a send to all directions is kept
/// in one column and one direction is overridden: the sender's C00 (sent to all) and C01
/// (sent north after).
#[test]
fn traced_messages_carry_the_values_sent() {
    let rules = "s\n1\nS*****\nC00 + C00 0001 #*01 + C00 0000 #N01 + C01 0000\n";
    let agents = block(4, 40, |x, y, _| {
        format!(" C00 {} C01 {}", x * 40 + y, 900 + y)
    });
    let (prog, lat) = common::compile(rules, &agents);
    let opts = Options {
        trace: true,
        ..Options::default()
    };
    let mut e = Engine::new(prog, lat, opts);
    for _ in 0..3 {
        let rep = e.step();
        let mut seen = 0;
        for ev in &rep.trace {
            if let TraceEvent::Message {
                from, dir, value, ..
            } = ev
            {
                let c = if *dir == 'N' { 1 } else { 0 };
                assert_eq!(*value, Some(e.lat.counter(*from, c)), "{ev:?}");
                seen += 1;
            }
        }
        assert_eq!(seen, 4 * 40 * 4);
    }
}

/// What a run shows of one step: its records and trace, and the lattice and statistics
/// after it.
fn shown(e: &mut Engine) -> (String, String, String) {
    let rep = e.step();
    (
        format!("{:?}{:?}", rep.records, rep.trace),
        e.lat.to_agents_text(),
        format!("{:?}", e.stats),
    )
}

/// A run resumed from a checkpoint made after any step goes on exactly as the run without
/// a stop (records, trace, lattice and statistics of every later step); a step undone with
/// an undo point leaves the lattice and statistics as they were before it.
fn resume_and_undo(rules: &str, agents: &str) -> Result<(), TestCaseError> {
    const STEPS: u64 = 10;
    let (prog, lat) = common::compile(rules, agents);
    for order in [Order::ActionsFirst, Order::MessagesFirst] {
        for static_first in [false, true] {
            // Checkpoints and undo points are taken while quiet agents are being skipped.
            let opts = Options {
                order,
                static_first,
                trace: true,
                threads: 1,
                skip: Skip::Eager,
                space_order: SpaceOrder::Off,
                records_per_step: None,
            };
            let mut whole = Engine::new(prog.clone(), lat.clone(), opts);
            let before: Vec<(String, String)> =
                std::iter::once((whole.lat.to_agents_text(), format!("{:?}", whole.stats)))
                    .collect();
            let mut states = before;
            let mut steps = Vec::new();
            for _ in 0..STEPS {
                let s = shown(&mut whole);
                states.push((s.1.clone(), s.2.clone()));
                steps.push(s);
            }
            for stop in [0, 1, 3, 7] {
                let mut e = Engine::new(prog.clone(), lat.clone(), opts);
                for _ in 0..stop {
                    e.step();
                }
                let mut bytes = Vec::new();
                e.write_checkpoint(&mut bytes).unwrap();
                let undo = e.undo_point();
                e.step();
                let e = e.undo(undo);
                prop_assert_eq!(
                    (e.lat.to_agents_text(), format!("{:?}", e.stats)),
                    states[stop as usize].clone(),
                    "undo at step {} ({:?}, static-first {})",
                    stop,
                    order,
                    static_first
                );
                let mut r = Engine::read_checkpoint(prog.clone(), opts, &bytes[..])
                    .map_err(|e| TestCaseError::fail(format!("{e}")))?;
                for k in stop..STEPS {
                    let s = shown(&mut r);
                    prop_assert_eq!(
                        &s,
                        &steps[k as usize],
                        "step {} resumed after step {} ({:?}, static-first {})\n{}\n{}",
                        k + 1,
                        stop,
                        order,
                        static_first,
                        rules,
                        agents
                    );
                }
            }
        }
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig {
        cases: std::env::var("PROPTEST_CASES").ok().and_then(|s| s.parse().ok()).unwrap_or(64),
        failure_persistence: None,
        ..ProptestConfig::default()
    })]

    #[test]
    fn resumed_runs_go_on_exactly_2d(r in prop_oneof![rules(false), themes(false)], a in agents(false)) {
        resume_and_undo(&r, &a)?;
    }

    #[test]
    fn resumed_runs_go_on_exactly_3d(r in prop_oneof![rules(true), themes(true)], a in agents(true)) {
        resume_and_undo(&r, &a)?;
    }

    /// Checkpoints of 32-bit counters keep them whole.
    #[test]
    fn resumed_runs_go_on_exactly_wide(r in prop_oneof![rules(false), themes(false)], a in agents(false)) {
        let (r, a) = widened(&r, &a, 715_827_882);
        resume_and_undo(&r, &a)?;
    }

    #[test]
    fn traced_runs_take_the_untraced_paths_2d(r in prop_oneof![rules(false), themes(false)], a in agents(false)) {
        traced_as_untraced(&r, &a)?;
    }

    #[test]
    fn traced_runs_take_the_untraced_paths_3d(r in prop_oneof![rules(true), themes(true)], a in agents(true)) {
        traced_as_untraced(&r, &a)?;
    }
}

/// A traced run takes the paths of an untraced one: the same records, lattice and
/// statistics at every step; and its trace agrees with what changed (a move event per
/// move counted; the state events of each agent lead from its old state to its new).
fn traced_as_untraced(rules: &str, agents: &str) -> Result<(), TestCaseError> {
    let (prog, lat) = common::compile(rules, agents);
    for order in [Order::ActionsFirst, Order::MessagesFirst] {
        for static_first in [false, true] {
            let opts = |trace| Options {
                order,
                static_first,
                trace,
                threads: 1,
                skip: Skip::Eager,
                space_order: SpaceOrder::Off,
                records_per_step: None,
            };
            let mut plain = Engine::new(prog.clone(), lat.clone(), opts(false));
            let mut traced = Engine::new(prog.clone(), lat.clone(), opts(true));
            for step in 1..=8 {
                let states: Vec<[u8; 5]> = traced.lat.state.clone();
                let moves = traced.stats.moves;
                let (a, b) = (plain.step(), traced.step());
                prop_assert_eq!(&a.records, &b.records, "records, step {}", step);
                prop_assert_eq!(plain.lat.to_agents_text(), traced.lat.to_agents_text());
                prop_assert_eq!(format!("{:?}", plain.stats), format!("{:?}", traced.stats));
                let moved = b
                    .trace
                    .iter()
                    .filter(|e| matches!(e, TraceEvent::Move { .. }))
                    .count();
                prop_assert_eq!(
                    moved as u64,
                    traced.stats.moves - moves,
                    "move events, step {}",
                    step
                );
                // Every state event starts from the agent's state so far (with
                // --static-first a state may change in both passes), and the last one of
                // each agent ends in its state after the step.
                let mut cur = states;
                for e in &b.trace {
                    if let TraceEvent::State { agent, from, to } = e {
                        let i = *agent as usize;
                        prop_assert_eq!(
                            from.as_bytes(),
                            &cur[i][..],
                            "state event from, step {}",
                            step
                        );
                        cur[i] = to.as_bytes().try_into().expect("5 characters");
                    }
                }
                prop_assert_eq!(&cur, &traced.lat.state, "state events, step {}", step);
            }
        }
    }
    Ok(())
}

/// Agents kept in space order change nothing but the order of a step's records: random
/// rule sets on clouds of 66,000 agents listed at random (2D and 3D), run in the file's
/// order on one thread and in space order (chosen by `SpaceOrder::Auto`, as `latticesim
/// run` chooses) on two, agree after every step on the configuration written, the
/// statistics and the records (as a multiset: kind, sentence, agents); a checkpoint of
/// each, taken halfway, is the same bytes (agents in the file's order), and the run
/// resumed from it in space order ends as the others.
#[test]
fn space_order_changes_nothing_but_the_order_of_records() {
    use latticesim_runtime::shapes::{agents_text, GenOptions, Shape};
    use proptest::strategy::ValueTree;
    let mut runner = fixed_runner(5);
    let mut records = 0;
    for i in 0..2u64 {
        let d3 = i % 2 == 1;
        let r = rules(d3).new_tree(&mut runner).unwrap().current();
        let o = GenOptions {
            three_d: d3,
            seed: i,
            ..Default::default()
        };
        let (w, h, d) = if d3 { (50, 50, 50) } else { (400, 400, 1) };
        let base = agents_text(&Shape::Cloud { n: 66_000, w, h, d }, &o).unwrap();
        let (prog, lat) = common::compile(&r, &with_states(&base));
        let opts = |threads, space_order| Options {
            threads,
            space_order,
            ..Options::default()
        };
        let mut file = Engine::new(prog.clone(), lat.clone(), opts(1, SpaceOrder::Off));
        let mut space = Engine::new(prog.clone(), lat, opts(2, SpaceOrder::Auto));
        assert!(!file.lat.in_space_order());
        assert!(space.lat.in_space_order(), "a cloud is listed scattered");
        // A step's records as a multiset, each with its agents in id order.
        let sorted = |rep: &latticesim_runtime::StepReport| {
            let mut v: Vec<String> = (rep.records.iter())
                .map(|r| {
                    let mut agents = r.agents.clone();
                    agents.sort();
                    format!("{:?} {} {:?}", r.kind, r.message, agents)
                })
                .collect();
            v.sort();
            v
        };
        let same = |x: &[String], y: &[String], what: &str| {
            let first = x.iter().zip(y).find(|(a, b)| a != b);
            assert!(
                x.len() == y.len() && first.is_none(),
                "{what}: {} and {} records, first difference {first:?}",
                x.len(),
                y.len()
            );
        };
        let mut resumed: Option<Engine> = None;
        for step in 1..=6 {
            let (a, b) = (file.step(), space.step());
            same(&sorted(&a), &sorted(&b), &format!("case {i}, step {step}"));
            records += a.records.len();
            assert_eq!(a.quiescent, b.quiescent);
            assert_eq!(file.lat.to_agents_text(), space.lat.to_agents_text());
            assert_eq!(format!("{:?}", file.stats), format!("{:?}", space.stats));
            if let Some(e) = &mut resumed {
                let c = e.step();
                same(
                    &sorted(&a),
                    &sorted(&c),
                    &format!("case {i}, step {step}, resumed"),
                );
                assert_eq!(file.lat.to_agents_text(), e.lat.to_agents_text());
            }
            if step == 3 {
                let (mut x, mut y) = (Vec::new(), Vec::new());
                file.write_checkpoint(&mut x).unwrap();
                space.write_checkpoint(&mut y).unwrap();
                assert!(x == y, "case {i}: the checkpoints differ");
                let e = Engine::read_checkpoint(prog.clone(), opts(2, SpaceOrder::Auto), &y[..]);
                resumed = Some(e.unwrap());
            }
        }
    }
    assert!(records > 0, "the cases make records");
}
