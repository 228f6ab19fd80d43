//! The cells outside the grid and its side box: small tiles of cells, allocated where
//! agents stand and freed when the last leaves, found through a hash map of tiles.
//!
//! A hash map of cells costs a look-up for every cell asked about; the tiles answer a
//! cell and its neighbours inside the same tile with one ([`Sparse::around`]), an agent
//! that moves finds its tile again without one (where it last entered a tile), and a
//! tile's key hashes with two multiplications where a position hashed as twelve bytes
//! took many more. A tile with one agent holds it in the tile itself, with no cells: a
//! cloud of agents each alone in its tile costs about what a hash map of cells did.
//! Agents scattered over more cells than any grid's budget (1,000 walkers spread over
//! 10^6 x 37,000 cells) and walkers gone far from the others stand here.

use std::hash::{Hash, Hasher};

use rustc_hash::FxHashMap;

use super::EMPTY;

/// No tile.
const NONE: u32 = u32::MAX;
/// Ids per page of [`Sparse::at`].
const PAGE: usize = 1024;
/// The key of a free tile: no cell's (every axis of a tile is at least two cells long but
/// z in 2D, where every key's z is 0).
const FREED: Key = Key([i32::MIN; 3]);

/// A tile's position: a cell's coordinates shifted right by the tile's size per axis.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Key([i32; 3]);

impl Hash for Key {
    #[inline]
    fn hash<H: Hasher>(&self, state: &mut H) {
        let [x, y, z] = self.0.map(|c| c as u32 as u64);
        state.write_u64((x | y << 32) ^ z.wrapping_mul(0x9e37_79b9_7f4a_7c15));
    }
}

/// Per direction index (`Dir::ALL`'s order): the axis it goes along, and whether up it.
const AXES: [(usize, bool); 6] = [
    (1, true),
    (0, false),
    (0, true),
    (1, false),
    (2, true),
    (2, false),
];

/// Words per tile in [`Sparse::head`]: its key's three coordinates, [`META`], and
/// [`HELD`].
const HEAD: usize = 5;
/// How many agents stand on the tile (the low 16 bits) and, when one does, its cell in
/// the tile (the high 16).
const META: usize = 3;
/// The agent, when one stands on the tile; its block of cells in [`Sparse::blocks`] when
/// more do.
const HELD: usize = 4;

/// The cells of agents outside the grid and its side box.
#[derive(Debug, Clone)]
pub(crate) struct Sparse {
    /// Per axis, log2 of the tile's side: 8 x 8 cells in 2D, 4 x 4 x 2 in 3D. (Walkers
    /// scattered one to a tile change tiles at every eighth step, and look into another
    /// tile for a fourth of their neighbours: with tiles of 4 x 4, twice as often.)
    shift: [u32; 3],
    /// log2 of the cells per tile.
    bits: u32,
    /// Tile index by key.
    tiles: FxHashMap<Key, u32>,
    /// Tile `t` from `t * HEAD` (see [`HEAD`]). A tile with one agent holds it there,
    /// with no block of cells: agents scattered one to a tile cost 20 bytes each, as in
    /// a hash map of cells, and a lone mover's tile is one place in memory.
    head: Vec<u32>,
    /// Blocks of cells (each an agent or [`EMPTY`], x outermost) of the tiles that hold
    /// two agents or more; block `b` from `b << bits`.
    blocks: Vec<u32>,
    /// Free tiles, and free blocks (all [`EMPTY`]).
    free: Vec<u32>,
    free_blocks: Vec<u32>,
    /// Tiles whose last agent left since the last [`Sparse::sweep`].
    emptied: Vec<u32>,
    /// Per agent (by id, up to the largest held), the tile it last entered (or [`NONE`]):
    /// an agent that moves is removed from it, put back near it, and asks about the cells
    /// around it, each without a look-up when the tile is still the one of that key.
    /// In pages of [`PAGE`] ids, each made when an agent of it first enters a tile: one
    /// column over every id cost a page-clearing 4 MB for a walker among 10^6 agents
    /// each time the cell index was made again (1.5x the steps of 3D walkers leaving a
    /// block).
    at: Vec<Option<Box<[u32; PAGE]>>>,
    len: usize,
}

