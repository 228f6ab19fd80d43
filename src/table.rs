//! A table of named, typed columns, written and read as CSV or Parquet: the rows of a
//! sweep (`sweep --out`), its shards and their merge (`latticesim merge`), and the Python
//! package's sweep DataFrame. One place decides each column's type and how it is written.

use parquet::basic::{LogicalType, Repetition, Type as Physical};
use parquet::data_type::{ByteArray, ByteArrayType, DoubleType, Int64Type};
use parquet::file::properties::WriterProperties;
use parquet::file::reader::{FileReader, SerializedFileReader};
use parquet::file::writer::SerializedFileWriter;
use parquet::record::RowAccessor;
use parquet::schema::types::Type;
use std::io::Write;
use std::path::Path;
use std::sync::Arc;

/// One column's values.
#[derive(Debug, Clone, PartialEq)]
pub enum Column {
    /// Counts (written as 64-bit integers).
    Int(Vec<u64>),
    /// Measurements (seconds).
    Float(Vec<f64>),
    /// Text.
    Text(Vec<String>),
}

impl Column {
    /// Its number of rows.
    pub fn len(&self) -> usize {
        match self {
            Column::Int(v) => v.len(),
            Column::Float(v) => v.len(),
            Column::Text(v) => v.len(),
        }
    }

    /// No rows.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// An empty column of the same type.
    fn empty_like(&self) -> Column {
        match self {
            Column::Int(_) => Column::Int(Vec::new()),
            Column::Float(_) => Column::Float(Vec::new()),
            Column::Text(_) => Column::Text(Vec::new()),
        }
    }

    /// Row `i` as CSV text.
    fn csv(&self, i: usize) -> String {
        match self {
            Column::Int(v) => v[i].to_string(),
            Column::Float(v) => format!("{:.6}", v[i]),
            Column::Text(v) => csv_field(&v[i]),
        }
    }

    /// Adds row `i` of `other` (a column of the same type).
    fn push_from(&mut self, other: &Column, i: usize) {
        match (self, other) {
            (Column::Int(a), Column::Int(b)) => a.push(b[i]),
            (Column::Float(a), Column::Float(b)) => a.push(b[i]),
            (Column::Text(a), Column::Text(b)) => a.push(b[i].clone()),
            _ => unreachable!("columns of one header have one type"),
        }
    }
}

/// The format of a table or series file by its name: `csv`, `parquet`, or none.
pub fn format_of(path: &Path) -> Option<&'static str> {
    let name = path.file_name()?.to_str()?.to_ascii_lowercase();
    if name.ends_with(".csv") {
        Some("csv")
    } else if name.ends_with(".parquet") {
        Some("parquet")
    } else {
        None
    }
}

/// A CSV field: quoted when it holds a comma, a quote or a line break (RFC 4180).
pub fn csv_field(s: &str) -> String {
    if s.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

/// The type of the column named `name` in a table read from CSV: text for the input and how
/// a run stopped, seconds for names ending in `_s`, counts for every other.
fn column_for(name: &str) -> Column {
    match name {
        "input" | "stopped_by" => Column::Text(Vec::new()),
        _ if name.ends_with("_s") => Column::Float(Vec::new()),
        _ => Column::Int(Vec::new()),
    }
}

/// Columns with names, all of one length.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Table {
    /// The header.
    pub names: Vec<String>,
    /// The values, one column per name.
    pub columns: Vec<Column>,
}

impl Table {
    /// Its number of rows.
    pub fn rows(&self) -> usize {
        self.columns.first().map_or(0, Column::len)
    }

    /// The column named `name`.
    pub fn column(&self, name: &str) -> Option<&Column> {
        let i = self.names.iter().position(|n| n == name)?;
        Some(&self.columns[i])
    }

    /// The table as CSV: a header line, then a line per row.
    pub fn to_csv(&self) -> String {
        let mut out = self.csv_header();
        for i in 0..self.rows() {
            out += &self.csv_row(i);
        }
        out
    }

    /// The CSV header line (with its line end).
    pub fn csv_header(&self) -> String {
        let head: Vec<String> = self.names.iter().map(|n| csv_field(n)).collect();
        head.join(",") + "\n"
    }

    /// Row `i` as a CSV line (with its line end).
    pub fn csv_row(&self, i: usize) -> String {
        let line: Vec<String> = self.columns.iter().map(|c| c.csv(i)).collect();
        line.join(",") + "\n"
    }

