//! Agents files in and out: compressed or not, read on several threads straight into the
//! lattice's columns, and written from the columns through a buffered, streaming writer.
//!
//! This module is the one place that decides which path reads an agents file. The
//! streaming path first: the fast reader of `latticesim_compiler::fast_agents`, and the
//! lines it leaves checked one at a time with the checker's code (`LineCheck`); agents on
//! one cell and one-sided bonds found in the lattice once built (`from_columns_mended`);
//! the warnings that follow from the states agents start in (W503, W603) from the states
//! read (`states_warnings_of`). Only the diagnostics that can still be shown are held
//! (`Shown`); their lines are read again at the end, and the file is held as its head and
//! those lines (`Sources::excerpt`). When the head cannot be read so (see
//! `fast_agents::clean_head`, `check_with_head`) or a line is not UTF-8, the whole pair is
//! read and checked by `latticesim_compiler::check`, whose diagnostics are the project's
//! one source of truth (and the streaming path's, line by line).

use crate::output::say;
use latticesim_compiler::fast_agents::{
    check_with_head, clean_head, read_head, read_lines, Cleaned, Head, LineCheck, Verdict,
};
use latticesim_compiler::lints::Lints;
use latticesim_compiler::{check_with, Checked, Columns, Input, StartState};
use latticesim_runtime::{Lattice, Mends};
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
    commit_lattice(f, lat, threads).map_err(|e| {
        say!("error: cannot write `{}`: {e}", path.display());
        ExitCode::from(2)
    })
}

/// Writes the lattice as agents.txt text into an output file (compressed by its name:
/// `.zst`, `.gz`) and commits it (`run --out`).
pub fn commit_lattice(
    f: crate::output::AtomicFile,
    lat: &Lattice,
    threads: usize,
) -> io::Result<()> {
    let packing = Packing::of(f.path());
    Packed::new(f, packing)
        .and_then(|mut w| {
            lat.write_agents_text(&mut w, threads)?;
            w.finish()
        })
        .and_then(|f| f.commit())
}

/// An agents file read and checked with its rules.
pub struct Loaded {
    /// The verdict: diagnostics, counts, the program when there are no errors.
    pub checked: Checked,
    /// The lattice, when there are no errors.
    pub lattice: Option<Lattice>,
    /// What the caller must print after the diagnostics, when the file was too large to
    /// be checked whole (its verdict is then an error).
    pub note: Option<String>,
    /// The time spent reading the agents file (and building the lattice).
    pub read: Duration,
    /// The time spent checking.
    pub check: Duration,
    /// True when the streaming reader read the file to its end (the checker did not read
    /// it whole).
    pub streamed: bool,
}

/// Where an agents file comes from (opened again for the diagnostic path).
#[derive(Clone, Copy)]
pub enum Source<'a> {
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

/// The checker's memory per byte of an agents file, about (575 MB for a 17.4 MB file of a
/// million agents, with the lattice made from its description).
const CHECK_BYTES_PER_BYTE: u64 = 36;
/// Lines checked past the first line the fast reader left, when the file is too large to
/// be checked whole (about: up to this many bytes).
const CHECKED_AFTER: u64 = 1 << 20;

/// The memory the checker may take: `LATTICESIM_CHECK_MEMORY` (bytes) when set, else what
/// the system has free, where it says (Linux).
fn available_memory() -> Option<u64> {
    if let Some(v) = std::env::var_os("LATTICESIM_CHECK_MEMORY") {
        return v.to_str().and_then(|v| v.parse().ok());
    }
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = text.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024)
}

/// Reads an agents file and checks it with its rules (`rules`: name and bytes): the fast
/// path when the file is clean, the checker otherwise. `Err` only when the file cannot be
/// read.
///
/// A file left to the checker that it cannot hold (it needs about 36 times the file's size,
/// all its agents described with their spans) is checked as far as its first defect and a
/// megabyte past it, with a note that says so (`Loaded::note`).
pub fn load(
    rules: (&str, &[u8]),
    agents_name: &str,
    open: Source<'_>,
    threads: usize,
    levels: &Lints,
) -> io::Result<Loaded> {
    load_keeping(rules, agents_name, open, (threads, levels), None)
}

/// What reading an agents file's lines gave, kept for checking the same file again with
/// rules that changed (the language server, at each edit of the rules beside a large
/// agents file): the lines depend on the rules only through the lint levels and the
/// counters' width, which are compared; the caller keeps it only while the file's text is
/// the same. A check that reuses it makes no lattice.
#[derive(Default)]
pub struct KeptReading(Option<Reading>);

#[derive(Clone)]
struct Reading {
    /// The rules' levels and the head the lines were read with.
    key: (Lints, Head),
    said: Said,
    mends: Mends,
    /// The start states, as [`distinct`] gives them.
    states: Vec<StartState>,
    agents_read: usize,
    /// The file's size.
    size: u64,
}

