//! The fast path of agents files: bytes straight into [`Columns`], with no per-agent
//! allocation, no spans and no diagnostics.
//!
//! It accepts exactly the files the diagnostic path ([`crate::check`]) accepts without a
//! word said of them, and reads them to the same agents; on anything else (an error, a
//! warning, a byte it does not expect) it answers "no", and the caller takes the
//! diagnostic path, which reports what is wrong. What lies beyond one line (two agents on
//! a cell, bonds not declared on both sides) is the lattice's to find once it is built:
//! it too only answers yes or no here.
//!
//! The head of a file (its `U` line and its first agent line) is read first, alone; it
//! fixes the dimension and the universe, after which every chunk of whole lines can be
//! read on its own, on any thread ([`read_lines`]).

use crate::check_rules::VALUE_MAX;
use crate::program::{Bounds, Columns, Dim};
use crate::{check, Checked, Input};
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
            // The comment may hold control characters, never bytes above ASCII (so the
            // file's text is valid UTF-8 without a decoder looking at it).
            if !line[i..].is_ascii() {
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
        };
        // The first agent line itself must read cleanly.
        let mut probe = Columns::new();
        return read_lines(&bytes[start..head.end], &head, &mut probe).then_some(head);
    }
    None
}

/// Reads whole agent lines (after the head: from [`Head::agents_at`] on, cut anywhere at
/// a line end) into `out`. False when some line needs the diagnostic path; `out` then
/// holds part of them.
pub fn read_lines(chunk: &[u8], head: &Head, out: &mut Columns) -> bool {
    let d = head.dim;
    let (coords, dirs, ncounters) = (d.coords(), d.dirs(), d.counters());
    for (_, raw) in lines(chunk) {
        let Some(t) = significant(raw) else {
            return false;
        };
        if t.is_empty() {
            continue;
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
        out.pos.push(pos);
        let (mut state, mut attach) = (None::<[u8; 5]>, None::<u8>);
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
                    let Some(v) = ws
                        .next()
                        .and_then(|v| int(v, -(VALUE_MAX as i64), VALUE_MAX as i64))
                    else {
                        return false;
                    };
                    if v != 0 {
                        out.set_counter(c, v as i16);
                    }
                }
                _ => return false,
            }
        }
        out.state.push(state.unwrap_or(*b"00000"));
        out.attach.push(attach.unwrap_or(0));
    }
    out.fill();
    true
}

/// The rules checked against the head of their agents file (its first bytes up to
/// [`Head::end`]), for the fast path: `None` when the diagnostic path must check the whole
/// pair, because there is an error, or something is said of the agents file. Otherwise
/// its diagnostics (warnings of the rules) are those the whole pair would have, once the
/// rest of the agents file has been read cleanly.
pub fn check_with_head(rules: Input<'_>, head: Input<'_>) -> Option<Checked> {
    let c = check(rules, Some(head), None);
    let clean = c.program.is_some()
        && c.config.is_some()
        && c.errors() == 0
        && !c.diags.iter().any(|d| d.primary.file == FileId(1))
        && c.not_shown.iter().all(|n| n.file != FileId(1));
    clean.then_some(c)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn read(src: &str) -> Option<(Head, Columns)> {
        let head = read_head(src.as_bytes())?;
        let mut cols = Columns::new();
        read_lines(&src.as_bytes()[head.agents_at..], &head, &mut cols).then_some((head, cols))
    }

    #[test]
    fn reads_a_clean_file() {
        let (head, cols) =
            read("// c\r\nU 0,9,0,9\r\n\r\n1,2 C03 -7 SAB(DE A1000 // x\n 3,4\t\n5,6 C00 0").unwrap();
        assert_eq!(head.dim, Dim::Two);
        assert_eq!(head.universe.unwrap()[1], (0, 9));
        assert_eq!(cols.pos, vec![[1, 2, 0], [3, 4, 0], [5, 6, 0]]);
        assert_eq!(cols.state[0], *b"AB(DE");
        assert_eq!(cols.state[1], *b"00000");
        assert_eq!(cols.attach, vec![1, 0, 0]);
        assert_eq!(cols.counters[3], vec![-7, 0, 0]);
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
            "1,2 // é\n",
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
