//! The fast path of agents files: bytes straight into [`Columns`], with no per-agent
//! allocation, no spans and no diagnostics.
//!
//! It reads exactly the lines the diagnostic path ([`crate::check`]) reads without a word
//! said of them, to the same agents; any other line it leaves ("no", and where it starts)
//! to [`LineCheck`], which checks it alone with the checker's code. What lies beyond one
//! line (two agents on a cell, bonds not declared on both sides) is the lattice's to find
//! once it is built.
//!
//! The head of a file (its `U` line and its first agent line) is read first, alone; it
//! fixes the dimension and the universe, after which every chunk of whole lines can be
//! read on its own, on any thread ([`read_lines`]).

use crate::checked::{Bounds, Columns, Dim, Width};
use crate::{Checked, Input};
use latticesim_grammar::FileId;

/// What the head of an agents file fixes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Head {
    /// The dimension (from the `U` line, else the first position).
    pub dim: Dim,
    /// The universe, if bounded.
    pub universe: Option<Bounds>,
    /// Where the first agent line starts.
    pub agents_at: usize,
    /// Where the line after the first agent line starts (the head is the bytes before).
    pub end: usize,
    /// The width of counters (the rules' width, which [`read_head`] cannot know: set it
    /// before [`read_lines`]; 16 bits until then).
    pub width: Width,
}

/// The lines of `bytes`, each without its line end: (start, line).
fn lines(bytes: &[u8]) -> impl Iterator<Item = (usize, &[u8])> {
    let mut at = 0;
    std::iter::from_fn(move || {
        if at >= bytes.len() {
            return None;
        }
        let start = at;
        let len = memchr_nl(&bytes[at..]);
        at += len + 1;
        Some((start, &bytes[start..start + len]))
    })
}

/// The length of the line at the start of `b` (up to its `\n`, or all of `b`).
#[inline]
fn memchr_nl(b: &[u8]) -> usize {
    b.iter().position(|&c| c == b'\n').unwrap_or(b.len())
}

/// A line's significant text (as `significant_lines` has it: the `\r` before the line
/// end, a comment and the blanks around gone), or `None` when it holds a byte the fast
/// path does not read (outside a comment: anything but printable ASCII, blank and tab;
/// anywhere: a byte above ASCII).
#[inline]
fn significant(raw: &[u8]) -> Option<&[u8]> {
    let line = raw.strip_suffix(b"\r").unwrap_or(raw);
    let mut end = line.len();
    let mut i = 0;
    while i < line.len() {
        let c = line[i];
        if c == b'/' && line.get(i + 1) == Some(&b'/') {
            end = i;
            // The comment may hold anything but text that is not UTF-8 (which the checker
            // speaks of; a line end cannot stand inside a character, so the line alone
            // tells).
            if !line[i..].is_ascii() && std::str::from_utf8(&line[i..]).is_err() {
                return None;
            }
            break;
        }
        if !(c == b' ' || c == b'\t' || (0x21..0x7f).contains(&c)) {
            return None;
        }
        i += 1;
    }
    let t = &line[..end];
    let s = t
        .iter()
        .position(|&c| c != b' ' && c != b'\t')
        .unwrap_or(t.len());
    let e = t
        .iter()
        .rposition(|&c| c != b' ' && c != b'\t')
        .map_or(s, |e| e + 1);
    Some(&t[s..e])
}

/// A whole number as the diagnostic path reads one (`-` and digits), when it fits in
/// `lo..=hi`.
#[inline]
fn int(w: &[u8], lo: i64, hi: i64) -> Option<i64> {
    let (neg, digits) = match w.split_first() {
        Some((b'-', rest)) => (true, rest),
        _ => (false, w),
    };
    if digits.is_empty() || digits.len() > 12 {
        return None;
    }
    let mut v: i64 = 0;
    for &d in digits {
        let d = d.wrapping_sub(b'0');
        if d > 9 {
            return None;
        }
        v = v * 10 + d as i64;
    }
    let v = if neg { -v } else { v };
    (lo..=hi).contains(&v).then_some(v)
}