/// [`load`], reusing the reading of the agents file `kept` holds when it was made with
/// the same levels and width, and keeping it otherwise (a reading reused makes no
/// lattice: `Loaded::lattice` is `None`).
pub fn load_keeping(
    rules: (&str, &[u8]),
    agents_name: &str,
    open: Source<'_>,
    (threads, levels): (usize, &Lints),
    kept: Option<&mut KeptReading>,
) -> io::Result<Loaded> {
    let started = Instant::now();
    let declined = match fast(rules, agents_name, open, (threads, levels), kept)? {
        Ok(l) => return Ok(l),
        Err(d) => d,
    };
    let size = match open.size() {
        Some(s) => s,
        None => io::copy(&mut open.open()?, &mut io::sink())?,
    };
    let need = size.saturating_mul(CHECK_BYTES_PER_BYTE);
    let room = available_memory().unwrap_or(u64::MAX);
    if need > room {
        return too_large(
            (rules, levels),
            agents_name,
            open,
            declined,
            (size, need, room),
            started,
        );
    }
    let mut bytes = Vec::new();
    open.open()?.read_to_end(&mut bytes)?;
    let read = started.elapsed();
    let t = Instant::now();
    let mut checked = check_with(
        Input {
            name: rules.0,
            bytes: rules.1,
        },
        Some(Input {
            name: agents_name,
            bytes: &bytes,
        }),
        None,
        levels,
    );
    drop(bytes);
    // The description of every agent is let go once the lattice holds them.
    let width = checked.lints.width();
    let lattice = checked.config.take().map(|c| {
        let mut lat = Lattice::new(&c);
        lat.set_width(width);
        lat
    });
    Ok(Loaded {
        checked,
        lattice,
        note: None,
        read,
        check: t.elapsed(),
        streamed: false,
    })
}

/// A size in GB, or in MB below a gigabyte, with one decimal.
fn gb(b: u64) -> String {
    if b >= 1_000_000_000 {
        format!("{:.1} GB", b as f64 / 1e9)
    } else {
        format!("{:.1} MB", b as f64 / 1e6)
    }
}

/// The checker's verdict on a file too large for it (see [`load`]): the file's first part
/// checked, or an error naming the agents the lattice found wrong.
fn too_large(
    (rules, levels): ((&str, &[u8]), &Lints),
    agents_name: &str,
    open: Source<'_>,
    declined: Declined,
    (size, need, room): (u64, u64, u64),
    started: Instant,
) -> io::Result<Loaded> {
    let why = format!(
        "`{agents_name}` ({}) is too large to be checked whole here (that takes about {}; {} are free)",
        gb(size),
        gb(need),
        gb(room)
    );
    let first_part = |upto: u64| -> io::Result<Vec<u8>> {
        let mut bytes = Vec::new();
        open.open()?.take(upto).read_to_end(&mut bytes)?;
        // Whole lines only.
        if (bytes.len() as u64) == upto {
            let end = memchr::memrchr(b'\n', &bytes).map_or(0, |p| p + 1);
            bytes.truncate(end);
        }
        Ok(bytes)
    };
    let checked_part = |bytes: &[u8]| {
        check_with(
            Input {
                name: rules.0,
                bytes: rules.1,
            },
            Some(Input {
                name: agents_name,
                bytes,
            }),
            None,
            levels,
        )
    };
    let (checked, note) = match declined {
        Declined::Head | Declined::Line(_) => {
            let at = match declined {
                Declined::Line(at) => at,
                _ => 0,
            };
            let bytes = first_part(at + CHECKED_AFTER)?;
            let lines = bytecount_lines(&bytes);
            let c = checked_part(&bytes);
            (
                c,
                format!("note: only its first {lines} lines were checked: {why}; fix what is said above and check it again"),
            )
        }
    };
    Ok(Loaded {
        checked,
        lattice: None,
        note: Some(note),
        read: started.elapsed(),
        check: Duration::ZERO,
        streamed: false,
    })
}

/// The number of lines in `bytes` (a last line without its end counts).
fn bytecount_lines(bytes: &[u8]) -> usize {
    let n = memchr::memchr_iter(b'\n', bytes).count();
    n + (bytes.last().is_some_and(|&b| b != b'\n')) as usize
}

/// An agent's line, found in its file.
#[derive(Default, Clone)]
struct AgentLine {
    /// 1-based.
    number: u64,
    /// Where it starts (in the decompressed text).
    at: u64,
    /// With its line end.
    text: Vec<u8>,
}

/// The lines of the agents with these ids (ids count the agent lines: not blank, not a
/// comment, not the `U` line), in the order given; read until the last of them.
fn agent_lines(open: Source<'_>, ids: &[u32]) -> io::Result<Vec<AgentLine>> {
    Ok(find_lines(open, false, &[], ids, &[])?.1)
}

