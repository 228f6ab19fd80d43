//! The fuzz targets: each takes any bytes, runs them through one reader of outside input
//! the way the commands do, checks what must hold of the result, and names what it saw
//! (diagnostic codes, error kinds, statuses), so that the harness (`fuzz/`) keeps inputs
//! that show something new. A target panics only where the project is wrong: a panic in
//! the code under test, or a property that does not hold.
//!
//! - [`rules`]: a rules file checked alone and beside a small agents file; every
//!   machine-applicable fix applied (the text must stay whole); a file that checks is
//!   compiled, and run a few steps.
//! - [`agents`]: an agents file read by the streaming reader (the commands' path) and by
//!   the checker on the whole pair: the same diagnostics and the same agents.
//! - [`checkpoint`]: a checkpoint resumed with the rules it may have been made with; one
//!   that is taken steps on, and is written again exactly as it was read.
//! - [`lsp`]: a byte stream to the language server (framing, then every message handled).
//! - [`http`]: a byte stream to the viewer's HTTP transport and its gate.

use crate::agents_file::{load, Source};
use latticesim_compiler::diagnostics::{not_shown_line, render_plain, to_json};
use latticesim_compiler::{check, compile, Checked, Input};
use latticesim_runtime::{Engine, Lattice, Options};
use std::sync::OnceLock;

/// A target: any bytes in, what they showed out.
pub type Target = fn(&[u8]) -> Vec<String>;

/// The targets by name, as the harness runs them.
pub const TARGETS: [(&str, Target); 5] = [
    ("rules", rules),
    ("agents", agents),
    ("checkpoint", checkpoint),
    ("lsp", lsp),
    ("http", http),
];

/// Everything a user sees of a verdict: rendered diagnostics, the lines of what is not
/// shown, JSON, counts.
pub fn seen(c: &Checked) -> String {
    let mut s = render_plain(&c.diags, &c.sources);
    for n in &c.not_shown {
        s += &not_shown_line(n, &c.sources);
        s.push('\n');
    }
    s += &serde_json::to_string(&to_json(&c.diags, &c.sources)).expect("plain data");
    s += &format!(
        "\n{} rules, {} agents, {:?}",
        c.rule_count, c.agent_count, c.dim
    );
    s
}

/// Each agent's position, state and bonds.
pub fn agents_of(l: &Lattice) -> Vec<([i32; 3], [u8; 5], u8)> {
    (0..l.pos.len())
        .map(|i| (l.pos[i], l.state[i], l.attach[i]))
        .collect()
}

/// The codes of a verdict, each with how often it was found (as a power of two), and
/// whether the rules checked.
/// A rules file and an agents file checked whole (`rules.txt`, `agents.txt`), as the
/// checker alone does.
pub fn whole(rules: &[u8], agents: &[u8]) -> Checked {
    check(
        Input {
            name: "rules.txt",
            bytes: rules,
        },
        Some(Input {
            name: "agents.txt",
            bytes: agents,
        }),
        None,
    )
}

/// The agents file read as the commands read it (the streaming reader, two threads, no
/// lint levels).
pub fn streamed(rules: &[u8], agents: &[u8]) -> crate::agents_file::Loaded {
    streamed_with(rules, agents, &Default::default())
}

/// The agents file read as the commands read it, with lint levels (two threads).
pub fn streamed_with(
    rules: &[u8],
    agents: &[u8],
    levels: &latticesim_compiler::lints::Lints,
) -> crate::agents_file::Loaded {
    load(
        ("rules.txt", rules),
        "agents.txt",
        Source::Bytes(agents),
        2,
        levels,
    )
    .expect("bytes in memory are read whole")
}

fn codes(c: &Checked, into: &mut Vec<String>) {
    let mut count: std::collections::BTreeMap<String, u32> = Default::default();
    for d in &c.diags {
        *count.entry(format!("{:?}", d.code)).or_default() += 1;
    }
    into.extend(
        count
            .iter()
            .map(|(code, n)| format!("{code} x{}", n.ilog2())),
    );
    into.push(format!(
        "rules {}, {} rules",
        c.rules.is_some(),
        c.rule_count.min(8)
    ));
}

/// A small agents file in each dimension, for rules to run on.
const SMALL_AGENTS: [&str; 2] = [
    "SA0000\n1,0 SB0000\n0,1 C00 0003\n2,0 SLEAD0 C01 0007\n5,5\n",
    "SA0000\n1,0,0 SB0000\n0,1,0 C00 0003\n0,0,1 SLEAD0 C01 0007\n",
];

