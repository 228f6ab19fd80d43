//! What a step changed, kept backwards: the earlier values of the agents and inboxes it
//! changed ([`Back`]), found by comparing the configuration with a copy of the one
//! before ([`Shadow`]), and put back with [`Lattice::rewind`]. A run's history
//! ([`crate::History`]) keeps one per step, so that going back a step costs what the
//! step changed, not a step of the engine.
//!
//! Messages left with their senders ([`Pending`]) are compared as what they mean (a sent
//! bit, and the value where it is set), not as stored: a column holds stale values where no
//! bit is set, which differ between a run and the same run made again from a keyframe.

use super::*;

/// One column's earlier values where a step changed them.
#[derive(Debug, Clone)]
enum Back<T> {
    Same,
    /// The agents (ascending) and their earlier values.
    Some(Vec<u32>, Vec<T>),
    /// The whole earlier column (most agents changed, or its length did).
    Whole(Vec<T>),
    /// Most agents changed, by few distinct changes (a counter less one, a state
    /// character set): per agent a byte naming its change ([`Change`]; 0: unchanged), and
    /// the changes (at most 256).
    Coded(Vec<T>, Vec<u8>),
}

/// Values and how one changed: the earlier value from the later one and the change. A
/// number's change is a difference (a counter less one is one change for every agent), a
/// byte's or a bit set's an XOR (a state character set).
trait Change: Copy + PartialEq {
    fn between(old: Self, new: Self) -> Self;
    fn undo(new: Self, change: Self) -> Self;
}

impl Change for u8 {
    fn between(old: u8, new: u8) -> u8 {
        old ^ new
    }
    fn undo(new: u8, c: u8) -> u8 {
        new ^ c
    }
}

impl Change for u64 {
    fn between(old: u64, new: u64) -> u64 {
        old ^ new
    }
    fn undo(new: u64, c: u64) -> u64 {
        new ^ c
    }
}

impl Change for i16 {
    fn between(old: i16, new: i16) -> i16 {
        old.wrapping_sub(new)
    }
    fn undo(new: i16, c: i16) -> i16 {
        new.wrapping_add(c)
    }
}

impl Change for i32 {
    fn between(old: i32, new: i32) -> i32 {
        old.wrapping_sub(new)
    }
    fn undo(new: i32, c: i32) -> i32 {
        new.wrapping_add(c)
    }
}

impl<const N: usize, T: Change> Change for [T; N] {
    fn between(old: [T; N], new: [T; N]) -> [T; N] {
        let mut r = old;
        for (a, b) in r.iter_mut().zip(new) {
            *a = T::between(*a, b);
        }
        r
    }
    fn undo(new: [T; N], c: [T; N]) -> [T; N] {
        let mut r = new;
        for (a, b) in r.iter_mut().zip(c) {
            *a = T::undo(*a, b);
        }
        r
    }
}

/// Per agent, a byte naming its change among at most 256 (the first: none), or `None`
/// when there are more.
fn coded<T: Change>(was: &[T], now: &[T]) -> Option<(Vec<T>, Vec<u8>)> {
    let zero = match now.first() {
        Some(&v) => T::between(v, v),
        None => return Some((Vec::new(), Vec::new())),
    };
    let mut table = vec![zero];
    let mut codes = Vec::with_capacity(now.len());
    let mut last = (zero, 0u8);
    for (&a, &b) in was.iter().zip(now) {
        let x = T::between(a, b);
        if x != last.0 {
            let c = match table.iter().position(|&t| t == x) {
                Some(c) => c,
                None if table.len() < 256 => {
                    table.push(x);
                    table.len() - 1
                }
                None => return None,
            };
            last = (x, c as u8);
        }
        codes.push(last.1);
    }
    Some((table, codes))
}

