//! Helpers shared by the runtime's integration tests.

use latticesim_compiler::{check, Checked, Input};
use latticesim_runtime::{Engine, Lattice};

/// Checks a rules and an agents file (named rules.txt and agents.txt).
pub fn checked(rules: &str, agents: &str) -> Checked {
    check(
        Input {
            name: "rules.txt",
            bytes: rules.as_bytes(),
        },
        Some(Input {
            name: "agents.txt",
            bytes: agents.as_bytes(),
        }),
        None,
    )
}

/// Checks a rules and an agents file that must have no errors: the verified program and
/// the lattice.
pub fn compile(rules: &str, agents: &str) -> (latticesim_vm::Verified, Lattice) {
    let c = checked(rules, agents);
    assert_eq!(c.errors(), 0, "{:#?}", c.diags);
    let prog = latticesim_compiler::compile(c.rules.as_ref().unwrap()).unwrap();
    (prog, Lattice::new(c.config.as_ref().unwrap()))
}

/// Everything a viewer shows of a configuration: agents (with counters and bonds) and
/// every inbox slot.
#[allow(dead_code)]
pub fn picture(e: &Engine) -> String {
    let mut s = e.lat.to_agents_text();
    for a in 0..e.lat.len() as u32 {
        for d in 0..e.lat.dim.dirs() as u8 {
            for k in 0..e.lat.dim.slots() as u8 {
                s += &format!("{} ", e.lat.inbox(a, d, k));
            }
        }
    }
    s
}