impl PartialEq for Sparse {
    /// The same agents on the same cells (however the tiles were allocated).
    fn eq(&self, other: &Sparse) -> bool {
        self.len == other.len && self.agents().all(|(p, a)| other.get(p) == Some(a))
    }
}

impl Sparse {
    /// An empty set of cells for a 3D lattice or a 2D one.
    pub(crate) fn new(three_d: bool) -> Sparse {
        let shift: [u32; 3] = if three_d { [2, 2, 1] } else { [3, 3, 0] };
        Sparse {
            shift,
            bits: shift.iter().sum(),
            tiles: FxHashMap::default(),
            head: Vec::new(),
            blocks: Vec::new(),
            free: Vec::new(),
            free_blocks: Vec::new(),
            emptied: Vec::new(),
            at: Vec::new(),
            len: 0,
        }
    }

    /// The agents held.
    #[inline]
    pub(crate) fn len(&self) -> usize {
        self.len
    }

    #[cfg(test)]
    pub(crate) fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// The tile of `p` and `p`'s cell in it.
    #[inline]
    fn split(&self, p: [i32; 3]) -> (Key, usize) {
        let s = self.shift;
        let key = Key([0, 1, 2].map(|k| p[k] >> s[k]));
        let o = [0, 1, 2].map(|k| (p[k] & ((1 << s[k]) - 1)) as usize);
        (key, (o[0] << s[1] | o[1]) << s[2] | o[2])
    }

    /// Where tile `t`'s words start in `head`.
    #[inline]
    fn base(t: u32) -> usize {
        t as usize * HEAD
    }

    /// Tile `t`'s key.
    #[inline]
    fn key_of(&self, t: u32) -> Key {
        let b = Sparse::base(t);
        Key([0, 1, 2].map(|k| self.head[b + k] as i32))
    }

    /// Tile `t`'s count of agents, and the cell of its one agent (when it has one).
    #[inline]
    fn meta(&self, t: u32) -> (u32, usize) {
        let m = self.head[Sparse::base(t) + META];
        (m & 0xffff, (m >> 16) as usize)
    }

    #[inline]
    fn set_meta(&mut self, t: u32, count: u32, cell: usize) {
        self.head[Sparse::base(t) + META] = count | (cell as u32) << 16;
    }

    /// The tile of `key`, looked for first where agent `a` last entered one.
    #[inline]
    fn tile(&self, key: Key, a: u32) -> Option<u32> {
        match self
            .at
            .get(a as usize / PAGE)
            .and_then(|p| p.as_ref())
            .map(|p| &p[a as usize % PAGE])
        {
            // (A tile past the end: one of before a [`Sparse::clear`].)
            Some(&t) if t != NONE && Sparse::base(t) < self.head.len() && self.key_of(t) == key => {
                Some(t)
            }
            _ => self.tiles.get(&key).copied(),
        }
    }

    /// The agent on cell `o` of tile `t`, or [`EMPTY`].
    #[inline]
    fn cell(&self, t: u32, o: usize) -> u32 {
        let held = self.head[Sparse::base(t) + HELD];
        match self.meta(t) {
            (0, _) => EMPTY,
            (1, c) => [EMPTY, held][(c == o) as usize],
            _ => self.blocks[((held as usize) << self.bits) + o],
        }
    }

    /// Puts agent `a` on cell `o` of tile `t`: false when another stood there (it is no
    /// longer found). A second agent gives the tile a block of cells.
    fn put(&mut self, t: u32, o: usize, a: u32) -> bool {
        let h = Sparse::base(t) + HELD;
        let free = match self.meta(t) {
            (0, _) => {
                self.set_meta(t, 1, o);
                self.head[h] = a;
                true
            }
            (1, c) if c == o => {
                self.head[h] = a;
                false
            }
            (1, c) => {
                let b = match self.free_blocks.pop() {
                    Some(b) => b,
                    None => {
                        let b = (self.blocks.len() >> self.bits) as u32;
                        self.blocks
                            .resize(self.blocks.len() + (1 << self.bits), EMPTY);
                        b
                    }
                };
                let at = (b as usize) << self.bits;
                self.blocks[at + c] = self.head[h];
                self.blocks[at + o] = a;
                self.head[h] = b;
                self.set_meta(t, 2, 0);
                true
            }
            (n, _) => {
                let cell = &mut self.blocks[((self.head[h] as usize) << self.bits) + o];
                let free = *cell == EMPTY;
                *cell = a;
                if free {
                    self.set_meta(t, n + 1, 0);
                }
                free
            }
        };
        self.len += free as usize;
        free
    }

