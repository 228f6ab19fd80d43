//! Steps 1 to 4 of the actions when every group is one agent ([`Act::move_alone`]): the
//! movers' targets, the collisions judged, and the moves made, in chunks of movers on the
//! pool when it pays. What threads share they write by atomic instructions (the marks of
//! targets and movers, the grid's occupancy bits) or not at all (each mover's position and
//! cell are its chunk's; no two movers share a target, and a mover's old cell is emptied
//! only when no mover targets it); everything that is recorded, counted or listed is
//! joined in the movers' order, so a step is the same for any split.

use super::moves::collision_text;
use super::*;
use crate::lattice::{BitLog, Bits, Placed};
use std::sync::atomic::{AtomicU64, Ordering::Relaxed};

/// A set of indices (cells, agents), with a second mark for those marked more than once.
/// Atomics, so that chunks mark at once; clear between steps.
#[derive(Default)]
pub(super) struct Twice {
    once: Vec<AtomicU64>,
    twice: Vec<AtomicU64>,
}

/// Sets bits `b` of `word`, returning it as it was: by an atomic instruction when
/// `shared` (chunks mark at once), else by a load and a store.
#[inline]
fn or(word: &AtomicU64, b: u64, shared: bool) -> u64 {
    match shared {
        true => word.fetch_or(b, Relaxed),
        false => {
            let v = word.load(Relaxed);
            word.store(v | b, Relaxed);
            v
        }
    }
}

impl Twice {
    /// Sizes the marks for indices below `n` (all clear).
    pub(super) fn size(&mut self, n: usize) {
        if self.once.len() != n.div_ceil(64) {
            self.once = zeros(n);
            self.twice = zeros(n);
        }
    }

    /// Marks `i` (a second time: marks it twice).
    #[inline]
    pub(super) fn mark(&self, i: usize, shared: bool) {
        let (w, b) = bit(i);
        if or(&self.once[w], b, shared) & b != 0 {
            or(&self.twice[w], b, shared);
        }
    }

    #[inline]
    pub(super) fn once(&self, i: usize) -> bool {
        let (w, b) = bit(i);
        self.once[w].load(Relaxed) & b != 0
    }

    #[inline]
    pub(super) fn twice(&self, i: usize) -> bool {
        let (w, b) = bit(i);
        self.twice[w].load(Relaxed) & b != 0
    }

    /// Clears `i`'s marks (one thread).
    pub(super) fn unmark(&self, i: usize) {
        let (w, b) = bit(i);
        self.once[w].store(self.once[w].load(Relaxed) & !b, Relaxed);
        self.twice[w].store(self.twice[w].load(Relaxed) & !b, Relaxed);
    }

    /// Clears the marks of `i` and of the indices beside it, its whole word (when
    /// every index marked is cleared so, this clears all).
    #[inline]
    pub(super) fn clear_around(&self, i: usize) {
        self.once[i / 64].store(0, Relaxed);
        self.twice[i / 64].store(0, Relaxed);
    }
}

/// `n` clear bits.
fn zeros(n: usize) -> Vec<AtomicU64> {
    (0..n.div_ceil(64)).map(|_| AtomicU64::new(0)).collect()
}

/// Marks for deciding moves and swaps, clear between steps: per grid cell, whether movers
/// target it (once, or more); per agent, whether it is moving; per agent, whether it is
/// in swaps (once, or more).
#[derive(Default)]
pub(super) struct MoveScratch {
    cells: Twice,
    moving: Vec<AtomicU64>,
    pub(super) paired: Twice,
}

impl MoveScratch {
    /// Sizes the marks for `cells` grid cells and `agents` agents (all clear).
    pub(super) fn size(&mut self, cells: usize, agents: usize) {
        self.cells.size(cells);
        if self.moving.len() != agents.div_ceil(64) {
            self.moving = zeros(agents);
        }
    }

    /// Marks agent `a` as moving, and its target's grid slot `s` (if any) as claimed: by
    /// atomic instructions when `shared` (chunks claim at once), else by loads and stores.
    #[inline]
    pub(super) fn claim(&self, a: u32, s: Option<usize>, shared: bool) {
        let (w, b) = bit(a as usize);
        or(&self.moving[w], b, shared);
        if let Some(s) = s {
            self.cells.mark(s, shared);
        }
    }

