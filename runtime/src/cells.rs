//! The cell-to-agent index: a flat grid where the agents are dense, tiles of cells
//! allocated where they stand where they are sparse (`sparse.rs`). The grid covers the agents' bounding box (with a margin), or a bounded
//! universe when it is small enough, when that box has at most a few cells per agent;
//! cells outside it fall back to the tiles, so agents may go anywhere. When many agents
//! have left the grid, it is made again over where the agents are now, with room to grow
//! ([`CellIndex::regrow`]), when that box is within the same budget. A sparse set in a
//! huge universe costs memory in proportion to the agents.

use latticesim_vm::model::{Bounds, Dir};

mod sparse;
use sparse::Sparse;

/// In the grid and in neighbour lists: no agent.
pub const EMPTY: u32 = u32::MAX;
/// A slot code ([`CellIndex::code`]) of a position outside the grid.
pub const NO_SLOT: u32 = u32::MAX;
/// The flag of a slot code for a cell on the grid's rim (some of its neighbours are
/// outside the grid).
pub const RIM: u32 = 1 << 31;
/// Grid cells allowed per agent before the index is tiles (a grid of eight cells per
/// agent holds about what a hash map of cells and a neighbour table held, and answers faster); see
/// [`budget`].
const CELLS_PER_AGENT: i64 = 8;
/// Grid cells allowed whatever the agents' number (4 MiB of cells): a few agents spread
/// over a box of a million cells are 3-20x faster on a grid than in the hash map (1,000
/// walkers above a block of 100 agents, 200 walkers scattered over 1,000 x 1,000 cells;
/// in 3D a slab of 1,000 walkers beside a block of 125), for a few MiB.
const CELLS_FLOOR: i64 = 1 << 20;

/// The most cells a grid (or a side box) over `n` agents may have: eight per agent and
/// 4,096 more, and at least [`CELLS_FLOOR`] (so the budget of more than 131,072 agents is
/// what it was before the floor, and with it when grids are made again as agents move).
fn budget(n: usize) -> i64 {
    (CELLS_PER_AGENT * n as i64 + 4096).max(CELLS_FLOOR)
}
/// Cells added around the agents' bounding box.
const MARGIN: i32 = 2;
/// Agents outside a grid are put into a side box from this many on (fewer stay in tiles).
const GATHER_FROM: usize = 8;
/// Room ahead of agents that left the grid when it is made again for them
/// ([`CellIndex::regrow`]): their extent along the axis over this. (A half: 1,000 walkers
/// beside 10^5 agents at rest had the grid made again twice over their 1,000 steps with a
/// quarter, once with a half: 0.93x the stepping time, eight alternating pairs; the 3D
/// walkers leaving a box of 10^6 0.98x; peaks the same.)
pub(crate) const ROOM_SHARE: i64 = 2;

/// The slot code of cell `i` whose word of rim bits is `rim_word`: `i`, with [`RIM`] when
/// its bit is set (every way a code is made from a cell goes through here).
#[inline(always)]
fn slot_code(i: usize, rim_word: u64) -> u32 {
    i as u32 | ((rim_word >> (i % 64) & 1) as u32) << 31
}

/// Whether every slot of `codes` is interior (below [`RIM`]: its neighbours are all in the
/// grid), in one pass without a branch per slot.
#[inline]
pub(crate) fn all_interior(codes: &[u32]) -> bool {
    codes.iter().fold(true, |ok, &s| ok & (s < RIM))
}

/// How far ahead a loop over agents asks for the cells it will touch ([`prefetch`]).
pub(crate) const AHEAD: usize = 12;

/// Asks the processor to bring the memory at `p` into its caches: a hint that reads
/// nothing and never faults, whatever the address. Agents listed in no spatial order
/// touch cells all over the grid; a loop that asks for the cells a few agents ahead waits
/// on memory once for several agents instead of once for each (a step of a million
/// agents listed at random took 40 % less time).
/// Whether cells given by their slot codes (in the order a loop visits them, the first
/// 65 of them) lie scattered over the grid: then the loop asks for the cells ahead
/// ([`prefetch`]); in order, the processor finds them by itself and asking costs more
/// than it saves.
pub(crate) fn scattered(codes: impl Iterator<Item = u32>) -> bool {
    let (mut jumps, mut count, mut last) = (0, 0, None);
    for c in codes.take(65) {
        let c = c & !RIM;
        if last.is_some_and(|l: u32| l.abs_diff(c) > 4096) {
            jumps += 1;
        }
        last = Some(c);
        count += 1;
    }
    jumps > count / 4
}

#[inline(always)]
pub(crate) fn prefetch<T>(p: *const T) {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: a prefetch reads no memory and cannot fault on any address; SSE, which has
    // it, is part of every x86-64 processor.
    unsafe {
        std::arch::x86_64::_mm_prefetch::<{ std::arch::x86_64::_MM_HINT_T0 }>(p.cast());
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = p;
}

/// The box of positions `pos`: its low and high corner (empty: `i32::MAX`, `i32::MIN`).
fn bounds<'p>(pos: impl IntoIterator<Item = &'p [i32; 3]>) -> ([i32; 3], [i32; 3]) {
    let (mut lo, mut hi) = ([i32::MAX; 3], [i32::MIN; 3]);
    for p in pos {
        for k in 0..3 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    (lo, hi)
}

/// The box of most of the agents at `pos`, per axis from the `1/q`-th smallest coordinate
/// to the `1/q`-th largest, judged on a sample of at most 4,096 of them (`None` for fewer
/// than 1,024 agents: a grid over so few is within budget or pointless).
fn core_bounds(pos: &[[i32; 3]], q: usize) -> Option<([i32; 3], [i32; 3])> {
    if pos.len() < 1024 {
        return None;
    }
    let every = pos.len().div_ceil(4096);
    let sample: Vec<[i32; 3]> = pos.iter().step_by(every).copied().collect();
    let (lo, hi) = (sample.len() / q, sample.len() - 1 - sample.len() / q);
    let mut axis: Vec<i32> = Vec::with_capacity(sample.len());
    let (mut blo, mut bhi) = ([0; 3], [0; 3]);
    for k in 0..3 {
        axis.clear();
        axis.extend(sample.iter().map(|p| p[k]));
        axis.sort_unstable();
        (blo[k], bhi[k]) = (axis[lo], axis[hi]);
    }
    Some((blo, bhi))
}

/// Which agent stands on which cell.
#[derive(Debug, Clone, PartialEq)]
pub struct CellIndex {
    grid: Option<Grid>,
    /// Beside a grid: a box of cells over the agents outside it (a line that walks away
    /// while the grid over it and the others would be over budget), made from the tiles
    /// by [`CellIndex::gather_outside`]; agents outside both are in tiles of cells
    /// allocated where they stand.
    side: Option<Side>,
    map: Sparse,
    /// How long [`CellIndex::gather_outside`] waits after a box over budget.
    refused: Backoff,
    /// The universe's bounds, when it is bounded (the grid stays inside them), and the
    /// axes of the dimension.
    walls: Option<Bounds>,
    coords: usize,
}

/// After [`CellIndex::gather_outside`] found the agents outside the grid over budget: how
/// many calls to let pass before it tries again, and how many after the next refusal
/// (doubling to 1,024): a try costs a pass over those agents, and walkers far from a
/// block tried it every step.
#[derive(Debug, Clone, Copy)]
struct Backoff {
    left: u32,
    next: u32,
}

impl Default for Backoff {
    fn default() -> Backoff {
        Backoff { left: 0, next: 1 }
    }
}

impl PartialEq for Backoff {
    /// Always: when to look again is not what an index holds.
    fn eq(&self, _: &Backoff) -> bool {
        true
    }
}

impl Backoff {
    /// Whether to let this call pass (counting it).
    fn wait(&mut self) -> bool {
        let wait = self.left > 0;
        self.left = self.left.saturating_sub(1);
        wait
    }

    fn refused(&mut self) {
        self.left = self.next;
        self.next = (self.next * 2).min(1024);
    }
}

/// The side box of the index: cells, each an agent id or [`EMPTY`], from `lo`, with how
/// many agents it holds.
#[derive(Debug, Clone, PartialEq)]
struct Side {
    lo: [i32; 3],
    size: [i64; 3],
    cells: Vec<u32>,
    count: usize,
}

impl Side {
    /// A side box over `agents` (each with its cell), with room around them on the axes
    /// of a lattice of `coords` dimensions when `roomy` (a quarter of their extent, halved
    /// down to none while the box is over the budget of their count), and whether each had
    /// a cell of its own (a later agent on an earlier one's cell takes it); `None` when even
    /// their own box is over the budget.
    fn over<'p>(
        agents: impl ExactSizeIterator<Item = (&'p [i32; 3], u32)> + Clone,
        (coords, roomy): (usize, bool),
    ) -> Option<(Side, bool)> {
        let (lo, hi) = bounds(agents.clone().map(|(p, _)| p));
        let len = agents.len();
        let budget = budget(len);
        let mut room = [0, 1, 2].map(|k| match k >= coords || !roomy {
            true => 0,
            false => ((hi[k] as i64 - lo[k] as i64) / 4).clamp(MARGIN as i64, 1 << 20),
        });
        loop {
            let (slo, size) = (
                [0, 1, 2].map(|k| (lo[k] as i64 - room[k]).max(i32::MIN as i64) as i32),
                [0, 1, 2].map(|k| {
                    (hi[k] as i64 + room[k]).min(i32::MAX as i64)
                        - (lo[k] as i64 - room[k]).max(i32::MIN as i64)
                        + 1
                }),
            );
            let volume = size.iter().fold(1i64, |v, &s| v.saturating_mul(s));
            if volume <= budget {
                let mut side = Side {
                    lo: slo,
                    size,
                    cells: vec![EMPTY; volume as usize],
                    count: 0,
                };
                for (&p, a) in agents {
                    let i = side.slot(p).expect("inside the side box");
                    side.count += (side.cells[i] == EMPTY) as usize;
                    side.cells[i] = a;
                }
                let own = side.count == len;
                return Some((side, own));
            }
            // (Room down to the margin, then none: the box needs no margin, as nothing
            // reads a neighbour's cell from a cell of it.)
            if room.iter().all(|&r| r == 0) {
                return None;
            }
            room = room.map(|r| match r <= MARGIN as i64 {
                true => 0,
                false => (r / 2).max(MARGIN as i64),
            });
        }
    }

    #[inline]
    fn slot(&self, p: [i32; 3]) -> Option<usize> {
        box_slot((self.lo, self.size), p)
    }

    /// The agents it holds, with their cells.
    fn agents(&self) -> impl Iterator<Item = ([i32; 3], u32)> + '_ {
        let [_, h, d] = self.size;
        (self.cells.iter().enumerate())
            .filter(|c| *c.1 != EMPTY)
            .map(move |(i, &a)| {
                let i = i as i64;
                let o = [i / (h * d), i / d % h, i % d];
                ([0, 1, 2].map(|k| (self.lo[k] as i64 + o[k]) as i32), a)
            })
    }
}

