//! Binary frames (`GET /api/frame?format=bin`): what the viewer draws of a step in a few
//! bytes per agent, whole or as the changes since the frame the tab holds, so that a
//! million agents step at interactive rates (docs/viewer.md gives the layout).
//!
//! Layout, little-endian: `LSF2`, the length of a JSON head (u32), the head (the frame's
//! step, dim, quiescent, states, universe, records, stats, keyframes, note, `n`, `delta`,
//! `base`, `attach`, and `columns`), zero bytes to a multiple of 4, then the columns the
//! head lists, in its order (`pos`, `state`, and `attach` when the run has bonds), each
//! starting at a multiple of 4:
//! - `set` `all`: every agent's value; else (a delta) the agents whose value changed: as a
//!   bit set (`bits`: ⌈n/8⌉ bytes, agent i is bit i mod 8 of byte i div 8) or as a list of
//!   ids (`ids`: u32 each, ascending), whichever is smaller; zero bytes to a multiple of 4;
//! - then their values (`count` of them), `bytes` wide: `pos` is `dim` coordinates an
//!   agent (i32; or, in a delta where every change fits, i8 with `bytes` 1: how far each
//!   coordinate moved), `state` an index into `states` (u8, u16 or u32; `states` lists
//!   every state the run has shown, in order of first appearance, so an index keeps its
//!   state for the run), `attach` the attachment bits (u8).
//!
//! With `counter` (asked for with `counter=Cnn`), that counter of every agent follows at a
//! multiple of 4: i16, or i32 when the head's `counter_bytes` is 4 (32-bit counters). A falling cloud of a million agents is then about 2 bytes an agent
//! moved, and the transport compresses it (zstd) to a few kilobytes when the page accepts.

use super::*;

/// The columns of the last binary frame sent to a tab, to send the next as a delta.
pub(super) struct Sent {
    step: u64,
    pos: Vec<[i32; 3]>,
    state: Vec<u32>,
    attach: Vec<u8>,
}

fn pad(out: &mut Vec<u8>) {
    while !out.len().is_multiple_of(4) {
        out.push(0);
    }
}

/// How a column's agents are named.
#[derive(Clone, Copy, PartialEq, Debug)]
enum Set {
    /// Every agent, in id order.
    All,
    /// A bit per agent.
    Bits,
    /// A list of ids.
    Ids,
}

/// What a column carries.
#[derive(Clone, Copy, PartialEq, Debug)]
enum Kind {
    Pos,
    State,
    Attach,
}

/// One column of a frame: the agents it carries and how wide a value is.
struct Column {
    kind: Kind,
    /// The agents carried (every one, for [`Set::All`]).
    ids: Option<Vec<u32>>,
    set: Set,
    /// The bytes of a number (a coordinate, a state index, attachment bits).
    bytes: usize,
    /// The bytes of an agent's value (`dim` numbers for positions, else one).
    width: usize,
}

impl Column {
    /// A column of the agents `ids` (all of them when `None`) of `n`, naming them the
    /// smaller way; `bytes` a number, `per` numbers an agent.
    fn new(kind: Kind, ids: Option<Vec<u32>>, n: usize, bytes: usize, per: usize) -> Column {
        let set = match &ids {
            None => Set::All,
            Some(ids) if ids.len() * 4 > n.div_ceil(8) => Set::Bits,
            Some(_) => Set::Ids,
        };
        Column {
            kind,
            ids,
            set,
            bytes,
            width: bytes * per,
        }
    }

    fn count(&self, n: usize) -> usize {
        self.ids.as_ref().map_or(n, Vec::len)
    }

    /// Its size in the frame, padding included.
    fn size(&self, n: usize) -> usize {
        let set = match self.set {
            Set::All => 0,
            Set::Bits => n.div_ceil(8),
            Set::Ids => 4 * self.count(n),
        };
        set.div_ceil(4) * 4 + (self.count(n) * self.width).div_ceil(4) * 4
    }

    /// Writes its set, then the value of each of its agents as `value` gives it.
    fn write(&self, out: &mut Vec<u8>, n: usize, value: impl Fn(usize, &mut [u8])) {
        match (self.set, &self.ids) {
            (Set::Bits, Some(ids)) => {
                let at = out.len();
                out.resize(at + n.div_ceil(8), 0);
                for &i in ids {
                    out[at + i as usize / 8] |= 1 << (i % 8);
                }
            }
            (Set::Ids, Some(ids)) => ids.iter().for_each(|i| out.extend(i.to_le_bytes())),
            _ => {}
        }
        pad(out);
        let at = out.len();
        out.resize(at + self.count(n) * self.width, 0);
        let chunks = out[at..].chunks_exact_mut(self.width);
        match &self.ids {
            Some(ids) => (chunks.zip(ids)).for_each(|(c, &i)| value(i as usize, c)),
            None => chunks.enumerate().for_each(|(i, c)| value(i, c)),
        }
        pad(out);
    }

    fn head(&self, n: usize) -> Value {
        let set = match self.set {
            Set::All => "all",
            Set::Bits => "bits",
            Set::Ids => "ids",
        };
        let name = match self.kind {
            Kind::Pos => "pos",
            Kind::State => "state",
            Kind::Attach => "attach",
        };
        json!({ "name": name, "set": set, "count": self.count(n), "bytes": self.bytes })
    }
}