    #[inline]
    pub(super) fn moving(&self, a: u32) -> bool {
        let (w, b) = bit(a as usize);
        self.moving[w].load(Relaxed) & b != 0
    }

    #[inline]
    pub(super) fn claimed(&self, s: usize) -> bool {
        self.cells.once(s)
    }

    #[inline]
    pub(super) fn claimed_twice(&self, s: usize) -> bool {
        self.cells.twice(s)
    }

    /// Clears slot `s`'s claims (one thread).
    pub(super) fn unmark(&self, s: usize) {
        self.cells.unmark(s);
    }

    /// Clears what [`MoveScratch::claim`] marked (whole words: nothing else is marked).
    #[inline]
    pub(super) fn unclaim(&self, a: u32, s: Option<usize>) {
        self.moving[a as usize / 64].store(0, Relaxed);
        if let Some(s) = s {
            self.cells.clear_around(s);
        }
    }
}

/// Which mover targets a cell (one, but where the first round of collisions cancels them
/// all), for the later rounds: when every mover moves by one offset, the mover standing
/// that far back (found on the grid, no map made); else a map of every target.
pub(super) enum Targets {
    One([i32; 3]),
    Map(FxHashMap<[i32; 3], u32>),
}

impl Targets {
    /// Of `movers` (agent, target).
    pub(super) fn of(
        lat: &Lattice,
        movers: impl Iterator<Item = (u32, [i32; 3])> + Clone,
    ) -> Targets {
        let off = |(a, t): (u32, [i32; 3])| {
            let p = lat.pos[a as usize];
            [t[0] - p[0], t[1] - p[1], t[2] - p[2]]
        };
        let first = movers.clone().next().map(off);
        match first {
            Some(o) if movers.clone().all(|m| off(m) == o) => Targets::One(o),
            _ => Targets::Map(movers.map(|(a, t)| (t, a)).collect()),
        }
    }

    /// The mover that targets cell `p`, if any (`marks`: the movers).
    pub(super) fn at(&self, lat: &Lattice, marks: &MoveScratch, p: [i32; 3]) -> Option<u32> {
        match self {
            Targets::One(o) => {
                let back = |i: usize| p[i].checked_sub(o[i]);
                let back = [back(0)?, back(1)?, back(2)?];
                lat.agent_at(back).filter(|&m| marks.moving(m))
            }
            Targets::Map(map) => map.get(&p).copied(),
        }
    }
}

/// The grid slot of a slot code, if the code is on the grid.
#[inline]
pub(super) fn slot(code: u32) -> Option<usize> {
    (code != NO_SLOT).then_some((code & !RIM) as usize)
}

/// One chunk of movers (kept between steps for their allocations).
#[derive(Default)]
pub(super) struct AlonePart {
    /// Movers (in agent order) with their targets, and the targets' slot codes.
    live: Vec<(u32, [i32; 3])>,
    codes: Vec<u32>,
    /// Movers whose targets lie outside the universe, with their offsets.
    blocked: Vec<(u32, [i32; 3])>,
    /// Every target was seen empty (looked at only for movers by one offset).
    empty: bool,
    /// Movers that would collide, with their targets, in mover order.
    bad: Vec<([i32; 3], u32)>,
    /// The cells the movers leave (for the activity), and their moves (traced).
    notes: Vec<Moved>,
    trace: Vec<TraceEvent>,
    /// Movers from and to cells outside the grid (see
    /// [`crate::lattice::Relocation::part`]).
    outside: Vec<Placed>,
    leaving: Vec<Placed>,
    /// The occupancy bits its moves change, when parts move at once.
    bits: BitLog,
}

/// Runs `f` on each chunk's part, on the pool when the split `par` has one.
fn each(
    par: Option<(&Workers, usize)>,
    parts: &mut [AlonePart],
    f: impl Fn((usize, &mut AlonePart)) + Sync,
) {
    map_on(par, parts.iter_mut().enumerate().collect(), f);
}

impl AlonePart {
    /// The part's movers: movers decided elsewhere (agent, target, the target's slot
    /// code), in agent order, for [`Act::move_parts`].
    pub(super) fn set_moves(&mut self, moves: &[(u32, [i32; 3], u32)]) {
        self.live.clear();
        self.live.extend(moves.iter().map(|&(a, t, _)| (a, t)));
        self.codes.clear();
        self.codes.extend(moves.iter().map(|m| m.2));
    }

