//! Exact checkpoints: the whole state a later step depends on, as a versioned, checksummed
//! binary snapshot, so that a run resumed from one ends exactly as the run without a stop.
//!
//! What is kept: the lattice (positions, states, bonds, every counter column, the numeric
//! and text messages received in the last step, which the next step reads), the statistics
//! (so the step count and every sum go on), the options that change results (the order and
//! `--static-first`) and a hash of the compiled rules. Everything else an [`Engine`] holds
//! (dispatch tables, selections, pools) is made again from these.
//!
//! The format (all numbers little-endian): the magic `LSIMCKPT`, the format version (u32),
//! the rules' hash (u64), the order (u8), static-first (u8), the dimension's coordinates
//! (u8), the universe (u8 flag, then 6 i32), the agent count (u64), the width of counters
//! (u8: 16 or 32), a CRC-32 of the header so far; per agent its
//! coordinates (i32 each), state (5 bytes), bonds (u8); the counters with columns (u8 count,
//! then per column its number (u8) and a value per agent, i16 or i32 by the width); the
//! numeric slots with inboxes (u8 count, per slot its number (u8) and per direction a value
//! per agent, as counters);
//! text inboxes (u8 flag, then per agent a byte of directions received and 5 bytes per
//! direction); the statistics (steps u64, quiescent u8, firings per rule u64 after a u32
//! count, moves, carried, swaps, sent, delivered, dropped u64, records as a u32 count of (kind name
//! length u8, name, count u64)); and last a CRC-32 of every byte before it.

use crate::engine::{Engine, Options, Order, Stats};
use crate::lattice::LatticeBuilder;
use crate::record::RecordKind;
use crate::Lattice;
use latticesim_vm::model::{Bounds, Column, Dim, Width};
use latticesim_vm::{Program, Verified};
use std::io::{self, Read, Write};

/// The first bytes of every checkpoint.
const MAGIC: &[u8; 8] = b"LSIMCKPT";
/// The format written; only it is read (version 2 added the carried agents, version 3 the
/// width of counters).
pub const VERSION: u32 = 3;
/// Agents handled at a time.
const BLOCK: usize = 1 << 16;

/// Why a checkpoint cannot be resumed.
#[derive(Debug)]
pub enum CheckpointError {
    /// It could not be read.
    Io(io::Error),
    /// It does not start as a checkpoint does.
    NotACheckpoint,
    /// It is of another format version.
    Version(u32),
    /// It ends before its end.
    Truncated,
    /// Its checksum does not match its content.
    Corrupt,
    /// It was made with other rules.
    OtherRules,
    /// It was made with other options that change results.
    OtherOptions(String),
    /// Its content is not a possible state.
    Invalid(String),
}

impl std::fmt::Display for CheckpointError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            CheckpointError::Io(e) => write!(f, "{e}"),
            CheckpointError::NotACheckpoint => write!(f, "it is not a latticesim checkpoint"),
            CheckpointError::Version(v) => write!(
                f,
                "it is a checkpoint of format version {v}; this latticesim reads version {VERSION}"
            ),
            CheckpointError::Truncated => {
                write!(f, "it is truncated (it ends before its checksum)")
            }
            CheckpointError::Corrupt => {
                write!(
                    f,
                    "it is corrupted (its checksum does not match its content)"
                )
            }
            CheckpointError::OtherRules => {
                write!(f, "it was made with other rules than the rules file given")
            }
            CheckpointError::OtherOptions(o) => write!(f, "it was made with {o}; give the same"),
            CheckpointError::Invalid(why) => write!(f, "its content is not a valid state: {why}"),
        }
    }
}

impl std::error::Error for CheckpointError {}

/// A hash of a compiled program (FNV-1a over its full description): the same for the same
/// rules, whatever their layout or comments.
pub fn rules_hash(prog: &Program) -> u64 {
    let text = format!("{prog:?}");
    text.bytes().fold(0xcbf2_9ce4_8422_2325u64, |h, b| {
        (h ^ b as u64).wrapping_mul(0x0000_0100_0000_01b3)
    })
}

/// A writer that keeps the CRC-32 of what passes.
struct Summed<W> {
    w: W,
    crc: crc32fast::Hasher,
}

impl<W: Write> Write for Summed<W> {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        let n = self.w.write(buf)?;
        self.crc.update(&buf[..n]);
        Ok(n)
    }
    fn flush(&mut self) -> io::Result<()> {
        self.w.flush()
    }
}

/// A reader that keeps the CRC-32 of what passes.
struct Checked<R> {
    r: R,
    crc: crc32fast::Hasher,
}