/// The blank-separated words of a significant line.
#[inline]
fn words(t: &[u8]) -> impl Iterator<Item = &[u8]> {
    t.split(|&c| c == b' ' || c == b'\t')
        .filter(|w| !w.is_empty())
}

/// The coordinates of a position word (at most three; the count is returned too).
#[inline]
fn position(w: &[u8]) -> Option<([i32; 3], usize)> {
    let mut p = [0i32; 3];
    let mut n = 0;
    for part in w.split(|&c| c == b',') {
        if n == 3 {
            return None;
        }
        p[n] = int(part, i32::MIN as i64, i32::MAX as i64)? as i32;
        n += 1;
    }
    Some((p, n))
}

/// Reads the head of an agents file from its first bytes (a prefix of the file that ends
/// at a line end, or the whole file). `None`: the diagnostic path must read the file (a
/// defect in the head, or no agent line in these bytes).
pub fn read_head(bytes: &[u8]) -> Option<Head> {
    let mut universe: Option<(Bounds, usize)> = None;
    for (start, raw) in lines(bytes) {
        let t = significant(raw)?;
        if t.is_empty() {
            continue;
        }
        if let Some(rest) = t.strip_prefix(b"U") {
            if universe.is_some() {
                return None;
            }
            let body = &rest[rest
                .iter()
                .position(|&c| c != b' ' && c != b'\t')
                .unwrap_or(rest.len())..];
            if body.contains(&b' ') || body.contains(&b'\t') {
                return None;
            }
            let v: Vec<i64> = body
                .split(|&c| c == b',')
                .map(|p| int(p, i32::MIN as i64, i32::MAX as i64))
                .collect::<Option<_>>()?;
            if v.len() != 4 && v.len() != 6 {
                return None;
            }
            let mut b: Bounds = [(0, 0); 3];
            for (i, pair) in v.chunks(2).enumerate() {
                if pair[0] > pair[1] {
                    return None;
                }
                b[i] = (pair[0] as i32, pair[1] as i32);
            }
            universe = Some((b, v.len() / 2));
            continue;
        }
        let first = words(t).next()?;
        let (_, coords) = position(first)?;
        let dim = match universe.map_or(coords, |(_, c)| c) {
            2 => Dim::Two,
            3 => Dim::Three,
            _ => return None,
        };
        let head = Head {
            dim,
            universe: universe.map(|(b, _)| b),
            agents_at: start,
            end: (start + raw.len() + 1).min(bytes.len()),
            width: Width::W16,
        };
        // The first agent line itself must read cleanly (in either width: the rules say
        // which, and the line is read again in it).
        let wide = Head {
            width: Width::W32,
            ..head
        };
        let mut probe = Columns::new(Width::W32);
        return read_lines(&bytes[start..head.end], &wide, &mut probe)
            .is_ok()
            .then_some(head);
    }
    None
}