    /// The targets of the movers in `live` (given with their offsets, which the targets
    /// replace), and whether they are empty when `look_empty`.
    fn targets(&mut self, lat: &Lattice, look_empty: bool) {
        self.codes.clear();
        self.blocked.clear();
        self.empty = look_empty;
        let mut kept = 0;
        for i in 0..self.live.len() {
            let (a, o) = self.live[i];
            match lat.moved(lat.pos[a as usize], o) {
                Some(t) => {
                    let c = lat.cells.code(t);
                    self.empty = self.empty
                        && match slot(c) {
                            Some(s) => !lat.cells.filled_slot(s),
                            None => lat.agent_beside(a, o, t).is_none(),
                        };
                    self.live[kept] = (a, t);
                    self.codes.push(c);
                    kept += 1;
                }
                None => self.blocked.push((a, o)),
            }
        }
        self.live.truncate(kept);
    }

    fn claim(&self, marks: &MoveScratch, shared: bool) {
        for (&(a, _), &c) in self.live.iter().zip(&self.codes) {
            marks.claim(a, slot(c), shared);
        }
    }

    fn unclaim(&self, marks: &MoveScratch) {
        for (&(a, _), &c) in self.live.iter().zip(&self.codes) {
            marks.unclaim(a, slot(c));
        }
    }

    /// The movers whose target another mover claims too (`count`: movers per target
    /// outside the grid), or an agent holds that does not move.
    fn check(&mut self, lat: &Lattice, marks: &MoveScratch, count: &FxHashMap<[i32; 3], u32>) {
        self.bad.clear();
        for (&(a, t), &c) in self.live.iter().zip(&self.codes) {
            let bad = match slot(c) {
                Some(s) => {
                    marks.claimed_twice(s)
                        || (lat.cells.filled_slot(s) && !marks.moving(lat.cells.at_slot(s)))
                }
                None => count[&t] > 1 || lat.cells.get(t).is_some_and(|b| !marks.moving(b)),
            };
            if bad {
                self.bad.push((t, a));
            }
        }
    }

    /// The movers' notes (when `noting`) and trace events (when `tracing`), before they
    /// move.
    fn note(&mut self, lat: &Lattice, (noting, tracing): (bool, bool)) {
        self.notes.clear();
        self.trace.clear();
        if noting {
            (self.notes).extend(
                self.live
                    .iter()
                    .map(|&(a, _)| (a, lat.pos[a as usize], lat.code_of(a))),
            );
        }
        if tracing {
            (self.trace).extend(self.live.iter().map(|&(a, to)| TraceEvent::Move {
                agent: a,
                from: lat.pos[a as usize],
                to,
            }));
        }
    }
}

