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

/// The run numbers missing below the largest: how many, and the first ten.
#[derive(Debug, Default, PartialEq)]
struct Missing {
    count: u64,
    first: Vec<u64>,
}

impl Missing {
    /// The gaps of `sorted` (distinct run numbers, ascending) below its last, counted
    /// without walking the range: a damaged table's run 2^60 costs no more than run 60.
    fn of(sorted: impl IntoIterator<Item = u64>) -> Missing {
        let mut m = Missing::default();
        let mut next = 1u64;
        for r in sorted {
            if r > next {
                m.count += r - next;
                m.first.extend((next..r).take(10 - m.first.len()));
            }
            next = next.max(r.saturating_add(1));
        }
        m
    }
}

/// The parts read and joined, checked (one header, no run twice), sorted by run; with the
/// run numbers missing below the largest.
fn merged(parts: &[PathBuf]) -> Result<(Table, Missing), String> {
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
    let missing = Missing::of(order.iter().map(|&i| runs[i]));
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
        "{} from {}; wrote {}",
        crate::plural(table.rows(), "run"),
        crate::plural(a.parts.len(), "part"),
        a.out.display()
    );
    if missing.count > 0 {
        let shown: Vec<String> = missing.first.iter().map(u64::to_string).collect();
        say!(
            "warning: {} run{} missing below the last ({}{}): failed, or a part not given",
            missing.count,
            if missing.count == 1 { " is" } else { "s are" },
            shown.join(", "),
            if missing.count > 10 { ", ..." } else { "" }
        );
    }
    ExitCode::SUCCESS
}

#[cfg(test)]
mod tests {
    use super::Missing;

    #[test]
    fn missing_runs_are_counted_not_walked() {
        assert_eq!(Missing::of([1, 2, 3]), Missing::default());
        assert_eq!(
            Missing::of([0, 2, 5]),
            Missing {
                count: 3,
                first: vec![1, 3, 4]
            }
        );
        // A damaged table's huge run number: counted at once, the first ten listed.
        let m = Missing::of([3, 1 << 60]);
        assert_eq!(m.count, (1 << 60) - 2);
        assert_eq!(m.first, vec![1, 2, 4, 5, 6, 7, 8, 9, 10, 11]);
        let m = Missing::of([u64::MAX]);
        assert_eq!(m.count, u64::MAX - 1);
    }
}