/// The binary frame of the run's current step; a delta when the tab holds the frame of
/// step `since` (the last one sent) and that is smaller.
pub(super) fn frame_bin(run: &mut Run, since: Option<u64>, counter: Option<u8>) -> Vec<u8> {
    let e = run.hist.engine();
    let lat = &e.lat;
    let (n, dim) = (lat.len(), lat.dim.coords());
    let (state, states) = states_view(run);
    let attach = lat.attach.iter().any(|&b| b != 0);
    let state_bytes = match states.len() {
        0..=256 => 1,
        257..=65536 => 2,
        _ => 4,
    };
    let whole = [
        Column::new(Kind::Pos, None, n, 4, dim),
        Column::new(Kind::State, None, n, state_bytes, 1),
        Column::new(Kind::Attach, None, n, 1, 1),
    ];
    // What changed since the frame the tab holds, if it holds the last one sent.
    let base = run
        .sent
        .as_ref()
        .filter(|s| Some(s.step) == since && s.pos.len() == n);
    let delta = base.map(|b| {
        let (mut moved, mut restated, mut reattached) = (Vec::new(), Vec::new(), Vec::new());
        for (i, (s, now)) in b.state.iter().zip(&state).enumerate() {
            if b.pos[i] != lat.pos[i] {
                moved.push(i as u32);
            }
            if s != now {
                restated.push(i as u32);
            }
            if b.attach[i] != lat.attach[i] {
                reattached.push(i as u32);
            }
        }
        // Moves of a step are a cell or two: as i8 changes where every one fits.
        let near = moved.iter().all(|&i| {
            let (a, b) = (lat.pos[i as usize], b.pos[i as usize]);
            (0..dim).all(|d| i8::try_from(a[d] as i64 - b[d] as i64).is_ok())
        });
        [
            Column::new(Kind::Pos, Some(moved), n, if near { 1 } else { 4 }, dim),
            Column::new(Kind::State, Some(restated), n, state_bytes, 1),
            Column::new(Kind::Attach, Some(reattached), n, 1, 1),
        ]
    });
    // The columns sent: attachment bits only when the run has bonds.
    let used = if attach { 3 } else { 2 };
    let size = |cols: &[Column]| -> usize { cols[..used].iter().map(|c| c.size(n)).sum() };
    let delta = delta.filter(|d| size(d) < size(&whole));
    let is_delta = delta.is_some();
    let all = delta.unwrap_or(whole);
    let cols = &all[..used];
    let (k, every) = run.hist.keyframes();
    let s = &e.stats;
    let head = json!({
        "step": run.hist.steps(),
        "dim": dim,
        "quiescent": s.quiescent,
        "n": n,
        "states": states,
        "universe": lat.universe.map(|b| b[..dim].iter().map(|&(lo, hi)| [lo, hi]).collect::<Vec<_>>()),
        "records": records_view(run),
        "stats": stats_view(e),
        "keyframes": [k as u64, every],
        "history": super::views::history_view(run),
        "note": run.note,
        "attach": attach,
        "delta": is_delta,
        "base": if is_delta { since } else { None },
        "columns": cols.iter().map(|c| c.head(n)).collect::<Vec<_>>(),
        "counters": lat.counter_numbers().iter().map(|c| format!("C{c:02}")).collect::<Vec<_>>(),
        "counter": counter.map(|c| format!("C{c:02}")),
        "counter_bytes": lat.width().bits() / 8,
    });
    let head = head.to_string();
    let body = size(cols);
    let mut out = Vec::with_capacity(8 + head.len() + 4 + body + 4 * n + 4);
    out.extend_from_slice(b"LSF2");
    out.extend_from_slice(&(head.len() as u32).to_le_bytes());
    out.extend_from_slice(head.as_bytes());
    pad(&mut out);
    for c in cols {
        match (c.kind, c.bytes, base) {
            (Kind::Pos, 1, Some(b)) if is_delta => c.write(&mut out, n, |i, v| {
                for (d, v) in v.iter_mut().enumerate() {
                    *v = (lat.pos[i][d] - b.pos[i][d]) as i8 as u8;
                }
            }),
            (Kind::Pos, ..) => c.write(&mut out, n, |i, v| {
                for (d, v) in v.chunks_exact_mut(4).enumerate() {
                    v.copy_from_slice(&lat.pos[i][d].to_le_bytes());
                }
            }),
            (Kind::State, ..) => c.write(&mut out, n, |i, v| {
                v.copy_from_slice(&state[i].to_le_bytes()[..v.len()])
            }),
            (Kind::Attach, ..) => c.write(&mut out, n, |i, v| v[0] = lat.attach[i]),
        }
    }
    if let Some(c) = counter {
        let wide = lat.width() == latticesim_vm::model::Width::W32;
        for a in 0..n as u32 {
            let v = lat.counter(a, c);
            if wide {
                out.extend_from_slice(&v.to_le_bytes());
            } else {
                out.extend_from_slice(&(v as i16).to_le_bytes());
            }
        }
    }
    let step = run.hist.steps();
    match (run.sent.as_mut(), is_delta) {
        // A delta: what the tab holds now is the last frame with the changes (bonds all
        // gone too: a frame without `attach` has none).
        (Some(sent), true) => {
            sent.step = step;
            for c in &all {
                let ids = c.ids.iter().flatten().map(|&i| i as usize);
                match c.kind {
                    Kind::Pos => ids.for_each(|i| sent.pos[i] = lat.pos[i]),
                    Kind::State => ids.for_each(|i| sent.state[i] = state[i]),
                    Kind::Attach => ids.for_each(|i| sent.attach[i] = lat.attach[i]),
                }
            }
        }
        _ => {
            run.sent = Some(Sent {
                step,
                pos: lat.pos.clone(),
                state,
                attach: lat.attach.clone(),
            })
        }
    }
    out
}
