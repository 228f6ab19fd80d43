//! Agents files in and out: compressed or not, read on several threads straight into the
//! lattice's columns when the file is clean (the diagnostic path reads it when not), and
//! written from the columns through a buffered, streaming writer.
//!
//! This module is the one place that decides which path reads an agents file: the fast
//! reader of `latticesim_compiler::fast_agents` first; when it (or the lattice's check of
//! cells and bonds, or the rules checked against the file's head) says no, the whole pair
//! is read and checked by `latticesim_compiler::check`, whose diagnostics are the project's
//! one source of truth.

use crate::output::say;
use latticesim_compiler::fast_agents::{check_with_head, read_head, read_lines, Head};
use latticesim_compiler::{check, Checked, Columns, Input};
use latticesim_runtime::Lattice;
use std::fs::File;
use std::io::{self, BufReader, BufWriter, Read, Write};
use std::path::Path;
use std::process::ExitCode;
use std::time::{Duration, Instant};

/// The bytes read from an agents file at a time (then cut at the last line end).
const CHUNK: usize = 16 << 20;
/// Below this many bytes a chunk is read on one thread.
const BYTES_PER_THREAD: usize = 1 << 20;

/// How a file is compressed, by its name's ending.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub(crate) enum Packing {
    Plain,
    Zstd,
    Gzip,
}

impl Packing {
    pub(crate) fn of(path: &Path) -> Packing {
        match path.extension().and_then(|e| e.to_str()) {
            Some("zst") => Packing::Zstd,
            Some("gz") => Packing::Gzip,
            _ => Packing::Plain,
        }
    }
}

/// Opens a file for reading, decompressing by its name (`.zst`, `.gz`).
pub(crate) fn open_read(path: &Path) -> io::Result<Box<dyn Read + Send>> {
    let f = BufReader::with_capacity(1 << 20, File::open(path)?);
    Ok(match Packing::of(path) {
        Packing::Plain => Box::new(f),
        Packing::Zstd => Box::new(zstd::Decoder::with_buffer(f)?),
        Packing::Gzip => Box::new(flate2::bufread::MultiGzDecoder::new(f)),
    })
}

/// The whole (decompressed) content of a file, or the message and exit status 2.
pub(crate) fn read_all(path: &Path) -> Result<Vec<u8>, ExitCode> {
    let mut bytes = Vec::new();
    open_read(path)
        .and_then(|mut r| r.read_to_end(&mut bytes))
        .map_err(|e| {
            say!("error: cannot read `{}`: {e}", path.display());
            ExitCode::from(2)
        })?;
    Ok(bytes)
}

/// A writer that compresses by the name of the file it ends in.
pub(crate) enum Packed<W: Write> {
    Plain(BufWriter<W>),
    Zstd(zstd::Encoder<'static, BufWriter<W>>),
    Gzip(flate2::write::GzEncoder<BufWriter<W>>),
}

impl<W: Write> Packed<W> {
    pub(crate) fn new(w: W, packing: Packing) -> io::Result<Packed<W>> {
        let b = BufWriter::with_capacity(1 << 20, w);
        Ok(match packing {
            Packing::Plain => Packed::Plain(b),
            Packing::Zstd => Packed::Zstd(zstd::Encoder::new(b, 3)?),
            Packing::Gzip => Packed::Gzip(flate2::write::GzEncoder::new(
                b,
                flate2::Compression::fast(),
            )),
        })
    }

    /// Ends the compressed stream and gives back the writer, flushed.
    pub(crate) fn finish(self) -> io::Result<W> {
        let b = match self {
            Packed::Plain(b) => b,
            Packed::Zstd(z) => z.finish()?,
            Packed::Gzip(g) => g.finish()?,
        };
        b.into_inner().map_err(|e| e.into_error())
    }
}

impl<W: Write> Write for Packed<W> {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        match self {
            Packed::Plain(w) => w.write(buf),
            Packed::Zstd(w) => w.write(buf),
            Packed::Gzip(w) => w.write(buf),
        }
    }
    fn write_all(&mut self, buf: &[u8]) -> io::Result<()> {
        match self {
            Packed::Plain(w) => w.write_all(buf),
            Packed::Zstd(w) => w.write_all(buf),
            Packed::Gzip(w) => w.write_all(buf),
        }
    }
    fn flush(&mut self) -> io::Result<()> {
        match self {
            Packed::Plain(w) => w.flush(),
            Packed::Zstd(w) => w.flush(),
            Packed::Gzip(w) => w.flush(),
        }
    }
}

/// Writes the lattice as agents.txt text into an output file (compressed by its name) and
/// commits it; the message and exit status 2 when it cannot.
pub(crate) fn write_lattice(
    f: crate::output::AtomicFile,
    lat: &Lattice,
    threads: usize,
) -> Result<(), ExitCode> {
    let path = f.path().to_path_buf();
    let packing = Packing::of(&path);
    Packed::new(f, packing)
        .and_then(|mut w| {
            lat.write_agents_text(&mut w, threads)?;
            w.finish()
        })
        .and_then(|f| f.commit())
        .map_err(|e| {
            say!("error: cannot write `{}`: {e}", path.display());
            ExitCode::from(2)
        })
}

/// An agents file read and checked with its rules.
pub(crate) struct Loaded {
    /// The verdict: diagnostics, counts, the program when there are no errors.
    pub checked: Checked,
    /// The lattice, when there are no errors.
    pub lattice: Option<Lattice>,
    /// The time spent reading the agents file (and building the lattice).
    pub read: Duration,
    /// The time spent checking.
    pub check: Duration,
}