    /// Writes the table as Parquet (one row group; text as UTF-8 strings).
    pub fn write_parquet<W: Write + Send>(&self, out: W) -> std::io::Result<W> {
        let other = std::io::Error::other;
        let fields = (self.names.iter().zip(&self.columns))
            .map(|(name, col)| {
                let b = match col {
                    Column::Int(_) => Type::primitive_type_builder(name, Physical::INT64),
                    Column::Float(_) => Type::primitive_type_builder(name, Physical::DOUBLE),
                    Column::Text(_) => Type::primitive_type_builder(name, Physical::BYTE_ARRAY)
                        .with_logical_type(Some(LogicalType::String)),
                };
                b.with_repetition(Repetition::REQUIRED)
                    .build()
                    .map(Arc::new)
            })
            .collect::<parquet::errors::Result<Vec<_>>>()
            .map_err(other)?;
        let schema = Type::group_type_builder("table")
            .with_fields(fields)
            .build()
            .map_err(other)?;
        let props = Arc::new(WriterProperties::builder().build());
        let mut writer = SerializedFileWriter::new(out, Arc::new(schema), props).map_err(other)?;
        let mut group = writer.next_row_group().map_err(other)?;
        for col in &self.columns {
            let mut w = group
                .next_column()
                .map_err(other)?
                .expect("a column per name");
            match col {
                Column::Int(v) => {
                    let v: Vec<i64> = v.iter().map(|&x| x as i64).collect();
                    w.typed::<Int64Type>().write_batch(&v, None, None)
                }
                Column::Float(v) => w.typed::<DoubleType>().write_batch(v, None, None),
                Column::Text(v) => {
                    let v: Vec<ByteArray> = v.iter().map(|s| ByteArray::from(s.as_str())).collect();
                    w.typed::<ByteArrayType>().write_batch(&v, None, None)
                }
            }
            .map_err(other)?;
            w.close().map_err(other)?;
        }
        group.close().map_err(other)?;
        writer.into_inner().map_err(other)
    }

    /// Writes the table into an output file, as Parquet when its name ends in `.parquet`,
    /// else as CSV, and commits it; the message and exit status 2 when it cannot.
    pub(crate) fn commit(
        &self,
        f: crate::output::AtomicFile,
    ) -> Result<(), std::process::ExitCode> {
        if format_of(f.path()) != Some("parquet") {
            return crate::output::write_output(f, self.to_csv().as_bytes());
        }
        let path = f.path().to_path_buf();
        self.write_parquet(f).and_then(|f| f.commit()).map_err(|e| {
            crate::output::say!("error: cannot write `{}`: {e}", path.display());
            std::process::ExitCode::from(2)
        })
    }

    /// Reads a table written by [`Table::to_csv`] (the types by the column names).
    pub fn from_csv(text: &str) -> Result<Table, String> {
        let mut r = csv::ReaderBuilder::new()
            .flexible(true)
            .from_reader(text.as_bytes());
        let names: Vec<String> = (r.headers().map_err(|e| e.to_string())?.iter())
            .map(str::to_string)
            .collect();
        let mut columns: Vec<Column> = names.iter().map(|n| column_for(n)).collect();
        for (i, rec) in r.records().enumerate() {
            let rec = rec.map_err(|e| e.to_string())?;
            let line = i + 2;
            if rec.len() != names.len() {
                return Err(format!(
                    "line {line}: {} fields, the header has {}",
                    rec.len(),
                    names.len()
                ));
            }
            for ((col, field), name) in columns.iter_mut().zip(rec.iter()).zip(&names) {
                let bad =
                    |what: &str| format!("line {line}: column `{name}`: `{field}` is not {what}");
                match col {
                    Column::Int(v) => v.push(field.parse().map_err(|_| bad("a count"))?),
                    Column::Float(v) => v.push(field.parse().map_err(|_| bad("a number"))?),
                    Column::Text(v) => v.push(field.to_string()),
                }
            }
        }
        Ok(Table { names, columns })
    }

    /// Reads a table written by [`Table::write_parquet`]. A damaged file is an error, never a
    /// panic or an allocation it cannot back: the row count in its metadata is bounded by
    /// its size, and a panic inside the parquet crate (which some damaged files cause) is
    /// caught and reported as damage.
    pub fn from_parquet(bytes: Vec<u8>) -> Result<Table, String> {
        let damaged = |e: String| format!("a damaged Parquet file ({e})");
        let read = std::panic::AssertUnwindSafe(move || Table::parquet_rows(bytes));
        match quietly(read) {
            Ok(Ok(t)) => Ok(t),
            Ok(Err(e)) => Err(damaged(e)),
            Err(panic) => Err(damaged(format!("its reader stopped: {panic}"))),
        }
    }