impl<T: Change> Back<T> {
    /// What changed from `was` to `now`, and `was` made `now`. Past `limit` changed
    /// agents the whole column is kept.
    fn of(was: &mut Vec<T>, now: &[T], limit: usize) -> Back<T> {
        if was.len() != now.len() {
            return Back::Whole(std::mem::replace(was, now.to_vec()));
        }
        // How many changed (a pass that allocates nothing, given up past the limit).
        let mut count = 0;
        for (a, b) in was.chunks(64).zip(now.chunks(64)) {
            if a != b {
                count += a.iter().zip(b).filter(|(x, y)| x != y).count();
                if count > limit {
                    break;
                }
            }
        }
        if count == 0 {
            return Back::Same;
        }
        if count > limit {
            // A byte an agent when its changes are few and the column wider.
            let back = match (size_of::<T>() > 1).then(|| coded(was, now)).flatten() {
                Some((table, codes)) => Back::Coded(table, codes),
                None => Back::Whole(was.clone()),
            };
            was.copy_from_slice(now);
            return back;
        }
        let (mut ids, mut old) = (Vec::with_capacity(count), Vec::with_capacity(count));
        for (k, (a, b)) in was.chunks_mut(64).zip(now.chunks(64)).enumerate() {
            if a == b {
                continue;
            }
            for (j, (x, y)) in a.iter_mut().zip(b).enumerate() {
                if x != y {
                    ids.push((k * 64 + j) as u32);
                    old.push(std::mem::replace(x, *y));
                }
            }
        }
        Back::Some(ids, old)
    }

    /// The most changed agents worth listing: a listed one costs an id too.
    fn limit(n: usize) -> usize {
        n * size_of::<T>() / (4 + size_of::<T>())
    }

    /// Puts the earlier values back.
    fn rewind(&self, v: &mut Vec<T>) -> Result<(), Mismatch> {
        match self {
            Back::Same => {}
            Back::Some(ids, old) => {
                for (&i, &x) in ids.iter().zip(old) {
                    *v.get_mut(i as usize).ok_or(Mismatch)? = x;
                }
            }
            Back::Whole(w) => v.clone_from(w),
            Back::Coded(table, codes) => {
                if codes.len() != v.len() {
                    return Err(Mismatch);
                }
                for (a, &c) in v.iter_mut().zip(codes) {
                    *a = T::undo(*a, *table.get(c as usize).ok_or(Mismatch)?);
                }
            }
        }
        Ok(())
    }

    fn bytes(&self) -> usize {
        match self {
            Back::Same => 0,
            Back::Some(ids, old) => ids.capacity() * 4 + old.capacity() * size_of::<T>(),
            Back::Whole(w) => w.capacity() * size_of::<T>(),
            Back::Coded(table, codes) => table.capacity() * size_of::<T>() + codes.capacity(),
        }
    }
}

/// A delta that does not fit the configuration it is put on (the history then steps
/// again from a keyframe instead).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Mismatch;

/// A counter or message column's earlier values.
#[derive(Debug, Clone)]
enum ColBack {
    W16(Back<i16>),
    W32(Back<i32>),
    Whole(Column),
}

impl ColBack {
    fn of(was: &mut Column, now: &Column) -> ColBack {
        match (was, now) {
            (Column::W16(a), Column::W16(b)) => {
                ColBack::W16(Back::of(a, b, Back::<i16>::limit(b.len())))
            }
            (Column::W32(a), Column::W32(b)) => {
                ColBack::W32(Back::of(a, b, Back::<i32>::limit(b.len())))
            }
            (was, now) => ColBack::Whole(std::mem::replace(was, now.clone())),
        }
    }

    fn rewind(&self, c: &mut Column) -> Result<(), Mismatch> {
        match (self, c) {
            (ColBack::W16(b), Column::W16(v)) => b.rewind(v),
            (ColBack::W32(b), Column::W32(v)) => b.rewind(v),
            (ColBack::Whole(w), c) => {
                c.clone_from(w);
                Ok(())
            }
            _ => Err(Mismatch),
        }
    }

    fn bytes(&self) -> usize {
        match self {
            ColBack::W16(b) => b.bytes(),
            ColBack::W32(b) => b.bytes(),
            ColBack::Whole(c) => c.bytes(),
        }
    }
}