impl Act<'_> {
    /// Steps 1 to 4 when no agent is attached and no rule attaches: every group is one
    /// agent, so only the movers (`live`, in agent order, with their offsets) are looked
    /// at (the same decisions and records as [`Act::detach_move_attach`]). Collisions
    /// cancel every move involved, round after round until none is left: the first round
    /// looks at every mover (targets claimed in bits per grid cell, once and more than
    /// once, where the grid covers them, counted in a hash map elsewhere; movers marked
    /// in bits per agent); a later round only at the movers whose targets the movers
    /// cancelled in the round before stand on (nothing else changes between rounds: a
    /// target claimed twice, or held by an agent that stays from the start, is found in
    /// the first), so a queue of movers cancelled one after another costs what it holds.
    pub(super) fn move_alone(&mut self, live: &mut Vec<(u32, [i32; 3])>, rep: &mut StepReport) {
        let one_offset = live.iter().all(|m| m.1 == live[0].1);
        let mut parts = std::mem::take(&mut self.bufs.alone);
        // (On the pool from 8,192 movers, the work per mover being light: gravity's movers
        // left by the moves at once, a few thousand a step, stay on this thread. B2F on
        // two threads 0.968x the time with 1,024, the cloud the same: six pairs each.)
        let (par, size, chunks) = self.threads.chunks_from(live.len(), 8 * AGENTS_PER_THREAD);
        let shared = par.is_some();
        parts.resize_with(chunks, AlonePart::default);
        // 1. The targets, reading only. (One chunk takes the movers' list as it is.)
        if chunks == 1 {
            std::mem::swap(live, &mut parts[0].live);
        }
        {
            let (lat, moves) = (&*self.lat, &live[..]);
            each(par, &mut parts, |(c, part)| {
                if chunks > 1 {
                    part.live.clear();
                    (part.live)
                        .extend_from_slice(&moves[c * size..((c + 1) * size).min(moves.len())]);
                }
                part.targets(lat, one_offset);
            });
        }
        for part in &parts {
            for &(a, o) in &part.blocked {
                let msg = |lat: &Lattice| {
                    format!(
                        "agent {} cannot move by {}: the target cell is blocked; its group does not move",
                        lat.label(a),
                        lat.cell_text(o)
                    )
                };
                self.record_with(rep, RecordKind::MoveBlocked, &[a], msg);
            }
        }
        // 2. Collisions. Movers by one offset have distinct targets; when every target is
        // empty, none is held by an agent that stays and none is a mover's old cell: no
        // marks are needed.
        let mut sc = std::mem::take(&mut self.bufs.scratch);
        sc.size(self.lat.cells.slots(), self.lat.len());
        let marked = !(one_offset && parts.iter().all(|p| p.empty));
        let mut cancelled: Vec<(u32, u32)> = Vec::new();
        if marked {
            let marks = &sc;
            each(par, &mut parts, |(_, part)| part.claim(marks, shared));
            let mut count: FxHashMap<[i32; 3], u32> = FxHashMap::default();
            for part in &parts {
                for (&(_, t), &c) in part.live.iter().zip(&part.codes) {
                    if c == NO_SLOT {
                        *count.entry(t).or_insert(0) += 1;
                    }
                }
            }
            let lat = &*self.lat;
            each(par, &mut parts, |(_, part)| part.check(lat, marks, &count));
            if parts.iter().any(|p| !p.bad.is_empty()) {
                cancelled = self.cancel_collisions(&mut parts, &sc, rep);
            }
        }
        // 3. The moves.
        let marks = &sc;
        self.move_parts(par, &mut parts, |s| marked && marks.claimed(s), rep);
        if marked {
            let marks = &sc;
            each(par, &mut parts, |(_, part)| part.unclaim(marks));
            for &(a, c) in &cancelled {
                sc.unclaim(a, slot(c));
            }
        }
        self.bufs.scratch = sc;
        if chunks == 1 {
            std::mem::swap(live, &mut parts[0].live);
        }
        live.clear();
        self.bufs.alone = parts;
    }

    /// The moves of the parts' movers (`live`, with their targets' slot codes), whose
    /// collisions are cancelled: their notes and trace events (before they move), their
    /// count, and the moves, through a [`crate::lattice::Relocation`] per part (on the
    /// pool when the split `par` has one; `targeted`: whether a grid slot is one of the
    /// targets), or [`Lattice::relocate`] without a grid.
    pub(super) fn move_parts(
        &mut self,
        par: Option<(&Workers, usize)>,
        parts: &mut [AlonePart],
        targeted: impl Fn(usize) -> bool + Sync,
        rep: &mut StepReport,
    ) {
        let noting = (self.bufs.changes.on, self.opts.trace);
        {
            let lat = &*self.lat;
            each(par, parts, |(_, part)| part.note(lat, noting));
        }
        for part in parts.iter_mut() {
            self.bufs.changes.moved.append(&mut part.notes);
            rep.trace.append(&mut part.trace);
            self.stats.moves += part.live.len() as u64;
        }
        let shared = par.is_some();
        match self.lat.relocation() {
            Some(r) => {
                let (r, targeted) = (&r, &targeted);
                let split = r.buckets(parts.len());
                each(par, parts, |(_, part)| {
                    part.outside.clear();
                    part.leaving.clear();
                    let AlonePart {
                        live,
                        codes,
                        outside,
                        leaving,
                        bits,
                        ..
                    } = part;
                    let bits = match shared {
                        true => {
                            bits.ready(split);
                            Bits::Log(bits)
                        }
                        false => Bits::Write,
                    };
                    // SAFETY: each mover is in one part; no two movers share a target
                    // (the collisions are cancelled), and a mover's old cell is emptied
                    // only when no mover targets it (`targeted`); nothing else uses the
                    // lattice meanwhile; one part at a time without the pool.
                    unsafe { r.part((live, codes), targeted, (outside, leaving), bits) };
                });
                if shared {
                    // The occupancy bits, a range of words per bucket, each bucket on
                    // one thread from every part's log.
                    let logs: Vec<&BitLog> = parts.iter().map(|p| &p.bits).collect();
                    // SAFETY: after every part; bucket `b`'s words are written here alone;
                    // nothing else uses the lattice meanwhile.
                    map_on(par, (0..split.1).collect(), |b| unsafe {
                        r.apply(&logs, b)
                    });
                }
                let outside = parts.iter().flat_map(|p| &p.outside);
                let leaving = parts.iter().flat_map(|p| &p.leaving);
                self.lat.relocated(outside, leaving);
            }
            None => {
                let all: Vec<(u32, [i32; 3])> =
                    parts.iter().flat_map(|p| p.live.iter().copied()).collect();
                self.lat.relocate(&all);
            }
        }
    }

    /// Records a round of collisions (`round`: target and mover, in the movers' order):
    /// one record per cell where agents would meet, in the cells' order, naming its movers
    /// and the agent standing there when it stays (`stays`). Returns the round's movers,
    /// cell by cell, for the caller to cancel.
    pub(super) fn record_collisions(
        &mut self,
        round: &mut [([i32; 3], u32)],
        stays: impl Fn(u32) -> bool,
        rep: &mut StepReport,
    ) -> Vec<u32> {
        round.sort_by_key(|m| m.0);
        let mut movers = Vec::with_capacity(round.len());
        let mut involved = Vec::new();
        for at in round.chunk_by(|a, b| a.0 == b.0) {
            let (cell, first) = (at[0].0, movers.len());
            movers.extend(at.iter().map(|m| m.1));
            involved.clear();
            involved.extend_from_slice(&movers[first..]);
            involved.extend(self.lat.agent_at(cell).filter(|&s| stays(s)));
            let ms = &movers[first..];
            let msg = |lat: &Lattice| collision_text(lat, cell, ms, &involved);
            self.record_with(rep, RecordKind::MoveCollision, &involved, msg);
        }
        movers
    }

    /// The collision rounds (see [`Act::move_alone`]), from the first round's movers that
    /// would collide (the parts' `bad`): records made, one per cell where agents would
    /// meet, naming them all, round by round in the order of the cells; the movers
    /// cancelled are taken out of the parts, and their claims cleared (every other mover
    /// that claimed their targets is cancelled too). Returns the movers cancelled, with
    /// their targets' slot codes.
    fn cancel_collisions(
        &mut self,
        parts: &mut [AlonePart],
        marks: &MoveScratch,
        rep: &mut StepReport,
    ) -> Vec<(u32, u32)> {
        let movers = parts.iter().flat_map(|p| p.live.iter().copied());
        let targets = Targets::of(self.lat, movers);
        let mut gone: rustc_hash::FxHashSet<u32> = Default::default();
        let mut round: Vec<([i32; 3], u32)> =
            parts.iter().flat_map(|p| p.bad.iter().copied()).collect();
        while !round.is_empty() {
            // Agents that stay: not moving from the start, or cancelled before.
            let stays = |s: u32| !marks.moving(s) || gone.contains(&s);
            let now = self.record_collisions(&mut round, stays, rep);
            gone.extend(now.iter().copied());
            // The next round: the movers whose targets those cancelled now stand on.
            round.clear();
            for &a in &now {
                let p = self.lat.pos[a as usize];
                if let Some(m) = (targets.at(self.lat, marks, p)).filter(|m| !gone.contains(m)) {
                    round.push((p, m));
                }
            }
            round.sort_unstable_by_key(|&(_, m)| m);
        }
        let mut cancelled = Vec::with_capacity(gone.len());
        for part in parts.iter_mut() {
            let mut k = 0;
            for i in 0..part.live.len() {
                let (a, c) = (part.live[i].0, part.codes[i]);
                if gone.contains(&a) {
                    cancelled.push((a, c));
                    if let Some(s) = slot(c) {
                        marks.unmark(s);
                    }
                } else {
                    part.live[k] = part.live[i];
                    part.codes[k] = c;
                    k += 1;
                }
            }
            part.live.truncate(k);
            part.codes.truncate(k);
        }
        cancelled
    }
}
