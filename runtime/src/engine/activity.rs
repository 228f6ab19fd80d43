//! Activity: which agents the next selection evaluates. An agent that had no valid rule at
//! its last evaluation ("quiet") would have none again while nothing it reads changes, so
//! it is skipped until something does: its own state, counters or bonds, its inbox, or a
//! cell at an offset some precondition reads ([`Reads`], from the plan). Every change of
//! a step wakes the agents that read it, and the next selection evaluates only the agents
//! woken (in id order); the others keep their entry `NO_RULE`. The results are exactly
//! those of evaluating everyone (`Skip::Off`), which the differential tests check.
//!
//! What wakes an agent for the next step:
//! - it had a valid rule (it executes, or may with priorities): it is evaluated again;
//! - it moved (alone, carried or swapped): itself, and the readers of its old and new
//!   cells (the agents at those cells minus each occupancy offset);
//! - its state changed: the readers of its state (state offsets);
//! - it calculated: the readers of its counters (counter offsets);
//! - its bonds changed, when a precondition reads bonds;
//! - it received a message in the last delivery or the one before (its inbox changed);
//! - its state has a rule whose offsets depend on a counter: at every step.
//!
//! When more than an eighth of the agents are woken (or with priority terms, or after a
//! selection kept from the step before), the next selection evaluates every agent, as
//! without skipping: its dense paths are faster than a list that long.

use super::*;
use crate::cells::{Grid, EMPTY};
use crate::lattice::drop_agents;

/// Whether quiet agents are skipped.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Skip {
    /// Skip quiet agents, and evaluate everyone when many are woken (the default).
    #[default]
    Auto,
    /// Evaluate every agent at every step.
    Off,
    /// Skip quiet agents whenever any is quiet, however many are woken (for tests: the
    /// lists of woken agents are used even on small lattices).
    Eager,
}

/// A share of the agents: more woken than `n / SPARSE_SHARE`, and the next selection
/// evaluates every agent. (B2 at W = 1000 on one thread, best of five: a half 1.67 s, a
/// quarter 1.14 s, an eighth 1.07 s, a sixteenth 1.10 s: a listed agent costs several
/// times what one in a pass over all does.)
pub(super) const SPARSE_SHARE: usize = 8;

/// A set of agents as a bit per agent and a bit per word of those, with the span of the
/// words of those that hold any (so that taking the set in order costs its size and the
/// span, not `n`: the walkers beside 10^7 agents at rest spent 2.8 µs a step on the words
/// of 10^7 agents), with its count; `all` once it holds more than `limit`.
pub(super) struct WakeSet {
    words: Vec<u64>,
    tops: Vec<u64>,
    /// The words of `tops` that may have a bit set are `span.0..span.1`.
    span: (usize, usize),
    count: usize,
    limit: usize,
    pub(super) all: bool,
}

impl Default for WakeSet {
    fn default() -> WakeSet {
        WakeSet {
            words: Vec::new(),
            tops: Vec::new(),
            span: (usize::MAX, 0),
            count: 0,
            limit: 0,
            all: false,
        }
    }
}

impl WakeSet {
    /// A set of agents that turns into "all" beyond `limit`, "all" now; its bits are
    /// made for `n` agents by [`WakeSet::ready`] (runs that evaluate every agent at every
    /// step never need them).
    fn new(limit: usize) -> WakeSet {
        WakeSet {
            limit,
            all: true,
            ..WakeSet::default()
        }
    }

    /// Makes the bits for `n` agents, if not made yet.
    fn ready(&mut self, n: usize) {
        if self.words.is_empty() && n > 0 {
            self.words = vec![0; n.div_ceil(64)];
            self.tops = vec![0; n.div_ceil(64).div_ceil(64)];
        }
    }