/// A list of columns' earlier values: column by column, or the whole list when their
/// number changed.
#[derive(Debug, Clone)]
enum ColsBack {
    Each(Vec<ColBack>),
    Whole(Vec<Column>),
}

impl ColsBack {
    fn of(was: &mut Vec<Column>, now: &[Column]) -> ColsBack {
        if was.len() != now.len() {
            return ColsBack::Whole(std::mem::replace(was, now.to_vec()));
        }
        ColsBack::Each(
            was.iter_mut()
                .zip(now)
                .map(|(a, b)| ColBack::of(a, b))
                .collect(),
        )
    }

    fn rewind(&self, cols: &mut Vec<Column>) -> Result<(), Mismatch> {
        match self {
            ColsBack::Each(each) if each.len() == cols.len() => {
                each.iter().zip(cols).try_for_each(|(b, c)| b.rewind(c))
            }
            ColsBack::Each(_) => Err(Mismatch),
            ColsBack::Whole(w) => {
                cols.clone_from(w);
                Ok(())
            }
        }
    }

    fn bytes(&self) -> usize {
        match self {
            ColsBack::Each(each) => each.iter().map(ColBack::bytes).sum(),
            ColsBack::Whole(w) => w.iter().map(Column::bytes).sum(),
        }
    }
}

/// Positions' earlier values: as [`Back`], or, when every changed agent moved at most 127
/// cells along each axis, as how far back each moved: listed (7 bytes a mover), or one
/// byte an agent naming one of a step's few distinct moves.
#[derive(Debug, Clone)]
enum PosBack {
    Far(Back<[i32; 3]>),
    /// The agents that moved, and each one's earlier position less its new one.
    Near(Vec<u32>, Vec<[i8; 3]>),
    /// Per agent, an index into the moves (0: it did not move).
    Coded(Vec<[i8; 3]>, Vec<u8>),
}

impl PosBack {
    fn of(was: &mut Vec<[i32; 3]>, now: &[[i32; 3]]) -> PosBack {
        let n = now.len();
        if was.len() != n {
            return PosBack::Far(Back::Whole(std::mem::replace(was, now.to_vec())));
        }
        let fits = |x: &[i32; 3], y: &[i32; 3]| {
            (0..3).all(|k| i8::try_from(x[k] as i64 - y[k] as i64).is_ok())
        };
        let back = |x: &[i32; 3], y: &[i32; 3]| [0, 1, 2].map(|k| x[k].wrapping_sub(y[k]) as i8);
        // One pass: per agent, the code of how far back it moved (0: not), a step having
        // few distinct moves; or how many moved, when one moved far or the moves are too
        // many to code.
        let mut table = vec![[0i8; 3]];
        let mut codes: Vec<u8> = Vec::with_capacity(n);
        let (mut count, mut coded) = (0usize, true);
        let mut last = ([0i8; 3], 0u8);
        for (a, b) in was.chunks(64).zip(now.chunks(64)) {
            if a == b {
                codes.extend_from_slice(&[0; 64][..a.len()]);
                continue;
            }
            for (x, y) in a.iter().zip(b) {
                if x == y {
                    codes.push(0);
                    continue;
                }
                count += 1;
                coded &= fits(x, y);
                if !coded {
                    continue;
                }
                let d = back(x, y);
                if d != last.0 {
                    let c = match table.iter().position(|&t| t == d) {
                        Some(c) => c,
                        None => {
                            table.push(d);
                            table.len() - 1
                        }
                    };
                    coded &= c < 256;
                    last = (d, c as u8);
                }
                codes.push(last.1);
            }
        }
        let kept = if count == 0 {
            return PosBack::Far(Back::Same);
        } else if !coded {
            return PosBack::Far(Back::of(was, now, Back::<[i32; 3]>::limit(n)));
        } else if count * 7 > n {
            PosBack::Coded(table, codes)
        } else {
            let ids: Vec<u32> = (codes.iter().enumerate())
                .filter(|(_, &c)| c != 0)
                .map(|(i, _)| i as u32)
                .collect();
            let d = ids
                .iter()
                .map(|&i| table[codes[i as usize] as usize])
                .collect();
            PosBack::Near(ids, d)
        };
        was.copy_from_slice(now);
        kept
    }