/// The dense part of the index: a box of cells, each an agent id or [`EMPTY`], with an
/// occupancy bit per cell kept with it by [`Grid::put`].
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Grid {
    lo: [i32; 3],
    size: [i64; 3],
    cells: Vec<u32>,
    /// A bit per cell: it holds an agent (the same as `cells`, in a 32nd of the memory,
    /// for questions that need no id).
    occ: Vec<u64>,
    /// Per direction (`Dir::ALL` order): the step in `cells` to the neighbouring cell.
    delta: [isize; 6],
    /// Per axis: the interior starts `first` cells in and is `span` cells long (the grid
    /// minus its outer layer; a one-cell axis is all interior).
    first: [u32; 3],
    span: [u32; 3],
    /// A bit per cell on the grid's outer layer (the rim: some neighbour is outside),
    /// made when first needed ([`Grid::ready_rim`]: only moves made at once need it).
    rim: Vec<u64>,
}

impl Grid {
    /// A grid of `size` cells from `lo`, all empty.
    fn empty(lo: [i32; 3], size: [i64; 3]) -> Grid {
        let volume = (size[0] * size[1] * size[2]) as usize;
        let delta = Dir::ALL
            .map(|d| d.offset())
            .map(|d| ((d[0] as i64 * size[1] + d[1] as i64) * size[2] + d[2] as i64) as isize);
        Grid {
            lo,
            size,
            cells: vec![EMPTY; volume],
            occ: vec![0; volume.div_ceil(64)],
            delta,
            first: size.map(|s| (s > 1) as u32),
            span: size.map(|s| if s > 1 { s as u32 - 2 } else { 1 }),
            rim: Vec::new(),
        }
    }

    /// Makes the bits of the rim (for slot codes made from slots), if not made yet.
    pub(crate) fn ready_rim(&mut self) {
        if !self.rim.is_empty() {
            return;
        }
        let (size, volume) = (self.size, self.cells.len());
        let mut rim = vec![0u64; volume.div_ceil(64)];
        let at = |o: [i64; 3]| ((o[0] * size[1] + o[1]) * size[2] + o[2]) as usize;
        // The outer layer, face by face (a one-cell axis has none).
        for k in (0..3).filter(|&k| size[k] > 1) {
            let (a, b) = ((k + 1) % 3, (k + 2) % 3);
            for side in [0, size[k] - 1] {
                for i in 0..size[a] {
                    for j in 0..size[b] {
                        let mut o = [0i64; 3];
                        (o[k], o[a], o[b]) = (side, i, j);
                        let c = at(o);
                        rim[c / 64] |= 1 << (c % 64);
                    }
                }
            }
        }
        self.rim = rim;
    }

    /// Puts `a` (an agent or [`EMPTY`]) into cell `i`.
    #[inline]
    pub(crate) fn put(&mut self, i: usize, a: u32) {
        if a == EMPTY {
            self.vacate(i);
        } else {
            self.occupy(i, a);
        }
    }

    /// Puts agent `a` into cell `i`.
    #[inline]
    pub(crate) fn occupy(&mut self, i: usize, a: u32) {
        self.cells_mut().occupy(i, a);
    }

    /// Empties cell `i`.
    #[inline]
    pub(crate) fn vacate(&mut self, i: usize) {
        self.cells_mut().vacate(i);
    }

    /// The cells and their occupancy bits as slices, for loops that write many cells
    /// (held in locals, they need not be reloaded after every write).
    #[inline]
    pub(crate) fn cells_mut(&mut self) -> CellsMut<'_> {
        CellsMut {
            cells: &mut self.cells,
            occ: &mut self.occ,
            rim: &self.rim,
        }
    }

    /// Whether cell `i` holds an agent.
    #[inline]
    pub(crate) fn filled(&self, i: usize) -> bool {
        self.occ[i / 64] >> (i % 64) & 1 != 0
    }

    /// For slots `codes` that are all interior (each a [`CellIndex::code`] below [`RIM`]),
    /// clears `out[j]` unless the cell `step` away from `codes[j]` (a step between
    /// neighbours, [`Grid::step`]) is filled (`want`) or empty, and returns true: the same
    /// as [`Grid::filled`] cell by cell, four cells at a time where the processor gathers
    /// words (AVX2). Returns false, having done nothing, when some slot is on the rim (its
    /// neighbour may lie off the grid): the test of the rim comes with the first pass over
    /// the codes (a pass of its own before it took a quarter of B2's tests of the cell
    /// below).
    pub(crate) fn keep_next_filled(
        &self,
        codes: &[u32],
        step: isize,
        want: bool,
        out: &mut [bool],
    ) -> bool {
        assert_eq!(codes.len(), out.len(), "an entry per slot");
        #[cfg(target_arch = "x86_64")]
        // SAFETY: AVX2 is there (checked).
        if std::arch::is_x86_feature_detected!("avx2")
            && unsafe {
                keep_next_filled_avx2((&self.occ, self.cells.len()), codes, step, want, out)
            }
        {
            return true;
        }
        if !all_interior(codes) {
            return false;
        }
        for (t, &s) in out.iter_mut().zip(codes) {
            *t &= self.filled(Grid::along(s, step)) == want;
        }
        true
    }

    /// Asks for the occupancy bit of cell `i` ahead of [`Grid::filled`] (any `i`).
    #[inline]
    pub(crate) fn prefetch_filled(&self, i: usize) {
        prefetch(self.occ.as_ptr().wrapping_add(i / 64));
    }

    /// The cell next to interior slot `s` (a [`CellIndex::code`] below [`RIM`]) in
    /// direction index `d`.
    #[inline]
    pub(crate) fn next(&self, s: u32, d: usize) -> usize {
        Self::along(s, self.delta[d])
    }

    /// The step between neighbouring cells in direction index `d`, for loops that go
    /// [`Grid::along`] it.
    #[inline]
    pub(crate) fn step(&self, d: usize) -> isize {
        self.delta[d]
    }

    /// The cell a `step` away from interior slot `s`.
    #[inline]
    pub(crate) fn along(s: u32, step: isize) -> usize {
        (s as isize + step) as usize
    }

    /// The slot of a cell whose neighbours in every direction are also in the grid (in 2D
    /// the grid is one cell thick in z: only its one layer counts, and the caller asks only
    /// for the four directions in the plane).
    #[inline]
    fn interior(&self, p: [i32; 3]) -> Option<usize> {
        // Exact in 64 bits: a cell below the interior wraps to a large number.
        let o = [0, 1, 2].map(|k| (p[k] as i64 - self.lo[k] as i64) as u64);
        let inside = (0..3).all(|k| o[k].wrapping_sub(self.first[k] as u64) < self.span[k] as u64);
        inside.then(|| {
            (o[0] as usize * self.size[1] as usize + o[1] as usize) * self.size[2] as usize
                + o[2] as usize
        })
    }

    #[inline]
    pub(crate) fn slot(&self, p: [i32; 3]) -> Option<usize> {
        box_slot((self.lo, self.size), p)
    }
}