pub fn rules(data: &[u8]) -> Vec<String> {
    fn input(bytes: &[u8]) -> Input<'_> {
        Input {
            name: "rules.txt",
            bytes,
        }
    }
    let alone = check(input(data), None, None);
    let mut seen = Vec::new();
    codes(&alone, &mut seen);
    if let Ok(text) = std::str::from_utf8(data) {
        for d in &alone.diags {
            for f in &d.fixes {
                // A fix is applied to the file's text: it must leave it whole (the check
                // of the result may find other things).
                let fixed = f.apply(text, latticesim_grammar::span::FileId(0));
                check(input(fixed.as_bytes()), None, None);
            }
        }
    }
    for agents in SMALL_AGENTS {
        let pair = whole(data, agents.as_bytes());
        codes(&pair, &mut seen);
        if let (Some(r), Some(cfg)) = (&pair.rules, &pair.config) {
            let prog =
                compile(r).unwrap_or_else(|e| panic!("rules that check do not compile: {e}"));
            let mut e = Engine::new(prog, Lattice::new(cfg), Options::default());
            for _ in 0..4 {
                if e.step().quiescent {
                    break;
                }
            }
            seen.push(format!("ran, {} agents", e.lat.len()));
        }
    }
    seen
}

/// Rules for agents files: a state no rule tests (W603), every state accepted, 3D.
const AGENT_RULES: [&str; 3] = [
    "walk\n1\nSWALK0 N**0* >C01 0000\nP1,0 C01 - C01 0001\n",
    "fall\n1\nN***0\nP0,-1\n",
    "up\n1\nSUP000 U***0**\nP0,0,1\n",
];

pub fn agents(data: &[u8]) -> Vec<String> {
    let mut out = Vec::new();
    for rules in AGENT_RULES {
        let l = streamed(rules.as_bytes(), data);
        let whole = whole(rules.as_bytes(), data);
        assert_eq!(
            seen(&l.checked),
            seen(&whole),
            "the streaming reader and the checker disagree"
        );
        assert_eq!(
            l.lattice.as_ref().map(agents_of),
            whole
                .config
                .as_ref()
                .map(Lattice::new)
                .as_ref()
                .map(agents_of),
            "the streaming reader and the checker read other agents"
        );
        codes(&l.checked, &mut out);
    }
    out
}

/// The example pairs whose checkpoints the harness starts from (rules, agents, counters of
/// 32 bits): moves, counters, messages, swaps, 3D.
pub const CHECKPOINT_EXAMPLES: [(&str, &str); 5] = [
    ("gravity/rules.txt", "gravity/agents.txt"),
    ("leader-election/rules.txt", "leader-election/agents-30.txt"),
    ("maxflood/rules.txt", "maxflood/agents.txt"),
    ("odd-even-sort/rules.txt", "odd-even-sort/agents.txt"),
    ("gravity-3d/rules.txt", "gravity-3d/agents.txt"),
];

/// An example's program and lattice, made as `run` makes them.
fn example(rules: &str, agents: &str) -> (latticesim_vm::Verified, Lattice) {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("examples");
    let read = |p: &str| std::fs::read(dir.join(p)).expect("the examples are beside the source");
    let (rules, agents) = (read(rules), read(agents));
    let c = whole(&rules, &agents);
    let (Some(r), Some(cfg)) = (&c.rules, &c.config) else {
        panic!("an example does not check:\n{}", seen(&c));
    };
    (compile(r).expect("the examples compile"), Lattice::new(cfg))
}

/// The programs of [`CHECKPOINT_EXAMPLES`] (read from the examples folder once).
fn checkpoint_programs() -> &'static [latticesim_vm::Verified] {
    static PROGS: OnceLock<Vec<latticesim_vm::Verified>> = OnceLock::new();
    PROGS.get_or_init(|| {
        (CHECKPOINT_EXAMPLES.iter())
            .map(|(r, a)| example(r, a).0)
            .collect()
    })
}

/// Checkpoints to start from: each example of [`CHECKPOINT_EXAMPLES`] at its start, after
/// a few steps and after more.
pub fn checkpoint_seeds() -> Vec<Vec<u8>> {
    let mut seeds = Vec::new();
    for (r, a) in CHECKPOINT_EXAMPLES {
        let (prog, lat) = example(r, a);
        let mut e = Engine::new(prog, lat, Options::default());
        for steps in [0, 3, 20] {
            while e.stats.steps < steps && !e.step().quiescent {}
            let mut b = Vec::new();
            e.write_checkpoint(&mut b).expect("into memory");
            seeds.push(b);
        }
    }
    seeds
}

pub fn checkpoint(data: &[u8]) -> Vec<String> {
    let mut out = Vec::new();
    for prog in checkpoint_programs() {
        match Engine::read_checkpoint(prog.clone(), Options::default(), data) {
            Err(e) => out.push(format!("{e:?}").split('(').next().unwrap_or("").into()),
            Ok(mut e) => {
                let mut again = Vec::new();
                e.write_checkpoint(&mut again).expect("into memory");
                assert!(
                    again == data,
                    "a checkpoint read is not written again as it was"
                );
                for _ in 0..3 {
                    e.step();
                }
                out.push(format!("resumed, {} agents", e.lat.len()));
            }
        }
    }
    out
}

pub fn lsp(data: &[u8]) -> Vec<String> {
    crate::lsp::replay(data)
}

pub fn http(data: &[u8]) -> Vec<String> {
    crate::serve::replay(data)
}