    /// Empties cell `o` of tile `t` if agent `a` stands there (and says whether it did).
    /// A tile left with one agent gives back its block; one left with none is listed for
    /// the next sweep.
    fn take(&mut self, t: u32, o: usize, a: u32) -> bool {
        let h = Sparse::base(t) + HELD;
        match self.meta(t) {
            (1, c) if c == o && self.head[h] == a => self.set_meta(t, 0, 0),
            (0 | 1, _) => return false,
            (n, _) => {
                let at = (self.head[h] as usize) << self.bits;
                if self.blocks[at + o] != a {
                    return false;
                }
                self.blocks[at + o] = EMPTY;
                if n > 2 {
                    self.set_meta(t, n - 1, 0);
                } else {
                    // (The block's other agent, alone now: held in the tile.)
                    let block = &mut self.blocks[at..at + (1 << self.bits)];
                    let c = block.iter().position(|&b| b != EMPTY).expect("one left");
                    self.head[h] = std::mem::replace(&mut block[c], EMPTY);
                    self.free_blocks.push((at >> self.bits) as u32);
                    self.set_meta(t, 1, c);
                }
            }
        }
        self.len -= 1;
        if self.meta(t).0 == 0 {
            // (Swept here too when no sweep came for long: the list stays bounded.)
            if self.emptied.len() > 2 * self.tiles.len() + 64 {
                self.sweep();
            }
            self.emptied.push(t);
        }
        true
    }

    /// The agent on `p`.
    #[inline]
    pub(crate) fn get(&self, p: [i32; 3]) -> Option<u32> {
        let (key, o) = self.split(p);
        let a = self.cell(*self.tiles.get(&key)?, o);
        (a != EMPTY).then_some(a)
    }

    /// The agents on the cells next to `p`, where agent `a` stands, in the first `nd`
    /// directions (`Dir::ALL`'s order; an id, or [`EMPTY`]): `p`'s tile (`known`, when
    /// [`Sparse::shift`] just gave it, else found through `a`), and a look-up for each
    /// neighbour in another tile.
    #[inline]
    pub(crate) fn around(
        &self,
        p: [i32; 3],
        (a, known): (u32, Option<u32>),
        nd: usize,
        out: &mut [u32; 6],
    ) {
        let (key, o) = self.split(p);
        let tile = known.or_else(|| self.tile(key, a));
        let s = self.shift;
        // Per axis: the step between neighbouring cells in a tile.
        let step = [1 << (s[1] + s[2]), 1 << s[2], 1];
        for (d, slot) in out.iter_mut().enumerate().take(nd) {
            let (k, up) = AXES[d];
            let inner = p[k] & ((1 << s[k]) - 1);
            let within = if up {
                inner < (1 << s[k]) - 1
            } else {
                inner > 0
            };
            *slot = match tile {
                Some(t) if within => self.cell(t, if up { o + step[k] } else { o - step[k] }),
                // (A neighbour past i32's range is outside the universe: the caller asks.)
                _ if within => EMPTY,
                _ => {
                    let mut q = p;
                    q[k] = if up {
                        q[k].wrapping_add(1)
                    } else {
                        q[k].wrapping_sub(1)
                    };
                    self.get(q).unwrap_or(EMPTY)
                }
            };
        }
    }

    /// Moves agent `a` from `old` (if it still stands there) to `new`: one tile found
    /// when both are in it. Returns the tile of `new` (for [`Sparse::around`], until
    /// the next [`Sparse::sweep`]).
    #[inline]
    pub(crate) fn shift(&mut self, old: [i32; 3], new: [i32; 3], a: u32) -> u32 {
        let (key, o) = self.split(old);
        let (nkey, no) = self.split(new);
        let Some(t) = self.tile(key, a) else {
            return self.insert_in(new, a).0;
        };
        if key == nkey {
            match self.meta(t) {
                (1, c) if c == o && self.head[Sparse::base(t) + HELD] == a => {
                    self.set_meta(t, 1, no);
                    return t;
                }
                (n, _) if n > 1 => {
                    let at = (self.head[Sparse::base(t) + HELD] as usize) << self.bits;
                    if self.blocks[at + o] == a && self.blocks[at + no] == EMPTY {
                        self.blocks[at + o] = EMPTY;
                        self.blocks[at + no] = a;
                        return t;
                    }
                }
                _ => {}
            }
        }
        self.take(t, o, a);
        self.insert_in(new, a).0
    }