/// The head of an agents file as the rules are checked against it, whatever its agent
/// lines say: its `U` line, or else the first bytes of the file up to the end of its first
/// line that parses as an agent (whose position then decides the dimension, as in the
/// checker), with every line before it blanked, and that line cut to its position
/// (blanks in place of the rest: every offset stays). Every agent line is then read with
/// the others, the head's too. `None` when the `U` line or that position has an error
/// of its own.
pub fn clean_head(bytes: &[u8]) -> Option<Cleaned> {
    use latticesim_grammar::lines::significant_lines;
    let text = std::str::from_utf8(bytes).ok()?;
    let file = FileId(1);
    let mut out = bytes.to_vec();
    let blank = |out: &mut Vec<u8>, r: std::ops::Range<usize>| {
        for b in &mut out[r] {
            if *b != b'\n' {
                *b = b' ';
            }
        }
    };
    let from = 0;
    // Where the previous significant line ended (the bytes between are comments, blanks).
    let mut done = 0;
    for (i, line) in significant_lines(text).enumerate() {
        let end = text[line.start..]
            .find('\n')
            .map_or(text.len(), |e| line.start + e + 1);
        let mut diags = Vec::new();
        let mut f = latticesim_grammar::ast::AgentsFile::default();
        latticesim_grammar::agents::parse_line(line, i == 0, file, &mut diags, &mut f);
        if i == 0 && line.text.starts_with('U') {
            if !diags.is_empty() || f.universe.is_none() {
                return None;
            }
            // The universe line decides the dimension: every agent line is read after.
            return Some(Cleaned::Universe(end));
        }
        let Some(a) = f.agents.first() else {
            blank(&mut out, done..end);
            done = end;
            continue;
        };
        let pos = crate::check_agents::position_span(a);
        blank(&mut out, done..line.start);
        blank(&mut out, pos.end as usize..end);
        out.truncate(end);
        let head = read_head(&out)?;
        return (head.end == end || head.end == out.len()).then_some(Cleaned::Head(out, from));
    }
    Some(Cleaned::NoAgent(from))
}

/// What [`clean_head`] made of a file's first bytes.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Cleaned {
    /// The head made readable, and where the agents' lines start.
    Head(Vec<u8>, usize),
    /// The file starts with a `U` line, which ends here and decides the dimension.
    Universe(usize),
    /// No line parses as an agent in these bytes, and there is no `U` line: the head ends
    /// here (before the first significant line). The rules decide the dimension unless a
    /// later line parses as an agent.
    NoAgent(usize),
}

/// Reads whole agent lines (after the head: from [`Head::agents_at`] on, cut anywhere at
/// a line end) into `out`. `Err` with where it starts when a line needs the diagnostic
/// path; `out` then holds part of them.
pub fn read_lines(chunk: &[u8], head: &Head, out: &mut Columns) -> Result<(), usize> {
    let mut at = 0;
    while at < chunk.len() {
        if let Some(next) = quick_line(chunk, at, head, out) {
            at = next;
            continue;
        }
        let len = memchr::memchr(b'\n', &chunk[at..]).unwrap_or(chunk.len() - at);
        if !line(&chunk[at..at + len], head, out) {
            return Err(at);
        }
        at += len + 1;
    }
    out.fill();
    Ok(())
}

/// Where a field may end in `b`: at a blank, the line's end, or the end of the chunk.
#[inline(always)]
fn ends(b: &[u8], j: usize) -> bool {
    j == b.len()
        || matches!(b[j], b' ' | b'\t' | b'\n')
        || (b[j] == b'\r' && (j + 1 == b.len() || b[j + 1] == b'\n'))
}

/// The whole number at `*i` in `b` (`-` and at most 12 digits) ending at a field's end or
/// a comma, when it lies in `lo..=hi`; `*i` is moved past it.
#[inline(always)]
fn int_at(b: &[u8], i: &mut usize, lo: i64, hi: i64) -> Option<i64> {
    let n = b.len();
    let neg = b.get(*i) == Some(&b'-');
    *i += neg as usize;
    let start = *i;
    let mut v: i64 = 0;
    while *i < n && b[*i].is_ascii_digit() && *i - start < 12 {
        v = v * 10 + (b[*i] - b'0') as i64;
        *i += 1;
    }
    let v = if neg { -v } else { v };
    (*i > start && (ends(b, *i) || b[*i] == b',') && (lo..=hi).contains(&v)).then_some(v)
}

