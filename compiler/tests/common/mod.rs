//! What the compiler's test files share: checking a pair of files as `latticesim check`
//! does, and the dimension a case folder's `args` asks for.

#![allow(dead_code)] // each test file uses its part

use latticesim_compiler::{check, Checked, Dim, Input};
use std::path::Path;

/// Checks `rules.txt` (and `agents.txt`) with these bytes, in `dim` if given.
pub fn run_bytes(rules: &[u8], agents: Option<&[u8]>, dim: Option<Dim>) -> Checked {
    check(
        Input {
            name: "rules.txt",
            bytes: rules,
        },
        agents.map(|bytes| Input {
            name: "agents.txt",
            bytes,
        }),
        dim,
    )
}

/// [`run_bytes`] of texts.
pub fn run(rules: &str, agents: Option<&str>, dim: Option<Dim>) -> Checked {
    run_bytes(rules.as_bytes(), agents.map(str::as_bytes), dim)
}

/// The dimension a case folder's `args` file asks for (`dim=2`, `dim=3`), if any.
pub fn dim_of(case: &Path) -> Option<Dim> {
    match std::fs::read_to_string(case.join("args"))
        .unwrap_or_default()
        .trim()
    {
        "dim=2" => Some(Dim::Two),
        "dim=3" => Some(Dim::Three),
        _ => None,
    }
}
