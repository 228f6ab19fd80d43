//! A sweep keeps what it finished. Each run that ends is appended to a journal beside the
//! table (`OUT.partial.csv`: a CSV line per run, written and flushed as the run ends), so
//! that Ctrl-C, a kill or a crash loses no finished run. The table itself is written whole
//! at the end (or at Ctrl-C, with the runs finished so far), and then the journal is
//! removed. `sweep --resume` reads the table and any journal back, checks that their runs
//! are runs of this sweep, and leaves only the others to run.

use super::{header, table, Row};
use crate::table::{Column, Table};
use latticesim_runtime::StepCost;
use std::collections::{BTreeMap, HashMap};
use std::fs::File;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::Mutex;

/// The journal of the table `out`: `OUT.partial.csv` beside it.
pub(super) fn journal_path(out: &Path) -> PathBuf {
    let name = out
        .file_name()
        .map_or_else(|| "sweep".to_string(), |n| n.to_string_lossy().into_owned());
    out.with_file_name(format!("{name}.partial.csv"))
}

/// The finished runs, appended to the journal as they end.
pub(super) struct Journal {
    path: PathBuf,
    state: Mutex<State>,
}

struct State {
    /// The open journal; `None` when there is none (the table is a device such as
    /// `/dev/null`) or writing it failed.
    file: Option<File>,
    /// The header written (with the first run), which every later run must have.
    header: Option<Vec<String>>,
    /// Why writing failed.
    error: Option<String>,
    /// The runs it holds.
    runs: usize,
}

impl Journal {
    /// Starts the journal of the table `out` with the runs `kept` (resumed), replacing any
    /// journal there (a new one is written beside it and renamed over it, so a kill now
    /// loses nothing). No journal for a table that is not a regular file.
    pub(super) fn create(out: &Path, kept: &[Row]) -> Result<Journal, String> {
        let path = journal_path(out);
        let device = std::fs::metadata(out).is_ok_and(|m| !m.is_file());
        let mut state = State {
            file: None,
            header: None,
            error: None,
            runs: 0,
        };
        if !device {
            let fail = |e: std::io::Error| format!("cannot write `{}`: {e}", path.display());
            let t = table(kept);
            let mut f = crate::output::AtomicFile::create(&path).map_err(fail)?;
            if !kept.is_empty() {
                f.write_all(t.to_csv().as_bytes()).map_err(fail)?;
                state.header = Some(t.names);
                state.runs = kept.len();
            }
            f.commit().map_err(fail)?;
            let file = std::fs::OpenOptions::new()
                .append(true)
                .open(&path)
                .map_err(fail)?;
            state.file = Some(file);
        }
        Ok(Journal {
            path,
            state: Mutex::new(state),
        })
    }

    /// Appends a finished run. An error (a full disk, rules named otherwise than those of
    /// the runs resumed) is kept and returned; the journal is not written again.
    pub(super) fn add(&self, row: &Row) -> Result<(), String> {
        let mut s = self.state.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(e) = &s.error {
            return Err(e.clone());
        }
        let t = table(std::slice::from_ref(row));
        let mut text = String::new();
        match &s.header {
            None => text += &t.csv_header(),
            Some(h) if *h != t.names => {
                let e = format!(
                    "run {}: its rules are not those of the runs in the table resumed (their names differ): the rules file changed; run the sweep without --resume",
                    row.run
                );
                s.error = Some(e.clone());
                return Err(e);
            }
            Some(_) => {}
        }
        text += &t.csv_row(0);
        let Some(f) = s.file.as_mut() else {
            return Ok(());
        };
        if let Err(e) = f.write_all(text.as_bytes()).and_then(|_| f.flush()) {
            let e = format!("cannot write `{}`: {e}", self.path.display());
            s.error = Some(e.clone());
            s.file = None;
            return Err(e);
        }
        s.header = Some(t.names);
        s.runs += 1;
        Ok(())
    }

    /// Why writing the journal failed, if it did.
    pub(super) fn error(&self) -> Option<String> {
        let s = self.state.lock().unwrap_or_else(|e| e.into_inner());
        s.error.clone()
    }