/// Where an agents file comes from (opened again for the diagnostic path).
#[derive(Clone, Copy)]
pub(crate) enum Source<'a> {
    /// A file on disk, decompressed by its name.
    File(&'a Path),
    /// Text in memory.
    Bytes(&'a [u8]),
}

impl<'a> Source<'a> {
    fn open(self) -> io::Result<Box<dyn Read + Send + 'a>> {
        match self {
            Source::File(p) => open_read(p),
            Source::Bytes(b) => Ok(Box::new(b)),
        }
    }
}

/// Reads an agents file and checks it with its rules (`rules`: name and bytes): the fast
/// path when the file is clean, the diagnostic path otherwise. `Err` only when the file
/// cannot be read.
pub(crate) fn load(
    rules: (&str, &[u8]),
    agents_name: &str,
    open: Source<'_>,
    threads: usize,
) -> io::Result<Loaded> {
    let started = Instant::now();
    if let Some(l) = fast(rules, agents_name, open, threads)? {
        return Ok(l);
    }
    let mut bytes = Vec::new();
    open.open()?.read_to_end(&mut bytes)?;
    let read = started.elapsed();
    let t = Instant::now();
    let checked = check(
        Input {
            name: rules.0,
            bytes: rules.1,
        },
        Some(Input {
            name: agents_name,
            bytes: &bytes,
        }),
        None,
    );
    drop(bytes);
    let lattice = checked.config.as_ref().map(Lattice::new);
    Ok(Loaded {
        checked,
        lattice,
        read,
        check: t.elapsed(),
    })
}

/// Fills `buf` from `r` up to `want` bytes (fewer at the end): whether the end was reached.
fn fill(r: &mut dyn Read, buf: &mut Vec<u8>, want: usize) -> io::Result<bool> {
    while buf.len() < want {
        let had = buf.len();
        let room = (want - had).min(CHUNK);
        buf.resize(had + room, 0);
        let n = loop {
            match r.read(&mut buf[had..]) {
                Err(e) if e.kind() == io::ErrorKind::Interrupted => continue,
                other => break other,
            }
        };
        match n {
            Ok(0) => {
                buf.truncate(had);
                return Ok(true);
            }
            Ok(n) => buf.truncate(had + n),
            Err(e) => {
                buf.truncate(had);
                return Err(e);
            }
        }
    }
    Ok(false)
}

/// Reads whole lines into columns on up to `threads` threads (cut at line ends): false
/// when some line needs the diagnostic path.
fn read_parallel(bytes: &[u8], head: &Head, out: &mut Columns, threads: usize) -> bool {
    let parts = threads.min(bytes.len() / BYTES_PER_THREAD).max(1);
    if parts == 1 {
        let mut cols = Columns::new();
        let ok = read_lines(bytes, head, &mut cols);
        out.append(cols);
        return ok;
    }
    let mut cuts = vec![0];
    for k in 1..parts {
        let at = (bytes.len() * k / parts).max(*cuts.last().expect("one cut"));
        let end = bytes[at..]
            .iter()
            .position(|&c| c == b'\n')
            .map_or(bytes.len(), |p| at + p + 1);
        cuts.push(end);
    }
    cuts.push(bytes.len());
    let results: Vec<(bool, Columns)> = std::thread::scope(|s| {
        let handles: Vec<_> = cuts
            .windows(2)
            .map(|w| {
                let piece = &bytes[w[0]..w[1]];
                s.spawn(move || {
                    let mut cols = Columns::new();
                    let ok = read_lines(piece, head, &mut cols);
                    (ok, cols)
                })
            })
            .collect();
        handles
            .into_iter()
            .map(|h| h.join().unwrap_or_else(|_| (false, Columns::new())))
            .collect()
    });
    let mut ok = true;
    for (good, cols) in results {
        ok &= good;
        if ok {
            out.append(cols);
        }
    }
    ok
}

/// The fast path: `None` when the diagnostic path must read the file.
fn fast(
    rules: (&str, &[u8]),
    agents_name: &str,
    open: Source<'_>,
    threads: usize,
) -> io::Result<Option<Loaded>> {
    let started = Instant::now();
    let mut r = open.open()?;
    let mut buf = Vec::new();
    let mut eof = fill(&mut *r, &mut buf, 1 << 20)?;
    let whole = |buf: &[u8], eof: bool| {
        if eof {
            buf.len()
        } else {
            buf.iter().rposition(|&c| c == b'\n').map_or(0, |p| p + 1)
        }
    };
    let Some(head) = read_head(&buf[..whole(&buf, eof)]) else {
        return Ok(None);
    };
    let t = Instant::now();
    let Some(mut checked) = check_with_head(
        Input {
            name: rules.0,
            bytes: rules.1,
        },
        Input {
            name: agents_name,
            bytes: &buf[..head.end],
        },
    ) else {
        return Ok(None);
    };
    let check_time = t.elapsed();
    let mut cols = Columns::new();
    let mut from = head.agents_at;
    loop {
        let upto = whole(&buf, eof);
        if upto > from && !read_parallel(&buf[from..upto], &head, &mut cols, threads) {
            return Ok(None);
        }
        if eof {
            break;
        }
        buf.drain(..upto);
        from = 0;
        // A line longer than a chunk makes the buffer grow until its end is in it.
        let want = buf.len() + CHUNK;
        eof = fill(&mut *r, &mut buf, want)?;
    }
    drop(buf);
    cols.fill();
    let n = cols.len();
    let Some(lat) = Lattice::from_columns(head.dim, head.universe, cols) else {
        return Ok(None);
    };
    checked.agent_count = n;
    checked.config = None;
    Ok(Some(Loaded {
        checked,
        lattice: Some(lat),
        read: started.elapsed() - check_time,
        check: check_time,
    }))
}
