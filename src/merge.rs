//! `latticesim merge`: the parts of a sharded sweep (`sweep --shard I/N`, CSV or Parquet)
//! joined into one table, its rows in the order of their run numbers: the table the
//! sweep run whole writes (but for the wall times).

use crate::output::{open_output, say};
use crate::table::{Column, Table};
use std::path::PathBuf;
use std::process::ExitCode;

/// The arguments of `latticesim merge`.
#[derive(clap::Args)]
pub struct MergeArgs {
    /// The parts (CSV or Parquet, in any order and mix).
    #[arg(required = true)]
    parts: Vec<PathBuf>,
    /// The merged table: Parquet for a name ending in .parquet, else CSV.
    #[arg(long)]
    out: PathBuf,
}

/// The parts read and joined, checked (one header, no run twice), sorted by run; with the
/// run numbers missing below the largest.
fn merged(parts: &[PathBuf]) -> Result<(Table, Vec<u64>), String> {
    let mut all = Table::default();
    let mut from: Vec<usize> = Vec::new();
    for (i, p) in parts.iter().enumerate() {
        let t = Table::read(p).map_err(|e| format!("`{}`: {e}", p.display()))?;
        if t.column("run").is_none() {
            return Err(format!(
                "`{}`: not a part of a sweep (it has no `run` column)",
                p.display()
            ));
        }
        all.append(&t)
            .map_err(|e| format!("`{}`: {e} (`{}`)", p.display(), parts[0].display()))?;
        from.extend(std::iter::repeat_n(i, t.rows()));
    }
    let Some(Column::Int(runs)) = all.column("run") else {
        return Err("the `run` column holds no run numbers".into());
    };
    let mut order: Vec<usize> = (0..runs.len()).collect();
    order.sort_by_key(|&i| runs[i]);
    for w in order.windows(2) {
        if runs[w[0]] == runs[w[1]] {
            return Err(format!(
                "run {} is in `{}` and in `{}`: parts of one sweep hold each run once",
                runs[w[0]],
                parts[from[w[0]]].display(),
                parts[from[w[1]]].display()
            ));
        }
    }
    let last = order.last().map_or(0, |&i| runs[i]);
    let have: std::collections::HashSet<u64> = runs.iter().copied().collect();
    let missing = (1..=last).filter(|r| !have.contains(r)).collect();
    Ok((all.reorder(&order), missing))
}

/// `latticesim merge`.
pub fn merge(a: MergeArgs) -> ExitCode {
    let out = match open_output(&a.out) {
        Ok(f) => f,
        Err(c) => return c,
    };
    let (table, missing) = match merged(&a.parts) {
        Ok(m) => m,
        Err(e) => {
            say!("error: {e}");
            return ExitCode::from(2);
        }
    };
    if let Err(c) = table.commit(out) {
        return c;
    }
    say!(
        "{} runs from {} parts; wrote {}",
        table.rows(),
        a.parts.len(),
        a.out.display()
    );
    if !missing.is_empty() {
        let shown: Vec<String> = missing.iter().take(10).map(u64::to_string).collect();
        say!(
            "warning: {} run{} missing below the last ({}{}): failed, or a part not given",
            missing.len(),
            if missing.len() == 1 { " is" } else { "s are" },
            shown.join(", "),
            if missing.len() > 10 { ", ..." } else { "" }
        );
    }
    ExitCode::SUCCESS
}