/// The usual agent line at `at` in `b`, read in one pass: the position, then `S`, `A` and
/// `C` fields separated by blanks, nothing else (no comment, no `/` at all), ended by `\n`,
/// `\r\n` or the end of `b`. Where the next line starts; `None` when the line is anything
/// else (or not clean): [`line`] then reads it. When it answers, it has read exactly what
/// [`line`] would have.
#[inline]
fn quick_line(b: &[u8], mut i: usize, head: &Head, out: &mut Columns) -> Option<usize> {
    let d = head.dim;
    let n = b.len();
    let blank = |c: u8| c == b' ' || c == b'\t';
    let ends = |j: usize| ends(b, j);
    let int = |i: &mut usize, lo: i64, hi: i64| int_at(b, i, lo, hi);
    while i < n && blank(b[i]) {
        i += 1;
    }
    let (lo, hi) = (i32::MIN as i64, i32::MAX as i64);
    let mut pos = [0i32; 3];
    for (k, p) in pos.iter_mut().enumerate().take(d.coords()) {
        if k > 0 {
            if b.get(i) != Some(&b',') {
                return None;
            }
            i += 1;
        }
        *p = int(&mut i, lo, hi)? as i32;
    }
    if !ends(i) {
        return None;
    }
    if let Some(u) = head.universe {
        if (0..d.coords()).any(|k| pos[k] < u[k].0 || pos[k] > u[k].1) {
            return None;
        }
    }
    let (mut state, mut attach) = (None::<[u8; 5]>, None::<u8>);
    let mut counters = [(0u8, 0i32); 8];
    let max = head.width.max() as i64;
    let (mut nc, mut seen) = (0, 0u64);
    let next = loop {
        while i < n && blank(b[i]) {
            i += 1;
        }
        if i == n {
            break n;
        }
        match b[i] {
            b'\n' => break i + 1,
            b'\r' if i + 1 == n => break n,
            b'\r' if b[i + 1] == b'\n' => break i + 2,
            b'S' if i + 6 <= n && ends(i + 6) && state.is_none() => {
                let st: [u8; 5] = b[i + 1..i + 6].try_into().expect("5 bytes");
                if st
                    .iter()
                    .any(|&c| !(0x21..0x7f).contains(&c) || c == b'*' || c == b'/')
                {
                    return None;
                }
                state = Some(st);
                i += 6;
            }
            b'A' if i + 1 + d.dirs() <= n && ends(i + 1 + d.dirs()) && attach.is_none() => {
                let mut bits = 0u8;
                for (k, &c) in b[i + 1..i + 1 + d.dirs()].iter().enumerate() {
                    match c {
                        b'0' => {}
                        b'1' => bits |= 1 << k,
                        _ => return None,
                    }
                }
                attach = Some(bits);
                i += 1 + d.dirs();
            }
            b'C' if i + 3 < n && blank(b[i + 3]) => {
                let (x, y) = (b[i + 1].wrapping_sub(b'0'), b[i + 2].wrapping_sub(b'0'));
                if x > 9 || y > 9 || nc == counters.len() {
                    return None;
                }
                let c = x * 10 + y;
                if c as usize >= d.counters() || seen & (1 << c) != 0 {
                    return None;
                }
                seen |= 1 << c;
                i += 3;
                while i < n && blank(b[i]) {
                    i += 1;
                }
                let v = int(&mut i, -max, max)?;
                if !ends(i) {
                    return None;
                }
                counters[nc] = (c, v as i32);
                nc += 1;
            }
            _ => return None,
        }
    };
    out.pos.push(pos);
    out.state.push(state.unwrap_or(*b"00000"));
    out.attach.push(attach.unwrap_or(0));
    for &(c, v) in &counters[..nc] {
        if v != 0 {
            out.set_counter(c as usize, v);
        }
    }
    Some(next)
}