impl<R: Read> Checked<R> {
    fn bytes(&mut self, buf: &mut [u8]) -> Result<(), CheckpointError> {
        self.r.read_exact(buf).map_err(|e| {
            if e.kind() == io::ErrorKind::UnexpectedEof {
                CheckpointError::Truncated
            } else {
                CheckpointError::Io(e)
            }
        })?;
        self.crc.update(buf);
        Ok(())
    }
    fn u8(&mut self) -> Result<u8, CheckpointError> {
        let mut b = [0u8; 1];
        self.bytes(&mut b)?;
        Ok(b[0])
    }
    fn u32(&mut self) -> Result<u32, CheckpointError> {
        let mut b = [0u8; 4];
        self.bytes(&mut b)?;
        Ok(u32::from_le_bytes(b))
    }
    fn i32(&mut self) -> Result<i32, CheckpointError> {
        Ok(self.u32()? as i32)
    }
    fn u64(&mut self) -> Result<u64, CheckpointError> {
        let mut b = [0u8; 8];
        self.bytes(&mut b)?;
        Ok(u64::from_le_bytes(b))
    }
    /// `n` values of `size` bytes, read a block at a time into `each`.
    fn column(
        &mut self,
        n: usize,
        size: usize,
        mut each: impl FnMut(&[u8]),
    ) -> Result<(), CheckpointError> {
        let mut buf = vec![0u8; BLOCK * size];
        let mut left = n;
        while left > 0 {
            let m = left.min(BLOCK);
            self.bytes(&mut buf[..m * size])?;
            buf[..m * size].chunks_exact(size).for_each(&mut each);
            left -= m;
        }
        Ok(())
    }
}

fn order_byte(o: Order) -> u8 {
    match o {
        Order::ActionsFirst => 0,
        Order::MessagesFirst => 1,
    }
}

/// Writes `items` a block at a time, each as `put` makes it.
fn put_column<W: Write>(
    w: &mut W,
    n: usize,
    mut put: impl FnMut(usize, &mut Vec<u8>),
) -> io::Result<()> {
    let mut buf = Vec::with_capacity(BLOCK * 16);
    let mut a = 0;
    while a < n {
        buf.clear();
        for i in a..(a + BLOCK).min(n) {
            put(i, &mut buf);
        }
        w.write_all(&buf)?;
        a += BLOCK;
    }
    Ok(())
}

/// Whether a checkpoint's first bytes (its magic) and format version are ones this
/// latticesim reads.
fn known(magic: &[u8], version: u32) -> Result<(), CheckpointError> {
    if magic != MAGIC {
        return Err(CheckpointError::NotACheckpoint);
    }
    if version != VERSION {
        return Err(CheckpointError::Version(version));
    }
    Ok(())
}

/// What a checkpoint's first bytes say: the dimension, the number of agents and the width
/// of counters (to check its rules so, and choose threads).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Peek {
    /// The dimension.
    pub dim: Dim,
    /// The number of agents.
    pub agents: u64,
    /// The width of counters and messages.
    pub width: Width,
}

/// The width a checkpoint's byte says.
fn width_of(b: u8) -> Result<Width, CheckpointError> {
    Width::from_bits(b as u32).ok_or_else(|| CheckpointError::Invalid(format!("{b}-bit counters")))
}

/// What a checkpoint was made in, from its first bytes ([`Peek`]).
pub fn peek(mut r: impl Read) -> Result<Peek, CheckpointError> {
    let mut head = [0u8; 57];
    r.read_exact(&mut head).map_err(|e| match e.kind() {
        io::ErrorKind::UnexpectedEof => CheckpointError::NotACheckpoint,
        _ => CheckpointError::Io(e),
    })?;
    known(
        &head[..8],
        u32::from_le_bytes(head[8..12].try_into().expect("4 bytes")),
    )?;
    let n = u64::from_le_bytes(head[48..56].try_into().expect("8 bytes"));
    Ok(Peek {
        dim: match head[22] {
            3 => Dim::Three,
            _ => Dim::Two,
        },
        agents: n,
        width: width_of(head[56])?,
    })
}