    fn rewind(&self, pos: &mut Vec<[i32; 3]>) -> Result<(), Mismatch> {
        let back = |p: &mut [i32; 3], d: &[i8; 3]| {
            for k in 0..3 {
                p[k] += d[k] as i32;
            }
        };
        match self {
            PosBack::Far(b) => b.rewind(pos)?,
            PosBack::Coded(table, codes) if codes.len() == pos.len() => {
                for (p, &c) in pos.iter_mut().zip(codes) {
                    back(p, table.get(c as usize).ok_or(Mismatch)?);
                }
            }
            PosBack::Coded(..) => return Err(Mismatch),
            PosBack::Near(ids, d) => {
                for (&i, d) in ids.iter().zip(d) {
                    back(pos.get_mut(i as usize).ok_or(Mismatch)?, d);
                }
            }
        }
        Ok(())
    }

    fn changed(&self) -> bool {
        !matches!(self, PosBack::Far(Back::Same))
    }

    fn bytes(&self) -> usize {
        match self {
            PosBack::Far(b) => b.bytes(),
            PosBack::Near(ids, d) => ids.capacity() * 4 + d.capacity() * 3,
            PosBack::Coded(table, codes) => table.capacity() * 3 + codes.capacity(),
        }
    }
}

/// The plan of senders of [`Pending`].
type SenderPlan = Vec<Option<Vec<(u32, u32)>>>;

/// Messages left with their senders, as they were: per column, the values sent where they
/// were sent and no longer are the same, and the sent bits.
#[derive(Debug, Clone)]
enum PendingBack {
    /// None before and after.
    Same,
    Sent {
        num: Vec<(Vec<u32>, Vec<i32>)>,
        has: Vec<Back<u64>>,
        full: Vec<bool>,
        empty: Vec<bool>,
        /// The plan of senders, when it changed.
        plan: Option<SenderPlan>,
    },
    Whole(Option<Pending>),
}

impl PendingBack {
    fn of(was: &mut Option<Pending>, now: &Option<Pending>) -> PendingBack {
        let (w, n) = match (was.as_mut(), now) {
            (None, None) => return PendingBack::Same,
            (Some(w), Some(n))
                if w.num.len() == n.num.len()
                    && w.has.len() == n.has.len()
                    && (w.num.iter().zip(&n.num))
                        .all(|(a, b)| a.width() == b.width() && a.len() == b.len())
                    && (w.has.iter().zip(&n.has)).all(|(a, b)| a.len() == b.len()) =>
            {
                (w, n)
            }
            _ => return PendingBack::Whole(std::mem::replace(was, now.clone())),
        };
        let mut num = Vec::with_capacity(w.num.len());
        for c in 0..w.num.len() {
            let (mut ids, mut old) = (Vec::new(), Vec::new());
            for (k, (&hw, &hn)) in w.has[c].iter().zip(&n.has[c]).enumerate() {
                let mut bits = hw;
                while bits != 0 {
                    let i = k * 64 + bits.trailing_zeros() as usize;
                    bits &= bits - 1;
                    let v = w.num[c].get(i);
                    if hn & (1 << (i & 63)) == 0 || n.num[c].get(i) != v {
                        ids.push(i as u32);
                        old.push(v);
                    }
                }
            }
            num.push((ids, old));
        }
        let has = (w.has.iter_mut().zip(&n.has))
            .map(|(a, b)| Back::of(a, b, Back::<u64>::limit(b.len())))
            .collect();
        let plan = (w.plan != n.plan).then(|| std::mem::replace(&mut w.plan, n.plan.clone()));
        let full = std::mem::replace(&mut w.full, n.full.clone());
        let empty = std::mem::replace(&mut w.empty, n.empty.clone());
        for (a, b) in w.num.iter_mut().zip(&n.num) {
            a.clone_from(b);
        }
        PendingBack::Sent {
            num,
            has,
            full,
            empty,
            plan,
        }
    }