    /// Puts agent `a` on `p`: false when another stood there (it is no longer found).
    pub(crate) fn insert(&mut self, p: [i32; 3], a: u32) -> bool {
        self.insert_in(p, a).1
    }

    /// [`Sparse::insert`], and the tile of `p`.
    fn insert_in(&mut self, p: [i32; 3], a: u32) -> (u32, bool) {
        let (key, o) = self.split(p);
        let t = match self.tile(key, a) {
            Some(t) => t,
            None => self.new_tile(key),
        };
        let page = a as usize / PAGE;
        if self.at.len() <= page {
            self.at.resize_with(page + 1, || None);
        }
        self.at[page].get_or_insert_with(|| Box::new([NONE; PAGE]))[a as usize % PAGE] = t;
        (t, self.put(t, o, a))
    }

    /// Empties `p` if agent `a` stands there (its tile freed at the next sweep if that
    /// was the last).
    pub(crate) fn remove(&mut self, p: [i32; 3], a: u32) {
        let (key, o) = self.split(p);
        if let Some(t) = self.tile(key, a) {
            self.take(t, o, a);
        }
    }

    /// Takes out every agent (what it holds per agent kept, for those that come again, and
    /// its lists' room: made anew instead, walkers that a side box gathers now and then
    /// took 1.07x the time).
    pub(crate) fn clear(&mut self) {
        self.tiles.clear();
        self.head.clear();
        self.blocks.clear();
        self.free.clear();
        self.free_blocks.clear();
        self.emptied.clear();
        self.len = 0;
    }

    /// Frees the tiles left empty since the last sweep and still empty (an agent alone in
    /// its tile that moves within it leaves and enters it in the same step).
    pub(crate) fn sweep(&mut self) {
        for t in std::mem::take(&mut self.emptied) {
            let key = self.key_of(t);
            // (A tile emptied twice is listed twice: freed once.)
            if self.meta(t).0 == 0 && self.tiles.get(&key) == Some(&t) {
                self.tiles.remove(&key);
                let b = Sparse::base(t);
                self.head[b..b + 3].copy_from_slice(&FREED.0.map(|c| c as u32));
                self.free.push(t);
            }
        }
    }

    /// A tile for `key`, with no agent: a freed one, or a new one.
    fn new_tile(&mut self, key: Key) -> u32 {
        let t = match self.free.pop() {
            Some(t) => t,
            None => {
                let t = (self.head.len() / HEAD) as u32;
                self.head.resize(self.head.len() + HEAD, 0);
                t
            }
        };
        let b = Sparse::base(t);
        self.head[b..b + 3].copy_from_slice(&key.0.map(|c| c as u32));
        self.set_meta(t, 0, 0);
        self.tiles.insert(key, t);
        t
    }