impl Engine {
    /// Writes a checkpoint of the engine's state into `w`.
    pub fn write_checkpoint(&self, w: impl Write) -> io::Result<()> {
        let mut w = Summed {
            w,
            crc: crc32fast::Hasher::new(),
        };
        let lat = &self.lat;
        let (n, d) = (lat.len(), lat.dim);
        w.write_all(MAGIC)?;
        w.write_all(&VERSION.to_le_bytes())?;
        w.write_all(&rules_hash(&self.prog).to_le_bytes())?;
        w.write_all(&[
            order_byte(self.opts.order),
            self.opts.static_first as u8,
            d.coords() as u8,
        ])?;
        match lat.universe {
            Some(b) => {
                w.write_all(&[1])?;
                for (lo, hi) in b {
                    w.write_all(&lo.to_le_bytes())?;
                    w.write_all(&hi.to_le_bytes())?;
                }
            }
            None => w.write_all(&[0; 25])?,
        }
        w.write_all(&(n as u64).to_le_bytes())?;
        w.write_all(&[lat.width().bits()])?;
        let head_crc = w.crc.clone().finalize();
        w.w.write_all(&head_crc.to_le_bytes())?;
        let c = d.coords();
        // Agents in the agents file's order, whatever order the engine keeps them in.
        let at = |id: usize| lat.agent_of(id as u32) as usize;
        put_column(&mut w, n, |id, b| {
            let a = at(id);
            for k in 0..c {
                b.extend_from_slice(&lat.pos[a][k].to_le_bytes());
            }
            b.extend_from_slice(&lat.state[a]);
            b.push(lat.attach[a]);
        })?;
        let wide = lat.width() == Width::W32;
        let put_value = |v: i32, b: &mut Vec<u8>| {
            if wide {
                b.extend_from_slice(&v.to_le_bytes())
            } else {
                b.extend_from_slice(&(v as i16).to_le_bytes())
            }
        };
        let counters = lat.counter_numbers();
        w.write_all(&[counters.len() as u8])?;
        for &i in &counters {
            w.write_all(&[i])?;
            put_column(&mut w, n, |id, b| {
                put_value(lat.counter(at(id) as u32, i), b)
            })?;
        }
        let slots = lat.slot_numbers();
        w.write_all(&[slots.len() as u8])?;
        for &s in &slots {
            w.write_all(&[s])?;
            for dir in 0..d.dirs() as u8 {
                put_column(&mut w, n, |id, b| {
                    put_value(lat.inbox(at(id) as u32, dir, s), b)
                })?;
            }
        }
        let texts = lat.inbox_text_has.len() == n && n > 0;
        w.write_all(&[texts as u8])?;
        if texts {
            put_column(&mut w, n, |id, b| {
                let a = at(id);
                b.push(lat.inbox_text_has[a]);
                for dir in 0..d.dirs() as u8 {
                    b.extend_from_slice(&lat.inbox_text(a as u32, dir).unwrap_or([0; 5]));
                }
            })?;
        }
        let s = &self.stats;
        w.write_all(&s.steps.to_le_bytes())?;
        w.write_all(&[s.quiescent as u8])?;
        w.write_all(&(s.firings.len() as u32).to_le_bytes())?;
        for f in &s.firings {
            w.write_all(&f.to_le_bytes())?;
        }
        for v in [s.moves, s.carried, s.swaps, s.sent, s.delivered, s.dropped] {
            w.write_all(&v.to_le_bytes())?;
        }
        w.write_all(&(s.records.len() as u32).to_le_bytes())?;
        for (k, v) in &s.records {
            w.write_all(&[k.name().len() as u8])?;
            w.write_all(k.name().as_bytes())?;
            w.write_all(&v.to_le_bytes())?;
        }
        let crc = w.crc.clone().finalize();
        w.w.write_all(&crc.to_le_bytes())?;
        w.flush()
    }

    /// An engine in the state of the checkpoint in `r`, which must have been made with the
    /// same rules (`prog`) and the same order and `--static-first` as `opts`.
    pub fn read_checkpoint(
        prog: Verified,
        opts: Options,
        r: impl Read,
    ) -> Result<Engine, CheckpointError> {
        let mut r = Checked {
            r,
            crc: crc32fast::Hasher::new(),
        };
        let (dim, universe, n) = read_header(&mut r, &prog, opts)?;
        let (lat, bad) = read_lattice(&mut r, dim, universe, (n, prog.width))?;
        let (stats, nr) = read_stats(&mut r, &prog)?;
        let want = r.crc.clone().finalize();
        let mut sum = [0u8; 4];
        r.r.read_exact(&mut sum).map_err(|e| match e.kind() {
            io::ErrorKind::UnexpectedEof => CheckpointError::Truncated,
            _ => CheckpointError::Io(e),
        })?;
        if u32::from_le_bytes(sum) != want {
            return Err(CheckpointError::Corrupt);
        }
        let mut extra = [0u8; 1];
        if matches!(r.r.read(&mut extra), Ok(1)) {
            return Err(CheckpointError::Corrupt);
        }
        if let Some(why) = bad {
            return Err(CheckpointError::Invalid(why));
        }
        if nr as usize > RecordKind::ALL.len() {
            return Err(CheckpointError::Invalid("too many kinds of record".into()));
        }
        check_cells(&lat)?;
        let mut e = Engine::new(prog, lat, opts);
        e.stats = stats;
        Ok(e)
    }
}