/// Any line after the head, read as the diagnostic path splits it (comments, blanks, line
/// ends): true when it is blank, a comment or a clean agent line (then read into `out`).
fn line(raw: &[u8], head: &Head, out: &mut Columns) -> bool {
    let d = head.dim;
    let (coords, dirs, ncounters) = (d.coords(), d.dirs(), d.counters());
    let Some(t) = significant(raw) else {
        return false;
    };
    if t.is_empty() {
        return true;
    }
    if t[0] == b'U' {
        return false;
    }
    let mut ws = words(t);
    let Some((pos, n)) = ws.next().and_then(position) else {
        return false;
    };
    if n != coords {
        return false;
    }
    if let Some(b) = head.universe {
        if (0..coords).any(|i| pos[i] < b[i].0 || pos[i] > b[i].1) {
            return false;
        }
    }
    let (mut state, mut attach) = (None::<[u8; 5]>, None::<u8>);
    let mut counters = Vec::new();
    let mut seen = 0u64;
    while let Some(w) = ws.next() {
        match w[0] {
            b'S' => {
                let s = &w[1..];
                if state.is_some() || s.len() != 5 || s.contains(&b'*') {
                    return false;
                }
                state = Some([s[0], s[1], s[2], s[3], s[4]]);
            }
            b'A' => {
                let s = &w[1..];
                if attach.is_some() || s.len() != dirs {
                    return false;
                }
                let mut bits = 0u8;
                for (i, &c) in s.iter().enumerate() {
                    match c {
                        b'0' => {}
                        b'1' => bits |= 1 << i,
                        _ => return false,
                    }
                }
                attach = Some(bits);
            }
            b'C' if w.len() == 3 => {
                let (a, b) = (w[1].wrapping_sub(b'0'), w[2].wrapping_sub(b'0'));
                if a > 9 || b > 9 {
                    return false;
                }
                let c = (a * 10 + b) as usize;
                if c >= ncounters || seen & (1 << c) != 0 {
                    return false;
                }
                seen |= 1 << c;
                let max = head.width.max() as i64;
                let Some(v) = ws.next().and_then(|v| int(v, -max, max)) else {
                    return false;
                };
                counters.push((c, v as i32));
            }
            _ => return false,
        }
    }
    out.pos.push(pos);
    out.state.push(state.unwrap_or(*b"00000"));
    out.attach.push(attach.unwrap_or(0));
    for (c, v) in counters {
        if v != 0 {
            out.set_counter(c, v);
        }
    }
    true
}

/// The lines the fast reader leaves, checked one at a time as the checker checks them
/// (after the head, which fixes the dimension and the universe): the streaming reader of
/// files with errors and warnings. What lies beyond a line (agents on one cell, bonds) is
/// the lattice's to find ([`crate::shared_cell`], [`crate::bond_made`],
/// [`crate::bond_dropped`] say it).
pub struct LineCheck {
    dim: crate::dim::DimSource,
    width: Width,
    universe: Option<(Bounds, latticesim_grammar::ast::Universe)>,
    /// No agent line was found in the head: the first line that parses as an agent would
    /// decide the dimension, and is left to the checker of the whole file.
    agentless: bool,
}

/// What a line was, to [`LineCheck::line`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Verdict {
    /// Blank or a comment.
    Nothing,
    /// An agent, read into the columns (perhaps with diagnostics).
    Agent,
    /// An agent line with an error (it counts among the agents read, not in the lattice).
    Refused,
    /// A line that is no agent (a universe line, a line that is not one) with an error.
    Other,
}

impl LineCheck {
    /// The checks of the lines after the head `head` (the file's bytes up to
    /// [`Head::end`]), whose counters are of width `width`; `None` when the head does not
    /// read cleanly.
    pub fn new(head: &[u8], width: Width) -> Option<LineCheck> {
        LineCheck::of_head(head, width, None)
    }

    /// The checks of the lines after a head without agents (`head`: the `U` line, if
    /// any, with what stands before it), in the dimension of the universe line or else
    /// `rules_dim` (the rules' own, as the checker decides it). `agentless` (no `U` line):
    /// lines are then read only here (see [`LineCheck::agentless`]), and one that parses
    /// as an agent is not.
    pub fn without_agents(
        head: &[u8],
        rules_dim: &crate::dim::DimSource,
        width: Width,
        agentless: bool,
    ) -> Option<LineCheck> {
        LineCheck::of_head(head, width, Some((rules_dim, agentless)))
    }