    fn parquet_rows(bytes: Vec<u8>) -> Result<Table, String> {
        // Every row of a sweep table holds a distinct run number, so no honest file holds
        // more rows than bits.
        let most_rows = bytes.len() as i64 * 8;
        let reader =
            SerializedFileReader::new(bytes::Bytes::from(bytes)).map_err(|e| e.to_string())?;
        let meta = reader.metadata();
        let rows = meta.file_metadata().num_rows();
        if !(0..=most_rows).contains(&rows) {
            return Err(format!("it claims {rows} rows"));
        }
        let schema = meta.file_metadata().schema_descr_ptr();
        let mut names = Vec::new();
        let mut columns = Vec::new();
        for c in schema.columns() {
            names.push(c.name().to_string());
            columns.push(match c.physical_type() {
                Physical::INT64 => Column::Int(Vec::new()),
                Physical::DOUBLE => Column::Float(Vec::new()),
                Physical::BYTE_ARRAY => Column::Text(Vec::new()),
                t => return Err(format!("column `{}`: type {t} is not of a sweep", c.name())),
            });
        }
        let mut read = 0i64;
        for row in reader.get_row_iter(None).map_err(|e| e.to_string())? {
            let row = row.map_err(|e| e.to_string())?;
            read += 1;
            if read > rows {
                return Err(format!("more rows than the {rows} it claims"));
            }
            for (i, col) in columns.iter_mut().enumerate() {
                match col {
                    Column::Int(v) => v.push(row.get_long(i).map_err(|e| e.to_string())? as u64),
                    Column::Float(v) => v.push(row.get_double(i).map_err(|e| e.to_string())?),
                    Column::Text(v) => {
                        v.push(row.get_string(i).map_err(|e| e.to_string())?.clone())
                    }
                }
            }
        }
        if read != rows {
            return Err(format!("{read} rows where it claims {rows}"));
        }
        Ok(Table { names, columns })
    }

    /// Reads a CSV or Parquet table (by its first bytes: Parquet files start with `PAR1`).
    pub fn read(path: &Path) -> Result<Table, String> {
        let bytes = std::fs::read(path).map_err(|e| e.to_string())?;
        if bytes.starts_with(b"PAR1") {
            return Table::from_parquet(bytes);
        }
        let text = String::from_utf8(bytes).map_err(|e| e.to_string())?;
        Table::from_csv(&text)
    }

    /// The rows of the table in the order of `order` (row indices).
    pub fn reorder(&self, order: &[usize]) -> Table {
        let columns = (self.columns.iter())
            .map(|c| {
                let mut out = c.empty_like();
                for &i in order {
                    out.push_from(c, i);
                }
                out
            })
            .collect();
        Table {
            names: self.names.clone(),
            columns,
        }
    }

    /// Adds the rows of `other`, a table with the same header.
    pub fn append(&mut self, other: &Table) -> Result<(), String> {
        if self.names.is_empty() && self.columns.is_empty() {
            *self = other.clone();
            return Ok(());
        }
        if self.names != other.names {
            return Err("its columns differ from those of the first part".into());
        }
        for (a, b) in self.columns.iter_mut().zip(&other.columns) {
            if std::mem::discriminant(a) != std::mem::discriminant(b) {
                return Err("the types of its columns differ from those of the first part".into());
            }
            for i in 0..b.len() {
                a.push_from(b, i);
            }
        }
        Ok(())
    }
}

std::thread_local! {
    static QUIET: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
}