/// [`Grid::keep_next_filled`] with AVX2: the words of four cells gathered at once, their
/// bits made into four bytes of 0 or 1 and and-ed into `out` together (B2's test of the
/// cell below took 16 % of its time cell by cell).
///
/// Returns false, having done nothing, when some slot of `codes` is on the rim, or some
/// cell `step` away from one lies outside the grid of `len` cells whose bits `occ` holds
/// (in this function, the check takes an instruction per eight slots, where the
/// baseline's took several per four).
///
/// # Safety
/// The processor has AVX2; `codes` and `out` have one length.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn keep_next_filled_avx2(
    (occ, len): (&[u64], usize),
    codes: &[u32],
    step: isize,
    want: bool,
    out: &mut [bool],
) -> bool {
    use std::arch::x86_64::*;
    // Every cell read lies in the grid (and so below 2^31, as slots are). (A loop, not a
    // fold: a closure is not compiled for AVX2, and was called per slot.)
    let (mut lo, mut hi) = (u32::MAX, 0);
    for &s in codes {
        (lo, hi) = (lo.min(s), hi.max(s));
    }
    let inside = hi < RIM && lo as isize + step >= 0 && (hi as isize + step) < len as isize;
    if !inside || occ.len() < len.div_ceil(64) || codes.is_empty() {
        return codes.is_empty();
    }
    /// Per mask of four lanes, the four bytes 0 or 1 it spreads to (lane 0 the lowest).
    const SPREAD: [u32; 16] = {
        let mut t = [0u32; 16];
        let mut m = 0;
        while m < 16 {
            let mut l = 0;
            while l < 4 {
                t[m] |= ((m as u32 >> l) & 1) << (8 * l);
                l += 1;
            }
            m += 1;
        }
        t
    };
    let flip = if want { 0 } else { 0x0101_0101 };
    let four = codes.len() / 4 * 4;
    let (vstep, low) = (_mm_set1_epi32(step as i32), _mm256_set1_epi64x(63));
    let (codes_at, out_at) = (codes.as_ptr(), out.as_mut_ptr());
    for j in (0..four).step_by(4) {
        // SAFETY: `j + 4 <= four <= codes.len() == out.len()`; every word gathered is in
        // `occ` (checked above); `bool` bytes are written 0 or 1 only.
        unsafe {
            let cell = _mm_add_epi32(_mm_loadu_si128(codes_at.add(j).cast()), vstep);
            let words = _mm256_i32gather_epi64::<8>(occ.as_ptr().cast(), _mm_srli_epi32::<6>(cell));
            let shift = _mm256_and_si256(_mm256_cvtepu32_epi64(cell), low);
            // The bit of each cell moved to its lane's sign, read as a mask.
            let top = _mm256_sllv_epi64(words, _mm256_sub_epi64(low, shift));
            let mask = _mm256_movemask_pd(_mm256_castsi256_pd(top)) as usize;
            let keep = SPREAD[mask] ^ flip;
            let t = out_at.add(j).cast::<u32>();
            t.write_unaligned(t.read_unaligned() & keep);
        }
    }
    for j in four..codes.len() {
        let i = (codes[j] as isize + step) as usize;
        out[j] &= (occ[i / 64] >> (i % 64) & 1 != 0) == want;
    }
    true
}

/// The index of cell `p` in a box of cells of `size` from `lo` (x-major, z fastest), if
/// it lies inside.
#[inline]
fn box_slot((lo, size): ([i32; 3], [i64; 3]), p: [i32; 3]) -> Option<usize> {
    // Offsets from the low corner, exact in 64 bits; below it wraps to large.
    let o = [0, 1, 2].map(|k| (p[k] as i64 - lo[k] as i64) as u64);
    let inside = (0..3).all(|k| o[k] < size[k] as u64);
    inside.then(|| ((o[0] * size[1] as u64 + o[1]) * size[2] as u64 + o[2]) as usize)
}

/// How [`SharedCells::occupy`] and [`SharedCells::vacate`] keep the occupancy bits.
pub(crate) enum Bits<'l> {
    /// Written at once, by loads and stores: one thread moves agents.
    Write,
    /// Noted in a log, written after ([`SharedCells::apply`]): threads move agents at once
    /// and share words of bits. (Written by locked instructions, each waited for the
    /// writes before it: the moves of 25,000 carried bars on two threads took three times
    /// the processor time of one thread's.)
    Log(&'l mut BitLog),
    /// Left as they are: every cell written stays filled (agents swapping cells).
    Keep,
}

/// The bit of a [`BitLog`] entry that says its cell is filled (else emptied); slot codes
/// keep this bit for [`RIM`], so no slot has it.
const FILL: u32 = 1 << 31;

/// Occupancy bits to set and clear (entries: the cell, with [`FILL`] when filled), in
/// buckets by ranges of words ([`SharedCells::buckets`]), so that after the moves each
/// bucket can be written by one thread while others write theirs.
#[derive(Default)]
pub(crate) struct BitLog {
    buckets: Buckets<u32>,
}

impl BitLog {
    /// Empties the log, for buckets as [`SharedCells::buckets`] gives them.
    pub(crate) fn ready(&mut self, split: (u32, usize)) {
        self.buckets.ready(split);
    }

    #[inline]
    fn push(&mut self, i: usize, fill: bool) {
        let e = i as u32 | if fill { FILL } else { 0 };
        self.buckets.push(i / 64, e);
    }
}

/// Entries of a log of bits of occupancy, in buckets by ranges of words (bucket `b`: the
/// words whose index shifted right by `shift` is `b`), for [`BitLog`] and [`Words`].
#[derive(Default)]
struct Buckets<T> {
    shift: u32,
    lists: Vec<Vec<T>>,
}

impl<T> Buckets<T> {
    /// Empties the buckets, for a split as [`SharedCells::buckets`] gives it.
    fn ready(&mut self, (shift, count): (u32, usize)) {
        self.shift = shift;
        self.lists.resize_with(count, Vec::new);
        self.lists.truncate(count);
        self.lists.iter_mut().for_each(Vec::clear);
    }

    /// Adds entry `e` of word `w`.
    #[inline]
    fn push(&mut self, w: usize, e: T) {
        self.lists[w >> self.shift].push(e);
    }
}

/// The bits of occupancy that moves made at once clear and set, word by word (moves that
/// come in order change a word several times in a row: one entry), in buckets by ranges of
/// words ([`SharedCells::buckets`]), written after the moves ([`SharedCells::apply_words`]),
/// each bucket by one thread: the words are then written by no locked instruction (on two
/// threads, B2's moves at once took 1.7x the processor time of one thread's, two thirds of
/// it waiting on them).
#[derive(Default)]
pub(crate) struct Words {
    /// The word being changed: its index, the bits cleared, the bits set.
    now: (u32, u64, u64),
    buckets: Buckets<(u32, u64, u64)>,
}

impl Words {
    /// Empties the log, for buckets as [`SharedCells::buckets`] gives them.
    pub(crate) fn ready(&mut self, split: (u32, usize)) {
        self.now = (u32::MAX, 0, 0);
        self.buckets.ready(split);
    }

    /// Notes that cell `i` is emptied (or filled, `fill`).
    #[inline]
    fn note(&mut self, i: usize, fill: bool) {
        let w = (i / 64) as u32;
        if w != self.now.0 {
            self.flush();
            self.now = (w, 0, 0);
        }
        match fill {
            true => self.now.2 |= 1 << (i % 64),
            false => self.now.1 |= 1 << (i % 64),
        }
    }

    /// Ends the word being changed (after the moves).
    pub(crate) fn flush(&mut self) {
        let (w, clear, set) = self.now;
        if w != u32::MAX {
            self.buckets.push(w as usize, (w, clear, set));
            self.now = (u32::MAX, 0, 0);
        }
    }
}

/// The grid's cells and occupancy bits, for moving agents from several threads at once
/// ([`Grid::shared`]): cells are read and written atomically (each is written by one mover
/// at most, but read by others); the occupancy bits, which cells of different threads
/// share by the word, are noted per thread and written after the moves, a range of words
/// per thread: moves at once (in order, a word changed several times in a row) note words
/// ([`Words`]), other moves (scattered: a word per move) note cells ([`BitLog`], a fifth
/// of the bytes per move; the bouncing example on two threads 1.09x the time with
/// [`Words`]); one thread writes them at once ([`Bits::Write`]). Threads that each own a
/// range of words write them at once too ([`SharedCells::owned`]).
#[derive(Clone, Copy)]
pub(crate) struct SharedCells<'a> {
    cells: *const std::sync::atomic::AtomicU32,
    occ: *const std::sync::atomic::AtomicU64,
    rim: *const u64,
    len: usize,
    _grid: std::marker::PhantomData<&'a mut Grid>,
}

// SAFETY: cells and occupancy words are only read and written atomically; the rim bits
// are only read.
unsafe impl Sync for SharedCells<'_> {}
unsafe impl Send for SharedCells<'_> {}