    /// Adds agent `a`.
    #[inline]
    pub(super) fn add(&mut self, a: u32) {
        if self.all {
            return;
        }
        let (w, b) = (a as usize / 64, 1u64 << (a % 64));
        let word = &mut self.words[w];
        if *word & b == 0 {
            *word |= b;
            self.top(w);
            self.count += 1;
            self.all = self.count > self.limit;
        }
    }

    /// Adds agents `ids`, a word of bits at a time: consecutive ids (a run of agents
    /// that executed a rule, in id order) cost a write per 64 of them, where adding them
    /// one by one waits on each write of their word before the next.
    pub(super) fn add_all(&mut self, ids: impl IntoIterator<Item = u32>) {
        let (mut w, mut bits) = (usize::MAX, 0u64);
        for a in ids {
            if a as usize / 64 != w {
                self.add_word(w, bits);
                (w, bits) = (a as usize / 64, 0);
            }
            bits |= 1 << (a % 64);
        }
        self.add_word(w, bits);
    }

    /// Adds agents `ids` (a slice): [`WakeSet::add_all`], but a block of 64 that are
    /// consecutive ids (a row of walkers, in id order) is added as a range, a word or two
    /// at a time, without a look at each id after the test (which vectorises).
    pub(super) fn add_ids(&mut self, ids: &[u32]) {
        for block in ids.chunks(64) {
            let first = block[0];
            if is_sequence(block, first) {
                let lo = first as usize;
                for (w, bits) in range_words(lo..lo + block.len()) {
                    self.add_word(w, bits);
                }
            } else {
                self.add_all(block.iter().copied());
            }
        }
    }

    /// Adds the agents of word `w` whose bits `bits` has (none when `w` is `usize::MAX`).
    #[inline]
    fn add_word(&mut self, w: usize, bits: u64) {
        if self.all || w == usize::MAX {
            return;
        }
        let new = bits & !self.words[w];
        if new != 0 {
            self.words[w] |= new;
            self.top(w);
            self.count += new.count_ones() as usize;
            self.all = self.count > self.limit;
        }
    }

    /// Marks word `w` as holding agents.
    #[inline]
    fn top(&mut self, w: usize) {
        let t = w / 64;
        self.tops[t] |= 1 << (w % 64);
        self.span = (self.span.0.min(t), self.span.1.max(t + 1));
    }

    /// The words of `tops` that may have a bit set, and none marked after.
    fn take_span(&mut self) -> std::ops::Range<usize> {
        let (lo, hi) = std::mem::replace(&mut self.span, (usize::MAX, 0));
        lo.min(hi)..hi
    }

    /// Adds the agents of `other` (a set of the same agents) and empties it, visiting only
    /// the words it touched.
    fn merge(&mut self, other: &mut WakeSet) {
        for t in other.take_span() {
            let mut tb = std::mem::take(&mut other.tops[t]);
            while tb != 0 {
                let w = t * 64 + tb.trailing_zeros() as usize;
                tb &= tb - 1;
                let bits = std::mem::take(&mut other.words[w]);
                if !self.all {
                    self.count += (bits & !self.words[w]).count_ones() as usize;
                    self.words[w] |= bits;
                    self.top(w);
                }
            }
        }
        other.count = 0;
        self.all |= self.count > self.limit;
    }

    /// Moves the agents of the set into `out` (cleared first), in id order, and empties it.
    fn take(&mut self, out: &mut Vec<u32>) {
        // (Written in place: a push per agent waited on the last one's write of the
        // length. Every bit set is counted, unless the set turned into "all".)
        out.clear();
        let mut k = 0;
        for t in self.take_span() {
            let mut tb = std::mem::take(&mut self.tops[t]);
            while tb != 0 {
                let w = t * 64 + tb.trailing_zeros() as usize;
                tb &= tb - 1;
                let mut bits = std::mem::take(&mut self.words[w]);
                out.resize(k + bits.count_ones() as usize, 0);
                if bits == u64::MAX {
                    // A full word (a row of agents): written as a sequence.
                    let base = (w * 64) as u32;
                    for (j, o) in out[k..k + 64].iter_mut().enumerate() {
                        *o = base + j as u32;
                    }
                    k += 64;
                    continue;
                }
                while bits != 0 {
                    out[k] = (w * 64) as u32 + bits.trailing_zeros();
                    k += 1;
                    bits &= bits - 1;
                }
            }
        }
        self.count = 0;
        self.all = false;
    }
}

