//! Moves, carried groups and bonds: the actions that change positions (but swaps,
//! `swaps.rs`). A mover alone (`move_alone`) when no agent is bonded and no group moves;
//! otherwise bonds are broken, groups found and moved whole or not at all, and bonds made
//! again (`detach_move_attach`).

use super::*;
use crate::lattice::{drop_agents, OccWrites};

/// Whether the cells of `movers` lie scattered over the grid (see `cells::scattered`).
fn scattered(lat: &Lattice, movers: &[u32]) -> bool {
    crate::cells::scattered(movers.iter().map(|&a| lat.code_of(a)))
}

/// One chunk's part of [`Act::plain_moves_at_once`]: its movers, and those of them left
/// to the general way (kept between steps for their allocations).
#[derive(Default)]
pub(super) struct FusedPart {
    movers: Vec<u32>,
    deferred: Vec<u32>,
    /// The words of occupancy its moves touch (moved on the pool, noted).
    words: crate::lattice::Words,
    /// Its movers from or into a cell outside the words it owns (moved on the pool, the
    /// bits written at once), for one thread after the parts.
    crossing: Vec<u32>,
}

impl FusedPart {
    /// The movers among `agents` (their entries in `one`; `mover`: per rule, and one more
    /// entry for none, whether it moves), into `movers`.
    #[inline]
    fn collect(
        &mut self,
        agents: impl ExactSizeIterator<Item = usize>,
        (one, mover): (&[u32], &[bool]),
    ) {
        let last = mover.len() - 1;
        self.movers.clear();
        let kept = agents.map(|a| (a as u32, mover[(one[a] as usize).min(last)]));
        extend_kept(&mut self.movers, kept);
        self.deferred.clear();
    }

    /// [`FusedPart::collect`] of the agents `lo..hi`. When every rule moves, an agent is a
    /// mover when it executes any, and blocks of 64 agents of which none or all execute
    /// a rule are found with one vectorised test each (passed over, or taken as a run):
    /// B2's falling columns hold long runs of both (about half the time of `collect`).
    fn collect_range(&mut self, (lo, hi): (usize, usize), (one, mover): (&[u32], &[bool])) {
        let all = mover[..mover.len() - 1].iter().all(|&m| m);
        if !all {
            return self.collect(lo..hi, (one, mover));
        }
        self.movers.clear();
        self.deferred.clear();
        for (b, block) in one[lo..hi].chunks(64).enumerate() {
            // (`NO_RULE` has every bit set: the block holds nothing else when its AND does.)
            if block.iter().fold(NO_RULE, |m, &v| m & v) == NO_RULE {
                continue;
            }
            let first = (lo + b * 64) as u32;
            // Blocks where every agent moves, as one run.
            if !block.iter().fold(false, |any, &v| any | (v == NO_RULE)) {
                self.movers.extend(first..first + block.len() as u32);
                continue;
            }
            extend_ones(&mut self.movers, first, mask_ne(block, NO_RULE));
        }
    }
}

/// Drops from `notes` (the cells movers left, in the order of the movers) the entries of
/// the agents of `deferred` (a subsequence of the same movers): they have not moved.
fn unnote(notes: &mut Vec<Moved>, deferred: &[u32]) {
    drop_agents(notes, deferred, |m| m.0);
}

/// Where the movers of [`Act::moves_at_once`] come from.
#[derive(Clone, Copy)]
pub(super) enum Movers<'a> {
    /// The agents that the selection says execute a rule that moves
    /// (`Plan::plain_mask`).
    Selected(&'a Selection),
    /// The actions' moves (agent order), all by one offset.
    Listed(&'a [(u32, [i32; 3])]),
}

impl Movers<'_> {
    /// How many agents (or moves) the chunks split.
    fn len(self) -> usize {
        match self {
            Movers::Selected(sel) if sel.listed => sel.list.len(),
            Movers::Selected(sel) => sel.one.len(),
            Movers::Listed(moves) => moves.len(),
        }
    }

    /// The movers of items `lo..hi` into `part` (`mover`: `Plan::plain_mask`).
    fn collect(self, part: &mut FusedPart, (lo, hi): (usize, usize), mover: &[bool]) {
        match self {
            Movers::Selected(sel) if sel.listed => part.collect(
                sel.list[lo..hi].iter().map(|&a| a as usize),
                (&sel.one, mover),
            ),
            Movers::Selected(sel) => part.collect_range((lo, hi), (&sel.one, mover)),
            Movers::Listed(moves) => {
                part.movers.clear();
                part.movers.extend(moves[lo..hi].iter().map(|m| m.0));
                part.deferred.clear();
            }
        }
    }

    /// The agent of item `i` (below [`Movers::len`]).
    fn agent(self, i: usize) -> u32 {
        match self {
            Movers::Selected(sel) if sel.listed => sel.list[i],
            Movers::Selected(_) => i as u32,
            Movers::Listed(moves) => moves[i].0,
        }
    }

    /// The first agents (up to 65), to judge whether the movers lie scattered.
    fn first(self) -> Vec<usize> {
        (0..self.len().min(65))
            .map(|i| self.agent(i) as usize)
            .collect()
    }
}