/// Runs `f`, returning the message of a panic in it instead of unwinding, and without the
/// panic's report on stderr (other threads' panics are reported as before).
fn quietly<T>(f: impl FnOnce() -> T + std::panic::UnwindSafe) -> Result<T, String> {
    static HOOK: std::sync::Once = std::sync::Once::new();
    HOOK.call_once(|| {
        let report = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            if !QUIET.with(|q| q.get()) {
                report(info)
            }
        }));
    });
    QUIET.with(|q| q.set(true));
    let r = std::panic::catch_unwind(f);
    QUIET.with(|q| q.set(false));
    r.map_err(|p| {
        (p.downcast_ref::<&str>().map(|s| s.to_string()))
            .or_else(|| p.downcast_ref::<String>().cloned())
            .unwrap_or_else(|| "a panic".into())
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> Table {
        Table {
            names: vec!["run".into(), "input".into(), "wall_time_s".into()],
            columns: vec![
                Column::Int(vec![1, 2]),
                Column::Text(vec!["line n=3".into(), "a \"b\", c".into()]),
                Column::Float(vec![0.5, 0.25]),
            ],
        }
    }

    /// A table as a sweep writes it: distinct run numbers, sizes, seeds, text, times.
    fn sweep_like(rows: u64) -> Table {
        Table {
            names: ["run", "n", "seed", "input", "steps", "wall_time_s"]
                .map(String::from)
                .to_vec(),
            columns: vec![
                Column::Int((0..rows).collect()),
                Column::Int((0..rows).map(|r| 4 << (r / 10)).collect()),
                Column::Int((0..rows).map(|r| r % 10 + 1).collect()),
                Column::Text(
                    (0..rows)
                        .map(|r| format!("line n={}", 4 << (r / 10)))
                        .collect(),
                ),
                Column::Int((0..rows).map(|r| r * 7 % 13).collect()),
                Column::Float((0..rows).map(|r| r as f64 / 1000.0).collect()),
            ],
        }
    }

    #[test]
    fn a_damaged_parquet_table_is_an_error_never_a_panic() {
        let good = sweep_like(40).write_parquet(Vec::new()).unwrap();
        assert_eq!(Table::from_parquet(good.clone()).unwrap(), sweep_like(40));
        let mut x: u64 = 0x9e37_79b9_7f4a_7c15;
        let mut next = move || {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            x
        };
        let (mut damaged, mut panics) = (0, 0);
        // Every single bit flipped of the footer and the last page (where the metadata and its
        // lengths are), then 1,000 files with 1 to 4 bytes overwritten anywhere and 100 cut short.
        let flips = (good.len().saturating_sub(1500) * 8..good.len() * 8).map(|bit| {
            let mut b = good.clone();
            b[bit / 8] ^= 1 << (bit % 8);
            b
        });
        let writes = (0..1000).map(|_| {
            let mut b = good.clone();
            for _ in 0..1 + next() % 4 {
                let i = next() as usize % b.len();
                b[i] = [0xff, 0x7f, 0x00, next() as u8][next() as usize % 4];
            }
            b
        });
        let cuts: Vec<Vec<u8>> = (0..100)
            .map(|k| good[..good.len() * k / 100].to_vec())
            .collect();
        for b in flips.chain(writes).chain(cuts) {
            match Table::from_parquet(b) {
                Ok(_) => {}
                Err(e) => {
                    assert!(e.starts_with("a damaged Parquet file ("), "{e}");
                    damaged += 1;
                    panics += usize::from(e.contains("its reader stopped: "));
                }
            }
        }
        // The test means something only if it met damage, and panics in the crate among it.
        assert!(damaged > 1000, "{damaged}");
        assert!(panics > 0, "no panic was caught: {damaged} damaged");
    }

    #[test]
    fn csv_and_parquet_read_back_what_was_written() {
        let t = sample();
        assert_eq!(Table::from_csv(&t.to_csv()).unwrap(), t);
        let dir = std::env::temp_dir().join(format!("latticesim-table-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join("t.parquet");
        t.write_parquet(std::fs::File::create(&p).unwrap()).unwrap();
        assert_eq!(Table::read(&p).unwrap(), t);
        let c = dir.join("t.csv");
        std::fs::write(&c, t.to_csv()).unwrap();
        assert_eq!(Table::read(&c).unwrap(), t);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn a_bad_field_is_named_by_line_and_column() {
        let e = Table::from_csv("run,steps\n1,2\n2,x\n").unwrap_err();
        assert_eq!(e, "line 3: column `steps`: `x` is not a count");
        let e = Table::from_csv("run,steps\n1\n").unwrap_err();
        assert!(e.contains("line 2"), "{e}");
    }

    #[test]
    fn parts_append_only_with_one_header_and_reorder_by_rows() {
        let mut t = Table::default();
        t.append(&sample()).unwrap();
        t.append(&sample()).unwrap();
        assert_eq!(t.rows(), 4);
        let r = t.reorder(&[3, 0]);
        assert_eq!(r.column("run"), Some(&Column::Int(vec![2, 1])));
        let other = Table {
            names: vec!["run".into()],
            columns: vec![Column::Int(vec![1])],
        };
        assert!(t.append(&other).is_err());
    }
}