    /// [`LineCheck::new`], or with `no_agent` [`LineCheck::without_agents`].
    fn of_head(
        head: &[u8],
        width: Width,
        no_agent: Option<(&crate::dim::DimSource, bool)>,
    ) -> Option<LineCheck> {
        let text = std::str::from_utf8(head).ok()?;
        let file = FileId(1);
        let (f, diags) = latticesim_grammar::parse_agents(text, file);
        let dim = match no_agent {
            None => crate::dim::from_agents(&f, file)?,
            Some(_) if !f.agents.is_empty() => return None,
            Some((rules_dim, _)) => {
                crate::dim::from_agents(&f, file).unwrap_or_else(|| rules_dim.clone())
            }
        };
        let mut scratch = Vec::new();
        let mut ck = crate::check_agents::Checker {
            file,
            src: text,
            base: 0,
            dim: &dim,
            diags: &mut scratch,
            width,
        };
        let universe = match &f.universe {
            Some(u) => Some((ck.universe(u)?, u.clone())),
            None => None,
        };
        (diags.is_empty() && scratch.is_empty()).then_some(LineCheck {
            dim,
            width,
            universe,
            agentless: no_agent.is_some_and(|n| n.1),
        })
    }

    /// True when no agent line was found in the head: the fast reader must not read any
    /// line (it would take an agent line in a dimension not yet decided).
    pub fn agentless(&self) -> bool {
        self.agentless
    }

    /// The head that stands for this one's dimension and universe, for the lattice.
    pub fn head(&self, end: usize) -> Head {
        Head {
            dim: self.dim.dim,
            universe: self.universe.as_ref().map(|u| u.0),
            agents_at: end,
            end,
            width: self.width,
        }
    }

    /// Checks the line `raw` (without its line end) that starts at offset `at` of the
    /// file, as the checker would in the whole file: its diagnostics into `diags`, its
    /// agent (when it has no error) into `out`. `None` for a line that is not UTF-8 (the
    /// checker speaks of the whole file then), and after a head without agents for a line
    /// that parses as one.
    pub fn line(
        &self,
        raw: &[u8],
        at: usize,
        out: &mut Columns,
        diags: &mut Vec<latticesim_grammar::Diagnostic>,
    ) -> Option<Verdict> {
        let text = std::str::from_utf8(raw).ok()?;
        let Some(line) = latticesim_grammar::lines::significant_lines(text).next() else {
            return Some(Verdict::Nothing);
        };
        let line = latticesim_grammar::lines::Line {
            start: line.start + at,
            ..line
        };
        let file = FileId(1);
        let mut f = latticesim_grammar::ast::AgentsFile::default();
        latticesim_grammar::agents::parse_line(line, false, file, diags, &mut f);
        let Some(a) = f.agents.first() else {
            return Some(Verdict::Other);
        };
        if self.agentless {
            return None;
        }
        let mut ck = crate::check_agents::Checker {
            file,
            src: text,
            base: at,
            dim: &self.dim,
            diags,
            width: self.width,
        };
        let universe = self.universe.as_ref().map(|(b, u)| (*b, u));
        let Some(agent) = ck.agent(a, universe) else {
            return Some(Verdict::Refused);
        };
        out.pos.push(agent.pos);
        out.state.push(agent.state);
        out.attach.push(agent.attach);
        for (c, v) in agent.counters {
            out.set_counter(c as usize, v);
        }
        Some(Verdict::Agent)
    }
}