impl Act<'_> {
    /// The plain moves of a step at once, on the pool when it pays (see `plan.rs`): when
    /// every rule that acts only moves one step in one direction (`Plan::plain_step`) and
    /// no mover is bonded, as [`Act::moves_at_once`] makes them. Returns false, having
    /// changed nothing, when they were not made so.
    pub(super) fn plain_moves_at_once(&mut self, sel: &Selection, rep: &mut StepReport) -> bool {
        match self.plan.plain_step {
            Some(step) => self.moves_at_once(Movers::Selected(sel), step, rep),
            None => false,
        }
    }

    /// The moves of `live` (in agent order, with their offsets; none bonded): when all are
    /// one step in one direction, made at once (as [`Act::moves_at_once`] makes them: a
    /// rule that moves and sets the state, rules in several states that move alike);
    /// else, or when they were not made so, by [`Act::move_alone`].
    pub(super) fn move_list(&mut self, live: &mut Vec<(u32, [i32; 3])>, rep: &mut StepReport) {
        let off = live.first().map(|m| m.1);
        let step = off
            .filter(|&o| live.iter().all(|m| m.1 == o))
            .and_then(|o| {
                (0..self.lat.dim.dirs())
                    .find(|&d| Dir::ALL[d].offset() == o)
                    .map(|d| (o, d))
            });
        if let Some(step) = step {
            if self.moves_at_once(Movers::Listed(live), step, rep) {
                live.clear();
                return;
            }
        }
        self.move_alone(live, rep);
    }

    /// Moves by one step in direction `d` (offset `off`) at once, on the pool when it
    /// pays, when no mover is bonded. Then no move can collide and no bond changes: the
    /// movers of each chunk (of agents, or of the list) are found in one pass that reads,
    /// and each that stands on the grid away from its rim, with its target empty, is moved
    /// in one that writes (a target seen empty was empty at the start of the step, or
    /// left by an agent moving the same way, which nothing else may enter). The others go
    /// the general way after (`move_alone`): those at the rim (a cloud that falls, a line
    /// that walks away; the grid is first made again with room ahead of them when that
    /// pays, and they are tried at once again), and those whose target was filled when
    /// they were tried. Returns false, having changed nothing, when a mover is bonded (the
    /// moves then go the general way), and then does not try for the next 16 steps (nor
    /// after a step where more than half the movers were blocked: a jam goes the general
    /// way).
    fn moves_at_once(
        &mut self,
        src: Movers<'_>,
        (off, d): ([i32; 3], usize),
        rep: &mut StepReport,
    ) -> bool {
        let (rim, movers) = match self.moves_on_grid(src, (off, d)) {
            AtOnce::Done { rim, movers } => (rim, movers),
            AtOnce::NotTried => return false,
            AtOnce::Failed => {
                self.bufs.fused_pause = 16;
                return false;
            }
        };
        // (Those left to the general way move by the same offset.)
        self.bufs.changes.one_offset = Some(off);
        let mut parts = std::mem::take(&mut self.bufs.fused);
        let mut deferred: Vec<u32> = parts.iter().flat_map(|p| &p.deferred).copied().collect();
        let grown = rim > 0 && {
            let ids: Vec<&[u32]> = parts.iter().map(|p| &p.movers[..]).collect();
            self.lat.grow_toward(off, (movers, &ids))
        };
        if grown {
            // On the new grid, those at the rim are away from it: tried again.
            let part = &mut parts[0];
            std::mem::swap(&mut part.movers, &mut deferred);
            part.deferred.clear();
            let tried = self
                .lat
                .shift_alone(&part.movers, (off, d), false, &mut part.deferred);
            // (No mover is bonded: all were tried.)
            debug_assert!(tried.is_some());
            (self.bufs.changes).shifted(&part.movers, &part.deferred);
            self.stats.moves += (part.movers.len() - part.deferred.len()) as u64;
            deferred.clear();
            deferred.extend_from_slice(&part.deferred);
        }
        self.bufs.fused = parts;
        if !deferred.is_empty() {
            let before = self.stats.moves;
            let mut live: Vec<(u32, [i32; 3])> = deferred.iter().map(|&a| (a, off)).collect();
            self.move_alone(&mut live, rep);
            let blocked = deferred.len() as u64 - (self.stats.moves - before);
            if blocked as usize * 2 > movers {
                self.bufs.fused_pause = 16;
            }
        }
        true
    }

    /// [`Act::moves_at_once`] on the grid as it is, without the pause it sets and the
    /// general way for the movers it leaves (in the parts' `deferred`).
    fn moves_on_grid(&mut self, src: Movers<'_>, (off, d): ([i32; 3], usize)) -> AtOnce {
        if self.opts.trace {
            return AtOnce::NotTried;
        }
        if self.bufs.fused_pause > 0 {
            self.bufs.fused_pause -= 1;
            return AtOnce::NotTried;
        }
        match self.lat.cells.grid_mut() {
            Some(g) => g.ready_rim(),
            None => return AtOnce::NotTried,
        }
        let mover = &self.plan.plain_mask[..];
        let th = self.threads;
        let len = src.len();
        let (par, size, chunks) = th.chunks(len);
        if par.is_none() {
            // One thread: the movers, then their moves checked as they are made.
            self.bufs.fused.truncate(1);
            if self.bufs.fused.is_empty() {
                self.bufs.fused.push(FusedPart::default());
            }
            let part = &mut self.bufs.fused[0];
            src.collect(part, (0, len), mover);
            let ahead = scattered(self.lat, &part.movers);
            let movers = part.movers.len();
            let Some(rim) = self
                .lat
                .shift_alone(&part.movers, (off, d), ahead, &mut part.deferred)
            else {
                return AtOnce::Failed;
            };
            // (Those that moved left cells away from the rim.)
            (self.bufs.changes).shifted(&part.movers, &part.deferred);
            self.stats.moves += (movers - part.deferred.len()) as u64;
            return AtOnce::Done { rim, movers };
        }
        let Some((pool, _)) = par else {
            unreachable!("one thread went above")
        };
        // On the pool: each block of chunks finds its movers and moves them in place,
        // each checked as it goes (as on one thread); when one of them is bonded, every
        // move is undone. With agents in the order of their cells, each chunk owns the
        // words of occupancy (and their cells) from its first agent's to the next chunk's
        // and writes them at once; its movers from or into another's go after the parts,
        // on this thread. Otherwise the parts note their bits, written after them.
        let mut parts = std::mem::take(&mut self.bufs.fused);
        parts.resize_with(chunks, FusedPart::default);
        let owned = match self.bufs.owned_pause {
            0 => owned_words(self.lat, src, (size, chunks)),
            _ => {
                self.bufs.owned_pause -= 1;
                None
            }
        };
        let mut shift = (self.lat).shift(d, !self.bufs.bondless).expect("a grid");
        let split = shift.buckets(chunks);
        // Scattered movers are asked for ahead (judged on the first chunk's agents).
        // SAFETY: only codes are read, and no thread moves yet.
        shift.ahead = unsafe { shift.scattered(&src.first()) };
        let owned = owned.filter(|_| !shift.ahead);
        // The cells the movers leave, for the activity: a list per chunk, made with it.
        let changes = &mut self.bufs.changes;
        let noting = changes.on;
        changes.moved_parts.resize_with(chunks, Vec::new);
        let moves = |(c, (part, notes)): (usize, (&mut FusedPart, &mut Vec<Moved>))| {
            src.collect(part, (c * size, ((c + 1) * size).min(len)), mover);
            // SAFETY (both): every chunk's movers are its own agents (each agent in one
            // chunk), the words owned by chunks lie apart (they rise with the chunks), and
            // no other thread uses the lattice but through `shift`.
            if noting {
                notes.clear();
                notes.extend((part.movers.iter()).map(|&a| {
                    let (p, code) = unsafe { shift.at(a) };
                    (a, p, code)
                }));
            }
            part.crossing.clear();
            let writes = match &owned {
                Some(o) => OccWrites::Owned {
                    words: (o[c], o[c + 1]),
                    crossing: &mut part.crossing,
                },
                None => {
                    part.words.ready(split);
                    OccWrites::Log(&mut part.words)
                }
            };
            let made = unsafe { shift.in_place(&part.movers, &mut part.deferred, writes) };
            if owned.is_none() {
                part.words.flush();
            }
            if noting {
                unnote(notes, &part.deferred);
                unnote(notes, &part.crossing);
            }
            made
        };
        let items = parts.iter_mut().zip(&mut changes.moved_parts);
        let made: Vec<(usize, Option<usize>)> = pool.map(items.enumerate().collect(), moves);
        // The bits of occupancy the moves changed: a range of words per bucket, each bucket
        // on one thread (before any undoing).
        if owned.is_none() {
            let logs: Vec<&crate::lattice::Words> = parts.iter().map(|p| &p.words).collect();
            // SAFETY: after every part; bucket `b`'s words are written here alone.
            pool.map((0..split.1).collect(), |b| unsafe { shift.apply(&logs, b) });
        }
        let movers: usize = parts.iter().map(|p| p.movers.len()).sum();
        // The movers that crossed from one part's words into another's, on this thread.
        let crossing: Vec<u32> = parts.iter().flat_map(|p| &p.crossing).copied().collect();
        let failed = made.iter().any(|m| m.1.is_none());
        let mut left_over = Vec::new();
        if crossing.len() * 8 > movers {
            // (Agents far from the order of their cells: one thread makes these moves.)
            self.bufs.owned_pause = 16;
        }
        if !failed && !crossing.is_empty() {
            changes.moved_all(self.lat, crossing.iter().copied());
            let tried = (self.lat).shift_alone(&crossing, (off, d), false, &mut left_over);
            // (None is bonded: a part stops at a bonded mover before it asks whose the
            // move is.)
            debug_assert!(tried.is_some());
            unnote(&mut changes.moved, &left_over);
        }
        if failed {
            // Those moved: each part's movers it went through, but those it left.
            let undo: Vec<Vec<u32>> = (parts.iter().zip(&made))
                .map(|(p, m)| {
                    let mut moved = p.movers[..m.0].to_vec();
                    drop_agents(&mut moved, &p.deferred, |&a| a);
                    drop_agents(&mut moved, &p.crossing, |&a| a);
                    moved
                })
                .collect();
            self.lat.unshift(&undo, (off, d));
            changes.moved_parts.iter_mut().for_each(Vec::clear);
            self.bufs.fused = parts;
            return AtOnce::Failed;
        }
        if !left_over.is_empty() {
            // Those left to the general way, in agent order, as one part's.
            let mut all: Vec<u32> = parts
                .iter_mut()
                .flat_map(|p| p.deferred.drain(..))
                .collect();
            all.extend_from_slice(&left_over);
            all.sort_unstable();
            parts[0].deferred = all;
        }
        let rim = made.iter().map(|m| m.1.unwrap_or(0)).sum();
        let left: usize = parts.iter().map(|p| p.deferred.len()).sum();
        self.bufs.fused = parts;
        self.stats.moves += (movers - left) as u64;
        AtOnce::Done { rim, movers }
    }
}