/// An agent that moved, with the cell it left (its position and slot code).
pub(super) type Moved = (u32, [i32; 3], u32);

/// What the actions of a step changed, as the activity needs it (kept only while the next
/// selection may skip agents): agents that moved, with the cell they left (`moved`, and
/// `moved_parts` for the moves made on the pool, a list per chunk of agents); agents whose
/// state changed; agents whose bonds changed.
#[derive(Default)]
pub(super) struct Changes {
    pub(super) on: bool,
    /// The grid the cells' slot codes in `moved` refer to (the grid when the actions
    /// began; moves may make it again, after which the codes are found again).
    pub(super) grid: Option<([i32; 3], [i64; 3])>,
    pub(super) moved: Vec<Moved>,
    pub(super) moved_parts: Vec<Vec<Moved>>,
    /// Every agent in `moved`, `moved_parts` and `shifted` moved by this offset (a step
    /// of plain moves), when known.
    pub(super) one_offset: Option<[i32; 3]>,
    /// Agents that moved by `one_offset` from cells of the grid away from its rim, by id
    /// alone: the cell each left is its cell less the offset (on the grid of `grid`, its
    /// slot code less the offset's step). A row of walkers noted its movers' positions
    /// and codes before they moved: a tenth of its step.
    pub(super) shifted: Vec<u32>,
    pub(super) states: Vec<u32>,
    pub(super) bonds: Vec<u32>,
}

impl Changes {
    /// Notes that agent `a` leaves its cell in `lat` (before it moves).
    #[inline]
    pub(super) fn moved(&mut self, lat: &Lattice, a: u32) {
        if self.on {
            self.moved.push((a, lat.pos[a as usize], lat.code_of(a)));
        }
    }

    /// Notes that `agents` leave their cells in `lat` (before they move), at once.
    #[inline]
    pub(super) fn moved_all(&mut self, lat: &Lattice, agents: impl ExactSizeIterator<Item = u32>) {
        if self.on {
            let pos = &lat.pos;
            (self.moved).extend(agents.map(|a| (a, pos[a as usize], lat.code_of(a))));
        }
    }

    /// Notes that `movers` less `stayed` (both in agent order) moved by `one_offset` from
    /// cells of the grid away from its rim (see `shifted`).
    pub(super) fn shifted(&mut self, movers: &[u32], stayed: &[u32]) {
        if self.on {
            let first = self.shifted.len();
            self.shifted.extend_from_slice(movers);
            if !stayed.is_empty() {
                let mut moved = self.shifted.split_off(first);
                drop_agents(&mut moved, stayed, |&a| a);
                self.shifted.append(&mut moved);
            }
        }
    }

    /// Notes that agent `a`'s state changed.
    #[inline]
    pub(super) fn state(&mut self, a: u32) {
        if self.on {
            self.states.push(a);
        }
    }

    /// Notes that agent `a`'s bonds changed.
    #[inline]
    pub(super) fn bonds(&mut self, a: u32) {
        if self.on {
            self.bonds.push(a);
        }
    }

    fn clear(&mut self) {
        self.one_offset = None;
        self.moved.clear();
        self.moved_parts.iter_mut().for_each(Vec::clear);
        self.shifted.clear();
        self.states.clear();
        self.bonds.clear();
    }
}

