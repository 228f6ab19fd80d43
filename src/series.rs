//! `run --series FILE`: one row per step of what it cost ([`StepCost`]'s columns, then the
//! step's time in seconds unless `--no-timing`), as CSV or Parquet by the file's name.
//! CSV rows are written as the steps go; Parquet rows in groups of [`ROW_GROUP`] steps.
//! Either way the file appears whole when the run ends (it is an [`AtomicFile`]).

use crate::output::{open_output, say, AtomicFile};
use crate::table::{csv_field, format_of};
use latticesim_runtime::StepCost;
use parquet::basic::{Repetition, Type as Physical};
use parquet::data_type::{DoubleType, Int64Type};
use parquet::file::properties::WriterProperties;
use parquet::file::writer::SerializedFileWriter;
use parquet::schema::types::Type;
use std::io::Write;
use std::path::Path;
use std::process::ExitCode;
use std::sync::Arc;

/// Steps per Parquet row group.
pub(crate) const ROW_GROUP: usize = 1 << 16;

/// A series being written.
pub(crate) enum Series {
    /// CSV: the header is written, each row as it comes.
    Csv(AtomicFile),
    /// Parquet: the rows of the current group, column by column, and the file.
    Parquet {
        writer: Box<SerializedFileWriter<AtomicFile>>,
        counts: Vec<Vec<i64>>,
        times: Option<Vec<f64>>,
    },
}

/// A series file opened before the run, to be started when the rules are known.
pub(crate) struct SeriesFile {
    file: AtomicFile,
    parquet: bool,
}

impl SeriesFile {
    /// Opens the series file `path`: an error (exit status 2) when its name ends in neither
    /// `.csv` nor `.parquet`, or it cannot be written.
    pub(crate) fn open(path: &Path) -> Result<SeriesFile, ExitCode> {
        let Some(format) = format_of(path) else {
            say!(
                "error: --series `{}`: a series is written as CSV (a name ending in .csv) or Parquet (.parquet)",
                path.display()
            );
            return Err(ExitCode::from(2));
        };
        Ok(SeriesFile {
            file: open_output(path)?,
            parquet: format == "parquet",
        })
    }

    /// The series of a program whose rules are named `rules`, with a column of step times
    /// when `timing`.
    pub(crate) fn start(self, rules: &[&str], timing: bool) -> std::io::Result<Series> {
        let SeriesFile { mut file, parquet } = self;
        let mut names = StepCost::columns(rules);
        if timing {
            names.push("step_s".into());
        }
        if !parquet {
            let header: Vec<String> = names.iter().map(|n| csv_field(n)).collect();
            writeln!(file, "{}", header.join(","))?;
            return Ok(Series::Csv(file));
        }
        let other = std::io::Error::other;
        let schema = schema(&names, timing).map_err(other)?;
        let props = Arc::new(WriterProperties::builder().build());
        let writer = SerializedFileWriter::new(file, schema, props).map_err(other)?;
        let counts = names.len() - timing as usize;
        Ok(Series::Parquet {
            writer: Box::new(writer),
            counts: vec![Vec::new(); counts],
            times: timing.then(Vec::new),
        })
    }
}

impl Series {
    /// Adds the row of one step (its time in seconds, when the series has a time column).
    pub(crate) fn push(&mut self, cost: &StepCost, secs: Option<f64>) -> std::io::Result<()> {
        match self {
            Series::Csv(f) => {
                let mut line: Vec<String> = cost.values().iter().map(u64::to_string).collect();
                line.extend(secs.map(|s| format!("{s:.9}")));
                writeln!(f, "{}", line.join(","))
            }
            Series::Parquet {
                writer,
                counts,
                times,
            } => {
                for (col, v) in counts.iter_mut().zip(cost.values()) {
                    col.push(v as i64);
                }
                if let (Some(t), Some(s)) = (times.as_mut(), secs) {
                    t.push(s);
                }
                if counts[0].len() >= ROW_GROUP {
                    row_group(writer, counts, times).map_err(std::io::Error::other)?;
                }
                Ok(())
            }
        }
    }

    /// Writes what is left and commits the file.
    pub(crate) fn finish(self) -> std::io::Result<()> {
        match self {
            Series::Csv(f) => f.commit(),
            Series::Parquet {
                mut writer,
                mut counts,
                mut times,
            } => {
                if !counts[0].is_empty() {
                    row_group(&mut writer, &mut counts, &mut times)
                        .map_err(std::io::Error::other)?;
                }
                writer.into_inner().map_err(std::io::Error::other)?.commit()
            }
        }
    }
}

/// The Parquet schema: a required 64-bit integer per count, a double for the time.
fn schema(names: &[String], timing: bool) -> parquet::errors::Result<Arc<Type>> {
    let counts = names.len() - timing as usize;
    let fields = (names.iter().enumerate())
        .map(|(i, name)| {
            let physical = if i < counts {
                Physical::INT64
            } else {
                Physical::DOUBLE
            };
            Type::primitive_type_builder(name, physical)
                .with_repetition(Repetition::REQUIRED)
                .build()
                .map(Arc::new)
        })
        .collect::<parquet::errors::Result<Vec<_>>>()?;
    Ok(Arc::new(
        Type::group_type_builder("series")
            .with_fields(fields)
            .build()?,
    ))
}

/// Writes the rows gathered in `counts` and `times` as one row group, and empties them.
fn row_group(
    writer: &mut SerializedFileWriter<AtomicFile>,
    counts: &mut [Vec<i64>],
    times: &mut Option<Vec<f64>>,
) -> parquet::errors::Result<()> {
    let mut group = writer.next_row_group()?;
    for col in counts.iter_mut() {
        let mut w = group.next_column()?.expect("a column per count");
        w.typed::<Int64Type>().write_batch(col, None, None)?;
        w.close()?;
        col.clear();
    }
    if let Some(t) = times.as_mut() {
        let mut w = group.next_column()?.expect("the time column");
        w.typed::<DoubleType>().write_batch(t, None, None)?;
        w.close()?;
        t.clear();
    }
    group.close()?;
    Ok(())
}