/// The words of occupancy each chunk's part owns for [`crate::lattice::Shift::in_place`]'s
/// [`OccWrites::Owned`] (`size` items a chunk, `chunks` of them): chunk `c` the words
/// `o[c]..o[c + 1]`, cut at the word of each chunk's first agent. `None` when those words
/// do not rise with the chunks (agents not in the order of their cells: the parts note
/// their bits instead), or the first agent of a chunk is off the grid.
fn owned_words(
    lat: &Lattice,
    src: Movers<'_>,
    (size, chunks): (usize, usize),
) -> Option<Vec<usize>> {
    let words = lat.cells.grid().map(|_| lat.cells.slots().div_ceil(64))?;
    let mut o = Vec::with_capacity(chunks + 1);
    o.push(0);
    for c in 1..chunks {
        let code = lat.code_of(src.agent(c * size));
        if code == crate::cells::NO_SLOT {
            return None;
        }
        let w = (code & !RIM) as usize / 64;
        if w < *o.last()? || w > words {
            return None;
        }
        o.push(w);
    }
    o.push(words);
    Some(o)
}

/// How the plain moves of a step at once went.
enum AtOnce {
    /// Made, but for the movers left to the general way: `rim` of the `movers` stood on
    /// the grid's rim (or off it).
    Done { rim: usize, movers: usize },
    /// Not tried: not a step of plain moves on a grid, or paused.
    NotTried,
    /// Tried and undone: a mover is bonded.
    Failed,
}