/// The activity part of the engine: the agents woken for the next selection, the agents
/// of the current one, and the recipients of the last delivery.
pub(super) struct Activity {
    skip: Skip,
    n: usize,
    /// The agents to evaluate at the next selection.
    next: WakeSet,
    /// The agents the current selection evaluates, in id order (when `listed`).
    pub(super) list: Vec<u32>,
    /// The current selection evaluates only `list`.
    pub(super) listed: bool,
    /// The recipients of the last delivery (`None` when not known: the next selection
    /// then evaluates everyone, as their inboxes may have been emptied).
    recipients: Option<Vec<u32>>,
    /// This step's recipients, being found.
    found: Vec<u32>,
    /// Per thread, the agents it woke in a pass on the pool (merged into `next` after).
    parts: Vec<WakeSet>,
}

impl Activity {
    /// The activity of `n` agents: the first selection evaluates everyone.
    pub(super) fn new(skip: Skip, n: usize) -> Activity {
        let limit = match skip {
            Skip::Auto => n / SPARSE_SHARE,
            Skip::Off | Skip::Eager => usize::MAX,
        };
        Activity {
            skip,
            n,
            next: WakeSet::new(limit),
            list: Vec::new(),
            listed: false,
            recipients: None,
            found: Vec::new(),
            parts: Vec::new(),
        }
    }

    /// Bytes held.
    pub(super) fn bytes(&self) -> usize {
        (self.parts.iter().chain([&self.next]))
            .map(|w| (w.words.capacity() + w.tops.capacity()) * 8)
            .sum::<usize>()
            + (self.list.capacity() + self.found.capacity()) * 4
            + self.recipients.as_ref().map_or(0, |r| r.capacity() * 4)
    }

    /// At the start of a step: takes the agents woken for this selection into `list`
    /// (`listed`), or none when every agent is evaluated.
    pub(super) fn begin(&mut self, prog_reads_priorities: bool) {
        let all = self.next.all;
        // (When the set turned into "all", this clears what was marked before.)
        self.next.take(&mut self.list);
        if all {
            self.list.clear();
        }
        self.listed = !all;
        // Without skipping, or with priorities, the next selection evaluates everyone:
        // nothing of this step is noted for it.
        self.next.all = self.skip == Skip::Off || prog_reads_priorities;
        self.listed &= !self.next.all;
    }

    /// Whether the selection's `active` agents are to be listed for the phases after it
    /// and for waking them (few enough, and skipping on).
    ///
    /// Past the limit, the next selection evaluates everyone (these agents are woken),
    /// and nothing more of this step is noted for it.
    /// Called at every step, before anything is woken.
    pub(super) fn lists(&mut self, active: u64) -> bool {
        if active as usize > self.next.limit {
            self.next.all = true;
        }
        if !self.next.all {
            self.next.ready(self.n);
        }
        !self.next.all
    }

    /// Whether the changes of this step are needed (the next selection may skip agents).
    pub(super) fn wanted(&self) -> bool {
        !self.next.all
    }

    /// Runs `wake(run, set)` over the items of `lists`, `set` being the agents woken for
    /// the next selection: on the pool when there are threads and enough items (each
    /// thread a run of the items, into a set of its own; the sets merged after), else on
    /// this thread, all items one run. The set woken is the same either way.
    fn wake_each<T: Sync>(
        &mut self,
        th: &Threads,
        lists: &[&[T]],
        wake: impl Fn(&[&[T]], &mut WakeSet) + Sync,
    ) {
        let total: usize = lists.iter().map(|l| l.len()).sum();
        let Some((pool, _)) = th.parallel(total) else {
            wake(lists, &mut self.next);
            return;
        };
        // One run of about equal length per thread, cut from the lists in turn.
        let k = pool.threads;
        let mut runs: Vec<Vec<&[T]>> = vec![Vec::new(); k];
        let per = total.div_ceil(k);
        let (mut r, mut room) = (0, per);
        for &l in lists {
            let mut l = l;
            while !l.is_empty() {
                let take = room.min(l.len());
                runs[r].push(&l[..take]);
                (l, room) = (&l[take..], room - take);
                if room == 0 {
                    (r, room) = ((r + 1).min(k - 1), per);
                }
            }
        }
        let n = self.n;
        // (Sets of no limit, never "all".)
        self.parts.resize_with(k, || WakeSet {
            limit: usize::MAX,
            ..WakeSet::default()
        });
        let items: Vec<_> = runs.into_iter().zip(self.parts.drain(..)).collect();
        let sets = pool.map(items, |(run, mut set)| {
            set.ready(n);
            wake(&run, &mut set);
            set
        });
        for mut set in sets {
            self.next.merge(&mut set);
            self.parts.push(set);
        }
    }