    fn rewind(&self, p: &mut Option<Pending>) -> Result<(), Mismatch> {
        match (self, p.as_mut()) {
            (PendingBack::Same, None) => Ok(()),
            (PendingBack::Whole(w), _) => {
                p.clone_from(w);
                Ok(())
            }
            (
                PendingBack::Sent {
                    num,
                    has,
                    full,
                    empty,
                    plan,
                },
                Some(p),
            ) if p.num.len() == num.len() && p.has.len() == has.len() => {
                for ((ids, old), col) in num.iter().zip(&mut p.num) {
                    for (&i, &v) in ids.iter().zip(old) {
                        if i as usize >= col.len() {
                            return Err(Mismatch);
                        }
                        col.set(i as usize, v);
                    }
                }
                for (b, h) in has.iter().zip(&mut p.has) {
                    b.rewind(h)?;
                }
                p.full.clone_from(full);
                p.empty.clone_from(empty);
                if let Some(plan) = plan {
                    p.plan.clone_from(plan);
                }
                Ok(())
            }
            _ => Err(Mismatch),
        }
    }

    fn bytes(&self) -> usize {
        match self {
            PendingBack::Same => 0,
            PendingBack::Sent { num, has, plan, .. } => {
                num.iter()
                    .map(|(i, o)| i.capacity() * 4 + o.capacity() * 4)
                    .sum::<usize>()
                    + has.iter().map(Back::bytes).sum::<usize>()
                    + plan
                        .iter()
                        .flatten()
                        .flatten()
                        .map(|s| s.capacity() * 8)
                        .sum::<usize>()
            }
            PendingBack::Whole(w) => w.as_ref().map_or(0, |p| {
                p.num.iter().map(Column::bytes).sum::<usize>()
                    + p.has.iter().map(|h| h.capacity() * 8).sum::<usize>()
            }),
        }
    }
}

/// Which counters and slots have columns, and their width.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Layout {
    counter_col: [u8; 45],
    width: Width,
    slot_col: [u8; 8],
    slots: u8,
}

impl Layout {
    fn of(lat: &Lattice) -> Layout {
        Layout {
            counter_col: lat.counter_col,
            width: lat.width,
            slot_col: lat.slot_col,
            slots: lat.slots,
        }
    }
}

/// What one step changed, as it was before: put back with [`Lattice::rewind`].
#[derive(Debug, Clone)]
pub struct Delta {
    layout: Layout,
    pos: PosBack,
    state: Back<[u8; 5]>,
    attach: Back<u8>,
    counters: ColsBack,
    inbox_num: ColsBack,
    inbox_text: Back<[u8; 5]>,
    inbox_text_has: Back<u8>,
    pending: PendingBack,
}

impl Delta {
    /// Bytes held, about.
    pub fn bytes(&self) -> usize {
        size_of::<Delta>()
            + self.pos.bytes()
            + self.state.bytes()
            + self.attach.bytes()
            + self.counters.bytes()
            + self.inbox_num.bytes()
            + self.inbox_text.bytes()
            + self.inbox_text_has.bytes()
            + self.pending.bytes()
    }
}

/// A copy of what steps change in a lattice (no cell index), kept one step behind to find
/// what the next step changed ([`Shadow::advance`]).
#[derive(Debug, Clone)]
pub struct Shadow {
    layout: Layout,
    pos: Vec<[i32; 3]>,
    state: Vec<[u8; 5]>,
    attach: Vec<u8>,
    counters: Vec<Column>,
    inbox_num: Vec<Column>,
    inbox_text: Vec<[u8; 5]>,
    inbox_text_has: Vec<u8>,
    pending: Option<Pending>,
}