/// The carried groups' moves of a step are made on the pool from this many movers: the
/// decisions before are made on this thread, and the pool must first fetch what they
/// wrote. Two threads against one, the steps of carried bars of four (the moves' bits
/// written after, `Bits::Log`): 100,000 movers a step 1.10x the time, 250,000 0.96x,
/// 1,000,000 0.95x (four, four and three pairs of runs).
const GROUP_MOVES_ON_POOL: usize = 1 << 18;

/// Whether a bond stays rigid through the moves, from the letters of its two ends: one
/// says `+` and neither `0`.
fn rigid_bond(la: AttachLetter, lb: AttachLetter) -> bool {
    la != AttachLetter::Detach
        && lb != AttachLetter::Detach
        && (la == AttachLetter::Rigid || lb == AttachLetter::Rigid)
}

/// The agents the bonds and groups of a step concern, each with its index among them (in
/// id order) and its intent: the agents with a move or attachment letters, the groups
/// their rigid bonds carry, and the bonded partners of all of these (whose bonds to a
/// mover break, or to an agent saying `0`). Any other agent's bonds are to agents that
/// neither move nor change them, and stay. When these are many (or `all`), every agent.
pub(super) struct Among {
    /// The agents, in id order (empty when every agent is among them).
    ids: Vec<u32>,
    /// Every agent's index is its id.
    every: usize,
    index: FxHashMap<u32, u32>,
    /// Per index, the intent.
    intents: Vec<Intent>,
}