    /// After the actions: wakes the agents that moved, changed state or bonds, and those
    /// that read their cells; `changes` is emptied.
    pub(super) fn after_actions(
        &mut self,
        (lat, th): (&Lattice, &Threads),
        reads: &Reads,
        changes: &mut Changes,
    ) {
        if !self.next.all {
            let back = &reads.back;
            let mut moved: Vec<&[Moved]> = vec![&changes.moved];
            moved.extend(changes.moved_parts.iter().map(|l| &l[..]));
            // A grid made again during the moves lays its cells out anew.
            let same_grid = changes.grid == lat.cells.grid_box();
            let how = Shifted {
                off: changes.one_offset.unwrap_or_default(),
                same_grid,
                step: (changes.one_offset)
                    .filter(|_| same_grid)
                    .and_then(|off| Some(lat.cells.grid()?.step(Dir::from_offset(off)?.index()))),
            };
            let occupancy = &back.occupancy[..];
            self.wake_each(th, &moved, |run, next| {
                wake_movers(next, lat, (run, how), occupancy)
            });
            if !changes.shifted.is_empty() {
                let shifted = &changes.shifted[..];
                self.wake_each(th, &[shifted], |run, next| {
                    wake_movers(next, lat, (run, how), occupancy)
                });
            }
            // (An agent whose state changed executed a rule: it is woken as such.)
            for &a in &changes.states {
                let at = (lat.pos[a as usize], lat.code_of(a));
                wake_readers(&mut self.next, lat, at, &back.states);
            }
            if reads.bonds {
                for &a in &changes.bonds {
                    self.next.add(a);
                }
            }
        }
        changes.clear();
        changes.on = !self.next.all;
    }

    /// After the selection and the calculations: the agents that executed a rule (`sel`,
    /// with its list when it has one) are evaluated again, and the readers of the
    /// counters of those that calculated; agents whose candidate list is evaluated at
    /// every step (`always`) too. `evaluated`: the agents this selection evaluated.
    pub(super) fn after_step(
        &mut self,
        (plan, lat, th): (&Plan, &Lattice, &Threads),
        (sel, active, reused): (&Selection, u64, bool),
        dispatch: &Dispatch,
    ) {
        if reused && !sel.listed {
            // Kept from the step before, whose agents are not listed.
            self.next.all = true;
        }
        if self.next.all {
            return;
        }
        if !sel.listed && active as usize > self.next.limit {
            self.next.all = true;
            return;
        }
        let reads = &plan.reads;
        let offs = &reads.back.counters;
        let each = |a: u32, next: &mut WakeSet| {
            next.add(a);
            if !offs.is_empty()
                && sel
                    .of(a as usize)
                    .iter()
                    .any(|&r| plan.computes[r as usize])
            {
                let at = (lat.pos[a as usize], lat.code_of(a));
                for o in offs {
                    if let Some(b) = lat.agent_near(at, o.off, o.dir) {
                        next.add(b);
                    }
                }
            }
        };
        if sel.listed {
            self.wake_each(th, &[&sel.list[..]], |run, next| {
                let agents = run.iter().flat_map(|l| l.iter().copied());
                match offs.is_empty() {
                    true => run.iter().for_each(|l| next.add_ids(l)),
                    false => agents.for_each(|a| each(a, next)),
                }
            });
        } else {
            for (a, &r) in sel.one.iter().enumerate() {
                if r != NO_RULE {
                    each(a as u32, &mut self.next);
                }
            }
        }
        if reads.any_unbounded() {
            let always = |a: usize| dispatch.always(a, &reads.unbounded);
            if self.listed {
                for k in 0..self.list.len() {
                    let a = self.list[k];
                    if always(a as usize) {
                        self.next.add(a);
                    }
                }
            } else {
                for a in 0..self.n {
                    if always(a) {
                        self.next.add(a as u32);
                    }
                }
            }
        }
    }