    /// The table of the `finished` runs could not be written: the journal is kept, with a
    /// note, when it holds any of them, else removed.
    pub(super) fn keep_or_remove(self, finished: usize) {
        let runs = {
            let s = self.state.lock().unwrap_or_else(|e| e.into_inner());
            s.runs
        };
        match runs {
            0 => {
                let _ = std::fs::remove_file(&self.path);
            }
            _ if runs == finished => crate::output::say!(
                "`{}` keeps the {runs} runs finished; the same command with --resume goes on from them",
                self.path.display()
            ),
            _ => crate::output::say!(
                "`{}` keeps {runs} of the {finished} runs finished; the same command with --resume goes on from them",
                self.path.display()
            ),
        }
    }

    /// Removes it: the table holds every finished run.
    pub(super) fn remove(self) {
        let mut s = self.state.lock().unwrap_or_else(|e| e.into_inner());
        if s.file.take().is_some() || s.error.is_some() {
            let _ = std::fs::remove_file(&self.path);
        }
    }
}

/// A run of this sweep, as `--resume` checks a kept run against it: its input and seed.
pub(super) struct Planned {
    pub input: String,
    pub seed: u64,
}

/// The runs finished by an earlier try of this sweep: those in the table `out` and in its
/// journal, each checked against the run of the same number in `planned` (this sweep's
/// runs, of this shard). The journal's last line is left out when a kill cut it short.
pub(super) fn resumed(out: &Path, planned: &HashMap<usize, Planned>) -> Result<Vec<Row>, String> {
    let mut kept: BTreeMap<usize, Row> = BTreeMap::new();
    let mut rules: Option<(Vec<String>, PathBuf)> = None;
    let journal = journal_path(out);
    let mut tables = Vec::new();
    if std::fs::metadata(out).is_ok_and(|m| m.is_file()) {
        tables.push((out.to_path_buf(), Table::read(out)));
    }
    if journal.is_file() {
        let text = std::fs::read(&journal).map_err(|e| format!("`{}`: {e}", journal.display()))?;
        let whole = text.iter().rposition(|&b| b == b'\n').map_or(0, |i| i + 1);
        let t = String::from_utf8(text[..whole].to_vec())
            .map_err(|_| "not UTF-8 text".to_string())
            .and_then(|t| {
                if t.is_empty() {
                    Ok(Table::default())
                } else {
                    Table::from_csv(&t)
                }
            });
        tables.push((journal, t));
    }
    for (path, t) in tables {
        let bad = |e: String| format!("`{}`: cannot resume from it: {e}", path.display());
        let t = t.map_err(bad)?;
        if t.names.is_empty() {
            continue;
        }
        let rows = rows_of(&t).map_err(bad)?;
        if let Some(first) = rows.first() {
            match &rules {
                Some((r, from)) if *r != first.rules => {
                    return Err(format!(
                        "`{}` and `{}` are tables of rules named differently: not of one sweep",
                        from.display(),
                        path.display()
                    ))
                }
                Some(_) => {}
                None => rules = Some((first.rules.clone(), path.clone())),
            }
        }
        for row in rows {
            let Some(p) = planned.get(&row.run) else {
                return Err(bad(format!(
                    "run {} is not a run of this sweep ({} runs here): is it the table of another sweep?",
                    row.run,
                    planned.len()
                )));
            };
            if p.input != row.input || p.seed != row.seed {
                return Err(bad(format!(
                    "run {} is `{}`, seed {}; this sweep's run {} is `{}`, seed {}: the table is of another sweep",
                    row.run, row.input, row.seed, row.run, p.input, p.seed
                )));
            }
            kept.entry(row.run).or_insert(row);
        }
    }
    Ok(kept.into_values().collect())
}