/// The header of a checkpoint, checked against the rules and options: the dimension, the
/// universe and the number of agents.
fn read_header<R: Read>(
    r: &mut Checked<R>,
    prog: &Program,
    opts: Options,
) -> Result<(Dim, Option<Bounds>, usize), CheckpointError> {
    let mut magic = [0u8; 8];
    r.bytes(&mut magic).map_err(|e| match e {
        CheckpointError::Truncated => CheckpointError::NotACheckpoint,
        e => e,
    })?;
    known(&magic, r.u32()?)?;
    let hash = r.u64()?;
    let (order, static_first, coords) = (r.u8()?, r.u8()?, r.u8()?);
    let has_universe = r.u8()?;
    let mut b: Bounds = [(0, 0); 3];
    for pair in b.iter_mut() {
        *pair = (r.i32()?, r.i32()?);
    }
    let n = r.u64()?;
    let width = r.u8()?;
    // The header has a checksum of its own, so that a damaged file is called damaged
    // rather than made with other rules.
    let want = r.crc.clone().finalize();
    let mut sum = [0u8; 4];
    r.r.read_exact(&mut sum)
        .map_err(|_| CheckpointError::Truncated)?;
    if u32::from_le_bytes(sum) != want {
        return Err(CheckpointError::Corrupt);
    }
    let dim = match coords {
        2 => Dim::Two,
        3 => Dim::Three,
        c => return Err(CheckpointError::Invalid(format!("{c} coordinates"))),
    };
    let width = width_of(width)?;
    if width != prog.width {
        return Err(CheckpointError::OtherOptions(format!(
            "{}-bit counters (`--counters {}`)",
            width.bits(),
            width.bits()
        )));
    }
    if hash != rules_hash(prog) {
        return Err(CheckpointError::OtherRules);
    }
    if dim != prog.dim {
        return Err(CheckpointError::OtherRules);
    }
    if order > 1 || static_first > 1 {
        return Err(CheckpointError::Invalid(format!(
            "order {order}, static-first {static_first}"
        )));
    }
    if order != order_byte(opts.order) {
        return Err(CheckpointError::OtherOptions(
            if order == 1 {
                "--order messages-first"
            } else {
                "--order actions-first"
            }
            .into(),
        ));
    }
    if (static_first != 0) != opts.static_first {
        return Err(CheckpointError::OtherOptions(
            if static_first != 0 {
                "--static-first"
            } else {
                "no --static-first"
            }
            .into(),
        ));
    }
    let n = usize::try_from(n)
        .ok()
        .filter(|&n| n <= u32::MAX as usize - 2)
        .ok_or_else(|| CheckpointError::Invalid(format!("{n} agents")))?;
    // Only what the writer writes is read: a flag of 0 or 1, a universe's bounds in order,
    // none after a flag of 0.
    let universe = match has_universe {
        0 if b == [(0, 0); 3] => None,
        1 if b.iter().all(|(lo, hi)| lo <= hi) => Some(b),
        _ => {
            return Err(CheckpointError::Invalid(format!(
                "a universe of {b:?} (flag {has_universe})"
            )))
        }
    };
    Ok((dim, universe, n))
}