    /// Before a delivery: the recipients of this step's messages (`sent(a)`: the
    /// directions agent `a` sends in, for the senders among `senders`) are woken, and so
    /// are those of the last delivery (their inboxes are emptied now). Returns whether the
    /// recipients of the last delivery are known ([`Activity::emptied`]): no other agent
    /// has anything in its inbox.
    pub(super) fn before_delivery(
        &mut self,
        lat: &Lattice,
        senders: Option<&[u32]>,
        sent: impl Fn(usize) -> u8,
    ) -> bool {
        let prev = self.recipients.take();
        if self.next.all {
            return false;
        }
        let Some(senders) = senders else {
            self.next.all = true;
            return false;
        };
        let mut found = std::mem::take(&mut self.found);
        found.clear();
        let nd = lat.dim.dirs();
        for &a in senders {
            let dirs = sent(a as usize);
            if dirs == 0 {
                continue;
            }
            for d in 0..nd {
                if dirs & (1 << d) != 0 {
                    if let Cell::Agent(b) = lat.neighbour_cell(a, d) {
                        found.push(b);
                        self.next.add(b);
                    }
                }
            }
        }
        let known = prev.is_some();
        match prev {
            Some(prev) => {
                for &a in &prev {
                    self.next.add(a);
                }
                self.found = prev;
            }
            // Who received the last messages is not known: everyone is evaluated.
            None => self.next.all = true,
        }
        self.recipients = Some(found);
        known
    }

    /// After [`Activity::before_delivery`] said they are known: the recipients of the last
    /// delivery (possibly with repeats).
    pub(super) fn emptied(&self) -> &[u32] {
        &self.found
    }
}

/// How the movers of a step moved, for [`Mover::left`]: the offset every one moved by when
/// one did (`Changes::one_offset`; else unused), whether the grid is the one the moves
/// began on (the slot codes noted are those of now), and then the offset's step on it.
#[derive(Clone, Copy)]
struct Shifted {
    off: [i32; 3],
    same_grid: bool,
    step: Option<isize>,
}

/// A mover as the activity notes it: a [`Moved`], or the id of an agent of
/// `Changes::shifted`.
trait Mover: Copy + Sync {
    fn id(self) -> u32;
    /// The cell it left, its position and slot code (that of the grid now).
    fn left(self, lat: &Lattice, how: Shifted) -> ([i32; 3], u32);
    /// Adds the agents of `movers` to `next`.
    fn add(next: &mut WakeSet, movers: &[Self]);
}

impl Mover for Moved {
    fn id(self) -> u32 {
        self.0
    }

    fn left(self, lat: &Lattice, how: Shifted) -> ([i32; 3], u32) {
        let (_, from, code) = self;
        match how.same_grid {
            true => (from, code),
            false => (from, lat.cells.code(from)),
        }
    }

    fn add(next: &mut WakeSet, movers: &[Moved]) {
        next.add_all(movers.iter().map(|m| m.0));
    }
}

impl Mover for u32 {
    fn id(self) -> u32 {
        self
    }

    fn left(self, lat: &Lattice, how: Shifted) -> ([i32; 3], u32) {
        let p = lat.pos[self as usize];
        let from = [0, 1, 2].map(|k| p[k] - how.off[k]);
        match how.step {
            // (It left a cell away from the rim: its code is its slot.)
            Some(step) => (from, Grid::along(lat.code_of(self) & !RIM, -step) as u32),
            None => (from, lat.cells.code(from)),
        }
    }