    /// The agents held, with their cells (in no particular order).
    pub(crate) fn agents(&self) -> impl Iterator<Item = ([i32; 3], u32)> + '_ {
        let s = self.shift;
        self.tiles.iter().flat_map(move |(key, &t)| {
            (0..1 << self.bits)
                .map(move |o| (o, self.cell(t, o)))
                .filter(|c| c.1 != EMPTY)
                .map(move |(o, a)| {
                    let off = [
                        o >> (s[1] + s[2]),
                        o >> s[2] & ((1 << s[1]) - 1),
                        o & ((1 << s[2]) - 1),
                    ];
                    ([0, 1, 2].map(|k| key.0[k] << s[k] | off[k] as i32), a)
                })
        })
    }

    /// Bytes held (the hash map of tiles counted at its capacity, with its control bytes).
    pub(crate) fn bytes(&self) -> usize {
        (self.head.capacity() + self.blocks.capacity()) * 4
            + (self.free.capacity() + self.free_blocks.capacity()) * 4
            + self.emptied.capacity() * 4
            + self.at.capacity() * 8
            + self.at.iter().flatten().count() * PAGE * 4
            + self.tiles.capacity() * (std::mem::size_of::<(Key, u32)>() + 1)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use latticesim_vm::model::Dir;
    use std::collections::HashMap;

    /// Inserts, removals and look-ups (of cells and their neighbours) over negative and
    /// far coordinates, tiles freed and reused, answer as a plain map of cells does.
    #[test]
    fn tiles_answer_as_a_map_of_cells() {
        for three_d in [false, true] {
            let nd = if three_d { 6 } else { 4 };
            let mut s = Sparse::new(three_d);
            let mut m: HashMap<[i32; 3], u32> = HashMap::new();
            let mut x: u64 = 12345;
            let mut rnd = |n: u64| {
                x = x
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                (x >> 33) % n
            };
            let far = [i32::MIN, -1_000_000, -5, 0, 3, 1_000_000, i32::MAX - 8];
            for i in 0..20_000u32 {
                let base = far[rnd(far.len() as u64) as usize];
                let p = [0, 1, 2].map(|k| {
                    if k == 2 && !three_d {
                        0
                    } else {
                        base.saturating_add(rnd(9) as i32)
                    }
                });
                // Ids on pages of their own, far apart; emptied halfway (tiles that agents
                // last entered before gone).
                let a = [0, 1000, 5000, 70_000][rnd(4) as usize] + rnd(13) as u32;
                if i == 10_000 {
                    s.clear();
                    m.clear();
                }
                let r = rnd(4);
                if r == 0 {
                    s.remove(p, a);
                    if m.get(&p) == Some(&a) {
                        m.remove(&p);
                    }
                } else if r == 1 {
                    // A move by a step, or to a cell of another tile.
                    let q = [0, 1, 2].map(|k| match (k, rnd(3)) {
                        (2, _) if !three_d => 0,
                        (_, 0) => p[k].wrapping_add(rnd(3) as i32 - 1),
                        (_, 1) => p[k].wrapping_add(rnd(20) as i32 - 10),
                        _ => p[k],
                    });
                    s.shift(p, q, a);
                    if m.get(&p) == Some(&a) {
                        m.remove(&p);
                    }
                    m.insert(q, a);
                } else {
                    assert_eq!(s.insert(p, a), m.insert(p, a).is_none(), "step {i}");
                }
                assert_eq!(s.len(), m.len());
                assert_eq!(s.get(p), m.get(&p).copied());
                if i % 500 == 0 {
                    // Each tile's count is its agents; a block for each tile of two or more.
                    for &t in s.tiles.values() {
                        let held = (0..1 << s.bits).filter(|&o| s.cell(t, o) != EMPTY).count();
                        assert_eq!(s.meta(t).0 as usize, held);
                    }
                    let multi = s.tiles.values().filter(|&&t| s.meta(t).0 > 1).count();
                    assert_eq!((multi + s.free_blocks.len()) << s.bits, s.blocks.len());
                }
                let mut out = [0; 6];
                s.around(p, (a, None), nd, &mut out);
                for (d, got) in out.iter().enumerate().take(nd) {
                    let off = Dir::ALL[d].offset();
                    let q = [0, 1, 2].map(|k| p[k].wrapping_add(off[k]));
                    let want = m.get(&q).copied().unwrap_or(EMPTY);
                    assert_eq!(*got, want, "around {p:?} in {d}");
                }
            }
            let mut all = s.agents().collect::<Vec<_>>();
            let mut want = m.iter().map(|(&p, &a)| (p, a)).collect::<Vec<_>>();
            all.sort_unstable();
            want.sort_unstable();
            assert_eq!(all, want);
            s.sweep();
            assert!(s.tiles.len() <= s.len(), "no empty tile is kept");
            for &(p, a) in &want {
                s.remove(p, a);
            }
            s.sweep();
            assert!(s.is_empty() && s.tiles.is_empty() && s.free.len() * HEAD == s.head.len());
            assert_eq!(s.free_blocks.len() << s.bits, s.blocks.len());
            assert!(
                s.blocks.iter().all(|&c| c == EMPTY),
                "free blocks are empty"
            );
        }
    }
}