impl SharedCells<'_> {
    /// Moves agent `a` from cell `from` to cell `to` when `to` is empty now, and says
    /// whether it did; the bits of occupancy of both cells are noted in `words`, written
    /// after the moves ([`SharedCells::apply_words`]).
    ///
    /// # Safety
    /// No other thread moves an agent from `from` or into `to` meanwhile.
    #[inline]
    pub(crate) unsafe fn take(
        &self,
        a: u32,
        (from, to): (usize, usize),
        words: &mut Words,
    ) -> bool {
        use std::sync::atomic::Ordering::Relaxed;
        assert!(from < self.len && to < self.len, "cells of the grid");
        // SAFETY: in bounds (checked); atomics (`AtomicU32` has the layout of `u32`).
        unsafe {
            if (*self.cells.add(to)).load(Relaxed) != EMPTY {
                return false;
            }
            (*self.cells.add(from)).store(EMPTY, Relaxed);
            (*self.cells.add(to)).store(a, Relaxed);
        }
        words.note(from, false);
        words.note(to, true);
        true
    }

    /// The cells of the words of occupancy `words` (a range) and those words, for one
    /// thread to move agents between them ([`OwnedCells`]).
    ///
    /// # Safety
    /// While the result lives, no other thread reads or writes those cells or words (the
    /// ranges of threads at once lie apart), and nothing writes the rim bits.
    pub(crate) unsafe fn owned(&self, (lo, hi): (usize, usize)) -> OwnedCells<'_> {
        let words = self.len.div_ceil(64);
        assert!(lo <= hi && hi <= words, "words of the grid");
        let (first, end) = ((64 * lo).min(self.len), (64 * hi).min(self.len));
        // SAFETY: in bounds (checked); these cells and words are the caller's alone while
        // the slices live (its promise); the rim bits are only read.
        unsafe {
            OwnedCells {
                cells: std::slice::from_raw_parts_mut(
                    (self.cells as *mut u32).add(first),
                    end - first,
                ),
                occ: std::slice::from_raw_parts_mut((self.occ as *mut u64).add(lo), hi - lo),
                rim: std::slice::from_raw_parts(self.rim.add(lo), hi - lo),
                first,
                held: Held::default(),
            }
        }
    }

    /// Writes the bits of occupancy of bucket `b` of `logs` (every part's, flushed): every
    /// bit cleared first, then every bit set, so that the order of the parts does not
    /// matter (a cell left and entered in one step, a column falling, ends filled: an agent
    /// that enters a cell stays there for the step).
    ///
    /// # Safety
    /// After the moves; no other thread writes the words of bucket `b` meanwhile (threads
    /// writing distinct buckets may run at once).
    pub(crate) unsafe fn apply_words(&self, logs: &[&Words], b: usize) {
        use std::sync::atomic::Ordering::Relaxed;
        for set in [false, true] {
            for &(w, c, s) in logs.iter().flat_map(|l| &l.buckets.lists[b]) {
                let w = w as usize;
                assert!(w < self.len.div_ceil(64), "a word of the grid");
                // SAFETY: in bounds (checked); atomics; the bucket's words are this
                // thread's (the caller's promise).
                let word = unsafe { &*self.occ.add(w) };
                let v = word.load(Relaxed);
                word.store(if set { v | s } else { v & !c }, Relaxed);
            }
        }
    }

    /// Puts agent `a` into cell `i`, its occupancy bit set as `bits` says.
    ///
    /// # Safety
    /// No other thread writes cell `i` meanwhile, nor, with [`Bits::Write`], any cell.
    #[inline]
    pub(crate) unsafe fn occupy(&self, i: usize, a: u32, bits: &mut Bits<'_>) {
        use std::sync::atomic::Ordering::Relaxed;
        assert!(i < self.len, "a cell of the grid");
        // SAFETY: in bounds (checked); atomics; the caller's promise.
        unsafe {
            (*self.cells.add(i)).store(a, Relaxed);
            match bits {
                Bits::Write => {
                    let word = &*self.occ.add(i / 64);
                    word.store(word.load(Relaxed) | 1 << (i % 64), Relaxed);
                }
                Bits::Log(log) => log.push(i, true),
                Bits::Keep => {}
            }
        }
    }

    /// Empties cell `i`, as [`SharedCells::occupy`] fills it.
    ///
    /// # Safety
    /// As for [`SharedCells::occupy`].
    #[inline]
    pub(crate) unsafe fn vacate(&self, i: usize, bits: &mut Bits<'_>) {
        use std::sync::atomic::Ordering::Relaxed;
        assert!(i < self.len, "a cell of the grid");
        // SAFETY: in bounds (checked); atomics; the caller's promise.
        unsafe {
            (*self.cells.add(i)).store(EMPTY, Relaxed);
            match bits {
                Bits::Write => {
                    let word = &*self.occ.add(i / 64);
                    word.store(word.load(Relaxed) & !(1 << (i % 64)), Relaxed);
                }
                Bits::Log(log) => log.push(i, false),
                Bits::Keep => {}
            }
        }
    }

    /// How the occupancy words split into at most `most` buckets of a [`BitLog`] or of
    /// [`Words`] (whole ranges of words): the shift from a word to its bucket, and how
    /// many there are.
    pub(crate) fn buckets(&self, most: usize) -> (u32, usize) {
        let last = self.len.div_ceil(64).max(1) - 1;
        let mut shift = 0;
        while last >> shift >= most.max(1) {
            shift += 1;
        }
        (shift, (last >> shift) + 1)
    }

    /// Sets and clears the occupancy bits of bucket `b` of `logs`, by loads and stores (the
    /// parts' logs in any order: a relocation empties no cell that a mover enters).
    ///
    /// # Safety
    /// No other thread writes the words of bucket `b` meanwhile (each bucket's words are
    /// its own: threads that write distinct buckets may run at once).
    pub(crate) unsafe fn apply(&self, logs: &[&BitLog], b: usize) {
        use std::sync::atomic::Ordering::Relaxed;
        for &e in logs.iter().flat_map(|l| &l.buckets.lists[b]) {
            let i = (e & !FILL) as usize;
            assert!(i < self.len, "a cell of the grid");
            // SAFETY: in bounds (checked); atomics; the bucket's words are this thread's
            // (the caller's promise).
            let word = unsafe { &*self.occ.add(i / 64) };
            let bit = 1u64 << (i % 64);
            let v = word.load(Relaxed);
            word.store(if e & FILL != 0 { v | bit } else { v & !bit }, Relaxed);
        }
    }

    /// Asks for cell `i` and its occupancy bit ahead of writing them (any `i`).
    #[inline]
    pub(crate) fn prefetch(&self, i: usize) {
        prefetch(self.cells.wrapping_add(i));
        prefetch(self.occ.wrapping_add(i / 64));
    }

    /// Cell `i`'s slot code: `i`, with [`RIM`] when it is on the rim.
    #[inline]
    pub(crate) fn code_of_slot(&self, i: usize) -> u32 {
        assert!(i < self.len, "a cell of the grid");
        // SAFETY: in bounds (checked); the rim bits are not written while shared.
        slot_code(i, unsafe { *self.rim.add(i / 64) })
    }

    /// Asks for cell `i`, its occupancy bit and its rim bit ahead of writing them (any
    /// `i`). (The rim bit makes the code of a mover's new cell: read after the occupancy
    /// word's locked instruction, it could not be asked for early by the processor, and a
    /// move waited for it.)
    #[inline]
    pub(crate) fn prefetch_cell(&self, i: usize) {
        prefetch(self.cells.wrapping_add(i));
        prefetch(self.occ.wrapping_add(i / 64));
        prefetch(self.rim.wrapping_add(i / 64));
    }
}

/// The cells of a range of whole words of occupancy bits and those words, one thread's
/// alone while agents move ([`SharedCells::owned`]): moves between its cells are written
/// at once, as on one thread ([`CellsMut::relocate`], the word of the last target held in
/// a register), with no log of bits to write after. Threads that move agents in cell
/// order each own the words their agents stand on (B2 on two threads, its moves logged and
/// the bits written after, spent 1.1-1.3x the time one thread spends per move).
pub(crate) struct OwnedCells<'a> {
    /// The cells owned, from cell `first`, and their words of occupancy bits.
    cells: &'a mut [u32],
    occ: &'a mut [u64],
    /// The rim bits of those words.
    rim: &'a [u64],
    first: usize,
    held: Held,
}

impl OwnedCells<'_> {
    /// Moves agent `a` from cell `from` into cell `to` when `to` is empty, and says
    /// whether it did, with `to`'s slot code; `None`, having done nothing, when either cell
    /// is not of this range.
    #[inline]
    pub(crate) fn relocate(
        &mut self,
        a: u32,
        (from, to): (usize, usize),
    ) -> Option<Result<u32, ()>> {
        let (f, t) = (from.wrapping_sub(self.first), to.wrapping_sub(self.first));
        if f >= self.cells.len() || t >= self.cells.len() {
            return None;
        }
        if !self.held.shift_bits((self.occ, self.rim), f, t) {
            return Some(Err(()));
        }
        self.cells[f] = EMPTY;
        self.cells[t] = a;
        // (The cells owned start at a word: `t` and `to` are one bit of a word.)
        Some(Ok(self.held.code_of(to)))
    }

    /// Writes back the word of occupancy bits held, if any: before the bits are read any
    /// other way.
    #[inline]
    pub(crate) fn put_back(&mut self) {
        self.held.put_back(self.occ);
    }
}

impl Grid {
    /// The agents on the grid in the order of their cells (x, then y, then z).
    pub(crate) fn agents_in_order(&self) -> impl Iterator<Item = u32> + '_ {
        self.cells.iter().copied().filter(|&a| a != EMPTY)
    }

    /// The cells and bits for moves made from several threads ([`SharedCells`]), after
    /// [`Grid::ready_rim`].
    pub(crate) fn shared(&mut self) -> SharedCells<'_> {
        SharedCells {
            cells: self.cells.as_mut_ptr().cast(),
            occ: self.occ.as_mut_ptr().cast(),
            rim: self.rim.as_ptr(),
            len: self.cells.len(),
            _grid: std::marker::PhantomData,
        }
    }
}

/// The grid's cells and occupancy bits, borrowed for writing ([`Grid::cells_mut`]).
pub(crate) struct CellsMut<'a> {
    cells: &'a mut [u32],
    occ: &'a mut [u64],
    rim: &'a [u64],
}