/// The rules checked against the head of their agents file (its first bytes up to
/// [`Head::end`]), for the fast path: `None` when the diagnostic path must check the whole
/// pair, because something is said of the agents file's head, or the files do not agree
/// on the dimension. Otherwise its diagnostics (of the rules) are those the whole pair
/// would have but the warnings that follow from the agents' start states (found once the
/// whole agents file is read).
pub fn check_with_head(
    rules: Input<'_>,
    head: Input<'_>,
    levels: &crate::lints::Lints,
) -> Option<Checked> {
    // Patterns no start state matches and states no rule tests are judged with the whole
    // file's states (see [`crate::states_warnings_of`]), not the head's: allowed here (a
    // denied one would fail the rules), with the levels as said kept for later.
    use crate::lints::{Level, Lints, Target};
    use latticesim_grammar::Code;
    let later = |code: Code| code == Code::W503 || code == Code::W603;
    let mut quiet = levels.clone();
    for code in [Code::W503, Code::W603] {
        quiet.push(Target::Code(code), Level::Allow, "the head");
    }
    // Not capped: the warnings added later take their place among the others, and then
    // the caller caps them as the checker does ([`crate::cap_checked`]).
    let mut c = crate::check_uncapped(rules, Some(head), None, &quiet);
    let (said, _) = Lints::from_rules(c.sources.text(FileId(0)), FileId(0));
    c.lints = said.then(levels);
    c.diags.retain(|d| !later(d.code));
    // Errors of the rules alone are the whole pair's too (the agents are then checked,
    // not run); a dimension the files do not agree on, and rules too large to compile
    // (said only of a pair without other errors, after its warnings), are the checker's.
    let whole = |code: Code| code == Code::E301 || code == Code::E321;
    let clean = !c
        .diags
        .iter()
        .any(|d| d.primary.file == FileId(1) || whole(d.code))
        && (c.not_shown.iter()).all(|n| n.file != FileId(1) && n.codes.iter().all(|k| !whole(k.0)));
    clean.then_some(c)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn read(src: &str) -> Option<(Head, Columns)> {
        let head = read_head(src.as_bytes())?;
        let mut cols = Columns::new(head.width);
        read_lines(&src.as_bytes()[head.agents_at..], &head, &mut cols)
            .is_ok()
            .then_some((head, cols))
    }

    #[test]
    fn reads_a_clean_file() {
        let (head, cols) =
            read("// c\r\nU 0,9,0,9\r\n\r\n1,2 C03 -7 SAB(DE A1000 // x\n 3,4\t\n5,6 C00 0")
                .unwrap();
        assert_eq!(head.dim, Dim::Two);
        assert_eq!(head.universe.unwrap()[1], (0, 9));
        assert_eq!(cols.pos, vec![[1, 2, 0], [3, 4, 0], [5, 6, 0]]);
        assert_eq!(cols.state[0], *b"AB(DE");
        assert_eq!(cols.state[1], *b"00000");
        assert_eq!(cols.attach, vec![1, 0, 0]);
        assert_eq!(
            cols.counters[3],
            crate::checked::Column::W16(vec![-7, 0, 0])
        );
        assert!(cols.counters[0].is_empty());
    }

    #[test]
    fn defers_what_the_diagnostic_path_would_speak_of() {
        for src in [
            "1,2\nU0,1,0,1\n",
            "1,2\n3,4,5\n",
            "1,2 S0000\n",
            "1,2 S0*000\n",
            "1,2 A100\n",
            "1,2 C3 1\n",
            "1,2 C25 1\n",
            "1,2 C01 1 C01 2\n",
            "1,2 C01 32768\n",
            "1,2 C01\n",
            "1,2 X\n",
            "1,2 S00000 S00000\n",
            "U0,1,0,1\n5,5\n",
            "1,2 // \u{1}\n\n1,3 //\u{ff}\n3\n",
            "1,2 \u{1}\n",
            "1,2\r3,4\n",
            "1,99999999999\n",
            "1\n",
            "U0,1\n1,1\n",
            "U1,0,0,1\n1,1\n",
            "// nothing\n",
        ] {
            assert!(read(src).is_none(), "{src:?}");
        }
    }
}