/// The runs in a sweep's table.
fn rows_of(t: &Table) -> Result<Vec<Row>, String> {
    let rules: Vec<String> = (t.names.iter())
        .filter_map(|n| n.strip_prefix("firings:"))
        .map(String::from)
        .collect();
    let names: Vec<&str> = rules.iter().map(String::as_str).collect();
    if t.names != header(&names) {
        return Err("its columns are not those of a sweep's table (of this version)".into());
    }
    let int = |i: usize| match &t.columns[i] {
        Column::Int(v) => Ok(v),
        _ => Err(format!("column `{}` holds no counts", t.names[i])),
    };
    let text = |i: usize| match &t.columns[i] {
        Column::Text(v) => Ok(v),
        _ => Err(format!("column `{}` holds no text", t.names[i])),
    };
    let last = t.names.len() - 1;
    let Column::Float(secs) = &t.columns[last] else {
        return Err("column `wall_time_s` holds no times".into());
    };
    let (run, n, seed, input, steps, stopped) =
        (int(0)?, int(1)?, int(2)?, text(3)?, int(4)?, text(5)?);
    let values: Vec<&Vec<u64>> = (6..last).map(int).collect::<Result<_, _>>()?;
    (0..t.rows())
        .map(|i| {
            let mut v = vec![steps[i]];
            v.extend(values.iter().map(|c| c[i]));
            let cost = StepCost::from_values(rules.len(), &v)
                .ok_or_else(|| format!("run {}: its totals do not add up", run[i]))?;
            let quiescent = match stopped[i].as_str() {
                "quiescence" => true,
                "max-steps" => false,
                s => return Err(format!("run {}: stopped by `{s}`?", run[i])),
            };
            Ok(Row {
                run: usize::try_from(run[i]).map_err(|_| format!("run {}?", run[i]))?,
                n: usize::try_from(n[i]).map_err(|_| format!("run {}: n?", run[i]))?,
                seed: seed[i],
                input: input[i].clone(),
                quiescent,
                cost,
                rules: rules.clone(),
                secs: secs[i],
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(run: usize) -> Row {
        Row {
            run,
            n: 10 * run,
            seed: 1,
            input: format!("line n={}", 10 * run),
            quiescent: run.is_multiple_of(2),
            cost: StepCost {
                step: 3,
                firings: vec![2, 5],
                executing: 6,
                records: vec![0; latticesim_runtime::RecordKind::ALL.len()],
                ..StepCost::default()
            },
            rules: vec!["a".into(), "b".into()],
            secs: 0.5,
        }
    }

    #[test]
    fn a_table_reads_back_as_its_rows() {
        let rows = [row(2), row(1)];
        let t = table(&rows);
        let back = rows_of(&Table::from_csv(&t.to_csv()).unwrap()).unwrap();
        assert_eq!(table(&back), t);
    }

    #[test]
    fn the_journal_keeps_each_run_and_resume_checks_them() {
        let dir = std::env::temp_dir().join(format!("latticesim-keep-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let out = dir.join("t.csv");
        let j = Journal::create(&out, &[row(1)]).unwrap();
        j.add(&row(3)).unwrap();
        let mut other = row(2);
        other.rules = vec!["c".into(), "b".into()];
        assert!(j.add(&other).unwrap_err().contains("rules file changed"));
        drop(j);
        // A kill cut the last line short: it is left out.
        let mut f = std::fs::OpenOptions::new()
            .append(true)
            .open(journal_path(&out))
            .unwrap();
        f.write_all(b"2,20,1,line n=2").unwrap();
        let plan = |runs: &[usize]| -> HashMap<usize, Planned> {
            (runs.iter())
                .map(|&r| {
                    let p = Planned {
                        input: format!("line n={}", 10 * r),
                        seed: 1,
                    };
                    (r, p)
                })
                .collect()
        };
        let kept = resumed(&out, &plan(&[1, 2, 3])).unwrap();
        assert_eq!(kept.iter().map(|r| r.run).collect::<Vec<_>>(), [1, 3]);
        let e = resumed(&out, &plan(&[1, 2])).unwrap_err();
        assert!(e.contains("run 3 is not a run of this sweep"), "{e}");
        let mut moved = plan(&[1, 2, 3]);
        moved.get_mut(&3).unwrap().seed = 2;
        let e = resumed(&out, &moved).unwrap_err();
        assert!(e.contains("the table is of another sweep"), "{e}");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