impl Shadow {
    /// A copy of `lat`'s columns.
    pub fn of(lat: &Lattice) -> Shadow {
        Shadow {
            layout: Layout::of(lat),
            pos: lat.pos.clone(),
            state: lat.state.clone(),
            attach: lat.attach.clone(),
            counters: lat.counters.clone(),
            inbox_num: lat.inbox_num.clone(),
            inbox_text: lat.inbox_text.clone(),
            inbox_text_has: lat.inbox_text_has.clone(),
            pending: lat.pending.clone(),
        }
    }

    /// What changed from the copy to `lat` (the copy's values), and the copy made `lat`'s.
    pub fn advance(&mut self, lat: &Lattice) -> Delta {
        // The positions on a second thread while this one does the rest, when there are
        // many agents (a million agents' columns are compared in about 10 ms, read and
        // written at the memory's pace).
        let mut pos = std::mem::take(&mut self.pos);
        let (back, delta) = if lat.len() < 1 << 16 {
            (
                PosBack::of(&mut pos, &lat.pos),
                self.advance_but_positions(lat),
            )
        } else {
            std::thread::scope(|sc| {
                let h = sc.spawn(|| PosBack::of(&mut pos, &lat.pos));
                let delta = self.advance_but_positions(lat);
                (h.join().expect("comparing positions does not panic"), delta)
            })
        };
        self.pos = pos;
        Delta { pos: back, ..delta }
    }

    /// [`Shadow::advance`] of all but the positions (left unchanged in the delta).
    fn advance_but_positions(&mut self, lat: &Lattice) -> Delta {
        Delta {
            layout: std::mem::replace(&mut self.layout, Layout::of(lat)),
            pos: PosBack::Far(Back::Same),
            state: Back::of(
                &mut self.state,
                &lat.state,
                Back::<[u8; 5]>::limit(lat.len()),
            ),
            attach: Back::of(&mut self.attach, &lat.attach, Back::<u8>::limit(lat.len())),
            counters: ColsBack::of(&mut self.counters, &lat.counters),
            inbox_num: ColsBack::of(&mut self.inbox_num, &lat.inbox_num),
            inbox_text: Back::of(
                &mut self.inbox_text,
                &lat.inbox_text,
                Back::<[u8; 5]>::limit(lat.inbox_text.len()),
            ),
            inbox_text_has: Back::of(
                &mut self.inbox_text_has,
                &lat.inbox_text_has,
                Back::<u8>::limit(lat.inbox_text_has.len()),
            ),
            pending: PendingBack::of(&mut self.pending, &lat.pending),
        }
    }

    /// Bytes held, about.
    pub fn bytes(&self) -> usize {
        self.pos.capacity() * 12
            + self.state.capacity() * 5
            + self.attach.capacity()
            + self.counters.iter().map(Column::bytes).sum::<usize>()
            + self.inbox_num.iter().map(Column::bytes).sum::<usize>()
            + self.inbox_text.capacity() * 5
            + self.inbox_text_has.capacity()
            + self.pending.as_ref().map_or(0, |p| {
                p.num.iter().map(Column::bytes).sum::<usize>()
                    + p.has.iter().map(|h| h.capacity() * 8).sum::<usize>()
            })
    }
}