/// The lattice of a checkpoint (after its header), and what is wrong with its states, if
/// anything (said after the checksum is known good).
fn read_lattice<R: Read>(
    r: &mut Checked<R>,
    dim: Dim,
    universe: Option<Bounds>,
    (n, width): (usize, Width),
) -> Result<(Lattice, Option<String>), CheckpointError> {
    let c = dim.coords();
    // The count is the header's word until the agents are read: room for at most 2^20 of
    // them at first, so that a forged count fails as a short file, not as an allocation.
    let mut builder = LatticeBuilder::new(dim, universe, n.min(1 << 20));
    let mut bad = None;
    r.column(n, 4 * c + 6, |v| {
        let mut p = [0i32; 3];
        for (k, q) in p.iter_mut().enumerate().take(c) {
            *q = i32::from_le_bytes(v[4 * k..4 * k + 4].try_into().expect("4 bytes"));
        }
        let state: [u8; 5] = v[4 * c..4 * c + 5].try_into().expect("5 bytes");
        if bad.is_none() && state.iter().any(|&ch| ch == b'*' || !ch.is_ascii_graphic()) {
            bad = Some("a state that is not 5 printable characters".to_string());
        }
        builder.push(p, state, v[4 * c + 5], &[]);
    })?;
    let mut lat = builder.finish();
    lat.set_width(width);
    // A value as written: 2 or 4 bytes.
    let size = width.bits() as usize / 8;
    let read_into = |r: &mut Checked<R>, column: &mut Column| {
        let mut a = 0;
        r.column(n, size, |v| {
            let x = match *v {
                [p, q] => i16::from_le_bytes([p, q]) as i32,
                [p, q, s, t] => i32::from_le_bytes([p, q, s, t]),
                _ => 0,
            };
            column.set(a, width.saturate(x as i64));
            a += 1;
        })
    };
    let ncounters = r.u8()?;
    for _ in 0..ncounters {
        let i = r.u8()?;
        if i as usize >= dim.counters() {
            return Err(CheckpointError::Invalid(format!("counter {i}")));
        }
        let col = lat.ensure_counter(i);
        read_into(r, &mut lat.counters[col])?;
    }
    let nslots = r.u8()?;
    for _ in 0..nslots {
        let s = r.u8()?;
        if s as usize >= dim.slots() {
            return Err(CheckpointError::Invalid(format!("message slot {s}")));
        }
        lat.ensure_slot(s);
        let (ns, sc) = (lat.slots as usize, lat.slot_col[s as usize] as usize);
        for dir in 0..dim.dirs() {
            read_into(r, &mut lat.inbox_num[dir * ns + sc])?;
        }
    }
    if r.u8()? != 0 {
        lat.ensure_text();
        let dirs = dim.dirs();
        let mut a = 0;
        let (has, text) = (&mut lat.inbox_text_has, &mut lat.inbox_text);
        r.column(n, 1 + 5 * dirs, |v| {
            has[a] = v[0];
            for k in 0..dirs {
                text[a * dirs + k] = v[1 + 5 * k..6 + 5 * k].try_into().expect("5 bytes");
            }
            a += 1;
        })?;
    }
    Ok((lat, bad))
}

/// The statistics of a checkpoint (after its lattice), and the number of kinds of record
/// it says it has.
fn read_stats<R: Read>(
    r: &mut Checked<R>,
    prog: &Program,
) -> Result<(Stats, u32), CheckpointError> {
    let mut stats = Stats {
        steps: r.u64()?,
        quiescent: r.u8()? != 0,
        ..Stats::default()
    };
    let nf = r.u32()? as usize;
    if nf != prog.rules.len() {
        return Err(CheckpointError::OtherRules);
    }
    for _ in 0..nf {
        stats.firings.push(r.u64()?);
    }
    stats.moves = r.u64()?;
    stats.carried = r.u64()?;
    stats.swaps = r.u64()?;
    stats.sent = r.u64()?;
    stats.delivered = r.u64()?;
    stats.dropped = r.u64()?;
    let nr = r.u32()?;
    for _ in 0..nr.min(RecordKind::ALL.len() as u32 + 1) {
        let len = r.u8()? as usize;
        let mut name = vec![0u8; len];
        r.bytes(&mut name)?;
        let count = r.u64()?;
        let kind = RecordKind::ALL
            .iter()
            .find(|k| k.name().as_bytes() == name.as_slice())
            .ok_or_else(|| CheckpointError::Invalid("an unknown kind of record".into()))?;
        stats.records.insert(*kind, count);
    }
    Ok((stats, nr))
}

/// One agent a cell, inside the universe, bonds symmetric.
fn check_cells(lat: &Lattice) -> Result<(), CheckpointError> {
    let n = lat.len();
    for a in 0..n {
        let p = lat.pos[a];
        if lat.agent_at(p) != Some(a as u32) {
            return Err(CheckpointError::Invalid(format!(
                "two agents on the cell {},{},{}",
                p[0], p[1], p[2]
            )));
        }
        if !lat.inside(p.map(|c| c as i64)) {
            return Err(CheckpointError::Invalid(
                "an agent outside the universe".into(),
            ));
        }
        if lat.attach[a] >> lat.dim.dirs() != 0 {
            return Err(CheckpointError::Invalid(
                "a bond towards no direction".into(),
            ));
        }
    }
    match lat.one_sided_bond() {
        Some(_) => Err(CheckpointError::Invalid("a bond on one side only".into())),
        None => Ok(()),
    }
}