/// Lines of an agents file found again, read until the last of them: those that start at
/// `offsets`, and those of the agents with the ids `ids` (ids count the agent lines: not
/// blank, not a comment, not the `U` line, and not in the runs `not_agents`, ascending),
/// each in the order given. `with_context`: the lines before
/// and after those found too, after those at `offsets` (for the excerpt of the file).
fn find_lines(
    open: Source<'_>,
    with_context: bool,
    offsets: &[u64],
    ids: &[u32],
    not_agents: &[(u64, u32)],
) -> io::Result<(Vec<AgentLine>, Vec<AgentLine>)> {
    let mut at_offsets = vec![AgentLine::default(); offsets.len()];
    let mut context = Vec::new();
    let mut found = vec![AgentLine::default(); ids.len()];
    let last = ids.iter().copied().max();
    let last_offset = offsets.iter().copied().max();
    let mut runs = not_agents.iter().copied().peekable();
    // Lines of the current run still to pass.
    let mut skipping = 0u32;
    let sorted = |v: Vec<(u64, usize)>| {
        let mut v = v;
        v.sort_unstable();
        v
    };
    let by_offset = sorted(offsets.iter().enumerate().map(|(k, &o)| (o, k)).collect());
    let by_id = sorted(
        ids.iter()
            .enumerate()
            .map(|(k, &i)| (i as u64, k))
            .collect(),
    );
    let mut by_offset = by_offset.iter().peekable();
    let mut by_id = by_id.iter().peekable();
    // The line before the last found, and whether the line after it is wanted: a label on
    // each of two lines with one between shows that one too.
    let mut prev = AgentLine::default();
    let mut after = false;
    let (mut line, mut id) = (0u64, 0u32);
    let mut r = open.open()?;
    let mut w = Window {
        buf: Vec::new(),
        len: 0,
        eof: false,
    };
    // The offset in the file of the window's first byte.
    let mut base = 0u64;
    'read: loop {
        let want = w.len + CHUNK;
        w.fill(&mut *r, want)?;
        let upto = w.whole();
        let bytes = &w.bytes()[..upto];
        let mut i = 0;
        while i < upto {
            let wanted = last.is_some_and(|l| id <= l)
                || last_offset.is_some_and(|l| base + i as u64 <= l)
                || after;
            if !wanted {
                break 'read;
            }
            let e = memchr::memchr(b'\n', &bytes[i..]).map_or(upto, |p| i + p + 1);
            let raw = &bytes[i..e];
            let (start, end) = (base + i as u64, base + e as u64);
            i = e;
            line += 1;
            let here = || AgentLine {
                number: line,
                at: start,
                text: raw.to_vec(),
            };
            if std::mem::take(&mut after) {
                context.push(here());
            }
            let (offsets_before, ids_before) = (by_offset.len(), by_id.len());
            // An offset within the line (after its leading blanks, say) finds it.
            while let Some(&(_, k)) = by_offset.next_if(|&&(o, _)| o < end.max(start + 1)) {
                at_offsets[k] = here();
            }
            // A line is significant as `significant_lines` has it: not blank, not a comment.
            let text = raw.strip_suffix(b"\n").unwrap_or(raw);
            let text = text.strip_suffix(b"\r").unwrap_or(text);
            let text = match memchr::memmem::find(text, b"//") {
                Some(c) => &text[..c],
                None => text,
            };
            let blank = |c: &u8| *c == b' ' || *c == b'\t';
            let significant = text.iter().position(|c| !blank(c));
            let mut skipped = false;
            if let Some(first) = significant {
                while runs.next_if(|&(o, _)| o < start).is_some() {}
                if let Some((_, n)) = runs.next_if(|&(o, _)| o == start) {
                    skipping = n;
                }
                if skipping > 0 {
                    skipping -= 1;
                    skipped = true;
                }
                skipped |= text[first] == b'U';
            }
            let agent = significant.is_some();
            if agent && !skipped {
                while let Some(&(_, k)) = by_id.next_if(|&&(i, _)| i <= id as u64) {
                    found[k] = here();
                }
                id += 1;
            }
            if with_context {
                if (by_offset.len(), by_id.len()) != (offsets_before, ids_before) {
                    context.push(std::mem::take(&mut prev));
                    after = true;
                }
                prev.number = line;
                prev.at = start;
                prev.text.clear();
                prev.text.extend_from_slice(raw);
            }
        }
        if w.eof {
            break;
        }
        w.consume(upto);
        base += upto as u64;
    }
    if with_context {
        at_offsets.append(&mut context);
    }
    Ok((at_offsets, found))
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

/// What the lines the fast reader left said, read as the checker reads them.
#[derive(Clone)]
struct Said {
    /// Their diagnostics that can still be shown, lint levels applied; the others counted.
    shown: latticesim_compiler::Shown,
    /// The errors found (before lint levels: as the checker, which finds the warnings that
    /// follow from the start states only where there is no error, denied warnings aside).
    errors: usize,
    /// Agent lines with an error (agents read, not in the lattice).
    refused: usize,
    /// The lines that are not agents of the lattice, as runs: (where the first starts, how
    /// many significant lines from it are such), ascending.
    not_agents: Vec<(u64, u32)>,
    /// The agents read when the last run was extended (a run goes on while none is).
    run_at: Option<usize>,
}

impl Said {
    fn new(levels: &Lints) -> Said {
        Said {
            shown: latticesim_compiler::Shown::new(levels.shown()),
            errors: 0,
            refused: 0,
            not_agents: Vec::new(),
            run_at: None,
        }
    }

    /// Takes in what the lines after these said.
    fn append(&mut self, mut other: Said) {
        self.shown.absorb(other.shown);
        self.errors += other.errors;
        self.refused += other.refused;
        self.not_agents.append(&mut other.not_agents);
    }

    /// One more line that is not an agent of the lattice, at `at`, with `agents` read.
    fn not_agent(&mut self, at: u64, agents: usize) {
        match self.not_agents.last_mut() {
            Some((_, n)) if self.run_at == Some(agents) => *n += 1,
            _ => self.not_agents.push((at, 1)),
        }
        self.run_at = Some(agents);
    }
}