    fn add(next: &mut WakeSet, movers: &[u32]) {
        next.add_ids(movers);
    }
}

/// Wakes the movers of `run` and the agents that read the cells they left and entered
/// (`how`: how they moved; `occupancy`: the offsets back from a cell to its readers).
fn wake_movers<M: Mover>(
    next: &mut WakeSet,
    lat: &Lattice,
    (run, how): (&[&[M]], Shifted),
    occupancy: &[Back],
) {
    // The grid cells of readers, looked at together after the loop: their loads overlap,
    // where one at a time each waited on the last (the movers' cells lie apart).
    let mut cells = Vec::new();
    for l in run {
        M::add(next, l);
    }
    // (Every offset read for a state or counter is read for occupancy too.)
    if how.step.is_some() && readers_of_shift(next, lat, (run, how), occupancy, &mut cells) {
        wake_cells(next, lat, &cells);
        return;
    }
    for &m in run.iter().flat_map(|l| l.iter()) {
        let a = m.id();
        let to = (lat.pos[a as usize], lat.code_of(a));
        readers_of_move(next, lat, (m.left(lat, how), to), occupancy, &mut cells);
    }
    wake_cells(next, lat, &cells);
}

/// Wakes the agents that read the cells a mover left and entered (`from`, `to`: position
/// and slot code), those at each cell plus each of `offsets`; a reader's grid cell away
/// from the rim is pushed to `cells` instead, for the caller to look at. Two readers are
/// known without looking: the mover itself, reading the cell it left from the one it
/// entered; and what stands on the cell it left, reading the one it entered from there
/// (nothing, or an agent that moved in: woken as a mover).
#[inline]
fn readers_of_move(
    next: &mut WakeSet,
    lat: &Lattice,
    (from, to): (([i32; 3], u32), ([i32; 3], u32)),
    offsets: &[Back],
    cells: &mut Vec<usize>,
) {
    let grid = lat.cells.grid();
    let is = |p: [i32; 3], off: [i32; 3], q: [i32; 3]| {
        (0..3).all(|k| p[k] as i64 + off[k] as i64 == q[k] as i64)
    };
    for o in offsets {
        for (at, other) in [(from, to.0), (to, from.0)] {
            if is(at.0, o.off, other) {
                continue;
            }
            match (grid, o.dir) {
                (Some(g), Some(d)) if at.1 < RIM => cells.push(g.next(at.1, d)),
                _ => {
                    if let Some(b) = lat.agent_near(at, o.off, o.dir) {
                        next.add(b);
                    }
                }
            }
        }
    }
}

/// [`readers_of_move`] for agents `moved` that all moved by one offset (`how`), on the
/// grid the codes are for: which readers are known without looking (the mover itself,
/// what stands on the cell it left) is then the same for every mover, and only codes are
/// read. Does nothing and returns false unless every offset is one step and there is a
/// grid.
fn readers_of_shift<M: Mover>(
    next: &mut WakeSet,
    lat: &Lattice,
    (moved, how): (&[&[M]], Shifted),
    offsets: &[Back],
    cells: &mut Vec<usize>,
) -> bool {
    let Some(g) = lat.cells.grid() else {
        return false;
    };
    let Some(dirs) = offsets
        .iter()
        .map(|o| o.dir)
        .collect::<Option<Vec<usize>>>()
    else {
        return false;
    };
    let off = how.off;
    let back = [-off[0], -off[1], -off[2]];
    for (o, d) in offsets.iter().zip(dirs) {
        let (from_known, to_known) = (o.off == off, o.off == back);
        for &l in moved {
            if !from_known {
                let codes = l.iter().map(|m| m.left(lat, how).1);
                if !interior_next(cells, g, d, codes) {
                    for at in l.iter().map(|m| m.left(lat, how)).filter(|at| at.1 >= RIM) {
                        if let Some(b) = lat.agent_near(at, o.off, o.dir) {
                            next.add(b);
                        }
                    }
                }
            }
            if !to_known {
                let codes = l.iter().map(|m| lat.code_of(m.id()));
                if !interior_next(cells, g, d, codes) {
                    for a in l.iter().map(|m| m.id()).filter(|&a| lat.code_of(a) >= RIM) {
                        let at = (lat.pos[a as usize], lat.code_of(a));
                        if let Some(b) = lat.agent_near(at, o.off, o.dir) {
                            next.add(b);
                        }
                    }
                }
            }
        }
    }
    true
}