impl CellsMut<'_> {
    /// Asks for cell `i` and its occupancy bit ahead of reading or writing them (any `i`).
    #[inline]
    pub(crate) fn prefetch_cell(&self, i: usize) {
        prefetch(self.cells.as_ptr().wrapping_add(i));
        prefetch(self.occ.as_ptr().wrapping_add(i / 64));
    }

    /// Cell `i`'s slot code: `i`, with [`RIM`] when it is on the rim.
    #[inline]
    pub(crate) fn code_of(&self, i: usize) -> u32 {
        slot_code(i, self.rim[i / 64])
    }

    /// Puts agent `a` into cell `i`.
    #[inline]
    pub(crate) fn occupy(&mut self, i: usize, a: u32) {
        self.cells[i] = a;
        self.occ[i / 64] |= 1 << (i % 64);
    }

    /// Empties cell `i`.
    #[inline]
    pub(crate) fn vacate(&mut self, i: usize) {
        self.cells[i] = EMPTY;
        self.occ[i / 64] &= !(1 << (i % 64));
    }

    /// Moves agent `a` from cell `from` into cell `to` when `to` is empty, and returns
    /// whether it did. The word of occupancy bits of `to` is held in `held` (a loop of moves
    /// keeps it in a register: the cells of agents next to each other mostly share their
    /// word, and each move would otherwise wait for the last one's write of it); it is
    /// written back when another word is needed, or by [`CellsMut::put_back`], which must
    /// come before the bits are read any other way.
    #[inline]
    pub(crate) fn relocate(&mut self, held: &mut Held, a: u32, from: usize, to: usize) -> bool {
        if !held.shift_bits((self.occ, self.rim), from, to) {
            return false;
        }
        self.cells[from] = EMPTY;
        self.cells[to] = a;
        true
    }

    /// Writes back the word of occupancy bits `held` holds, if any.
    #[inline]
    pub(crate) fn put_back(&mut self, held: &mut Held) {
        held.put_back(self.occ);
    }
}

/// A word of a grid's occupancy bits held apart while agents move (see
/// [`CellsMut::relocate`]).
pub(crate) struct Held {
    word: usize,
    bits: u64,
    /// The rim bits of the same word: the slot codes of cells in it need no load.
    rim: u64,
}

impl Held {
    /// The bits of a move from cell `from` into cell `to`, counted from the first word of
    /// `occ` (the words of occupancy, and `rim` the words of rim bits alike): `to`'s word
    /// is held here (the last held written back first), with its rim bits. False, having
    /// changed no bit, when `to` is filled.
    #[inline(always)]
    fn shift_bits(&mut self, (occ, rim): (&mut [u64], &[u64]), from: usize, to: usize) -> bool {
        let (wf, wt) = (from / 64, to / 64);
        if wt != self.word {
            self.put_back(occ);
            *self = Held {
                word: wt,
                bits: occ[wt],
                rim: rim[wt],
            };
        }
        let bt = 1u64 << (to % 64);
        if self.bits & bt != 0 {
            return false;
        }
        let bf = 1u64 << (from % 64);
        if wf == wt {
            self.bits ^= bf | bt;
        } else {
            self.bits |= bt;
            occ[wf] &= !bf;
        }
        true
    }

    /// The slot code of cell `i` (a [`CellIndex::code`]) of the word held, whose first
    /// cell is a multiple of 64 cells from cell `i`'s number: `i` with [`RIM`] when it is on
    /// the rim (a move's code read from the rim bits took a load per move: B2F's stepping
    /// 0.97x the time without it on two threads, 0.98x on one, ten alternating pairs).
    #[inline(always)]
    pub(crate) fn code_of(&self, i: usize) -> u32 {
        slot_code(i, self.rim)
    }

    /// Writes back the word held, if any, into `occ` (whose words [`Held::shift_bits`]
    /// counts from).
    #[inline]
    fn put_back(&mut self, occ: &mut [u64]) {
        if self.word != usize::MAX {
            occ[self.word] = self.bits;
            self.word = usize::MAX;
        }
    }
}

impl Default for Held {
    fn default() -> Held {
        Held {
            word: usize::MAX,
            bits: 0,
            rim: 0,
        }
    }
}

/// The kind of lattice an index is for: 3D or not, and the universe's bounds if bounded.
pub type Shape = (bool, Option<Bounds>);

impl CellIndex {
    /// An index for agents at these positions (z = 0 in 2D).
    pub fn new(pos: &[[i32; 3]], shape: Shape) -> CellIndex {
        CellIndex::new_coded(pos, shape).0
    }

    /// The grid over the agents' bounding box with `margin` cells below and above it per
    /// axis (or over a bounded universe small enough, or the box clipped to the universe),
    /// when it has few enough cells per agent.
    /// (The agents' box as [`bounds`] gives it, and their number.)
    fn grid_for(
        agents: (([i32; 3], [i32; 3]), usize),
        shape: Shape,
        margin: [[i32; 2]; 3],
    ) -> Option<Grid> {
        CellIndex::box_for(agents, shape, margin).map(|(lo, size)| Grid::empty(lo, size))
    }

    /// The low corner and size of [`CellIndex::grid_for`]'s grid.
    fn box_for(
        ((lo, hi), n): (([i32; 3], [i32; 3]), usize),
        (three_d, universe): Shape,
        margin: [[i32; 2]; 3],
    ) -> Option<([i32; 3], [i64; 3])> {
        let coords = if three_d { 3 } else { 2 };
        if n == 0 {
            return None;
        }
        let budget = budget(n);
        let volume = |lo: [i32; 3], hi: [i32; 3]| {
            (0..3).fold(1i64, |v, k| {
                v.saturating_mul(hi[k] as i64 - lo[k] as i64 + 1)
            })
        };
        let mut lo =
            [0, 1, 2].map(|k| lo[k].saturating_sub(if k < coords { margin[k][0] } else { 0 }));
        let mut hi =
            [0, 1, 2].map(|k| hi[k].saturating_add(if k < coords { margin[k][1] } else { 0 }));
        if let Some(u) = universe {
            // No cell outside the universe holds an agent: the grid need not cover it.
            let (ul, uh) = ([0, 1, 2].map(|k| u[k].0), [0, 1, 2].map(|k| u[k].1));
            let (ul, uh) = (
                [0, 1, 2].map(|k| if k < coords { ul[k] } else { lo[k] }),
                [0, 1, 2].map(|k| if k < coords { uh[k] } else { hi[k] }),
            );
            if (1..=budget).contains(&volume(ul, uh)) {
                (lo, hi) = (ul, uh);
            } else {
                lo = [0, 1, 2].map(|k| lo[k].max(ul[k]));
                hi = [0, 1, 2].map(|k| hi[k].min(uh[k]));
            }
        }
        let size = [0, 1, 2].map(|k| hi[k] as i64 - lo[k] as i64 + 1);
        let volume = volume(lo, hi);
        // (An empty box: agents outside a universe, which the callers refuse.)
        if volume > budget || size.iter().any(|&s| s < 1) {
            return None;
        }
        Some((lo, size))
    }

    /// [`CellIndex::new`], whether every agent has a cell of its own (false when a later
    /// agent stands on an earlier one's cell, and took it in the index), and every agent's
    /// [`CellIndex::code`], in one pass.
    ///
    /// When a grid over every agent is over budget, the grid is made over the box of most
    /// of them (the agents between the 1st and 99th percentile of each axis, or the 5th
    /// and 95th, judged on a sample), if that is within it, and the others are gathered
    /// beside it ([`CellIndex::gather_outside`]): a block beside a line of walkers in 3D
    /// (a box of 2,003 x 52 x 50 cells for 10^5 agents) was all in the hash map. That box
    /// is widened, side by side, to the agents' own bounds where the grid stays within
    /// the budget: cut at the percentiles, a block's outer rows were left out of its grid
    /// (and with walkers far away, gathered with them each step into a box over budget).
    pub fn new_coded(pos: &[[i32; 3]], shape: Shape) -> (CellIndex, bool, Vec<u32>) {
        let margin = [[MARGIN; 2]; 3];
        let all = bounds(pos);
        let grid = CellIndex::grid_for((all, pos.len()), shape, margin).or_else(|| {
            [100, 20].iter().find_map(|&q| {
                let mut core = core_bounds(pos, q)?;
                let fits = |b| CellIndex::box_for((b, pos.len()), shape, margin).is_some();
                fits(core).then_some(())?;
                for k in 0..3 {
                    let mut wide = core;
                    wide.0[k] = all.0[k];
                    if fits(wide) {
                        core = wide;
                    }
                    let mut wide = core;
                    wide.1[k] = all.1[k];
                    if fits(wide) {
                        core = wide;
                    }
                }
                CellIndex::grid_for((core, pos.len()), shape, margin)
            })
        });
        let (mut idx, one_each, code) = CellIndex::made(grid, pos, shape, true);
        idx.gather_outside();
        (idx, one_each, code)
    }

    /// The index with this grid (or none) of agents at `pos`, whether every agent has a
    /// cell of its own, and every agent's code.
    fn made(
        grid: Option<Grid>,
        pos: &[[i32; 3]],
        (three_d, walls): Shape,
        roomy: bool,
    ) -> (CellIndex, bool, Vec<u32>) {
        let mut idx = CellIndex {
            grid,
            side: None,
            map: Sparse::new(three_d),
            refused: Backoff::default(),
            walls,
            coords: if three_d { 3 } else { 2 },
        };
        let mut one_each = true;
        let mut code = Vec::with_capacity(pos.len());
        let mut outside = Vec::new();
        for (i, &p) in pos.iter().enumerate() {
            let c = idx.code(p);
            code.push(c);
            match &mut idx.grid {
                Some(g) if c != NO_SLOT => {
                    let s = (c & !RIM) as usize;
                    one_each &= g.cells[s] == EMPTY;
                    g.occupy(s, i as u32);
                }
                _ => outside.push(i as u32),
            }
        }
        // Beside a grid, the agents outside it go into a side box of cells at once when
        // [`CellIndex::gather_outside`] would gather them there (with its room when
        // `roomy`): a grid over walkers beside 10^6 agents at rest put those in tiles one
        // by one first (50 ms). Else in tiles.
        let gather = idx.grid.is_some() && outside.len() >= GATHER_FROM;
        let side = match gather {
            true => {
                let agents = outside.iter().map(|&a| (&pos[a as usize], a));
                Side::over(agents, (idx.coords, roomy))
            }
            false => None,
        };
        match side {
            Some((side, own)) => {
                one_each &= own;
                idx.side = Some(side);
            }
            None => {
                if gather {
                    idx.refused.refused();
                }
                for a in outside {
                    one_each &= idx.insert(pos[a as usize], a);
                }
            }
        }
        (idx, one_each, code)
    }