/// Reads whole lines (`bytes`, which start at offset `at` of the file) into columns: the
/// fast reader, and the lines it leaves checked one at a time (`check`). `Err` with where
/// a line starts that only the checker of the whole file reads (one not UTF-8).
fn read_part(
    bytes: &[u8],
    at: u64,
    (head, check, levels): (&Head, &LineCheck, &Lints),
    out: &mut Columns,
    said: &mut Said,
) -> Result<(), u64> {
    let mut from = 0;
    while from < bytes.len() {
        let k = if check.agentless() {
            0
        } else {
            match read_lines(&bytes[from..], head, out) {
                Ok(()) => return Ok(()),
                Err(k) => k,
            }
        };
        let s = from + k;
        let len = memchr::memchr(b'\n', &bytes[s..]).unwrap_or(bytes.len() - s);
        let line_at = at + s as u64;
        let mut diags = Vec::new();
        match check.line(&bytes[s..s + len], line_at as usize, out, &mut diags) {
            None => return Err(line_at),
            Some(Verdict::Agent | Verdict::Nothing) => {}
            Some(Verdict::Refused) => {
                said.refused += 1;
                said.not_agent(line_at, out.len());
            }
            Some(Verdict::Other) => said.not_agent(line_at, out.len()),
        }
        for d in diags {
            said.errors += d.is_error() as usize;
            if let Some(d) = levels.admit(d) {
                said.shown.push(d, line_at as usize);
            }
        }
        from = s + len + 1;
    }
    out.fill();
    Ok(())
}

/// Reads whole lines (`bytes`, at offset `at` of the file) into columns on up to `threads`
/// threads (cut at line ends), as [`read_part`] does.
fn read_parallel(
    bytes: &[u8],
    at: u64,
    how: (&Head, &LineCheck, &Lints),
    out: &mut Columns,
    threads: usize,
) -> Result<Said, u64> {
    let mut said = Said::new(how.2);
    let parts = threads.min(bytes.len() / BYTES_PER_THREAD).max(1);
    if parts == 1 {
        read_part(bytes, at, how, out, &mut said)?;
        return Ok(said);
    }
    let mut cuts = vec![0];
    for k in 1..parts {
        let at = (bytes.len() * k / parts).max(*cuts.last().expect("one cut"));
        let end = memchr::memchr(b'\n', &bytes[at..]).map_or(bytes.len(), |p| at + p + 1);
        cuts.push(end);
    }
    cuts.push(bytes.len());
    // This thread reads the first piece straight into `out`; the others, read beside it,
    // are appended after.
    let (first, rest) = (&bytes[..cuts[1]], &cuts[1..]);
    let width = how.0.width;
    type Part = (Result<(), u64>, Columns, Said);
    let (done, results): (Result<(), u64>, Vec<Part>) = std::thread::scope(|s| {
        let handles: Vec<_> = rest
            .windows(2)
            .map(|w| {
                let (from, piece) = (w[0], &bytes[w[0]..w[1]]);
                s.spawn(move || {
                    let mut cols = Columns::new(width);
                    let mut said = Said::new(how.2);
                    let done = read_part(piece, at + from as u64, how, &mut cols, &mut said);
                    (done, cols, said)
                })
            })
            .collect();
        let done = read_part(first, at, how, out, &mut said);
        let results = handles
            .into_iter()
            .map(|h| {
                h.join()
                    .unwrap_or_else(|_| (Err(at), Columns::new(width), Said::new(how.2)))
            })
            .collect();
        (done, results)
    });
    done?;
    for (done, cols, part) in results {
        done?;
        out.append(cols);
        said.append(part);
    }
    Ok(said)
}

/// Why the fast path left a file to the checker.
enum Declined {
    /// Its head (or the rules checked against it).
    Head,
    /// The line that starts at this offset (of the decompressed text).
    Line(u64),
}

/// The distinct states of `states`, in order of first appearance, with their first
/// agents (up to `FIXABLE`) and how many agents are in each (no spans yet).
fn distinct(states: &[[u8; 5]]) -> Vec<StartState> {
    use latticesim_compiler::FIXABLE;
    let mut index: std::collections::HashMap<[u8; 5], usize> = Default::default();
    let mut out: Vec<StartState> = Vec::new();
    let mut last: Option<([u8; 5], usize)> = None;
    for (i, s) in states.iter().enumerate() {
        let k = match last {
            Some((l, k)) if l == *s => k,
            _ => *index.entry(*s).or_insert_with(|| {
                out.push(StartState {
                    state: *s,
                    first: i,
                    span: latticesim_grammar::Span { start: 0, end: 0 },
                    count: 0,
                    rest: Vec::new(),
                });
                out.len() - 1
            }),
        };
        let e = &mut out[k];
        e.count += 1;
        if e.count > 1 && e.count <= FIXABLE {
            e.rest
                .push((i, latticesim_grammar::Span { start: 0, end: 0 }));
        }
        last = Some((*s, k));
    }
    out
}