impl Among {
    /// The agents of `todo`'s actions concern (every agent with `all`); `spare`: an
    /// allocation for the intents.
    fn of(todo: &Actions, lat: &Lattice, (all, th): (bool, &Threads), spare: Vec<Intent>) -> Among {
        let n = lat.len();
        let every = |spare| Among {
            ids: Vec::new(),
            every: n,
            index: FxHashMap::default(),
            intents: todo.dense(n, spare, th),
        };
        // (At least as many agents as have intents: every agent, without counting them.)
        let lettered = || {
            todo.links
                .iter()
                .filter(|l| l.1.iter().any(|&l| l != AttachLetter::Keep))
        };
        if all || todo.moves.len() + todo.blocked.len() + lettered().count() > n / 8 {
            return every(spare);
        }
        let mut sparse: FxHashMap<u32, Intent> = FxHashMap::default();
        for &(a, o) in &todo.moves {
            sparse.entry(a).or_default().mv = Some(o);
        }
        for &a in &todo.blocked {
            sparse.entry(a).or_default().mv_bad = true;
        }
        for &(a, letters, _) in &todo.links {
            if letters.iter().any(|&l| l != AttachLetter::Keep) {
                sparse.entry(a).or_default().letters = letters;
            }
        }
        let intent = |a: u32| sparse.get(&a).copied().unwrap_or_default();
        let nd = lat.dim.dirs();
        let partners = |a: u32| {
            let bits = lat.attach[a as usize];
            (0..nd)
                .filter(move |d| bits & (1 << d) != 0)
                .filter_map(move |d| lat.neighbour(a, Dir::ALL[d]).map(|b| (d, b)))
        };
        // The movers' groups, through rigid bonds (a member need not have an intent: a
        // partner's `+` holds it).
        let mut members: rustc_hash::FxHashSet<u32> = (sparse.iter())
            .filter(|(_, it)| it.mv.is_some() || it.mv_bad)
            .map(|(&a, _)| a)
            .collect();
        let mut stack: Vec<u32> = members.iter().copied().collect();
        while let Some(x) = stack.pop() {
            for (d, b) in partners(x) {
                let od = Dir::ALL[d].opposite().index();
                if rigid_bond(intent(x).letters[d], intent(b).letters[od]) && members.insert(b) {
                    stack.push(b);
                }
            }
        }
        // With the agents with intents, and the partners of all of these.
        let mut found: rustc_hash::FxHashSet<u32> = sparse.keys().copied().collect();
        found.extend(members.iter().copied());
        for &a in sparse.keys().chain(&members) {
            found.extend(partners(a).map(|(_, b)| b));
        }
        if found.len() > n / 4 {
            return every(spare);
        }
        let mut ids: Vec<u32> = found.into_iter().collect();
        ids.sort_unstable();
        let index = ids
            .iter()
            .enumerate()
            .map(|(i, &a)| (a, i as u32))
            .collect();
        let intents = ids.iter().map(|&a| intent(a)).collect();
        Among {
            ids,
            every: 0,
            index,
            intents,
        }
    }

    /// The intents' allocation, for the next step.
    fn into_intents(self) -> Vec<Intent> {
        self.intents
    }

    pub(super) fn len(&self) -> usize {
        self.every.max(self.ids.len())
    }

    /// The agent of index `i`.
    #[inline]
    pub(super) fn id(&self, i: usize) -> u32 {
        if self.every > 0 {
            i as u32
        } else {
            self.ids[i]
        }
    }

    /// Agent `a`'s index, when it is among them.
    #[inline]
    pub(super) fn local(&self, a: u32) -> Option<u32> {
        if self.every > 0 {
            Some(a)
        } else {
            self.index.get(&a).copied()
        }
    }

    /// The intent of the agent of index `i`.
    #[inline]
    pub(super) fn intent_at(&self, i: usize) -> &Intent {
        &self.intents[i]
    }

    /// Agent `a`'s intent (none when it is not among them).
    #[inline]
    pub(super) fn intent(&self, a: u32) -> Intent {
        self.local(a)
            .map_or_else(Intent::default, |i| self.intents[i as usize])
    }
}