    /// The agents outside the grid (all of them without one).
    pub fn outside(&self) -> usize {
        self.map.len() + self.side.as_ref().map_or(0, |s| s.count)
    }

    /// Beside a grid, when the tiles hold 8 agents or more (and more than an eighth
    /// of those in the side box): the side box made again over every agent outside the
    /// grid, with room around them (a quarter of their extent per axis, halved until
    /// within a budget of cells per agent as the grid's, and at last none); none when even
    /// their box is over it. Costs what those agents are; a look-up in the side box costs
    /// what one in the grid costs, less than one in the tiles. First frees the tiles
    /// of cells left empty outside both ([`Sparse::sweep`]).
    pub fn gather_outside(&mut self) {
        self.map.sweep();
        let side = self.side.as_ref().map_or(0, |s| s.count);
        let few = self.map.len() < GATHER_FROM.max(side / 8);
        if self.grid.is_none() || few || self.refused.wait() {
            return;
        }
        let mut all: Vec<([i32; 3], u32)> = self.map.agents().collect();
        if let Some(s) = &self.side {
            all.extend(s.agents());
        }
        match Side::over(all.iter().map(|(p, a)| (p, *a)), (self.coords, true)) {
            Some((side, _)) => {
                self.map.clear();
                self.side = Some(side);
                self.refused = Backoff::default();
            }
            None => self.refused.refused(),
        }
    }

    /// The index made again for agents at `pos` (each on a cell of its own) over where
    /// they are now, and every agent's code; `None` when even the agents' box with the
    /// usual margin is over the budget. The sides of the box that agents crossed to leave
    /// the grid (all sides without one), and those `toward` names (per axis, below and
    /// above), get room to grow: half the axis's extent ([`ROOM_SHARE`]), halved until the grid is
    /// within the budget (`None` too when that leaves less than a sixteenth of it on a
    /// side named by `toward`). A cloud that falls, or a line that walks
    /// away, so gets a grid long in its direction of travel, which agents leave again only
    /// after as many steps as the room is long (room on every side would be over the budget
    /// for a cloud that fills its box, and leave it a grid no larger than before).
    pub fn regrow(
        &self,
        pos: &[[i32; 3]],
        toward: [[bool; 2]; 3],
    ) -> Option<(CellIndex, Vec<u32>)> {
        let shape = (self.coords == 3, self.walls);
        let (lo, hi) = bounds(pos);
        let crossed = [0, 1, 2].map(|k| match &self.grid {
            Some(g) => [
                toward[k][0] || lo[k] < g.lo[k],
                toward[k][1] || hi[k] as i64 >= g.lo[k] as i64 + g.size[k],
            ],
            None => [true; 2],
        });
        let mut room = [0, 1, 2].map(|k| {
            ((hi[k] as i64 - lo[k] as i64) / ROOM_SHARE).clamp(MARGIN as i64, 1 << 20) as i32
        });
        // Room ahead of agents that move toward a side, if less than a sixteenth of what
        // was first asked, would soon be crossed again: no grid then.
        let least = room.map(|r| r / 16);
        let grid = loop {
            let margin = [0, 1, 2].map(|k| crossed[k].map(|c| if c { room[k] } else { MARGIN }));
            if let Some(g) = CellIndex::grid_for(((lo, hi), pos.len()), shape, margin) {
                break g;
            }
            if room.iter().all(|&r| r <= MARGIN) {
                return None;
            }
            room = room.map(|r| (r / 2).max(MARGIN));
            if (0..3).any(|k| toward[k].contains(&true) && room[k] < least[k]) {
                return None;
            }
        };
        let (mut idx, _, code) = CellIndex::made(Some(grid), pos, shape, true);
        idx.gather_outside();
        Some((idx, code))
    }

    /// The index made again with a grid over `movers` agents alone (`at`: their positions;
    /// agents that all move one way, `toward` naming the sides per axis as in
    /// [`CellIndex::regrow`]), for agents at `pos`: the others stand beside it (in a side
    /// box when they fit one). The grid has room ahead of the movers (below), within a
    /// quarter of the budget of cells over the movers' cross-section and 2^20 cells, and
    /// the usual margin elsewhere; `None` when that room is under 64 cells or the grid
    /// over budget. For walkers that leave a block at rest by more than a grid over both
    /// can span: they stay on a grid, and the block's agents are not looked at.
    pub fn regrow_over<'p>(
        &self,
        pos: &[[i32; 3]],
        (movers, at): (usize, impl IntoIterator<Item = &'p [i32; 3]>),
        toward: [[bool; 2]; 3],
    ) -> Option<(CellIndex, Vec<u32>)> {
        let shape = (self.coords == 3, self.walls);
        let (lo, hi) = bounds(at);
        if movers == 0 || lo[0] > hi[0] {
            return None;
        }
        let cross: i64 = (0..self.coords)
            .filter(|&k| !toward[k].contains(&true))
            .map(|k| hi[k] as i64 - lo[k] as i64 + 1 + 2 * MARGIN as i64)
            .product();
        // Room for as many steps as there are agents per mover, sixteen times over (the
        // grid is made again when they cross it, at the cost of a pass over every agent).
        let room = (16 * pos.len() as i64 / movers as i64)
            .max(64)
            .min(budget(pos.len()) / 4 / cross.max(1))
            .min(1 << 20);
        if room < 64 {
            return None;
        }
        let margin = [0, 1, 2].map(|k| toward[k].map(|t| if t { room as i32 } else { MARGIN }));
        let grid = CellIndex::grid_for(((lo, hi), pos.len()), shape, margin)?;
        // (The agents beside it are at rest: a side box without room.)
        let (mut idx, _, code) = CellIndex::made(Some(grid), pos, shape, false);
        idx.gather_outside();
        Some((idx, code))
    }

    /// The agent on a cell.
    #[inline]
    pub fn get(&self, p: [i32; 3]) -> Option<u32> {
        if let Some(g) = &self.grid {
            if let Some(i) = g.slot(p) {
                let a = g.cells[i];
                return (a != EMPTY).then_some(a);
            }
        }
        if let Some(s) = &self.side {
            if let Some(i) = s.slot(p) {
                let a = s.cells[i];
                return (a != EMPTY).then_some(a);
            }
        }
        self.map.get(p)
    }

    /// The agents on the cells next to `p`, where agent `a` stands, in the first `nd`
    /// directions (`Dir::ALL`'s order), as [`CellIndex::get`] answers each (an id, or
    /// [`EMPTY`]; cells past `i32`'s range wrap: the caller knows them outside the
    /// universe); where they are all outside the grid and the side box, those in `p`'s
    /// tile with no look-up.
    /// `tile`: the tile `p` is in, when [`CellIndex::shift`] just gave it (its look-up
    /// saved: about a tenth of the moves of walkers in tiles).
    #[inline]
    pub fn around_in(
        &self,
        p: [i32; 3],
        (a, tile): (u32, Option<u32>),
        nd: usize,
        out: &mut [u32; 6],
    ) {
        let near = |(lo, size): ([i32; 3], [i64; 3])| {
            (0..3).all(|k| {
                let o = p[k] as i64 - lo[k] as i64;
                (-1..=size[k]).contains(&o)
            })
        };
        let boxes = [
            self.grid.as_ref().map(|g| (g.lo, g.size)),
            self.side.as_ref().map(|s| (s.lo, s.size)),
        ];
        if boxes.iter().flatten().all(|&b| !near(b)) {
            return self.map.around(p, (a, tile), nd, out);
        }
        for (d, o) in out.iter_mut().enumerate().take(nd) {
            let off = Dir::ALL[d].offset();
            *o = (self.get([0, 1, 2].map(|k| p[k].wrapping_add(off[k])))).unwrap_or(EMPTY);
        }
    }

    /// Moves agent `a` from `old` (if it still stands there: another mover may have taken
    /// the cell already) to `new`, as [`CellIndex::remove`] then [`CellIndex::insert`].
    /// Returns the tile of `new` when both are in tiles (for [`CellIndex::around_in`],
    /// until the tiles are next swept: after the moves).
    #[inline]
    pub fn shift(&mut self, old: [i32; 3], new: [i32; 3], a: u32) -> Option<u32> {
        let outside = |p| {
            self.grid.as_ref().is_none_or(|g| g.slot(p).is_none())
                && self.side.as_ref().is_none_or(|s| s.slot(p).is_none())
        };
        if outside(old) && outside(new) {
            return Some(self.map.shift(old, new, a));
        }
        self.remove(old, a);
        self.insert(new, a);
        None
    }