/// Appends to `cells` the neighbour in direction index `d` of each interior slot code of
/// `codes`, and says whether every code was interior.
#[inline]
fn interior_next(
    cells: &mut Vec<usize>,
    g: &crate::cells::Grid,
    d: usize,
    codes: impl ExactSizeIterator<Item = u32>,
) -> bool {
    let len = codes.len();
    extend_kept(cells, codes.map(|c| (g.next(c & !RIM, d), c < RIM))) == len
}

/// Wakes the agents on grid cells `cells` (slots), found first and then added together
/// (a mover's reader is often the mover before it: their ids follow each other).
fn wake_cells(next: &mut WakeSet, lat: &Lattice, cells: &[usize]) {
    let mut found = Vec::with_capacity(cells.len());
    extend_kept(
        &mut found,
        cells.iter().map(|&c| {
            let b = lat.cells.at_slot(c);
            (b, b != EMPTY)
        }),
    );
    next.add_ids(&found);
}

/// Wakes the agents that read cell `at` (its position and slot code): those at `at` minus
/// each of `offsets`.
#[inline]
fn wake_readers(next: &mut WakeSet, lat: &Lattice, at: ([i32; 3], u32), offsets: &[Back]) {
    for o in offsets {
        if let Some(b) = lat.agent_near(at, o.off, o.dir) {
            next.add(b);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Adding agents a word at a time ([`WakeSet::add_all`]), or runs of consecutive ids
    /// as ranges ([`WakeSet::add_ids`]), gives the set adding them one by one gives: in
    /// order or not, with repeats and runs, past the limit or not; taken out in order
    /// (full words at once).
    #[test]
    fn adding_all_at_once_is_adding_each() {
        let mut rng = crate::shapes::Rng::new(0x2545_F491_4F6C_DD1Du64);
        let mut next = move || rng.next_u64();
        let n = 5000;
        for case in 0..300 {
            let len = next() as usize % 400;
            let mut ids: Vec<u32> = (0..len).map(|_| (next() % n) as u32).collect();
            if case % 2 == 0 {
                ids.sort_unstable();
            }
            if case % 3 == 0 {
                // Runs of consecutive ids (a row of walkers), at any start.
                let start = (next() % n) as u32;
                let run = (next() as usize % 300).min((n - start as u64) as usize);
                ids.splice(len / 2..len / 2, (0..run as u32).map(|j| start + j));
            }
            let limit = next() as usize % 500;
            let (mut one, mut all) = (WakeSet::new(limit), WakeSet::new(limit));
            let mut slice = WakeSet::new(limit);
            for s in [&mut one, &mut all, &mut slice] {
                s.all = false;
                s.ready(n as usize);
                s.add(7);
            }
            ids.iter().for_each(|&a| one.add(a));
            all.add_all(ids.iter().copied());
            slice.add_ids(&ids);
            assert_eq!(one.all, all.all, "case {case}");
            assert_eq!(one.all, slice.all, "case {case}");
            // (Past the limit the set is everyone, whatever its bits.)
            let everyone = one.all;
            let (mut a, mut b, mut c) = (Vec::new(), Vec::new(), Vec::new());
            one.take(&mut a);
            all.take(&mut b);
            slice.take(&mut c);
            if !everyone {
                assert_eq!(a, b, "case {case}");
                assert_eq!(a, c, "case {case}");
            }
        }
    }
}
