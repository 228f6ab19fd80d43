//! Agents files in and out: compressed or not, read on several threads straight into the
//! lattice's columns when the file is clean (the diagnostic path reads it when not), and
//! written from the columns through a buffered, streaming writer.
//!
//! This module is the one place that decides which path reads an agents file: the fast
//! reader of `latticesim_compiler::fast_agents` first; when it (or the lattice's check of
//! cells and bonds, or the rules checked against the file's head) says no, the whole pair
//! is read and checked by `latticesim_compiler::check`, whose diagnostics are the project's
//! one source of truth. The warnings that follow from the states agents start in (W503,
//! W603) are found on the fast path from the states read, with the checker's own code
//! (`states_warnings_of`); the first agent of each idle state is quoted from its line, read
//! again, and the file is held as its head and those lines (`Sources::excerpt`).

use crate::output::say;
use latticesim_compiler::fast_agents::{check_with_head, read_head, read_lines, Head};
use latticesim_compiler::lints::Lints;
use latticesim_compiler::{check_with, Checked, Columns, Input, StartState};
use latticesim_runtime::{Defect, Lattice};
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
/// A file the checker cannot hold (it needs about 36 times the file's size, all its agents
/// described with their spans) is checked as far as its first defect and a megabyte past
/// it, with a note that says so (`Loaded::note`); agents on one cell, or a bond declared on
/// one side only, in such a file are an error that names the agents and their lines.
pub fn load(
    rules: (&str, &[u8]),
    agents_name: &str,
    open: Source<'_>,
    threads: usize,
    levels: &Lints,
) -> io::Result<Loaded> {
    let started = Instant::now();
    let declined = match fast(rules, agents_name, open, threads, levels)? {
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
        Declined::Lattice(d) => {
            // The head's verdict (rules and dimension), then the agents' lines.
            let head = first_part(1 << 20)?;
            let c = checked_part(&head[..head_end(&head)]);
            let agents: Vec<u32> = match d {
                Defect::SharedCell { first, second, .. } => vec![first, second],
                Defect::OneSidedBond { agent, .. } => vec![agent],
            };
            let lines: Vec<u64> = (agent_lines(open, &agents)?.into_iter())
                .map(|l| l.number)
                .collect();
            let at = |k: usize| format!("{agents_name}:{}", lines[k]);
            let what = match d {
                Defect::SharedCell {
                    first, second, pos, ..
                } => format!(
                    "error: two agents on the cell {},{}{}: agent {first} ({}) and agent {second} ({})",
                    pos[0],
                    pos[1],
                    if c.dim.dim.coords() == 3 { format!(",{}", pos[2]) } else { String::new() },
                    at(0),
                    at(1)
                ),
                Defect::OneSidedBond { agent, dir } => format!(
                    "error: agent {agent} ({}) declares a bond towards {} that no agent there declares back (the checker would warn and make or drop it; here it is an error)",
                    at(0),
                    dir.letter()
                ),
            };
            (c, format!("{what}\nnote: {why}"))
        }
    };
    Ok(Loaded {
        checked,
        lattice: None,
        note: Some(note),
        read: started.elapsed(),
        check: Duration::ZERO,
    })
}

/// The number of lines in `bytes` (a last line without its end counts).
fn bytecount_lines(bytes: &[u8]) -> usize {
    let n = memchr::memchr_iter(b'\n', bytes).count();
    n + (bytes.last().is_some_and(|&b| b != b'\n')) as usize
}