    /// The agent next to `p` in direction index `d`, when `p` lies inside the grid with a
    /// cell of margin (`None` when the grid cannot answer; the caller then asks [`get`]).
    ///
    /// [`get`]: CellIndex::get
    #[inline]
    pub fn neighbour_in_grid(&self, p: [i32; 3], d: usize) -> Option<Option<u32>> {
        let g = self.grid.as_ref()?;
        let i = g.interior(p)?;
        let a = g.cells[(i as isize + g.delta[d]) as usize];
        Some((a != EMPTY).then_some(a))
    }

    /// For agents `first, first + 1, ...` (at most `max`), the first standing at `p`: how
    /// many stand on consecutive cells along the grid's innermost axis (y in 2D, z in 3D)
    /// away from the grid's rim, and per direction the grid cells next to them (agent ids
    /// or [`EMPTY`]). `None` when fewer than 8 do.
    ///
    /// The grid itself tells: agent `first + j` stands `j` cells further exactly when that
    /// cell holds it, so the test is one vectorised compare of a slice of the grid.
    #[inline]
    pub fn neighbour_run(
        &self,
        first: u32,
        p: [i32; 3],
        max: usize,
        nd: usize,
    ) -> Option<(usize, [&[u32]; 6])> {
        const MIN_RUN: usize = 8;
        let g = self.grid.as_ref()?;
        let i = g.interior(p)?;
        // Interior cells left in this row of the innermost axis.
        let axis = if g.size[2] > 1 { 2 } else { 1 };
        let o = (p[axis] as i64 - g.lo[axis] as i64) as usize;
        let row = (g.size[axis] as usize - 1 - o).min(max);
        let cells = &g.cells[i..i + row];
        let mut m = 0;
        for block in cells.chunks(32) {
            let base = first.wrapping_add(m as u32);
            let ok = block
                .iter()
                .enumerate()
                .fold(true, |ok, (j, &c)| ok & (c == base.wrapping_add(j as u32)));
            if !ok {
                m += block
                    .iter()
                    .enumerate()
                    .take_while(|&(j, &c)| c == base.wrapping_add(j as u32))
                    .count();
                break;
            }
            m += block.len();
        }
        if m < MIN_RUN {
            return None;
        }
        let mut out: [&[u32]; 6] = [&[]; 6];
        for (o, &delta) in out.iter_mut().zip(&g.delta).take(nd) {
            let s = (i as isize + delta) as usize;
            *o = &g.cells[s..s + m];
        }
        Some((m, out))
    }

    /// The agent in grid slot `s`, or [`EMPTY`].
    #[inline]
    pub fn at_slot(&self, s: usize) -> u32 {
        self.grid.as_ref().map_or(EMPTY, |g| g.cells[s])
    }

    /// Position `p`'s grid slot as a code: the slot for a cell whose neighbours are all in
    /// the grid, the slot `| RIM` for one on the grid's rim, [`NO_SLOT`] outside the grid
    /// (or for a grid of more than 2^31 cells).
    #[inline]
    pub fn code(&self, p: [i32; 3]) -> u32 {
        match &self.grid {
            Some(g) if g.cells.len() < RIM as usize => {
                let o = [0, 1, 2].map(|k| (p[k] as i64 - g.lo[k] as i64) as u64);
                if (0..3).any(|k| o[k] >= g.size[k] as u64) {
                    return NO_SLOT;
                }
                let s = ((o[0] * g.size[1] as u64 + o[1]) * g.size[2] as u64 + o[2]) as u32;
                // (The grid never reaches outside the universe: a cell with a blocked
                // neighbour is on its rim.)
                let rim = (0..3).any(|k| o[k].wrapping_sub(g.first[k] as u64) >= g.span[k] as u64);
                s | if rim { RIM } else { 0 }
            }
            _ => NO_SLOT,
        }
    }

    /// The agent next to interior slot `s` (a [`CellIndex::code`] below [`RIM`]) in
    /// direction index `d`, or [`EMPTY`].
    #[inline]
    pub fn next_to(&self, s: u32, d: usize) -> u32 {
        match &self.grid {
            Some(g) => g.cells[g.next(s, d)],
            None => EMPTY,
        }
    }

    /// Whether the cell next to interior slot `s` in direction index `d` holds an agent.
    #[inline]
    pub fn filled_next_to(&self, s: u32, d: usize) -> bool {
        self.grid.as_ref().is_some_and(|g| g.filled(g.next(s, d)))
    }

    /// The grid, for tight loops over slot codes.
    #[inline]
    pub(crate) fn grid(&self) -> Option<&Grid> {
        self.grid.as_ref()
    }

    /// The grid, for tight loops that move agents.
    #[inline]
    pub(crate) fn grid_mut(&mut self) -> Option<&mut Grid> {
        self.grid.as_mut()
    }

    /// Whether grid slot `s` holds an agent.
    #[inline]
    pub fn filled_slot(&self, s: usize) -> bool {
        self.grid.as_ref().is_some_and(|g| g.filled(s))
    }

    /// The number of grid slots (0 without a grid).
    pub fn slots(&self) -> usize {
        self.grid.as_ref().map_or(0, |g| g.cells.len())
    }

    /// Puts an agent on a cell: false when another stood there (it is no longer found).
    pub fn insert(&mut self, p: [i32; 3], a: u32) -> bool {
        if let Some(g) = &mut self.grid {
            if let Some(i) = g.slot(p) {
                let free = g.cells[i] == EMPTY;
                g.put(i, a);
                return free;
            }
        }
        if let Some(s) = &mut self.side {
            if let Some(i) = s.slot(p) {
                let free = s.cells[i] == EMPTY;
                s.cells[i] = a;
                s.count += free as usize;
                return free;
            }
        }
        self.map.insert(p, a)
    }

    /// Empties a cell if agent `a` stands there.
    pub fn remove(&mut self, p: [i32; 3], a: u32) {
        if let Some(g) = &mut self.grid {
            if let Some(i) = g.slot(p) {
                if g.cells[i] == a {
                    g.put(i, EMPTY);
                }
                return;
            }
        }
        if let Some(s) = &mut self.side {
            if let Some(i) = s.slot(p) {
                if s.cells[i] == a {
                    s.cells[i] = EMPTY;
                    s.count -= 1;
                }
                return;
            }
        }
        self.map.remove(p, a);
    }

    /// The grid's low corner and size, if there is a grid.
    pub fn grid_box(&self) -> Option<([i32; 3], [i64; 3])> {
        self.grid.as_ref().map(|g| (g.lo, g.size))
    }

    /// Whether the index is a grid.
    pub fn is_grid(&self) -> bool {
        self.grid.is_some()
    }