/// The spans of the first agents of the idle start states of `seen` (the others are not
/// quoted), from their lines read again; the lines, for the excerpt of the agents file.
fn quote_idle(
    checked: &Checked,
    open: Source<'_>,
    seen: &mut [StartState],
) -> io::Result<Vec<AgentLine>> {
    let rules = checked.rules.as_ref().expect("a clean head has rules");
    let states: Vec<[u8; 5]> = seen.iter().map(|s| s.state).collect();
    let idle = latticesim_compiler::idle_states(rules, &states);
    if idle.is_empty() {
        return Ok(Vec::new());
    }
    // Per idle state, its first agent, and the others when a fix can edit every one: (the
    // state's index in `seen`, None for the first or the index in its `rest`).
    let mut quoted: Vec<(usize, Option<usize>)> = Vec::new();
    for (k, s) in seen.iter().enumerate() {
        if idle.iter().any(|i| i.state == s.state) {
            quoted.push((k, None));
            if s.count <= latticesim_compiler::FIXABLE {
                quoted.extend((0..s.rest.len()).map(|r| (k, Some(r))));
            }
        }
    }
    let id = |&(k, r): &(usize, Option<usize>)| match r {
        None => seen[k].first as u32,
        Some(r) => seen[k].rest[r].0 as u32,
    };
    let ids: Vec<u32> = quoted.iter().map(id).collect();
    let lines = agent_lines(open, &ids)?;
    for (&(k, r), l) in quoted.iter().zip(&lines) {
        if let Some(a) = parse_line_again(l) {
            let span = l.shift(latticesim_compiler::state_field(&a.agent()));
            match r {
                None => seen[k].span = span,
                Some(r) => seen[k].rest[r].1 = span,
            }
        }
    }
    Ok(lines)
}

/// An agent line read again, parsed on its own (spans from its start).
struct Reparsed {
    text: String,
}

impl Reparsed {
    fn agent(&self) -> latticesim_grammar::ast::AgentLine<'_> {
        let (mut f, _) =
            latticesim_grammar::parse_agents(&self.text, latticesim_grammar::FileId(1));
        f.agents.remove(0)
    }
}

/// The agent of a line found again, when it parses.
fn parse_line_again(l: &AgentLine) -> Option<Reparsed> {
    let text = String::from_utf8_lossy(&l.text).into_owned();
    let (f, _) = latticesim_grammar::parse_agents(&text, latticesim_grammar::FileId(1));
    (!f.agents.is_empty()).then_some(Reparsed { text })
}

impl AgentLine {
    /// A span of the line's own text as a span of the file.
    fn shift(&self, s: latticesim_grammar::Span) -> latticesim_grammar::Span {
        latticesim_grammar::Span {
            start: s.start + self.at as u32,
            end: s.end + self.at as u32,
        }
    }
}

/// The agents file held as its head and these lines (see `Sources::excerpt`), in place of
/// its whole text, beside the rules.
fn excerpt(checked: &mut Checked, (head, name, size): (&[u8], &str, usize), lines: &[&AgentLine]) {
    let head_text = String::from_utf8_lossy(head).into_owned();
    let mut parts: Vec<(usize, usize, String)> = vec![(0, 1, head_text)];
    let mut later: Vec<&AgentLine> = (lines.iter().copied())
        .filter(|l| l.at as usize >= head.len() && l.number > 0)
        .collect();
    later.sort_by_key(|l| l.at);
    later.dedup_by_key(|l| l.at);
    for l in later {
        parts.push((
            l.at as usize,
            l.number as usize,
            String::from_utf8_lossy(&l.text).into_owned(),
        ));
    }
    let mut sources = latticesim_compiler::Sources::new();
    let rid = latticesim_grammar::FileId(0);
    sources.add(checked.sources.name(rid), checked.sources.text(rid));
    let parts: Vec<(usize, usize, &str)> =
        parts.iter().map(|(a, n, t)| (*a, *n, t.as_str())).collect();
    sources.excerpt(name, size, &parts);
    checked.sources = sources;
}