/// Lists of every agent concerned (or every group) that a step of carried groups makes
/// and drops, kept for the next step: made fresh, those of 2 MB and more were mapped anew
/// and their pages faulted in every step (an eighth of the time of 250,000 carried bars).
#[derive(Default)]
pub(super) struct Spares {
    u32s: Vec<Vec<u32>>,
    u8s: Vec<Vec<u8>>,
    /// The last step's moves.
    pub(super) movers: Vec<groups::Mover>,
}

impl Spares {
    /// A list of `n` times `v`.
    pub(super) fn u32s(&mut self, n: usize, v: u32) -> Vec<u32> {
        let mut x = self.u32s.pop().unwrap_or_default();
        x.clear();
        x.resize(n, v);
        x
    }

    /// A list of `n` zeros.
    fn u8s(&mut self, n: usize) -> Vec<u8> {
        let mut x = self.u8s.pop().unwrap_or_default();
        x.clear();
        x.resize(n, 0);
        x
    }

    /// Keeps `x` for a later list.
    pub(super) fn keep_u32s(&mut self, x: Vec<u32>) {
        self.u32s.push(x);
    }

    fn keep_u8s(&mut self, x: Vec<u8>) {
        self.u8s.push(x);
    }
}

/// Per direction, an agent's partner before the moves.
pub(super) type Partners = [Option<u32>; 6];

/// The root of `x` among `parent` (links to indices from `lo` up, `parent[i - lo]`
/// being `i`'s), halving the paths it walks.
fn find(parent: &mut [u32], lo: u32, mut x: u32) -> u32 {
    while parent[(x - lo) as usize] != x {
        let up = parent[(parent[(x - lo) as usize] - lo) as usize];
        parent[(x - lo) as usize] = up;
        x = up;
    }
    x
}

/// Joins the trees of `x` and `y` (as [`find`]): the greater root goes under the lesser,
/// so that every tree's root is its least index, whatever the order of the joins.
fn union(parent: &mut [u32], lo: u32, (x, y): (u32, u32)) {
    let (x, y) = (find(parent, lo, x), find(parent, lo, y));
    if x != y {
        parent[(x.max(y) - lo) as usize] = x.min(y);
    }
}