    /// Bytes held (hash maps counted at their capacity, with their control bytes).
    pub fn bytes(&self) -> usize {
        let grid = self
            .grid
            .as_ref()
            .map_or(0, |g| g.cells.capacity() * 4 + g.occ.capacity() * 8);
        let side = self.side.as_ref().map_or(0, |s| s.cells.capacity() * 4);
        grid + side + self.map.bytes()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Moves between the cells of a range of words owned by one thread: made at once, as
    /// `CellsMut::relocate` makes them, into a filled cell refused, from or into a cell of
    /// a word outside the range left to the caller; the bits all written back after.
    #[test]
    fn moves_within_owned_words_are_written_at_once() {
        let size = [20i64, 16, 1];
        let (mut g, mut h) = (Grid::empty([0, 0, 0], size), Grid::empty([0, 0, 0], size));
        for i in (0..320).step_by(3) {
            g.put(i, i as u32);
            h.put(i, i as u32);
        }
        g.ready_rim();
        h.ready_rim();
        // Words 1 and 2 (cells 64..192) owned; moves by one column (16 cells) and by one.
        let moves = [
            (66, 82),
            (69, 70),
            (72, 75),
            (75, 91),
            (63, 64),
            (189, 205),
            (126, 127),
        ];
        let shared = g.shared();
        // SAFETY: one thread.
        let mut owned = unsafe { shared.owned((1, 3)) };
        let mut held = Held::default();
        let mut mine = h.cells_mut();
        for (from, to) in moves {
            let a = from as u32;
            let got = owned.relocate(a, (from, to));
            let inside = (64..192).contains(&from) && (64..192).contains(&to);
            match inside {
                false => assert_eq!(got, None, "{from} -> {to}"),
                true => {
                    let made = mine.relocate(&mut held, a, from, to);
                    assert_eq!(got, Some(if made { Ok(mine.code_of(to)) } else { Err(()) }));
                }
            }
        }
        owned.put_back();
        mine.put_back(&mut held);
        assert_eq!(
            (g.cells.clone(), g.occ.clone()),
            (h.cells.clone(), h.occ.clone())
        );
        assert!(g.filled(82) && !g.filled(66) && g.filled(91) && !g.filled(75));
        assert!(g.filled(72) && g.filled(63) && !g.filled(64) && g.filled(189));
    }

    /// The cells next to slots, tested several at a time (`Grid::keep_next_filled`, four
    /// at a time with AVX2), answer as `Grid::filled` does cell by cell: in 2D and 3D, in
    /// every direction, for both answers wanted, any number of slots (and a remainder); with
    /// a slot on the rim among them, they do nothing and say so.
    #[test]
    fn cells_next_to_slots_tested_together_answer_as_one_by_one() {
        let mut x = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = move || {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            x
        };
        for size in [[19i64, 23, 1], [7, 6, 5]] {
            let mut g = Grid::empty([-3, 2, 0], size);
            let volume = g.cells.len();
            for i in 0..volume {
                if next() % 3 == 0 {
                    g.put(i, i as u32);
                }
            }
            g.ready_rim();
            let interior: Vec<u32> = (0..volume)
                .map(|i| g.cells_mut().code_of(i))
                .filter(|&c| c < RIM)
                .collect();
            let rim: Vec<u32> = (0..volume)
                .map(|i| g.cells_mut().code_of(i))
                .filter(|&c| c >= RIM)
                .collect();
            for d in 0..if size[2] > 1 { 6 } else { 4 } {
                let step = g.step(d);
                for len in 0..=37 {
                    let pick = |_| interior[next() as usize % interior.len()];
                    let codes: Vec<u32> = (0..len).map(pick).collect();
                    for want in [false, true] {
                        let before: Vec<bool> = (0..len).map(|_| next() % 4 != 0).collect();
                        let mut got = before.clone();
                        assert!(g.keep_next_filled(&codes, step, want, &mut got));
                        let one_by_one: Vec<bool> = (before.iter().zip(&codes))
                            .map(|(&t, &s)| t && g.filled(Grid::along(s, step)) == want)
                            .collect();
                        assert_eq!(got, one_by_one, "{size:?}, direction {d}, want {want}");
                        // One slot on the rim among them, anywhere: nothing is done.
                        if len > 0 {
                            let mut rimmed = codes.clone();
                            rimmed[next() as usize % len] = rim[next() as usize % rim.len()];
                            let mut untouched = before.clone();
                            assert!(!g.keep_next_filled(&rimmed, step, want, &mut untouched));
                            assert_eq!(untouched, before, "{size:?}, direction {d}");
                        }
                    }
                }
            }
        }
    }

    /// A block beside a long line (a box over both over budget) gets a grid over the block
    /// and a side box over the line, and every agent is found; a cloud with no core within
    /// budget is all in tiles.
    #[test]
    fn a_block_beside_a_line_gets_a_grid_and_a_side_box() {
        let mut pos: Vec<[i32; 3]> = (0..20 * 20 * 20)
            .map(|i| [i % 20, i / 20 % 20, i / 400])
            .collect();
        pos.extend((0..300).map(|i| [20 * i, 25, 0]));
        let idx = CellIndex::new(&pos, (true, None));
        let (lo, size) = idx.grid_box().expect("a grid");
        assert!(size.iter().product::<i64>() <= budget(pos.len()));
        assert!(
            lo[0] <= 0 && lo[0] as i64 + size[0] >= 20,
            "{lo:?} {size:?}"
        );
        assert!(idx.map.is_empty() && idx.side.is_some());
        // (The line runs five cells above the block: past the grid's margin. The grid
        // over the block's core widened to the block's sides takes in the line's first
        // agents, within the budget.)
        let in_grid =
            |p: &[i32; 3]| (0..3).all(|k| (0..size[k]).contains(&(p[k] as i64 - lo[k] as i64)));
        let out = pos.iter().filter(|p| !in_grid(p)).count();
        assert!((250..=300).contains(&out) && pos[..8000].iter().all(in_grid));
        assert_eq!(idx.outside(), out);
        for (i, p) in pos.iter().enumerate() {
            assert_eq!(idx.get(*p), Some(i as u32), "{p:?}");
        }
        assert_eq!(idx.get([21, 25, 0]), None);
        assert_eq!(idx.get([20, 25, 0]), Some(8001));
        let cloud: Vec<[i32; 3]> = (0..2000)
            .map(|i: i32| {
                [
                    i.wrapping_mul(7919) % 100_000,
                    i.wrapping_mul(104_729) % 90_000,
                    0,
                ]
            })
            .collect();
        let idx = CellIndex::new(&cloud, (false, None));
        assert!(!idx.is_grid());
        assert!(cloud
            .iter()
            .enumerate()
            .all(|(i, p)| idx.get(*p) == Some(i as u32)));
    }

    /// Agents outside the grid are gathered into a side box when 8 or more are in the hash
    /// map (not before), and answer alike there: found, moved within it, out of it into the
    /// tiles and back, counted as outside.
    #[test]
    fn agents_outside_the_grid_are_gathered_beside_it() {
        let block: Vec<[i32; 3]> = (0..100).map(|i| [i % 10, i / 10, 0]).collect();
        let mut idx = CellIndex::new(&block, (false, None));
        // A line walking away east, 1,000 cells out, one at a time.
        let line = |i: i32| [1000 + 2 * i, 5, 0];
        for i in 0..7 {
            idx.insert(line(i), 100 + i as u32);
        }
        idx.gather_outside();
        assert!(idx.side.is_none(), "seven are left in the tiles");
        idx.insert(line(7), 107);
        idx.gather_outside();
        let side = idx.side.as_ref().expect("a side box");
        assert!(idx.map.is_empty() && side.count == 8);
        assert!(side.cells.len() as i64 <= budget(8));
        assert_eq!(idx.outside(), 8);
        for i in 0..8 {
            assert_eq!(idx.get(line(i)), Some(100 + i as u32));
        }
        assert_eq!(idx.get([1001, 5, 0]), None);
        // Within the box, out of it (far), and back.
        idx.remove(line(0), 100);
        assert!(idx.insert([1001, 5, 0], 100));
        idx.remove(line(1), 101);
        assert!(idx.insert([-50_000, 7, 0], 101));
        assert_eq!((idx.map.len(), idx.outside()), (1, 8));
        assert_eq!(idx.get([-50_000, 7, 0]), Some(101));
        assert_eq!((idx.get(line(0)), idx.get([1001, 5, 0])), (None, Some(100)));
        // Another agent's cell: nothing removed; an agent placed on it replaces it.
        idx.remove([1001, 5, 0], 102);
        assert_eq!(idx.get([1001, 5, 0]), Some(100));
        assert!(!idx.insert(line(2), 100));
        assert_eq!(idx.get(line(2)), Some(100));
        // The grid still answers for its own cells, and the side box is no part of it.
        assert_eq!(idx.get([3, 4, 0]), Some(43));
        assert!(idx.bytes() > idx.grid.as_ref().unwrap().cells.len() * 4);
        // Made again with one in the tiles and far ones: over budget, the side box
        // and the tiles stay as they were, all found; the next try waits a call, the one
        // after two.
        for i in 0..8 {
            idx.insert([i * 1_000_000, -9, 0], 200 + i as u32);
        }
        idx.gather_outside();
        assert!(idx.side.as_ref().is_some_and(|s| s.count == 7) && idx.map.len() == 9);
        assert_eq!((idx.refused.left, idx.refused.next), (1, 2));
        idx.gather_outside();
        assert_eq!((idx.refused.left, idx.refused.next), (0, 2));
        idx.gather_outside();
        assert_eq!((idx.refused.left, idx.refused.next), (2, 4));
        assert_eq!(idx.get([7_000_000, -9, 0]), Some(207));
        assert_eq!(idx.get([-50_000, 7, 0]), Some(101));
        assert_eq!(idx.get([1001, 5, 0]), Some(100));
    }

    /// A few agents over a box of many cells per agent, within a few MiB of cells, get a
    /// grid: 1,000 walkers in a row of 2,000 cells above a block of 100 agents (24 cells
    /// per agent) were all in the hash map, a step of theirs 20x one alone; the same in 3D.
    #[test]
    fn few_agents_in_a_box_of_a_million_cells_get_a_grid() {
        let mut flat: Vec<[i32; 3]> = (0..100).map(|i| [i % 10, i / 10, 0]).collect();
        flat.extend((0..1000).map(|i| [2 * i, 12, 0]));
        // A block of 5^3 and a slab of 100 x 10 walkers beside it.
        let mut solid: Vec<[i32; 3]> = (0..125).map(|i| [i % 5, i / 5 % 5, i / 25]).collect();
        solid.extend((0..1000).map(|i| [2 * (i % 100), 7, 2 * (i / 100)]));
        for (pos, d3) in [(flat, false), (solid, true)] {
            let idx = CellIndex::new(&pos, (d3, None));
            assert!(idx.is_grid() && idx.outside() == 0, "3D {d3}");
        }
        // 200 agents scattered over 1,000 x 1,000 cells.
        let scattered: Vec<[i32; 3]> = (0..200)
            .map(|i: i32| [i * 7919 % 1000, i * 104_729 % 1000, 0])
            .collect();
        assert!(CellIndex::new(&scattered, (false, None)).is_grid());
    }

    #[test]
    fn dense_is_a_grid_sparse_is_a_map_and_both_answer_alike() {
        let dense: Vec<[i32; 3]> = (0..100).map(|i| [i % 10, i / 10, 0]).collect();
        let sparse: Vec<[i32; 3]> = (0..100).map(|i| [i * 100_000, -i * 7_000, 0]).collect();
        for (pos, grid) in [(dense, true), (sparse, false)] {
            let mut idx = CellIndex::new(&pos, (false, None));
            assert_eq!(idx.is_grid(), grid);
            for (i, p) in pos.iter().enumerate() {
                assert_eq!(idx.get(*p), Some(i as u32));
            }
            assert_eq!(idx.get([5, 1_000_000, 0]), None);
            // Moving far outside the grid, and back.
            idx.remove(pos[3], 3);
            idx.insert([i32::MAX, i32::MIN, 0], 3);
            assert_eq!(idx.get(pos[3]), None);
            assert_eq!(idx.get([i32::MAX, i32::MIN, 0]), Some(3));
            idx.remove([i32::MAX, i32::MIN, 0], 3);
            idx.insert(pos[3], 3);
            assert_eq!(idx.get(pos[3]), Some(3));
            // Removing a cell that another agent holds changes nothing.
            idx.remove(pos[4], 3);
            assert_eq!(idx.get(pos[4]), Some(4));
        }
    }
}