/// The diagnostics of what the lattice mended (agents on one cell, one-sided bonds), as
/// the checker says them, into `shown`; the lines they quote. In the order of the
/// diagnostics, only the first `per_file` can be shown: they are said in full, and of each
/// code the first after them, which stands for the others, counted.
fn mended(
    mends: &Mends,
    (open, dim, levels): (Source<'_>, latticesim_compiler::Dim, &Lints),
    not_agents: &[(u64, u32)],
    shown: &mut latticesim_compiler::Shown,
) -> io::Result<Vec<AgentLine>> {
    use latticesim_compiler::{bond_dropped, bond_made, position_span, shared_cell};
    use latticesim_grammar::Code;
    type Bond = (u32, latticesim_compiler::checked::Dir, Option<u32>);
    #[derive(Clone, Copy)]
    enum Mend {
        Shared(u32, u32),
        Bond(Bond),
    }
    let code = |m: &Mend| match m {
        Mend::Shared(..) => Code::E402,
        Mend::Bond((_, _, Some(_))) => Code::W601,
        Mend::Bond((_, _, None)) => Code::W602,
    };
    // The order of the diagnostics: by line (the column of the agent), then (the bonds of
    // one agent share their span) by code, then as found.
    let key = |m: &Mend, k: usize| match *m {
        Mend::Shared(gone, _) => (gone, code(m), k),
        Mend::Bond((a, ..)) => (mends.column_of(a), code(m), k),
    };
    let bonds: Vec<(u32, Code, usize, Mend)> = {
        let mut v: Vec<_> = (mends.bonds.iter().enumerate())
            .map(|(k, &b)| {
                let m = Mend::Bond(b);
                let (c, code, k) = key(&m, k);
                (c, code, k, m)
            })
            .collect();
        v.sort_by_key(|e| (e.0, e.1, e.2));
        v
    };
    // The bonds held of each kind end before these columns (where one is not held).
    let cut = |kind: usize| mends.first_more[kind].map_or(u32::MAX, |(a, ..)| mends.column_of(a));
    let allowed = |c: Code| levels.allows(c);
    let cutoff = [(Code::W601, 0), (Code::W602, 1)]
        .iter()
        .filter(|(c, _)| !allowed(*c))
        .map(|&(_, kind)| cut(kind))
        .min()
        .unwrap_or(u32::MAX);
    let per_file = levels.shown();
    // When the mends are all the file's diagnostics, those after the first `per_file`
    // need not be found (their order among themselves is that of their agents): else
    // the first of each code after them is, to place its code among the others in the
    // count of what is not shown.
    let alone = shown.is_empty();
    let mut full: Vec<Mend> = Vec::new();
    let mut reps: Vec<Code> = Vec::new();
    // The first of each code after them, by the column of its agent, when not found.
    let mut firsts: Vec<(Code, u32)> = Vec::new();
    let (mut si, mut bi, mut index) = (0, 0, 0usize);
    loop {
        let s = mends.shared.get(si).map(|&(g, f)| Mend::Shared(g, f));
        let b = bonds.get(bi).filter(|e| e.0 < cutoff).map(|e| e.3);
        let next = match (s, b) {
            (Some(sm), Some(bm)) if key(&sm, 0) < key(&bm, 0) => {
                si += 1;
                sm
            }
            (_, Some(bm)) => {
                bi += 1;
                bm
            }
            (Some(sm), None) => {
                si += 1;
                sm
            }
            (None, None) => break,
        };
        let c = code(&next);
        if allowed(c) {
            continue;
        }
        if index < per_file {
            full.push(next);
        } else if !reps.contains(&c) {
            reps.push(c);
            if alone {
                firsts.push((c, key(&next, 0).0));
            } else {
                full.push(next);
            }
        }
        index += 1;
        if index >= per_file && reps.len() == 3 {
            break;
        }
    }
    // Past the cut every bond stands after the first `per_file`: of a kind with none said
    // yet past them, its first held there, or else its first not held, stands for it.
    for (c, kind) in [(Code::W601, 0), (Code::W602, 1)] {
        if allowed(c) || reps.contains(&c) {
            continue;
        }
        let held = (bonds.iter())
            .find(|e| e.0 >= cutoff && e.1 == c)
            .map(|e| e.3);
        if let Some(m) = held.or(mends.first_more[kind].map(Mend::Bond)) {
            reps.push(c);
            if alone {
                firsts.push((c, key(&m, 0).0));
            } else {
                full.push(m);
            }
        }
    }
    // How many of each code there are, and how many are said in full.
    let made = mends.bonds.iter().filter(|b| b.2.is_some()).count();
    let total = |c: Code| match c {
        Code::E402 => mends.shared.len(),
        Code::W601 => made + mends.more[0],
        _ => mends.bonds.len() - made + mends.more[1],
    };
    let mut cols: Vec<u32> = Vec::new();
    for m in &full {
        match *m {
            Mend::Shared(gone, first) => cols.extend([gone, first]),
            Mend::Bond((a, _, b)) => {
                cols.push(mends.column_of(a));
                cols.extend(b.map(|b| mends.column_of(b)));
            }
        }
    }
    let offsets: Vec<u64> = shown.lines().iter().map(|&l| l as u64).collect();
    let (mut at_offsets, lines) = find_lines(open, true, &offsets, &cols, not_agents)?;
    let agents: Vec<Option<Reparsed>> = lines.iter().map(parse_line_again).collect();
    let line_of = |col: u32| {
        let k = cols
            .iter()
            .position(|&c| c == col)
            .expect("a line looked for");
        (&lines[k], agents[k].as_ref())
    };
    let aid = latticesim_grammar::FileId(1);
    let pos_span = |col: u32| {
        let (l, a) = line_of(col);
        let at = latticesim_grammar::Span::new(l.at as usize, l.at as usize);
        a.map_or(at, |a| l.shift(position_span(&a.agent())))
    };
    let attach_or_pos = |col: u32| {
        let (l, a) = line_of(col);
        match a.and_then(|a| latticesim_compiler::attach_span(&a.agent())) {
            Some(s) => l.shift(s),
            None => pos_span(col),
        }
    };
    let mut said = [0usize; 3];
    let mut rep: Vec<(Code, latticesim_compiler::diagnostics::Key, Option<bool>)> = Vec::new();
    for m in &full {
        let col = key(m, 0).0;
        let d = match *m {
            Mend::Shared(gone, first) => {
                let pos = line_of(gone).1.map_or([0; 3], |a| {
                    let mut p = [0i32; 3];
                    for (i, c) in a.agent().pos.iter().enumerate().take(3) {
                        p[i] = c.node as i32;
                    }
                    p
                });
                shared_cell(
                    aid,
                    (pos, dim),
                    (pos_span(gone), mends.id_of(gone) as usize),
                    (pos_span(first), mends.id_of(first) as usize),
                )
            }
            Mend::Bond((a, d, None)) => bond_dropped(aid, a as usize, d, attach_or_pos(col)),
            Mend::Bond((a, d, Some(b))) => bond_made(
                aid,
                (a as usize, attach_or_pos(col)),
                d,
                (b as usize, pos_span(mends.column_of(b))),
            ),
        };
        let c = code(m);
        said[[Code::E402, Code::W601, Code::W602]
            .iter()
            .position(|&x| x == c)
            .expect("a code of mends")] += 1;
        let k = latticesim_compiler::diagnostics::key(&d);
        let line = line_of(col).0.at as usize;
        let d = levels.admit(d);
        // The last of its code said in full stands for the others.
        rep.retain(|r| r.0 != c);
        rep.push((c, k, d.as_ref().map(|d| d.is_error())));
        if let Some(d) = d {
            shown.push(d, line);
        }
    }
    for (i, c) in [Code::E402, Code::W601, Code::W602].into_iter().enumerate() {
        let rest = total(c) - said[i];
        if rest == 0 || allowed(c) {
            continue;
        }
        let (k, error) = match firsts.iter().find(|f| f.0 == c) {
            // After every diagnostic made, in the order of their agents.
            Some(&(_, col)) => ((true, aid, u32::MAX, col, c), levels.is_error(c)),
            None => {
                let (_, k, verdict) = *rep.iter().find(|r| r.0 == c).expect("one is said in full");
                let Some(error) = verdict else {
                    continue;
                };
                (k, error)
            }
        };
        shown.hide(c, error, k, rest);
    }
    at_offsets.extend(lines);
    Ok(at_offsets)
}

/// The fast path: `Err` when the checker must read the file.
fn fast(
    rules: (&str, &[u8]),
    agents_name: &str,
    open: Source<'_>,
    (threads, levels): (usize, &Lints),
    kept: Option<&mut KeptReading>,
) -> io::Result<Result<Loaded, Declined>> {
    let started = Instant::now();
    let mut r = open.open()?;
    let mut w = Window {
        buf: Vec::new(),
        len: 0,
        eof: false,
    };
    w.fill(&mut *r, 1 << 20)?;
    // The head: the `U` line and the first agent line; when the first agent lines have
    // errors, the head made of the first that parses (it decides the dimension), and the
    // lines before it read with the others.
    // The head, as the rules are checked against it: the `U` line and the position of
    // the first line that parses as an agent (which decides the dimension); the rest of
    // that line, and the lines before it, are read with the others. When no line parses
    // as an agent in the first bytes, the head is the `U` line (or nothing), the rules
    // decide the dimension, and a later line that parses as an agent leaves the file to
    // the checker.
    let first = &w.bytes()[..w.whole()];
    let (mut head, cleaned, agentless) = match clean_head(first) {
        Some(Cleaned::Head(cleaned, from)) => {
            let Some(h) = read_head(&cleaned) else {
                return Ok(Err(Declined::Head));
            };
            (
                Head {
                    agents_at: from,
                    ..h
                },
                cleaned,
                None,
            )
        }
        Some(c @ (Cleaned::Universe(end) | Cleaned::NoAgent(end))) => {
            // Dimension and universe are set below, from the `U` line or the rules.
            let h = Head {
                dim: latticesim_compiler::Dim::Two,
                universe: None,
                agents_at: end,
                end,
                width: latticesim_compiler::checked::Width::W16,
            };
            let none = matches!(c, Cleaned::NoAgent(_));
            (h, first[..end].to_vec(), Some(none))
        }
        None => return Ok(Err(Declined::Head)),
    };
    let head_bytes = w.bytes()[..head.end].to_vec();
    let clean = &cleaned[..];
    let t = Instant::now();
    let Some(mut checked) = check_with_head(
        Input {
            name: rules.0,
            bytes: rules.1,
        },
        Input {
            name: agents_name,
            bytes: clean,
        },
        levels,
    ) else {
        return Ok(Err(Declined::Head));
    };
    let check_time = t.elapsed();
    // The agents' counters are read in the rules' width.
    head.width = checked.lints.width();
    let check = match agentless {
        Some(none) => LineCheck::without_agents(clean, &checked.dim, head.width, none),
        None => LineCheck::new(clean, head.width),
    };
    let Some(check) = check else {
        return Ok(Err(Declined::Head));
    };
    if agentless.is_some() {
        head = check.head(head.end);
    }
    let key = (checked.lints.clone(), head);
    let reused = (kept.as_deref())
        .and_then(|k| k.0.as_ref())
        .filter(|r| r.key == key)
        .cloned();
    let (reading, lat) = match reused {
        Some(r) => (r, None),
        None => {
            let lines = (&head, &check, &checked.lints);
            let (read, lat) = match read_agents(&mut w, &mut *r, lines, open, threads)? {
                Ok(read) => read,
                Err(d) => return Ok(Err(d)),
            };
            if let Some(k) = kept {
                k.0 = Some(read.clone());
            }
            (read, Some(lat))
        }
    };
    let lints = &checked.lints;
    let Reading {
        said,
        mends,
        states,
        agents_read,
        size: base,
        ..
    } = reading;
    // As the checker: the warnings that follow from the start states where there is no
    // error (agents on one cell are one), then the mends in their place.
    let Said {
        mut shown,
        errors,
        refused,
        not_agents,
        ..
    } = said;
    // The errors found before lint levels, the rules' among them.
    let errors = errors + checked.errors() + mends.shared.len();
    let agents_read = agents_read + refused;
    let mut quoted: Vec<AgentLine> = Vec::new();
    if errors == 0 {
        let mut seen = states;
        quoted.extend(quote_idle(&checked, open, &mut seen)?);
        let more =
            latticesim_compiler::states_warnings_of(&checked, latticesim_grammar::FileId(1), &seen);
        for d in more {
            let Some(d) = checked.lints.admit(d) else {
                continue;
            };
            if d.primary.file == latticesim_grammar::FileId(1) {
                let line = (quoted.iter())
                    .filter(|l| l.at <= d.primary.span.start as u64)
                    .map(|l| l.at)
                    .max()
                    .unwrap_or(0);
                shown.push(d, line as usize);
            } else {
                checked.diags.push(d);
            }
        }
    }
    if !mends.shared.is_empty() || !mends.bonds.is_empty() || !shown.lines().is_empty() {
        let lines = mended(&mends, (open, head.dim, lints), &not_agents, &mut shown)?;
        quoted.extend(lines);
    }
    // The rules' diagnostics capped as the checker caps them, with those just found.
    latticesim_compiler::cap_checked(&mut checked);
    let (file_diags, hidden) = shown.finish();
    checked.diags.extend(file_diags.into_iter().map(|(d, _)| d));
    checked.not_shown.extend(hidden);
    latticesim_compiler::diagnostics::sort(&mut checked.diags);
    // The head as written (the rules were checked against it made clean), and the lines
    // quoted.
    let refs: Vec<&AgentLine> = quoted.iter().collect();
    excerpt(
        &mut checked,
        (&head_bytes, agents_name, base as usize),
        &refs,
    );
    checked.agent_count = agents_read;
    checked.config = None;
    // A denied warning fails the check, as on the checker's path: nothing to run.
    let failed = checked.errors() > 0;
    if failed {
        checked.rules = None;
    }
    Ok(Ok(Loaded {
        checked,
        lattice: lat.filter(|_| !failed),
        note: None,
        read: started.elapsed() - check_time,
        check: check_time,
        streamed: true,
    }))
}

/// Reads the agent lines after the head (the window holds the file's first bytes, the
/// reader the rest) into a lattice: what they said, what the lattice mended, the start
/// states. `Ok(Err(..))` when a line is left to the checker.
fn read_agents(
    w: &mut Window,
    r: &mut dyn Read,
    (head, check, lints): (&Head, &LineCheck, &Lints),
    open: Source<'_>,
    threads: usize,
) -> io::Result<Result<(Reading, Lattice), Declined>> {
    let mut cols = Columns::new(head.width);
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
    // What the lines the fast reader leaves say: the diagnostics that can still be shown,
    // and counts.
    let mut said = Said::new(lints);
    let mut from = head.agents_at;
    // The offset in the file of the window's first byte.
    let mut base = 0u64;
    loop {
        let upto = w.whole();
        if upto > from {
            let part = read_parallel(
                &w.bytes()[from..upto],
                base + from as u64,
                (head, check, lints),
                &mut cols,
                threads,
            );
            match part {
                Ok(p) => said.append(p),
                Err(at) => return Ok(Err(Declined::Line(at))),
            }
        }
        if w.eof {
            base += upto as u64;
            break;
        }
        w.consume(upto);
        base += upto as u64;
        from = 0;
        // A line longer than a chunk makes the buffer grow until its end is in it.
        let want = w.len + CHUNK;
        w.fill(&mut *r, want)?;
    }
    cols.fill();
    let agents_read = cols.len();
    let keep = lints.shown() + 1;
    let (lat, mends) = Lattice::from_columns_mended(head.dim, head.universe, cols, keep);
    let states = distinct(&lat.state);
    let reading = Reading {
        key: (lints.clone(), *head),
        said,
        mends,
        states,
        agents_read,
        size: base,
    };
    Ok(Ok((reading, lat)))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A reading of the agents file kept and used again with other rules (the language
    /// server, at each edit of the rules) gives the diagnostics a fresh reading gives; it
    /// is used again only when the rules' levels and width are the same.
    #[test]
    fn a_kept_reading_checks_as_a_fresh_one() {
        let clean = "0,0 SFALL0 C00 3\n1,0 SFALL0 C00 3 C01 7\n1,1 SREST0\n2,5 SIDLE0\n";
        let faulty = "0,0 SFALL0 C00 3\n1,0 SFALL0 C00 3 C01 70000\n1,0 SREST0\n2,5 SIDLE0 N1\n3,3 SFALL0 xx\n4,4 SFAL0\n";
        let fall = "fall\n1\nSFALL0 N***0 >C00 0000\nP0,-1 C00 - C00 0001\n";
        let rules = [
            fall.to_string(),
            format!("{fall}\nrest\n1\nSREST0\nSIDLE0\n"),
            format!("// latticesim: counters 32\n{fall}"),
            format!("// latticesim: allow W603\n{fall}"),
            "fall\n1\nSFAL00 N***0\nP0,-1\n".to_string(),
        ];
        for agents in [clean, faulty] {
            let mut kept = KeptReading::default();
            let mut reused = 0;
            for r in rules.iter().chain(&rules) {
                let load = |kept: Option<&mut KeptReading>| {
                    let rules = ("rules.txt", r.as_bytes());
                    let source = Source::Bytes(agents.as_bytes());
                    load_keeping(rules, "agents.txt", source, (1, &Lints::new()), kept).unwrap()
                };
                let fresh = load(None);
                let again = load(Some(&mut kept));
                let (a, b) = (&fresh.checked, &again.checked);
                assert_eq!(a.diags, b.diags, "{r}\n{agents}");
                assert_eq!((a.errors(), a.agent_count), (b.errors(), b.agent_count));
                reused += usize::from(fresh.lattice.is_some() && again.lattice.is_none());
            }
            if agents == clean {
                assert!(reused >= 2, "a reading used again");
            }
        }
    }
}