impl Lattice {
    /// Puts back what `deltas` changed, the latest first: each the delta of the step that
    /// led to the configuration it is put on. The cell index is made again once, at the
    /// end, when positions came back. On a [`Mismatch`] the lattice is left part-way, to
    /// be dropped.
    pub(crate) fn rewind<'a>(
        &mut self,
        deltas: impl IntoIterator<Item = &'a Delta>,
    ) -> Result<(), Mismatch> {
        let mut moved = false;
        for d in deltas {
            let l = d.layout;
            (self.counter_col, self.width, self.slot_col, self.slots) =
                (l.counter_col, l.width, l.slot_col, l.slots);
            d.pos.rewind(&mut self.pos)?;
            moved |= d.pos.changed();
            d.state.rewind(&mut self.state)?;
            d.attach.rewind(&mut self.attach)?;
            d.counters.rewind(&mut self.counters)?;
            d.inbox_num.rewind(&mut self.inbox_num)?;
            d.inbox_text.rewind(&mut self.inbox_text)?;
            d.inbox_text_has.rewind(&mut self.inbox_text_has)?;
            d.pending.rewind(&mut self.pending)?;
        }
        let n = self.pos.len();
        if self.state.len() != n || self.attach.len() != n {
            return Err(Mismatch);
        }
        if moved {
            let (cells, _, code) = CellIndex::new_coded(&self.pos, self.shape());
            (self.cells, self.code) = (cells, code);
            self.nbr_valid = false;
            self.regrow_at = self.first_regrow();
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lattice(pos: &[[i32; 3]]) -> Lattice {
        let mut b = LatticeBuilder::new(Dim::Two, None, pos.len());
        for &p in pos {
            b.push(p, *b"A0000", 0, &[(0, p[0])]);
        }
        b.finish()
    }

    /// Positions moved by steps of every kind come back: a few near, most near (coded),
    /// far (past an i8, wrapping to a near one), and more distinct moves than a byte codes.
    #[test]
    fn positions_come_back_whatever_the_moves() {
        let n = 600;
        let start: Vec<[i32; 3]> = (0..n).map(|i| [i * 3, 0, 0]).collect();
        let moves: Vec<Box<dyn Fn(i32) -> [i32; 3]>> = vec![
            Box::new(|i| [i * 3 + (i % 50 == 0) as i32, 0, 0]),
            Box::new(|i| [i * 3, 1, 0]),
            Box::new(|i| [i * 3 + if i == 7 { 256 } else { 0 }, 1, 0]),
            Box::new(|i| [i * 3, 1 + i % 300, 0]),
            Box::new(|i| [i * 3, 1 - i, 0]),
        ];
        for (k, m) in moves.iter().enumerate() {
            let before = lattice(&start);
            let mut shadow = Shadow::of(&before);
            let after = lattice(&(0..n).map(m).collect::<Vec<_>>());
            let delta = shadow.advance(&after);
            assert_eq!(shadow.pos, after.pos);
            let mut back = after.clone();
            back.rewind([&delta]).unwrap();
            assert_eq!(back.pos, before.pos, "moves {k}: {:?}", delta.pos);
            assert_eq!(
                back.agent_at([3, 0, 0]),
                Some(1),
                "the cell index made again"
            );
            assert!(
                delta.bytes() < n as usize * 16,
                "moves {k}: {} bytes",
                delta.bytes()
            );
        }
    }

    /// A step that changes most agents of a long column (states, a counter, positions)
    /// by a few kinds of change is kept a byte an agent, and comes back exactly.
    #[test]
    fn columns_mostly_changed_come_back_from_coded_deltas() {
        let n = 40_000;
        let start: Vec<[i32; 3]> = (0..n).map(|i| [i % 200, 2 * (i / 200), 0]).collect();
        let before = lattice(&start);
        let mut shadow = Shadow::of(&before);
        let mut after = before.clone();
        for i in 0..n as usize {
            if i % 10 != 3 {
                after.state[i] = *b"B0000";
                let col = after.counter_col[0] as usize;
                let v = after.counters[col].get(i);
                after.counters[col].set(i, v - 1);
                after.pos[i][1] += 1;
            }
        }
        let delta = shadow.advance(&after);
        assert!(
            matches!(delta.state, Back::Coded(..)),
            "{:?}",
            delta.state.bytes()
        );
        let parts = (
            delta.pos.bytes(),
            delta.state.bytes(),
            delta.counters.bytes(),
        );
        // A byte an agent each (the columns are 12, 5 and 2 bytes an agent).
        let most = n as usize + 256;
        assert!(
            parts.0 <= most && parts.1 <= most && parts.2 <= most,
            "{parts:?}"
        );
        let mut back = after.clone();
        back.rewind([&delta]).unwrap();
        assert_eq!(back.pos, before.pos);
        assert_eq!(back.state, before.state);
        assert_eq!(back.counters, before.counters);
    }
}