impl Act<'_> {
    /// Steps 1 to 4: detach, decide, move rigid groups, attach, for the agents `among`
    /// concerns (see [`Among`]); every other agent's bonds stay as they were, as those steps
    /// over all agents would leave them.
    pub(super) fn detach_move_attach(&mut self, todo: &Actions, rep: &mut StepReport) {
        let all = self.opts.trace;
        let (lat, th) = (&*self.lat, self.threads);
        let among = Among::of(todo, lat, (all, th), std::mem::take(&mut self.bufs.intents));
        let (m, nd) = (among.len(), lat.dim.dirs());
        let mut spares = std::mem::take(&mut self.bufs.spares);
        let mut old = spares.u8s(m);
        th.fill(&mut old, |i| lat.attach[among.id(i) as usize]);
        // Partners before detaching (and before the moves, for `*`), per agent (by its
        // index among them) and direction.
        let mut partners = std::mem::take(&mut self.bufs.partners);
        partners.resize(m, [None; 6]);
        th.fill(&mut partners, |i| {
            let mut ps = [None; 6];
            for (d, p) in ps.iter_mut().enumerate().take(nd) {
                if old[i] & (1 << d) != 0 {
                    *p = lat.neighbour(among.id(i), Dir::ALL[d]);
                }
            }
            ps
        });
        // 1. Detach: keep rigid bonds only.
        let mut rigid = spares.u8s(m);
        th.fill(&mut rigid, |i| {
            let mut bits = 0;
            for d in 0..nd {
                if let Some(b) = partners[i][d] {
                    let od = Dir::ALL[d].opposite().index();
                    if rigid_bond(among.intent_at(i).letters[d], among.intent(b).letters[od]) {
                        bits |= 1 << d;
                    }
                }
            }
            bits
        });
        // 3. Move: groups of rigid bonds (a group's root: its first agent).
        let root = self.groups_roots(&among, &rigid, &partners, &mut spares);
        let mut sc = std::mem::take(&mut self.bufs.scratch);
        let (moves, cancelled) = self.move_groups(&among, &root, (&mut sc, &mut spares), rep);
        spares.keep_u32s(root);
        let carried = |lo: usize, hi: usize| {
            let ms = moves[lo..hi].iter();
            ms.filter(|m| among.intent(m.0).mv.is_none()).count() as u64
        };
        self.stats.carried += th.par_chunks(moves.len(), &carried).iter().sum::<u64>();
        // The moves (no two share a target; a mover's old cell is emptied only when no
        // mover targets it, as the claims left tell), per chunk of movers on the pool
        // from `GROUP_MOVES_ON_POOL` movers a step, else on this thread.
        let (par, size, _) = self.threads.chunks_from(moves.len(), GROUP_MOVES_ON_POOL);
        let mut parts = std::mem::take(&mut self.bufs.alone);
        parts.resize_with(moves.len().div_ceil(size), alone::AlonePart::default);
        for (part, ms) in parts.iter_mut().zip(moves.chunks(size)) {
            part.set_moves(ms);
        }
        self.move_parts(par, &mut parts, |s| sc.claimed(s), rep);
        self.bufs.alone = parts;
        for (a, c) in (moves.iter().map(|m| (m.0, m.2))).chain(cancelled) {
            sc.unclaim(a, alone::slot(c));
        }
        self.bufs.scratch = sc;
        spares.movers = moves;
        self.attach_after_moves(&among, (&old, &rigid, &partners), rep);
        spares.keep_u8s(old);
        spares.keep_u8s(rigid);
        self.bufs.spares = spares;
        // (Kept whole: the next step's as many agents need not write it twice.)
        self.bufs.partners = partners;
        self.bufs.intents = among.into_intents();
    }

    /// Per agent (by its index `among` them), the root of its rigid group: the least index
    /// joined to it by rigid bonds (`rigid`: per index, the directions of its rigid bonds;
    /// `partners`: their ends). Joined per chunk of indices (on the pool when there are
    /// threads), the bonds between chunks after; the roots are the same for any split.
    fn groups_roots(
        &self,
        among: &Among,
        rigid: &[u8],
        partners: &[Partners],
        spares: &mut Spares,
    ) -> Vec<u32> {
        let (m, nd) = (among.len(), self.lat.dim.dirs());
        let mut parent = spares.u32s(m, 0);
        self.threads.fill(&mut parent, |i| i as u32);
        let (par, size, _) = self.threads.chunks(m);
        let items: Vec<(usize, &mut [u32])> = parent.chunks_mut(size).enumerate().collect();
        let across: Vec<Vec<(u32, u32)>> = map_on(par, items, |(c, mine)| {
            let (lo, hi) = ((c * size) as u32, (c * size + mine.len()) as u32);
            let mut across = Vec::new();
            for i in lo..hi {
                for d in 0..nd {
                    let Some(b) =
                        partners[i as usize][d].filter(|_| rigid[i as usize] & (1 << d) != 0)
                    else {
                        continue;
                    };
                    let j = among
                        .local(b)
                        .expect("both ends of a rigid bond are among them");
                    match (lo..hi).contains(&j) {
                        true => union(mine, lo, (i, j)),
                        // (Each bond across once, from its lesser end.)
                        false if i < j => across.push((i, j)),
                        false => {}
                    }
                }
            }
            across
        });
        for (i, j) in across.into_iter().flatten() {
            union(&mut parent, 0, (i, j));
        }
        let mut root = spares.u32s(m, 0);
        let up = &parent;
        self.threads.fill(&mut root, |i| {
            let mut x = i as u32;
            while up[x as usize] != x {
                x = up[x as usize];
            }
            x
        });
        spares.keep_u32s(parent);
        root
    }

    /// Step 4: attach after the moves: rigid bonds stay; a bond forms where one side
    /// decided to attach and neither side said 0. For the agents `among` concerns, by
    /// their index there: `old`, their bonds before the step; `keep_partner`, per
    /// direction, their partner before the moves. An agent not among them keeps its bonds,
    /// and gains those the others make with it.
    pub(super) fn attach_after_moves(
        &mut self,
        among: &Among,
        (old, rigid, keep_partner): (&[u8], &[u8], &[Partners]),
        rep: &mut StepReport,
    ) {
        let (nd, cap) = (self.lat.dim.dirs(), self.opts.records_per_step);
        let lat = &*self.lat;
        // Each agent's side, in chunks (on the pool when there are threads): its bonds
        // kept rigid and those it makes, the bonds it makes for its partners among them
        // (set after: a bond is made from either side) and for those not among them, and
        // its refusals (recorded in agent order).
        let side = |lo: usize, hi: usize| {
            let mut bits: Vec<u8> = rigid[lo..hi].to_vec();
            let (mut partners, mut outside, mut notes) = (Vec::new(), Vec::new(), Notes::default());
            for i in lo..hi {
                let a = among.id(i);
                for d in 0..nd {
                    if bits[i - lo] & (1 << d) != 0 {
                        continue;
                    }
                    let la = among.intent_at(i).letters[d];
                    // Only `1`, or `*`/`+` towards a former partner, can form a bond:
                    // look up the neighbour only then.
                    let wants = match la {
                        AttachLetter::Attach => true,
                        AttachLetter::Keep | AttachLetter::Rigid => keep_partner[i][d].is_some(),
                        AttachLetter::Detach => false,
                    };
                    if !wants {
                        continue;
                    }
                    let Some(b) = lat.neighbour(a, Dir::ALL[d]) else {
                        continue;
                    };
                    if la != AttachLetter::Attach && keep_partner[i][d] != Some(b) {
                        continue;
                    }
                    let od = Dir::ALL[d].opposite().index();
                    let lb = among.intent(b).letters[od];
                    if lb == AttachLetter::Detach {
                        if la == AttachLetter::Attach {
                            let msg = || {
                                format!(
                                    "agent {} wants to attach towards {} to agent {}, which says 0; no bond",
                                    lat.label(a),
                                    Dir::ALL[d].letter(),
                                    lat.label(b)
                                )
                            };
                            notes.push(cap, (RecordKind::AttachRefused, vec![a, b]), msg);
                        }
                        continue;
                    }
                    bits[i - lo] |= 1 << d;
                    match among.local(b) {
                        Some(j) => partners.push((j, 1u8 << od)),
                        None => outside.push((b, 1u8 << od)),
                    }
                }
            }
            (bits, partners, outside, notes)
        };
        let parts = self.threads.par_chunks(among.len(), &side);
        let mut new_attach: Vec<u8> = Vec::with_capacity(among.len());
        // Bonds made with agents not among them.
        let mut outside: Vec<(u32, u8)> = Vec::new();
        let mut partners: Vec<(u32, u8)> = Vec::new();
        for (bits, ps, out, notes) in parts {
            new_attach.extend_from_slice(&bits);
            partners.extend(ps);
            outside.extend(out);
            self.record_notes(notes.list, rep);
        }
        for (j, bit) in partners {
            new_attach[j as usize] |= bit;
        }
        if self.opts.trace {
            // (Traced, every agent is among them: the events come in agent order.)
            for i in 0..among.len() {
                let a = among.id(i);
                for d in 0..nd {
                    let was = old[i] & (1 << d) != 0;
                    let now = new_attach[i] & (1 << d) != 0;
                    let b_now = self.lat.neighbour(a, Dir::ALL[d]);
                    let b_was = keep_partner[i][d];
                    if was && (!now || b_now != b_was) {
                        if let Some(b) = b_was.filter(|&b| b > a) {
                            rep.trace.push(TraceEvent::Bond {
                                a,
                                b,
                                formed: false,
                            });
                        }
                    }
                    if now && (!was || b_now != b_was) {
                        if let Some(b) = b_now.filter(|&b| b > a) {
                            rep.trace.push(TraceEvent::Bond { a, b, formed: true });
                        }
                    }
                }
            }
        }
        if among.len() == self.lat.len() {
            // Every agent among them (index = id): written per chunk (on the pool when
            // there are threads), the agents whose bonds changed listed in order.
            let noting = self.bufs.changes.on;
            let (par, size, _) = self.threads.chunks(among.len());
            let items: Vec<_> = (self.lat.attach.chunks_mut(size))
                .zip(old.chunks(size).zip(new_attach.chunks(size)))
                .enumerate()
                .collect();
            let changed = map_on(par, items, |(c, (attach, (old, new)))| {
                attach.copy_from_slice(new);
                let differ = (old.iter().zip(new))
                    .enumerate()
                    .filter(|(_, (o, n))| o != n);
                let ids = differ.map(|(k, _)| (c * size + k) as u32);
                match noting {
                    true => ids.collect(),
                    false => Vec::new(),
                }
            });
            changed
                .iter()
                .flatten()
                .for_each(|&a| self.bufs.changes.bonds(a));
        } else {
            for (i, (&o, &new)) in old.iter().zip(&new_attach).enumerate() {
                let a = among.id(i);
                if o != new {
                    self.bufs.changes.bonds(a);
                }
                self.lat.attach[a as usize] = new;
            }
        }
        for (b, bit) in outside {
            self.lat.attach[b as usize] |= bit;
            self.bufs.changes.bonds(b);
        }
    }
}

/// The sentence of a collision at `cell`: the agents that would meet there and the moves
/// cancelled (`movers`: the agents moving into it).
pub(super) fn collision_text(
    lat: &Lattice,
    cell: [i32; 3],
    movers: &[u32],
    involved: &[u32],
) -> String {
    let (s, are) = if movers.len() == 1 {
        ("", "is")
    } else {
        ("s", "are")
    };
    // (One string written in place: a jam makes thousands of these a step.)
    use std::fmt::Write;
    let mut text = String::with_capacity(80 + 8 * (involved.len() + movers.len()));
    text.push_str("agents ");
    lat.push_ids(&mut text, involved);
    text.push_str(" would meet on the cell ");
    lat.push_cell(&mut text, cell);
    let _ = write!(text, "; the move{s} of agent{s} ");
    lat.push_ids(&mut text, movers);
    let _ = write!(text, " {are} cancelled");
    text
}
