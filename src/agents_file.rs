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
const CHUNK: usize = 4 << 20;
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
    /// Its size in bytes, when known before reading (not for compressed files).
    fn size(self) -> Option<u64> {
        match self {
            Source::File(p) if Packing::of(p) == Packing::Plain => {
                std::fs::metadata(p).ok().map(|m| m.len())
            }
            Source::File(_) => None,
            Source::Bytes(b) => Some(b.len() as u64),
        }
    }

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
    let mut checked = checked;
    // The description of every agent is let go once the lattice holds them.
    let lattice = checked.config.take().map(|c| Lattice::new(&c));
    Ok(Loaded {
        checked,
        lattice,
        read,
        check: t.elapsed(),
    })
}

/// A buffer of bytes read from a file: `buf[..len]` holds them; the rest is room, zeroed
/// once when the buffer grows (not at every read).
struct Window {
    buf: Vec<u8>,
    len: usize,
    eof: bool,
}

impl Window {
    /// Reads until `want` bytes are held or the end is reached.
    fn fill(&mut self, r: &mut dyn Read, want: usize) -> io::Result<()> {
        if self.buf.len() < want {
            self.buf.resize(want, 0);
        }
        while self.len < want && !self.eof {
            match r.read(&mut self.buf[self.len..want]) {
                Ok(0) => self.eof = true,
                Ok(n) => self.len += n,
                Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
                Err(e) => return Err(e),
            }
        }
        Ok(())
    }

    /// The bytes held.
    fn bytes(&self) -> &[u8] {
        &self.buf[..self.len]
    }

    /// The length of the whole lines held (all of it at the end of the file).
    fn whole(&self) -> usize {
        if self.eof {
            self.len
        } else {
            memchr::memrchr(b'\n', self.bytes()).map_or(0, |p| p + 1)
        }
    }

    /// Forgets the first `n` bytes.
    fn consume(&mut self, n: usize) {
        self.buf.copy_within(n..self.len, 0);
        self.len -= n;
    }
}

/// Reads whole lines into columns on up to `threads` threads (cut at line ends): false
/// when some line needs the diagnostic path.
fn read_parallel(bytes: &[u8], head: &Head, out: &mut Columns, threads: usize) -> bool {
    let parts = threads.min(bytes.len() / BYTES_PER_THREAD).max(1);
    if parts == 1 {
        return read_lines(bytes, head, out);
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
    // This thread reads the first piece straight into `out`; the others, read beside it,
    // are appended after.
    let (first, rest) = (&bytes[..cuts[1]], &cuts[1..]);
    let (ok, results): (bool, Vec<(bool, Columns)>) = std::thread::scope(|s| {
        let handles: Vec<_> = rest
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
        let ok = read_lines(first, head, out);
        let results = handles
            .into_iter()
            .map(|h| h.join().unwrap_or_else(|_| (false, Columns::new())))
            .collect();
        (ok, results)
    });
    let mut ok = ok;
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
    let mut w = Window {
        buf: Vec::new(),
        len: 0,
        eof: false,
    };
    w.fill(&mut *r, 1 << 20)?;
    let Some(head) = read_head(&w.bytes()[..w.whole()]) else {
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
            bytes: &w.bytes()[..head.end],
        },
    ) else {
        return Ok(None);
    };
    let check_time = t.elapsed();
    let mut cols = Columns::new();
    // Room for the agents the file's size suggests (from the lines of its first bytes), so
    // that the columns do not move as they grow.
    if let Some(size) = open.size() {
        let first = &w.bytes()[head.agents_at..w.whole()];
        let lines = memchr::memchr_iter(b'\n', first).count().max(1);
        let guess = (size as f64 * lines as f64 / first.len().max(1) as f64 * 1.05) as usize + 64;
        cols.pos.reserve(guess);
        cols.state.reserve(guess);
        cols.attach.reserve(guess);
    }
    let mut from = head.agents_at;
    loop {
        let upto = w.whole();
        if upto > from && !read_parallel(&w.bytes()[from..upto], &head, &mut cols, threads) {
            return Ok(None);
        }
        if w.eof {
            break;
        }
        w.consume(upto);
        from = 0;
        // A line longer than a chunk makes the buffer grow until its end is in it.
        let want = w.len + CHUNK;
        w.fill(&mut *r, want)?;
    }
    drop(w);
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