/// The length of the head of an agents file's first bytes (through its first agent line),
/// as the fast reader finds it; all of them when it finds none.
fn head_end(bytes: &[u8]) -> usize {
    read_head(bytes).map_or(bytes.len(), |h| h.end)
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
    use std::io::BufRead;
    let mut found = vec![AgentLine::default(); ids.len()];
    let mut at = 0u64;
    let mut r = io::BufReader::with_capacity(1 << 20, open.open()?);
    let (mut line, mut id) = (0u64, 0u32);
    let mut buf = Vec::new();
    let last = ids.iter().copied().max().unwrap_or(0);
    while id <= last {
        buf.clear();
        if r.read_until(b'\n', &mut buf)? == 0 {
            break;
        }
        line += 1;
        let start = at;
        at += buf.len() as u64;
        let text = buf.split(|&b| b == b'\n').next().unwrap_or(&[]);
        let text = match memchr::memmem::find(text, b"//") {
            Some(c) => &text[..c],
            None => text,
        };
        let t = text.trim_ascii();
        if t.is_empty() || t[0] == b'U' {
            continue;
        }
        for (k, &want) in ids.iter().enumerate() {
            if want == id {
                found[k] = AgentLine {
                    number: line,
                    at: start,
                    text: buf.clone(),
                };
            }
        }
        id += 1;
    }
    Ok(found)
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

/// Reads whole lines into columns on up to `threads` threads (cut at line ends): `Err`
/// with where the first line that needs the checker starts.
fn read_parallel(
    bytes: &[u8],
    head: &Head,
    out: &mut Columns,
    threads: usize,
) -> Result<(), usize> {
    let parts = threads.min(bytes.len() / BYTES_PER_THREAD).max(1);
    if parts == 1 {
        return read_lines(bytes, head, out);
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
    type Part = (Result<(), usize>, Columns);
    let (done, results): (Result<(), usize>, Vec<Part>) = std::thread::scope(|s| {
        let handles: Vec<_> = rest
            .windows(2)
            .map(|w| {
                let (from, piece) = (w[0], &bytes[w[0]..w[1]]);
                s.spawn(move || {
                    let mut cols = Columns::new(head.width);
                    let done = read_lines(piece, head, &mut cols).map_err(|at| from + at);
                    (done, cols)
                })
            })
            .collect();
        let done = read_lines(first, head, out);
        let results = handles
            .into_iter()
            .map(|h| {
                h.join()
                    .unwrap_or_else(|_| (Err(0), Columns::new(head.width)))
            })
            .collect();
        (done, results)
    });
    done?;
    for (done, cols) in results {
        done?;
        out.append(cols);
    }
    Ok(())
}

/// Why the fast path left a file to the checker.
enum Declined {
    /// Its head (or the rules checked against it).
    Head,
    /// The line that starts at this offset (of the decompressed text).
    Line(u64),
    /// Its agents, read, do not make a lattice as they are.
    Lattice(Defect),
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
/// quoted), from their lines read again, and the agents file held as its head and those
/// lines (see `Sources::excerpt`), in place of the head alone.
fn quote_idle(
    checked: &mut Checked,
    (open, head, name, size): (Source<'_>, &[u8], &str, usize),
    seen: &mut [StartState],
) -> io::Result<()> {
    let rules = checked.rules.as_ref().expect("a clean head has rules");
    let states: Vec<[u8; 5]> = seen.iter().map(|s| s.state).collect();
    let idle = latticesim_compiler::idle_states(rules, &states);
    if idle.is_empty() {
        return Ok(());
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
    let aid = latticesim_grammar::FileId(1);
    for (&(k, r), l) in quoted.iter().zip(&lines) {
        let text = String::from_utf8_lossy(&l.text);
        let (f, _) = latticesim_grammar::parse_agents(&text, aid);
        if let Some(a) = f.agents.first() {
            let span = latticesim_compiler::state_field(a);
            let span = latticesim_grammar::Span {
                start: span.start + l.at as u32,
                end: span.end + l.at as u32,
            };
            match r {
                None => seen[k].span = span,
                Some(r) => seen[k].rest[r].1 = span,
            }
        }
    }
    let head_text = String::from_utf8_lossy(head).into_owned();
    let mut parts: Vec<(usize, usize, String)> = vec![(0, 1, head_text)];
    let mut later: Vec<&AgentLine> = lines
        .iter()
        .filter(|l| l.at as usize >= head.len())
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
    Ok(())
}

/// The fast path: `Err` when the checker must read the file.
fn fast(
    rules: (&str, &[u8]),
    agents_name: &str,
    open: Source<'_>,
    threads: usize,
    levels: &Lints,
) -> io::Result<Result<Loaded, Declined>> {
    let started = Instant::now();
    let mut r = open.open()?;
    let mut w = Window {
        buf: Vec::new(),
        len: 0,
        eof: false,
    };
    w.fill(&mut *r, 1 << 20)?;
    let Some(mut head) = read_head(&w.bytes()[..w.whole()]) else {
        return Ok(Err(Declined::Head));
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
        levels,
    ) else {
        return Ok(Err(Declined::Head));
    };
    let check_time = t.elapsed();
    let head_bytes = w.bytes()[..head.end].to_vec();
    // The agents' counters are read in the rules' width.
    head.width = checked.lints.width();
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
    let mut from = head.agents_at;
    // The offset in the file of the window's first byte.
    let mut base = 0u64;
    loop {
        let upto = w.whole();
        if upto > from {
            if let Err(at) = read_parallel(&w.bytes()[from..upto], &head, &mut cols, threads) {
                return Ok(Err(Declined::Line(base + (from + at) as u64)));
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
    drop(w);
    cols.fill();
    let n = cols.len();
    let lat = match Lattice::from_columns(head.dim, head.universe, cols) {
        Ok(lat) => lat,
        Err(d) => return Ok(Err(Declined::Lattice(d))),
    };
    let mut seen = distinct(&lat.state);
    quote_idle(
        &mut checked,
        (open, &head_bytes, agents_name, base as usize),
        &mut seen,
    )?;
    let mut more =
        latticesim_compiler::states_warnings_of(&checked, latticesim_grammar::FileId(1), &seen);
    checked.lints.apply(&mut more);
    checked.diags.extend(more);
    latticesim_compiler::diagnostics::sort(&mut checked.diags);
    checked.agent_count = n;
    checked.config = None;
    // A denied warning fails the check, as on the checker's path: nothing to run.
    let failed = checked.errors() > 0;
    if failed {
        checked.rules = None;
    }
    Ok(Ok(Loaded {
        checked,
        lattice: (!failed).then_some(lat),
        note: None,
        read: started.elapsed() - check_time,
        check: check_time,
    }))
}
