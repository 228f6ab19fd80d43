//! The lattice as structure-of-arrays: one column per agent attribute, indexed by agent id,
//! and a cell-to-agent index that serves dense and sparse, unbounded universes alike.
//!
//! Counters and message slots are stored only for the ones in use: a counter gets a column
//! when the agents file sets it or the rules read or write it, a numeric slot gets one
//! inbox column per direction when the rules send or read it, and text inboxes exist only
//! when the rules use text messages ([`Lattice::ensure_counter`], [`Lattice::ensure_slot`],
//! [`Lattice::ensure_text`]; the engine asks for what its program uses). A counter without
//! a column reads 0, as does a slot without one.
//!
//! Counter and message columns are of one width, the program's ([`Width`]): 16 bits as in
//! the paper, or 32 with the extension; a lattice takes the width of the program that runs
//! on it ([`Lattice::set_width`]).

use crate::bits::{all_bits, no_bits, run_of, sequence_len, set_bits};
pub(crate) use crate::cells::{BitLog, Bits, Words};
use crate::cells::{CellIndex, Grid, AHEAD, EMPTY, NO_SLOT, RIM};
use latticesim_vm::column::Value;
use latticesim_vm::eval::Cell;
use latticesim_vm::model::{AgentInit, Bounds, Column, Columns, Config, Dim, Dir, Width};
use std::collections::HashMap;

// Its parts: messages left with their senders, the agents file text, the undo point,
// steps kept backwards.
mod delta;
mod order;
mod pending;
mod text;
mod undo;
pub(crate) use delta::{Delta, Shadow};
pub(crate) use pending::Pending;
pub use undo::{Undo, Writes};

/// In a column map: no column.
pub(crate) const NO_COL: u8 = u8::MAX;

/// The agents and their cells.
#[derive(Debug, Clone, PartialEq)]
pub struct Lattice {
    /// The dimension.
    pub dim: Dim,
    /// Inclusive bounds, if the universe is bounded.
    pub universe: Option<Bounds>,
    /// Positions (z = 0 in 2D).
    pub pos: Vec<[i32; 3]>,
    /// States.
    pub state: Vec<[u8; 5]>,
    /// Attachment bits, bit i = direction i; symmetric between neighbours.
    pub attach: Vec<u8>,
    /// Per counter number: its column in `counters`, or [`NO_COL`].
    pub(crate) counter_col: [u8; 45],
    /// The width of counter and message columns.
    pub(crate) width: Width,
    /// Counter columns, one value per agent each.
    pub(crate) counters: Vec<Column>,
    /// Per slot number (0-based): its index among the slots in use, or [`NO_COL`].
    pub(crate) slot_col: [u8; 8],
    /// Slots in use.
    pub(crate) slots: u8,
    /// Numeric messages received: one column per direction and slot in use, at
    /// `dir * slots + slot_col[slot]`.
    pub(crate) inbox_num: Vec<Column>,
    /// Text messages received, `dirs` per agent (empty when no rule uses texts).
    pub(crate) inbox_text: Vec<[u8; 5]>,
    /// Which text messages were received: bit i = from direction i (empty when no rule
    /// uses texts).
    pub(crate) inbox_text_has: Vec<u8>,
    /// Numeric messages of the last step not copied into `inbox_num` (see [`Pending`]).
    pub(crate) pending: Option<Pending>,
    pub(crate) cells: CellIndex,
    /// Per agent, its cell's slot code in the grid ([`CellIndex::code`]): an agent away
    /// from the grid's rim finds its neighbours without reading its position.
    code: Vec<u32>,
    /// What stands next to each agent when the cell index has no grid: one column per
    /// direction ([`NO_AGENT`], [`BLOCKED`] or an id), valid while `nbr_valid`: made at
    /// the first step, and then changed only where agents move. A grid answers as fast
    /// without it.
    nbr: Vec<Vec<u32>>,
    nbr_valid: bool,
    /// How many agents may be outside the grid before it is made again over where the
    /// agents are ([`CellIndex::regrow`]).
    regrow_at: usize,
    /// The agents outside the grid summed over the steps with moves since the grid was
    /// made (or last tried): a few agents that walk away cost a look-up in the tiles
    /// each step, which adds up to the cost of a grid over them (see `after_moves`).
    off_work: u64,
    /// After grids over budget: the work before the next try is doubled this many times.
    off_tries: u32,
    /// Whether movers that reach the grid's rim get a grid of their own before one over
    /// every agent is tried ([`Lattice::grow_toward`]).
    own_grid: OwnGrid,
    /// The agents' ids in the agents file, when the lattice keeps them in space order
    /// ([`Lattice::keep_in_space_order`]); else an agent's id is its place.
    labels: Option<order::Labels>,
}

/// Whether a few movers get a grid of their own first ([`Lattice::grow_toward`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum OwnGrid {
    /// No grid made over movers alone yet: the next few movers at the rim get one.
    Untried,
    /// The last grid made was over movers going this way: movers going it again get one.
    Going([i32; 3]),
    /// Movers turned after a grid of their own (they would get one at every turn, each
    /// made at the cost of a pass over every agent): grids over every agent from now on.
    Turned,
}

/// What [`Lattice::from_columns_mended`] mended, as the checker does and says.
#[derive(Debug, Default, Clone, PartialEq, Eq)]
pub struct Mends {
    /// The agents left out (column ids, ascending): an earlier agent stands on their cell.
    pub gone: Vec<u32>,
    /// Per agent left out: (it, the earlier agent on its cell), column ids.
    pub shared: Vec<(u32, u32)>,
    /// Bonds mended, in the order the checker finds them: (the agent that declares it, its
    /// direction, the agent there that did not declare it back, made now; `None`: no agent
    /// stands there, the bond is dropped). Ids of the lattice (the agents left out gone).
    /// Of each kind (made, dropped), those of the first agents until `keep` are held
    /// (an agent's whole); the others are counted in `more`.
    pub bonds: Vec<(u32, Dir, Option<u32>)>,
    /// Per kind (made, dropped): how many are not held, and the first of them.
    pub more: [usize; 2],
    /// See `more`.
    pub first_more: [Option<(u32, Dir, Option<u32>)>; 2],
}

impl Mends {
    /// The column id (the agent's place among the agent lines read) of lattice id `id`.
    pub fn column_of(&self, id: u32) -> u32 {
        let mut k = id;
        for &g in &self.gone {
            if g <= k {
                k += 1;
            } else {
                break;
            }
        }
        k
    }

    /// The lattice id of the agent in column `col` (the id it would have had when left out).
    pub fn id_of(&self, col: u32) -> u32 {
        col - self.gone.partition_point(|&g| g < col) as u32
    }
}

/// In the neighbour table and in [`Lattice::neighbours`]: a free cell.
pub const NO_AGENT: u32 = crate::cells::EMPTY;
/// In the neighbour table: a cell outside the universe.
const BLOCKED: u32 = u32::MAX - 1;

/// An agent-step done the slow way (an agent outside the grid, a move refused at its rim)
/// weighs as this many agents or cells of a new grid when [`Lattice::slow_work_pays`]
/// and [`Lattice::room_pays`] weigh making the grid again.
const SLOW_STEP: u64 = 4;

/// A move refused at the grid's rim counts as this many agent-steps done the slow way
/// (it goes the general way: a look-up and a write in the tiles or the side box, and
/// the activity's look-ups around it by position).
const SLOW_MOVES: u64 = 4;

/// Builds a lattice one agent at a time, without holding a whole [`Config`] in memory.
pub struct LatticeBuilder {
    lat: Lattice,
}

impl LatticeBuilder {
    /// For tests: a 2D builder holding a `w` x `h` block of agents in state `AAAAA` from
    /// the origin, in order of x, then y.
    #[cfg(test)]
    pub(crate) fn block(w: i32, h: i32) -> LatticeBuilder {
        let mut b = LatticeBuilder::new(Dim::Two, None, 0);
        for x in 0..w {
            for y in 0..h {
                b.push([x, y, 0], *b"AAAAA", 0, &[]);
            }
        }
        b
    }

    /// An empty lattice of this dimension and universe, with room for `capacity` agents.
    pub fn new(dim: Dim, universe: Option<Bounds>, capacity: usize) -> LatticeBuilder {
        LatticeBuilder {
            lat: Lattice {
                dim,
                universe,
                pos: Vec::with_capacity(capacity),
                state: Vec::with_capacity(capacity),
                attach: Vec::with_capacity(capacity),
                counter_col: [NO_COL; 45],
                width: Width::W16,
                counters: Vec::new(),
                slot_col: [NO_COL; 8],
                slots: 0,
                inbox_num: Vec::new(),
                inbox_text: Vec::new(),
                inbox_text_has: Vec::new(),
                pending: None,
                cells: CellIndex::new(&[], (false, None)),
                code: Vec::new(),
                nbr: Vec::new(),
                nbr_valid: false,
                regrow_at: 0,
                off_work: 0,
                off_tries: 0,
                own_grid: OwnGrid::Untried,
                labels: None,
            },
        }
    }

    /// Adds an agent (the caller guarantees a free cell and valid counters; a counter
    /// outside 16 bits makes the lattice's columns 32-bit).
    pub fn push(&mut self, pos: [i32; 3], state: [u8; 5], attach: u8, counters: &[(u8, i32)]) {
        let lat = &mut self.lat;
        let a = lat.pos.len();
        lat.pos.push(pos);
        lat.state.push(state);
        lat.attach.push(attach);
        for &(c, v) in counters {
            if v != 0 {
                if !lat.width.holds(v as i64) {
                    lat.set_width(Width::W32);
                }
                let col = lat.ensure_counter(c);
                let column = &mut lat.counters[col];
                column.resize(a + 1);
                column.set(a, v);
            }
        }
    }

    /// The lattice.
    pub fn finish(self) -> Lattice {
        self.finish_checked().0
    }

    /// The lattice, and whether every agent has a cell of its own.
    fn finish_checked(mut self) -> (Lattice, bool) {
        let n = self.lat.pos.len();
        for col in &mut self.lat.counters {
            col.resize(n);
            col.shrink_to_fit();
        }
        let lat = &mut self.lat;
        let (cells, one_each, code) = CellIndex::new_coded(&lat.pos, lat.shape());
        (lat.cells, lat.code) = (cells, code);
        lat.regrow_at = lat.first_regrow();
        (self.lat, one_each)
    }
}

impl Lattice {
    /// The lattice of columns, and false when two agents stand on one cell (the index then
    /// holds one of them).
    fn of_columns(dim: Dim, universe: Option<Bounds>, cols: Columns) -> (Lattice, bool) {
        let Columns {
            pos,
            state,
            attach,
            counters,
        } = cols;
        let n = pos.len();
        let mut b = LatticeBuilder::new(dim, universe, 0);
        let lat = &mut b.lat;
        (lat.pos, lat.state, lat.attach) = (pos, state, attach);
        if let Some(c) = counters.first() {
            lat.width = c.width();
        }
        for (i, col) in counters.into_iter().enumerate() {
            if !col.is_empty() {
                debug_assert_eq!(col.len(), n);
                lat.counter_col[i] = lat.counters.len() as u8;
                lat.counters.push(col);
            }
        }
        b.finish_checked()
    }

    /// Builds the lattice of agents read as columns as the checker makes a configuration
    /// of an agents file with defects of the lattice: an agent on the cell of an earlier
    /// one is left out (E402), a bond towards an empty cell dropped (W602) and a bond
    /// declared on one side only made (W601), agent by agent in id order. What was mended
    /// is said in [`Mends`], for the diagnostics: of the bonds, the first `keep` of each
    /// kind (made, dropped) in full, the others counted.
    pub fn from_columns_mended(
        dim: Dim,
        universe: Option<Bounds>,
        cols: Columns,
        keep: usize,
    ) -> (Lattice, Mends) {
        let mut mends = Mends::default();
        let (mut lat, one_each) = Lattice::of_columns(dim, universe, cols);
        if !one_each {
            // The agents not in the index, and the ones that are, on the cells they share:
            // the first of each cell stays.
            let n = lat.len();
            let mut first: HashMap<[i32; 3], u32> = HashMap::new();
            let lost: Vec<u32> = (0..n as u32)
                .filter(|&a| lat.cells.get(lat.pos[a as usize]) != Some(a))
                .collect();
            for &a in &lost {
                let p = lat.pos[a as usize];
                let holder = lat.cells.get(p).expect("the cell is taken");
                let e = first.entry(p).or_insert(holder);
                *e = (*e).min(a);
            }
            let holders = first.keys().filter_map(|p| lat.cells.get(*p));
            let mut gone: Vec<u32> = lost
                .iter()
                .copied()
                .chain(holders)
                .filter(|&a| first[&lat.pos[a as usize]] != a)
                .collect();
            gone.sort_unstable();
            gone.dedup();
            mends.shared = (gone.iter())
                .map(|&a| (a, first[&lat.pos[a as usize]]))
                .collect();
            mends.gone = gone;
            let mut cols = lat.into_columns();
            cols.drop_rows(&mends.gone);
            lat = Lattice::of_columns(dim, universe, cols).0;
        }
        let mut held = [0usize; 2];
        for a in 0..lat.len() as u32 {
            let bits = lat.attach[a as usize];
            if bits == 0 {
                continue;
            }
            // Whether this agent's bonds of each kind are held (decided for all of them).
            let hold = held.map(|h| h < keep);
            for d in Dir::ALL.iter().take(lat.dim.dirs()) {
                if bits & (1 << d.index()) == 0 {
                    continue;
                }
                let mend = match lat.neighbour(a, *d) {
                    None => {
                        lat.attach[a as usize] &= !(1 << d.index());
                        (a, *d, None)
                    }
                    Some(b) => {
                        let back = 1 << d.opposite().index();
                        if lat.attach[b as usize] & back != 0 {
                            continue;
                        }
                        lat.attach[b as usize] |= back;
                        (a, *d, Some(b))
                    }
                };
                let kind = mend.2.is_none() as usize;
                if hold[kind] {
                    mends.bonds.push(mend);
                    held[kind] += 1;
                } else {
                    mends.more[kind] += 1;
                    mends.first_more[kind].get_or_insert(mend);
                }
            }
        }
        (lat, mends)
    }

    /// The agents as columns again (the lattice's other parts let go).
    fn into_columns(self) -> Columns {
        let mut counters: Vec<Column> = (0..45)
            .map(|_| Column::with_capacity(self.width, 0))
            .collect();
        let mut mine: Vec<Option<Column>> = self.counters.into_iter().map(Some).collect();
        for (i, &c) in self.counter_col.iter().enumerate() {
            if c != NO_COL {
                if let Some(col) = mine[c as usize].take() {
                    counters[i] = col;
                }
            }
        }
        Columns {
            pos: self.pos,
            state: self.state,
            attach: self.attach,
            counters,
        }
    }

    /// The first agent (and direction) with a bond that no agent there declares back, if
    /// any: bonds are symmetric between neighbours everywhere else.
    pub(crate) fn one_sided_bond(&self) -> Option<(u32, Dir)> {
        (0..self.len())
            .filter(|&a| self.attach[a] != 0)
            .find_map(|a| {
                Dir::ALL.iter().take(self.dim.dirs()).find_map(|d| {
                    let declared = self.attach[a] & (1 << d.index()) != 0;
                    let back = self.neighbour(a as u32, *d).is_some_and(|b| {
                        self.attach[b as usize] & (1 << d.opposite().index()) != 0
                    });
                    (declared && !back).then_some((a as u32, *d))
                })
            })
    }

    /// Builds the lattice of a checked configuration.
    pub fn new(cfg: &Config) -> Lattice {
        let mut b = LatticeBuilder::new(cfg.dim, cfg.universe, cfg.agents.len());
        for AgentInit {
            pos,
            state,
            attach,
            counters,
        } in &cfg.agents
        {
            b.push(*pos, *state, *attach, counters);
        }
        b.finish()
    }

    /// The shape of the lattice as the cell index needs it.
    pub(crate) fn shape(&self) -> crate::cells::Shape {
        (self.dim == Dim::Three, self.universe)
    }

    /// How many agents outside the grid make it worth making again.
    fn first_regrow(&self) -> usize {
        (self.len() / 64).max(64)
    }

    /// The agents on cells the cell index's grid does not cover (they are found in the side
    /// box or the tiles, the slow way).
    pub fn off_grid(&self) -> usize {
        if self.cells.is_grid() {
            self.cells.outside()
        } else {
            self.len()
        }
    }

    /// Number of agents.
    pub fn len(&self) -> usize {
        self.pos.len()
    }

    /// True when there are no agents.
    pub fn is_empty(&self) -> bool {
        self.pos.is_empty()
    }

    /// Counters per agent that the dimension has (25 or 45).
    pub fn nc(&self) -> usize {
        self.dim.counters()
    }

    /// The width of counters and numeric messages.
    pub fn width(&self) -> Width {
        self.width
    }

    /// Makes every counter and message column `w` wide (values saturate when narrowed,
    /// which a checked configuration never needs).
    pub fn set_width(&mut self, w: Width) {
        if self.width == w {
            return;
        }
        self.width = w;
        let conv = |c: &mut Column| {
            let mut n = Column::with_capacity(w, c.len());
            (0..c.len()).for_each(|i| n.push(w.saturate(c.get(i) as i64)));
            *c = n;
        };
        self.counters.iter_mut().for_each(conv);
        self.inbox_num.iter_mut().for_each(conv);
        if let Some(p) = &mut self.pending {
            p.num.iter_mut().for_each(conv);
        }
    }

    /// The column of counter `i`, creating it (all zero) if needed.
    pub fn ensure_counter(&mut self, i: u8) -> usize {
        if self.counter_col[i as usize] == NO_COL {
            self.counter_col[i as usize] = self.counters.len() as u8;
            self.counters.push(Column::zeros(self.width, self.len()));
        }
        self.counter_col[i as usize] as usize
    }

    /// Creates the inbox columns of numeric slot `s` (0-based) if needed.
    pub fn ensure_slot(&mut self, s: u8) {
        if self.slot_col[s as usize] != NO_COL {
            return;
        }
        self.slot_col[s as usize] = self.slots;
        self.slots += 1;
        let (nd, ns, n) = (self.dim.dirs(), self.slots as usize, self.len());
        // Columns are ordered by direction, then slot.
        let mut cols = std::mem::take(&mut self.inbox_num).into_iter();
        for _ in 0..nd {
            for k in 0..ns {
                self.inbox_num.push(if k + 1 < ns {
                    cols.next().expect("one column per direction and slot")
                } else {
                    Column::zeros(self.width, n)
                });
            }
        }
    }

    /// Creates the text inboxes if needed.
    pub fn ensure_text(&mut self) {
        if self.inbox_text_has.len() != self.len() {
            self.inbox_text = vec![[0; 5]; self.len() * self.dim.dirs()];
            self.inbox_text_has = vec![0; self.len()];
        }
    }

    /// Counter `i` of agent `a` (0 when no agent has it and no rule uses it).
    #[inline]
    pub fn counter(&self, a: u32, i: u8) -> i32 {
        match self.counter_col[i as usize] {
            NO_COL => 0,
            c => self.counters[c as usize].get(a as usize),
        }
    }

    /// A cell or offset as records write it: `(x,y)` in 2D, `(x,y,z)` in 3D.
    pub fn cell_text(&self, p: [i32; 3]) -> String {
        let mut s = String::with_capacity(16);
        self.push_cell(&mut s, p);
        s
    }

    /// [`Lattice::cell_text`] appended to `s`.
    pub(crate) fn push_cell(&self, s: &mut String, p: [i32; 3]) {
        use std::fmt::Write;
        let r = match self.dim.coords() {
            2 => write!(s, "({},{})", p[0], p[1]),
            _ => write!(s, "({},{},{})", p[0], p[1], p[2]),
        };
        r.expect("writing to a string");
    }

    /// The values of counter `i`, one per agent, when it has a column (see
    /// [`Lattice::counter_numbers`]). The column stays in place for the lattice's life.
    pub fn counter_column(&self, i: u8) -> Option<&Column> {
        match self.counter_col.get(i as usize) {
            None | Some(&NO_COL) => None,
            Some(&c) => Some(&self.counters[c as usize]),
        }
    }

    /// Sets counter `i` of agent `a` to `v`, saturated to the lattice's width.
    pub fn set_counter(&mut self, a: u32, i: u8, v: i32) {
        let c = self.ensure_counter(i);
        self.counters[c].set(a as usize, self.width.saturate(v as i64));
    }

    /// The numeric message agent `a` received from direction index `dir` in slot `slot`
    /// (0-based), 0 when none.
    #[inline]
    pub fn inbox(&self, a: u32, dir: u8, slot: u8) -> i32 {
        match (self.slot_col[slot as usize], &self.pending) {
            (NO_COL, _) => 0,
            (s, None) => {
                self.inbox_num[dir as usize * self.slots as usize + s as usize].get(a as usize)
            }
            (s, Some(p)) => {
                let Cell::Agent(f) = self.neighbour_cell(a, dir as usize) else {
                    return 0;
                };
                let od = Dir::ALL[dir as usize].opposite().index();
                let col = od * self.slots as usize + s as usize;
                p.value(col, self.all_col(p, s as usize), f as usize)
            }
        }
    }

    /// The text message agent `a` received from direction index `dir`, if any.
    #[inline]
    pub fn inbox_text(&self, a: u32, dir: u8) -> Option<[u8; 5]> {
        let a = a as usize;
        (self
            .inbox_text_has
            .get(a)
            .is_some_and(|h| h & (1 << dir) != 0))
        .then(|| self.inbox_text[a * self.dim.dirs() + dir as usize])
    }

    /// The counters that have a column (set by the agents file or used by the rules), in
    /// number order; every other counter reads 0.
    pub fn counter_numbers(&self) -> Vec<u8> {
        (0..self.nc() as u8)
            .filter(|&i| self.counter_col[i as usize] != NO_COL)
            .collect()
    }

    /// The numeric message slots (0-based) that have inbox columns, in number order.
    pub fn slot_numbers(&self) -> Vec<u8> {
        (0..8u8)
            .filter(|&s| self.slot_col[s as usize] != NO_COL)
            .collect()
    }

    /// Bytes held per agent by the columns (positions, states, attachments, counters and
    /// messages in use, the neighbour table) and the cell index, for reports.
    pub fn bytes(&self) -> usize {
        let cols: usize = self.counters.iter().map(Column::bytes).sum::<usize>()
            + self.inbox_num.iter().map(Column::bytes).sum::<usize>()
            + self.pending.as_ref().map_or(0, |p| {
                p.num.iter().map(Column::bytes).sum::<usize>()
                    + p.has.iter().map(|c| c.capacity() * 8).sum::<usize>()
            })
            + self.nbr.iter().map(|c| c.capacity() * 4).sum::<usize>();
        self.pos.capacity() * 12
            + self.code.capacity() * 4
            + self.state.capacity() * 5
            + self.attach.capacity()
            + cols
            + self.inbox_text.capacity() * 5
            + self.inbox_text_has.capacity()
            + self.cells.bytes()
    }

    /// Whether a position lies inside the universe.
    #[inline]
    pub fn inside(&self, p: [i64; 3]) -> bool {
        let in_i32 = p
            .iter()
            .all(|&c| c >= i32::MIN as i64 && c <= i32::MAX as i64);
        in_i32 && self.within(p.map(|c| c as i32))
    }

    /// The position `off` away from `p`, when it lies inside the universe.
    #[inline]
    pub fn moved(&self, p: [i32; 3], off: [i32; 3]) -> Option<[i32; 3]> {
        let t = [
            p[0].checked_add(off[0])?,
            p[1].checked_add(off[1])?,
            p[2].checked_add(off[2])?,
        ];
        self.within(t).then_some(t)
    }

    /// Whether a position (in the range of coordinates) lies inside the universe's bounds.
    #[inline]
    fn within(&self, p: [i32; 3]) -> bool {
        match self.universe {
            None => true,
            Some(b) => (0..self.dim.coords()).all(|i| p[i] >= b[i].0 && p[i] <= b[i].1),
        }
    }

    /// What is at `from + off`.
    #[inline]
    pub fn cell_at(&self, from: [i32; 3], off: [i32; 3]) -> Cell {
        let p = [
            from[0] as i64 + off[0] as i64,
            from[1] as i64 + off[1] as i64,
            from[2] as i64 + off[2] as i64,
        ];
        if !self.inside(p) {
            return Cell::Blocked;
        }
        match self.cells.get([p[0] as i32, p[1] as i32, p[2] as i32]) {
            Some(id) => Cell::Agent(id),
            None => Cell::Empty,
        }
    }

    /// Agent `a`'s row of the neighbour table when it stands on `p`: per direction of the
    /// dimension (`Dir::ALL`'s order), the agent there, [`NO_AGENT`] or [`BLOCKED`] (the
    /// rest [`BLOCKED`]), as [`Lattice::cell_at`] answers each, in one look-up of the cells
    /// around it ([`CellIndex::around_in`]; `tile`: its tile, when a move just gave it).
    #[inline]
    fn table_row(&self, a: u32, p: [i32; 3], tile: Option<u32>) -> [u32; 6] {
        let nd = self.dim.dirs();
        let mut row = [BLOCKED; 6];
        self.cells.around_in(p, (a, tile), nd, &mut row);
        // (Unbounded, a cell not at the end of i32's range has every neighbour inside.)
        let clear = self.universe.is_none() && p.iter().all(|&c| c > i32::MIN && c < i32::MAX);
        if !clear {
            for (d, o) in row.iter_mut().enumerate().take(nd) {
                if self.moved(p, Dir::ALL[d].offset()).is_none() {
                    *o = BLOCKED;
                }
            }
        }
        row
    }

    /// The agent at a cell, if any.
    pub fn agent_at(&self, p: [i32; 3]) -> Option<u32> {
        self.cells.get(p)
    }

    /// Agent `a`'s cell as a slot code ([`CellIndex::code`]).
    #[inline]
    pub(crate) fn code_of(&self, a: u32) -> u32 {
        self.code[a as usize]
    }

    /// The agent `off` away from cell `p` (whose slot code is `code`), if any; `dir`: the
    /// direction index of `off` when it is one step (then a cell away from the grid's rim
    /// answers with one load).
    #[inline]
    pub(crate) fn agent_near(
        &self,
        (p, code): ([i32; 3], u32),
        off: [i32; 3],
        dir: Option<usize>,
    ) -> Option<u32> {
        if let Some(d) = dir {
            if code < RIM {
                return match self.cells.next_to(code, d) {
                    EMPTY => None,
                    b => Some(b),
                };
            }
        }
        match self.cell_at(p, off) {
            Cell::Agent(b) => Some(b),
            _ => None,
        }
    }

    /// The agent on cell `t`, `off` away from agent `a`: from the neighbour table when
    /// it is kept and `off` is one step (agents in tiles of cells, [`CellIndex::around_in`],
    /// look their targets up there), else from the cell index.
    #[inline]
    pub(crate) fn agent_beside(&self, a: u32, off: [i32; 3], t: [i32; 3]) -> Option<u32> {
        if self.nbr_valid {
            if let Some(d) = Dir::from_offset(off) {
                return match self.nbr[d.index()][a as usize] {
                    NO_AGENT | BLOCKED => None,
                    b => Some(b),
                };
            }
        }
        self.cells.get(t)
    }

    /// The neighbour of agent `a` in direction `d`, if any.
    #[inline]
    pub fn neighbour(&self, a: u32, d: Dir) -> Option<u32> {
        match self.neighbour_cell(a, d.index()) {
            Cell::Agent(b) => Some(b),
            _ => None,
        }
    }

    /// What stands next to agent `a` in direction index `d`.
    #[inline(always)]
    pub fn neighbour_cell(&self, a: u32, d: usize) -> Cell {
        if self.nbr_valid {
            return match self.nbr[d][a as usize] {
                NO_AGENT => Cell::Empty,
                BLOCKED => Cell::Blocked,
                b => Cell::Agent(b),
            };
        }
        // In a grid, away from its rim and from the universe's walls, one load answers.
        let s = self.code[a as usize];
        if s < RIM {
            return match self.cells.next_to(s, d) {
                EMPTY => Cell::Empty,
                b => Cell::Agent(b),
            };
        }
        self.neighbour_cell_slow(self.pos[a as usize], d)
    }

    /// Whether the cell next to agent `a` in direction index `d` holds an agent (`None`:
    /// it is outside the universe). Cheaper than [`Lattice::neighbour_cell`] in a grid.
    #[inline(always)]
    pub fn neighbour_filled(&self, a: u32, d: usize) -> Option<bool> {
        let s = self.code[a as usize];
        if !self.nbr_valid && s < RIM {
            return Some(self.cells.filled_next_to(s, d));
        }
        match self.neighbour_cell(a, d) {
            Cell::Blocked => None,
            Cell::Empty => Some(false),
            Cell::Agent(_) => Some(true),
        }
    }

    /// For agents `first..first + out.len()`: clears `out[j]` unless the cell next to agent
    /// `first + j` in direction index `d` is filled (`want`) or empty (not `want`) and
    /// inside the universe. The same as [`Lattice::neighbour_filled`] agent by agent, in
    /// one tight loop over the agents' slot codes where the grid answers.
    pub fn keep_if_filled(&self, first: usize, d: usize, want: bool, out: &mut [bool]) {
        let codes = &self.code[first..first + out.len()];
        match self.cells.grid() {
            Some(g) if !self.nbr_valid => {
                let step = g.step(d);
                // Away from the grid's rim (the common case): one bit read per agent.
                if !crate::cells::scattered(codes.iter().copied()) {
                    if g.keep_next_filled(codes, step, want, out) {
                        return;
                    }
                } else if crate::cells::all_interior(codes) {
                    for (j, (t, &s)) in out.iter_mut().zip(codes).enumerate() {
                        if let Some(&ahead) = codes.get(j + AHEAD) {
                            g.prefetch_filled(Grid::along(ahead, step));
                        }
                        *t &= g.filled(Grid::along(s, step)) == want;
                    }
                    return;
                }
                for (j, (t, &s)) in out.iter_mut().zip(codes).enumerate() {
                    *t &= if s < RIM {
                        g.filled(Grid::along(s, step)) == want
                    } else {
                        self.neighbour_filled((first + j) as u32, d) == Some(want)
                    };
                }
            }
            _ => {
                for (j, t) in out.iter_mut().enumerate() {
                    *t &= self.neighbour_filled((first + j) as u32, d) == Some(want);
                }
            }
        }
    }

    /// For each agent of `agents`, into `out`: whether the cell `off` away from it (any
    /// literal offset) is filled (`filled`) or empty, and inside the universe: `F` and `E`
    /// as [`Lattice::cell_at`] answers them, with one bit read where the grid holds the
    /// cell (the bouncing example's `F2,2` and `E1,1` were evaluated agent by agent).
    pub fn cells_filled(
        &self,
        agents: impl Iterator<Item = usize>,
        off: [i32; 3],
        filled: bool,
        out: &mut [bool],
    ) {
        let grid = self.cells.grid();
        for (t, a) in out.iter_mut().zip(agents) {
            let p = self.pos[a];
            // (Beyond `i32`, no grid holds it: `cell_at` answers.)
            let q = [0, 1, 2].map(|k| p[k].wrapping_add(off[k]));
            let near = (0..3).all(|k| (p[k] as i64 + off[k] as i64) == q[k] as i64);
            let bit = grid
                .filter(|_| near)
                .and_then(|g| Some(g.filled(g.slot(q)?)));
            *t = match bit {
                Some(f) => f == filled,
                None => match self.cell_at(p, off) {
                    Cell::Agent(_) => filled,
                    Cell::Empty => !filled,
                    Cell::Blocked => false,
                },
            };
        }
    }

    /// [`Lattice::keep_if_filled`] for the agents `ids` (any, in any order): clears
    /// `out[j]` unless the cell next to agent `ids[j]` in direction index `d` is filled
    /// (`want`) or empty and inside the universe.
    pub fn keep_if_filled_ids(&self, ids: &[u32], d: usize, want: bool, out: &mut [bool]) {
        match self.cells.grid() {
            Some(g) if !self.nbr_valid => {
                let step = g.step(d);
                let ahead = crate::cells::scattered(ids.iter().map(|&a| self.code[a as usize]));
                for (j, (t, &a)) in out.iter_mut().zip(ids).enumerate() {
                    if let Some(&ahead) = ids.get(j + AHEAD).filter(|_| ahead) {
                        let s = self.code[ahead as usize];
                        if s < RIM {
                            g.prefetch_filled(Grid::along(s, step));
                        }
                    }
                    let s = self.code[a as usize];
                    *t &= if s < RIM {
                        g.filled(Grid::along(s, step)) == want
                    } else {
                        self.neighbour_filled(a, d) == Some(want)
                    };
                }
            }
            _ => {
                for (t, &a) in out.iter_mut().zip(ids) {
                    *t &= self.neighbour_filled(a, d) == Some(want);
                }
            }
        }
    }

    /// The agents next to agent `a` in every direction of the dimension: an id, or
    /// `u32::MAX` for an empty cell or one outside the universe.
    #[inline(always)]
    pub fn neighbours(&self, a: u32, out: &mut [u32; 6]) {
        let nd = self.dim.dirs();
        if self.nbr_valid {
            for (o, col) in out.iter_mut().zip(&self.nbr).take(nd) {
                *o = match col[a as usize] {
                    BLOCKED => NO_AGENT,
                    b => b,
                };
            }
            return;
        }
        let s = self.code[a as usize];
        if s < RIM {
            for (d, o) in out.iter_mut().enumerate().take(nd) {
                *o = self.cells.next_to(s, d);
            }
            return;
        }
        for (d, o) in out.iter_mut().enumerate().take(nd) {
            *o = match self.neighbour_cell_slow(self.pos[a as usize], d) {
                Cell::Agent(b) => b,
                _ => NO_AGENT,
            };
        }
    }

    /// For agents from `first` (at most `len`) standing on consecutive cells of a grid: how
    /// many do, and per direction the ids next to them (`u32::MAX` for none: the grid never
    /// reaches outside the universe), read straight from the grid. `None` when the grid
    /// cannot answer for a run of them at once.
    #[inline]
    pub fn neighbour_run(&self, first: usize, len: usize) -> Option<(usize, [&[u32]; 6])> {
        if self.nbr_valid {
            return None;
        }
        self.cells
            .neighbour_run(first as u32, self.pos[first], len, self.dim.dirs())
    }

    #[cold]
    #[inline(never)]
    fn neighbour_cell_slow(&self, p: [i32; 3], d: usize) -> Cell {
        if let Some(u) = self.universe {
            let walls = (0..self.dim.coords()).any(|k| p[k] <= u[k].0 || p[k] >= u[k].1);
            if !walls {
                if let Some(c) = self.cells.neighbour_in_grid(p, d) {
                    return c.map_or(Cell::Empty, Cell::Agent);
                }
            }
        }
        self.cell_at(p, Dir::ALL[d].offset())
    }

    /// Rebuilds the neighbour table if a move or swap made it stale (only when the cell
    /// index has no grid; a grid answers directly).
    pub fn refresh_neighbours(&mut self) {
        if self.nbr_valid || self.cells.is_grid() {
            return;
        }
        let nd = self.dim.dirs();
        let mut nbr = std::mem::take(&mut self.nbr);
        nbr.resize(nd, Vec::new());
        for col in &mut nbr {
            col.clear();
            col.reserve(self.len());
        }
        for (a, &p) in self.pos.iter().enumerate() {
            for (col, b) in nbr.iter_mut().zip(self.table_row(a as u32, p, None)) {
                col.push(b);
            }
        }
        self.nbr = nbr;
        self.nbr_valid = true;
    }

    /// Moves agents to new positions all at once (the caller guarantees no two share a cell).
    pub fn relocate(&mut self, moves: &[(u32, [i32; 3])]) {
        let nd = self.dim.dirs();
        // Each mover leaves its cell and takes its target. (One mover may take the cell
        // of another not yet moved: that one then finds its old cell not its own, and
        // leaves it as it is.)
        let mut tiles = Vec::with_capacity(if self.nbr_valid { moves.len() } else { 0 });
        for &(a, p) in moves {
            if self.nbr_valid {
                // What stood next to the cell left sees it empty (or a mover, below): the
                // mover's own row of the table, as it was, tells who without a look-up.
                // (A neighbour that moved too gets a row of its own below.)
                for d in 0..nd {
                    let b = self.nbr[d][a as usize];
                    if b != NO_AGENT && b != BLOCKED {
                        self.nbr[Dir::ALL[d].opposite().index()][b as usize] = NO_AGENT;
                    }
                }
            }
            let old = std::mem::replace(&mut self.pos[a as usize], p);
            let tile = self.cells.shift(old, p, a);
            self.code[a as usize] = self.cells.code(p);
            if self.nbr_valid {
                tiles.push(tile);
            }
        }
        if self.nbr_valid {
            // Each mover's row, and its new neighbours seeing it: a look-up of the cells
            // around it (in the tile the move gave, when it is in the tiles).
            for (&(a, p), &tile) in moves.iter().zip(&tiles) {
                for (d, b) in self.table_row(a, p, tile).into_iter().enumerate().take(nd) {
                    self.nbr[d][a as usize] = b;
                    if b != NO_AGENT && b != BLOCKED {
                        self.nbr[Dir::ALL[d].opposite().index()][b as usize] = a;
                    }
                }
            }
        }
        self.after_moves();
    }

    /// After moves: when many agents have left the grid, or a few have been outside it for
    /// long enough that their look-ups in the tiles cost what a grid over all agents
    /// costs to make (each agent outside counted once per step with moves, weighed as
    /// [`SLOW_STEP`] agents or cells of a new grid, as in [`Lattice::grow_toward`]), the
    /// cell index is made again over where they are (within its budget of cells; after a
    /// box over budget, tried again only when twice as many are out, or after as much
    /// work again), and the neighbour table is dropped with a grid. Otherwise the agents
    /// outside the grid may be gathered into its side box ([`CellIndex::gather_outside`]).
    fn after_moves(&mut self) {
        let out = self.cells.outside();
        let pays = self.slow_work_pays(out as u64);
        if out == 0 || (out < self.regrow_at && !pays) {
            self.cells.gather_outside();
            return;
        }
        match self.cells.regrow(&self.pos, [[false; 2]; 3]) {
            Some(index) => self.take_index(index),
            None => {
                self.regrow_at = out * 2;
                self.regrow_refused();
                self.cells.gather_outside();
            }
        }
    }

    /// Adds `work` agent-steps done the slow way (agents outside the grid, moves refused
    /// at its rim) and says whether all of it since the grid was made pays for making it
    /// again: an agent-step weighs as [`SLOW_STEP`] agents or cells of the new grid, and
    /// each try over budget doubles the work asked for before the next.
    fn slow_work_pays(&mut self, work: u64) -> bool {
        self.off_work = self.off_work.saturating_add(work);
        let cost = (self.len() + self.cells.slots()) as u64;
        (self.off_work.saturating_mul(SLOW_STEP) >> self.off_tries) >= cost
    }

    /// A try at a new grid that gave none (over budget, or the same grid).
    fn regrow_refused(&mut self) {
        self.off_work = 0;
        self.off_tries = (self.off_tries + 1).min(40);
    }

    /// Takes `cells` and every agent's slot code as the cell index, made again over where
    /// the agents are: the neighbour table is made again when next asked for (none with a
    /// grid), and the counts of agents outside the grid and of slow work start again.
    fn take_index(&mut self, (cells, code): (CellIndex, Vec<u32>)) {
        (self.cells, self.code) = (cells, code);
        if self.cells.is_grid() {
            self.nbr = Vec::new();
        }
        self.nbr_valid = false;
        self.regrow_at = self.first_regrow().max(self.cells.outside() * 2);
        (self.off_work, self.off_tries) = (0, 0);
    }

    /// Before `movers` agents move by `off` from the grid's rim: the grid made again with
    /// room on the sides `off` points to, when that pays and gives a grid other than this
    /// one (a universe's walls may keep it as it is). Says whether it did. It pays at once
    /// when the movers' steps through the room (about half the grid's extent along
    /// `off`), each weighed as [`SLOW_STEP`] agents or cells, reach what the new grid and
    /// its agents cost to make ([`Lattice::room_pays`]), unless a try since the grid was
    /// made gave none; so many movers get room at once, and 1,000 walkers beside 10^5
    /// agents at rest too. Else a refusal counts the moves as [`SLOW_MOVES`] agent-steps
    /// done the slow way (`off_work`, as agents outside the grid are), and it pays once
    /// that work reaches the cost: 1,000 walkers beside 10^7 agents at rest go the general
    /// way, through the side box, rather than have a grid of 10^7 cells made again every
    /// few dozen steps (in 3D 1.6-1.8 s for their 1,000 steps, against 0.06-0.08 s now; in
    /// 2D, walking west or north, 0.5-0.6 s against 0.04-0.08 s).
    ///
    /// When the movers (`ids`, in lists) are at most one agent in eight, the grid is made
    /// over them alone, with room ahead, the others beside it ([`CellIndex::regrow_over`]):
    /// first, while every grid so made was for movers going this same way (the 3D walkers
    /// beside a block of 10^6 agents took 0.050 s for their 1,000 steps with the block's
    /// grid made again with room ahead of them, 25 MB of fresh cells; 0.026 s so; beside
    /// 10^5 agents in 2D 0.016 and 0.012 s); and when no grid over every agent is within
    /// the budget (1,000 walkers 10^6 cells from a block of 10^5 agents took 0.056 s in
    /// the side box, 0.012 s so). Movers that turn after a grid of their own would get
    /// one at each turn, each a pass over every agent (walkers turning every 20 steps
    /// beside a block of 10^6 agents in 3D: 4.7x the time): from the first turn on, the grid
    /// is made over every agent first.
    pub(crate) fn grow_toward(&mut self, off: [i32; 3], (movers, ids): (usize, &[&[u32]])) -> bool {
        let Some(old) = self.cells.grid_box() else {
            return false;
        };
        // (Once a try gave no grid, the work asked for before the next doubles.)
        let at_once = self.off_tries == 0 && self.room_pays(old, off, movers);
        if !at_once && !self.slow_work_pays(movers as u64 * SLOW_MOVES) {
            return false;
        }
        let toward = [0, 1, 2].map(|k| [off[k] < 0, off[k] > 0]);
        let few = movers * 8 <= self.len();
        let over = |lat: &Lattice| {
            let pos = &lat.pos;
            let at = ids.iter().flat_map(|l| l.iter()).map(|&a| &pos[a as usize]);
            lat.cells.regrow_over(pos, (movers, at), toward)
        };
        let first = match self.own_grid {
            OwnGrid::Untried => true,
            OwnGrid::Going(way) if way == off => true,
            OwnGrid::Going(_) => {
                self.own_grid = OwnGrid::Turned;
                false
            }
            OwnGrid::Turned => false,
        };
        let tried = first && few;
        if let Some(index) = tried.then(|| over(self)).flatten() {
            self.own_grid = OwnGrid::Going(off);
            self.take_index(index);
            return true;
        }
        let index = match self.cells.regrow(&self.pos, toward) {
            Some(index) if index.0.grid_box() != Some(old) => Some(index),
            // Over budget: a few movers among many agents get a grid of their own.
            _ if few && !tried => over(self),
            _ => None,
        };
        match index {
            Some(index) => {
                self.take_index(index);
                true
            }
            None => {
                self.regrow_refused();
                false
            }
        }
    }

    /// Whether `movers` agents moving by `off` across the room a new grid would give them
    /// pay for that grid at once: their steps through it, weighed as [`SLOW_STEP`] each,
    /// against the agents and the cells of the grid `(lo, size)` grown by the room. The
    /// room is taken as half the grid's extent along each axis `off` moves on
    /// ([`CellIndex::regrow`] gives half the agents' extent, which the grid's
    /// exceeds by its margins; less where that is over its budget).
    fn room_pays(&self, (_, size): ([i32; 3], [i64; 3]), off: [i32; 3], movers: usize) -> bool {
        let volume = size.iter().product::<i64>() as u64;
        let (mut room, mut grown) = (u64::MAX, volume);
        for k in (0..3).filter(|&k| off[k] != 0) {
            let r = (size[k] / crate::cells::ROOM_SHARE).max(1) as u64;
            room = room.min(r / off[k].unsigned_abs().max(1) as u64);
            grown = grown.saturating_add(volume / size[k].max(1) as u64 * r);
        }
        let cost = (self.len() as u64).saturating_add(grown);
        (movers as u64)
            .saturating_mul(room)
            .saturating_mul(SLOW_STEP)
            >= cost
    }

    /// The moves of agents one step in direction index `d`, between cells of the grid
    /// (`None` without a grid), made in parts from any thread. Without `bonds` (the caller
    /// knows that no agent holds one), the parts do not look.
    pub(crate) fn shift(&mut self, d: usize, bonds: bool) -> Option<Shift<'_>> {
        let n = self.pos.len();
        let (pos, code) = (self.pos.as_mut_ptr(), self.code.as_mut_ptr());
        let attach = match bonds {
            true => self.attach.as_ptr(),
            false => std::ptr::null(),
        };
        let g = self.cells.grid_mut()?;
        g.ready_rim();
        let step = g.step(d);
        Some(Shift {
            cells: g.shared(),
            ahead: false,
            pos,
            code,
            attach,
            n,
            axis: Dir::ALL[d].axis(),
            step,
        })
    }

    /// Undoes the moves of one step `off` (of direction index `d`) made by
    /// [`Shift::in_place`] for the agents of `moved` (in any order): their targets are
    /// emptied, then their cells filled again.
    pub(crate) fn unshift(&mut self, moved: &[Vec<u32>], (off, d): ([i32; 3], usize)) {
        let Some(g) = self.cells.grid_mut() else {
            return;
        };
        let step = g.step(d);
        let mut cells = g.cells_mut();
        for &a in moved.iter().flat_map(|m| m.iter()) {
            cells.vacate((self.code[a as usize] & !RIM) as usize);
        }
        for &a in moved.iter().flat_map(|m| m.iter()) {
            let a = a as usize;
            let back = ((self.code[a] & !RIM) as isize - step) as usize;
            cells.occupy(back, a as u32);
            self.code[a] = cells.code_of(back);
            let p = self.pos[a];
            self.pos[a] = [p[0] - off[0], p[1] - off[1], p[2] - off[2]];
        }
    }

    /// Moves agents `movers` (distinct, in any order) by one offset `off`, which is one
    /// step of direction index `d`, each that stands on the grid away from its rim into its
    /// target when that is empty now (empty at the start of the step, or just left by an
    /// agent moving the same way), and returns how many of them stood on the rim (or off
    /// the grid). The others, those on the rim and those that found their target filled,
    /// are pushed to `deferred` (in the order of `movers`), for the general way: each move
    /// made is one the step makes whatever they do (with one offset, no other mover targets
    /// the same cell, and none can enter a cell taken so). When one of them is bonded,
    /// moves none and returns `None` (what it pushed to `deferred` stays there).
    /// `ahead`: ask for the cells of the movers a dozen ahead (when they are scattered).
    pub(crate) fn shift_alone(
        &mut self,
        movers: &[u32],
        (off, d): ([i32; 3], usize),
        ahead: bool,
        deferred: &mut Vec<u32>,
    ) -> Option<usize> {
        let g = self.cells.grid_mut()?;
        g.ready_rim();
        let step = g.step(d);
        let mut cells = g.cells_mut();
        let mut held = crate::cells::Held::default();
        // (Slices, whose lengths the loop keeps in registers: through the vectors, each
        // was read again after every write to the cells.)
        let (code, pos, attach) = (&mut self.code[..], &mut self.pos[..], &self.attach[..]);
        let (first, mut rim, mut bonded) = (deferred.len(), 0, None);
        // (A move changes one coordinate: its other two were read and written again.)
        let (axis, by) = Dir::ALL[d].axis();
        for (k, &a) in movers.iter().enumerate() {
            // The cells a dozen moves ahead (see `cells::prefetch`).
            if let Some(&b) = movers.get(k + AHEAD).filter(|_| ahead) {
                cells.prefetch_cell((code[b as usize] & !RIM) as usize);
            }
            let a = a as usize;
            let c = code[a];
            if attach[a] != 0 {
                bonded = Some(k);
                break;
            }
            if c >= RIM {
                rim += 1;
                deferred.push(a as u32);
                continue;
            }
            let to = Grid::along(c, step);
            if !cells.relocate(&mut held, a as u32, c as usize, to) {
                deferred.push(a as u32);
                continue;
            }
            code[a] = held.code_of(to);
            pos[a][axis] += by;
        }
        cells.put_back(&mut held);
        let Some(k) = bonded else {
            return Some(rim);
        };
        // Back: the movers gone through, but those left.
        let mut moved = movers[..k].to_vec();
        drop_agents(&mut moved, &deferred[first..], |&a| a);
        self.unshift(&[moved], (off, d));
        None
    }

    /// Movers to their targets on a grid, in parts that threads make at once
    /// ([`Relocation::part`]), then [`Lattice::relocated`]; `None` without a grid.
    pub(crate) fn relocation(&mut self) -> Option<Relocation<'_>> {
        let n = self.pos.len();
        let (pos, code) = (self.pos.as_mut_ptr(), self.code.as_mut_ptr());
        let g = self.cells.grid_mut()?;
        Some(Relocation {
            cells: g.shared(),
            pos,
            code,
            n,
        })
    }

    /// After the parts of a [`Relocation`]: the movers that came from outside the grid
    /// leave the side box or the tiles (`outside`: their old positions), then those that
    /// went outside it enter them (`leaving`: their new positions).
    pub(crate) fn relocated<'m>(
        &mut self,
        outside: impl Iterator<Item = &'m Placed>,
        leaving: impl Iterator<Item = &'m Placed>,
    ) {
        for &(old, a) in outside {
            self.cells.remove(old, a);
        }
        for &(p, a) in leaving {
            self.cells.insert(p, a);
        }
        self.after_moves();
    }
}

/// An agent with a position it left or takes (see [`Relocation::part`]).
pub(crate) type Placed = ([i32; 3], u32);

/// Agents moving to their targets on the grid ([`Lattice::relocation`]), in parts that
/// threads make at once.
pub(crate) struct Relocation<'a> {
    cells: crate::cells::SharedCells<'a>,
    pos: *mut [i32; 3],
    code: *mut u32,
    n: usize,
}

// SAFETY: written only through `Relocation::part`, whose callers give each thread movers
// and targets of its own; cells and their bits are atomics (see `SharedCells`).
unsafe impl Sync for Relocation<'_> {}
unsafe impl Send for Relocation<'_> {}

impl Relocation<'_> {
    /// Moves the agents of `moves` (agent, target) to their targets, given with their
    /// slot codes (`codes`: [`CellIndex::code`]; [`NO_SLOT`] for a target outside the
    /// grid), which no two movers share and which are empty or left by movers: as
    /// [`Lattice::relocate`] does. `targeted` tells whether a slot is one of the targets:
    /// a mover's old cell is emptied only when it is not, without reading the grid.
    /// Movers that come from outside the grid are pushed to `outside` with their old
    /// positions, those that go outside it to `leaving` with their new ones, for
    /// [`Lattice::relocated`]. The occupancy bits are written as `bits` says: with
    /// [`Bits::Log`] (several threads at once), by [`Relocation::apply`] after every part.
    ///
    /// # Safety
    /// Across all parts made at once, the movers are distinct, and so are the targets; no
    /// other thread reads or writes the lattice meanwhile but through this relocation;
    /// with [`Bits::Write`], one part at a time (one thread moves agents: the bits are
    /// written without locks).
    pub(crate) unsafe fn part(
        &self,
        (moves, codes): (&[(u32, [i32; 3])], &[u32]),
        targeted: impl Fn(usize) -> bool,
        (outside, leaving): (&mut Vec<Placed>, &mut Vec<Placed>),
        mut bits: Bits<'_>,
    ) {
        // (Copies, kept in registers, as in `Shift::in_place`.)
        let (cells, n, pos, code) = (self.cells, self.n, self.pos, self.code);
        for (k, (&(a, p), &c)) in moves.iter().zip(codes).enumerate() {
            let a = a as usize;
            assert!(a < n, "an agent of the lattice");
            // SAFETY: in bounds (checked, and `next` below); agent `a` and its target
            // belong to this part alone, its old cell is emptied only when no mover
            // targets it (the caller's promise); cells are atomics.
            unsafe {
                // The cells a few moves ahead leave and take (see `cells::prefetch`).
                if let (Some(&(next, _)), Some(&to)) = (moves.get(k + AHEAD), codes.get(k + AHEAD))
                {
                    cells.prefetch((*code.add((next as usize).min(n - 1)) & !RIM) as usize);
                    cells.prefetch((to & !RIM) as usize);
                }
                let old = std::mem::replace(&mut *pos.add(a), p);
                let was = std::mem::replace(&mut *code.add(a), c);
                let o = (was & !RIM) as usize;
                if was == NO_SLOT {
                    outside.push((old, a as u32));
                } else if !targeted(o) {
                    cells.vacate(o, &mut bits);
                }
                if c == NO_SLOT {
                    leaving.push((p, a as u32));
                } else {
                    cells.occupy((c & !RIM) as usize, a as u32, &mut bits);
                }
            }
        }
    }
}

impl Relocation<'_> {
    /// How a [`BitLog`] of the parts splits the occupancy bits (into at most `most`
    /// buckets), for [`BitLog::ready`].
    pub(crate) fn buckets(&self, most: usize) -> (u32, usize) {
        self.cells.buckets(most)
    }

    /// Writes the occupancy bits of bucket `b` of `logs`, every part's.
    ///
    /// # Safety
    /// After every part; no other thread writes the bits of bucket `b` meanwhile (threads
    /// writing distinct buckets may run at once), nor uses the lattice but through this
    /// relocation.
    pub(crate) unsafe fn apply(&self, logs: &[&BitLog], b: usize) {
        // SAFETY: the caller's promise.
        unsafe { self.cells.apply(logs, b) }
    }
}

/// Agents moving one step between cells of the grid ([`Lattice::shift`]), in parts that
/// threads make at once ([`Shift::in_place`]), or all undone ([`Lattice::unshift`]).
pub(crate) struct Shift<'a> {
    cells: crate::cells::SharedCells<'a>,
    /// Ask for the cells a dozen movers ahead.
    pub(crate) ahead: bool,
    pos: *mut [i32; 3],
    code: *mut u32,
    /// The agents' bonds; null when no agent holds one.
    attach: *const u8,
    n: usize,
    /// The axis the agents move along, and by how much ([`Dir::axis`]).
    axis: (usize, i32),
    step: isize,
}

// SAFETY: written only through `Shift::in_place`, whose callers give each thread agents of
// its own; cells and their bits are atomics (see `SharedCells`).
unsafe impl Sync for Shift<'_> {}
unsafe impl Send for Shift<'_> {}

impl Shift<'_> {
    /// How the parts' [`Words`] split the words of occupancy (into at most `most`
    /// buckets).
    pub(crate) fn buckets(&self, most: usize) -> (u32, usize) {
        self.cells.buckets(most)
    }

    /// Writes the bits of occupancy of bucket `b` of `logs` (every part's).
    ///
    /// # Safety
    /// After every part of [`Shift::in_place`]; no other thread writes the words of bucket
    /// `b` meanwhile (threads writing distinct buckets may run at once).
    pub(crate) unsafe fn apply(&self, logs: &[&Words], b: usize) {
        // SAFETY: the caller's promise.
        unsafe { self.cells.apply_words(logs, b) }
    }

    /// Moves the agents of `movers`, in turn, one step each, as [`Lattice::shift_alone`]
    /// does: those that stand on the grid's rim (or off it) or find their target filled now
    /// are pushed to `deferred`; stops at the first that is bonded. Returns how many it
    /// went through, and how many stood on the rim (`None` when it stopped at a bonded one).
    /// The bits of occupancy are written as `writes` says: noted in [`Words`] (made ready
    /// for this shift's buckets), for [`Shift::apply`] after every part; or, for a part
    /// that owns a range of words (and their cells), written at once, its movers from or
    /// into a cell outside the range pushed to `crossing` instead (for [`Lattice::shift_alone`]
    /// after every part).
    ///
    /// # Safety
    /// Across all parts made at once, the agents are distinct, and the ranges owned are
    /// apart and only written with [`OccWrites::Owned`]; no other thread reads or writes the
    /// lattice but through this `Shift`.
    pub(crate) unsafe fn in_place(
        &self,
        movers: &[u32],
        deferred: &mut Vec<u32>,
        writes: OccWrites<'_>,
    ) -> (usize, Option<usize>) {
        match writes {
            OccWrites::Log(words) => {
                let logged = Logged {
                    cells: self.cells,
                    words,
                };
                // SAFETY: the caller's promise.
                unsafe { self.moves(movers, (deferred, &mut Vec::new()), logged).0 }
            }
            OccWrites::Owned { words, crossing } => {
                // SAFETY: the caller's promise: these words and their cells are this part's.
                let cells = unsafe { self.cells.owned(words) };
                // SAFETY: as above.
                let (made, mut cells) = unsafe { self.moves(movers, (deferred, crossing), cells) };
                cells.put_back();
                made
            }
        }
    }

    /// [`Shift::in_place`]'s loop, moving agents between cells by `cells` (taken and given
    /// back by value, so that a word it holds stays in a register); movers that `cells`
    /// says are not its to move go to the second list.
    ///
    /// # Safety
    /// As for [`Shift::in_place`].
    #[inline(always)]
    unsafe fn moves<R: Relocate>(
        &self,
        movers: &[u32],
        (deferred, crossing): (&mut Vec<u32>, &mut Vec<u32>),
        mut cells: R,
    ) -> ((usize, Option<usize>), R) {
        let mut rim = 0;
        // (Copies, kept in registers: the fields of `self` were read again after every
        // write through the pointers.)
        let (shared, n, step, (axis, by)) = (self.cells, self.n, self.step, self.axis);
        let (codes, positions, attach, ahead) = (self.code, self.pos, self.attach, self.ahead);
        for (k, &a) in movers.iter().enumerate() {
            let a = a as usize;
            assert!(a < n, "an agent of the lattice");
            // SAFETY: in bounds (checked); agent `a` belongs to this part alone (the
            // caller's promise), and its target's cell only it may fill (one offset from
            // distinct cells).
            unsafe {
                if let Some(&b) = movers.get(k + AHEAD).filter(|_| R::AHEAD && ahead) {
                    let c = *codes.add((b as usize).min(n - 1));
                    shared.prefetch_cell((c & !RIM) as usize);
                }
                let code = &mut *codes.add(a);
                let c = *code;
                if !attach.is_null() && *attach.add(a) != 0 {
                    return ((k, None), cells);
                }
                if c >= RIM {
                    rim += 1;
                    deferred.push(a as u32);
                    continue;
                }
                let to = Grid::along(c, step);
                *code = match cells.relocate(a as u32, (c as usize, to)) {
                    Some(Ok(code)) => code,
                    Some(Err(())) => {
                        deferred.push(a as u32);
                        continue;
                    }
                    None => {
                        crossing.push(a as u32);
                        continue;
                    }
                };
                (*positions.add(a))[axis] += by;
            }
        }
        ((movers.len(), Some(rim)), cells)
    }

    /// Where agent `a` stands: its position, and its slot code as [`Lattice::code_of`].
    ///
    /// # Safety
    /// No other thread moves agent `a` meanwhile.
    pub(crate) unsafe fn at(&self, a: u32) -> ([i32; 3], u32) {
        let a = a as usize;
        assert!(a < self.n, "an agent of the lattice");
        // SAFETY: in bounds (checked); nothing writes agent `a` (the caller's promise).
        unsafe { (*self.pos.add(a), *self.code.add(a)) }
    }

    /// Whether the cells of `agents` lie scattered over the grid (agents listed in no
    /// spatial order), judged on the first 65 of them: then loops over them ask for the
    /// cells ahead (see `cells::prefetch`); in order, the processor finds them by itself.
    ///
    /// # Safety
    /// No thread writes the codes meanwhile.
    pub(crate) unsafe fn scattered(&self, agents: &[usize]) -> bool {
        // SAFETY: only reads, in bounds (clamped), with no writer (the caller's promise).
        let code = |a: usize| unsafe { *self.code.add(a.min(self.n - 1)) };
        crate::cells::scattered(agents.iter().map(|&a| code(a)))
    }
}

/// How a part of [`Shift::in_place`] moves agents between cells.
trait Relocate {
    /// Whether the loop asks for the cells of movers ahead when they lie scattered.
    const AHEAD: bool;
    /// Moves agent `a` from cell `from` into cell `to` when `to` is empty now, and says
    /// whether it did with `to`'s slot code; `None`, having done nothing, when the move is
    /// not this part's.
    fn relocate(&mut self, a: u32, from_to: (usize, usize)) -> Option<Result<u32, ()>>;
}

/// Moves whose bits of occupancy are noted, for [`Shift::apply`] after every part.
struct Logged<'a, 'w> {
    cells: crate::cells::SharedCells<'a>,
    words: &'w mut Words,
}

impl Relocate for Logged<'_, '_> {
    const AHEAD: bool = true;

    #[inline]
    fn relocate(&mut self, a: u32, (from, to): (usize, usize)) -> Option<Result<u32, ()>> {
        // SAFETY: made only by `Shift::in_place`, whose caller promises that no other
        // thread moves an agent from or into these cells (one offset from distinct cells).
        Some(
            match unsafe { self.cells.take(a, (from, to), self.words) } {
                true => Ok(self.cells.code_of_slot(to)),
                false => Err(()),
            },
        )
    }
}

impl Relocate for crate::cells::OwnedCells<'_> {
    // (Owned only by parts of agents in cell order.)
    const AHEAD: bool = false;

    #[inline]
    fn relocate(&mut self, a: u32, from_to: (usize, usize)) -> Option<Result<u32, ()>> {
        crate::cells::OwnedCells::relocate(self, a, from_to)
    }
}

/// How [`Shift::in_place`] writes the bits of occupancy of a part's moves.
pub(crate) enum OccWrites<'w> {
    /// Noted, for [`Shift::apply`] after every part.
    Log(&'w mut Words),
    /// Written at once: the part owns the words `words` (a range) and their cells, and its
    /// movers from or into a cell outside them go to `crossing`.
    Owned {
        words: (usize, usize),
        crossing: &'w mut Vec<u32>,
    },
}

/// Drops from `items` (entries of some agents, in their order; `agent`: an entry's agent)
/// the entries of the agents of `gone`, a subsequence of the same agents (the movers that
/// moves at once left, [`Lattice::shift_alone`] and [`Shift::in_place`]).
pub(crate) fn drop_agents<T>(items: &mut Vec<T>, gone: &[u32], agent: impl Fn(&T) -> u32) {
    if gone.is_empty() {
        return;
    }
    let mut left = gone.iter().peekable();
    items.retain(|m| match left.peek() {
        Some(&&a) if a == agent(m) => {
            left.next();
            false
        }
        _ => true,
    });
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Agents on one cell (three on one) are left out but the first; one-sided bonds are
    /// made and bonds towards no agent dropped, in id order; ids map to columns and back.
    #[test]
    fn columns_with_defects_are_mended_as_the_checker_mends_them() {
        let mut cols = Columns::new(Width::W16);
        // (position, attachments N W E S)
        for (p, a) in [
            ([0, 0, 0], 0b0100u8), // E, to 1, which does not declare W: made
            ([1, 0, 0], 0),
            ([0, 0, 0], 0),      // on agent 0's cell
            ([5, 5, 0], 0b0001), // N, towards no agent: dropped
            ([0, 0, 0], 0b1000), // on agent 0's cell
            ([1, 0, 0], 0),      // on agent 1's cell
        ] {
            cols.pos.push(p);
            cols.state.push(*b"AAAAA");
            cols.attach.push(a);
        }
        let (lat, m) = Lattice::from_columns_mended(Dim::Two, None, cols.clone(), 10);
        let (_, few) = Lattice::from_columns_mended(Dim::Two, None, cols, 0);
        assert_eq!(few.bonds, vec![]);
        assert_eq!(few.more, [1, 1]);
        assert_eq!(
            few.first_more,
            [Some((0, Dir::E, Some(1))), Some((2, Dir::N, None))]
        );
        assert_eq!(m.gone, vec![2, 4, 5]);
        assert_eq!(m.shared, vec![(2, 0), (4, 0), (5, 1)]);
        assert_eq!(m.bonds, vec![(0, Dir::E, Some(1)), (2, Dir::N, None)]);
        assert_eq!(lat.len(), 3);
        assert_eq!(lat.attach, vec![0b0100, 0b0010, 0]);
        assert_eq!(lat.one_sided_bond(), None);
        assert_eq!((m.column_of(2), m.id_of(3)), (3, 2));
        assert_eq!((m.id_of(4), m.id_of(6)), (3, 3));
    }

    /// Moves at once leave to the general way the movers at the grid's rim and those whose
    /// target is filled when they are tried (by an agent that stays, or by a mover not
    /// moved yet), and move the others; a bonded mover undoes every move made.
    #[test]
    fn moves_at_once_defer_the_rim_and_filled_targets() {
        let mut lat = LatticeBuilder::block(10, 10).finish();
        let (east, d) = ([1, 0, 0], Dir::E.index());
        let id = |x: i32, y: i32| (x * 10 + y) as u32;
        let mut deferred = Vec::new();
        // The agent at 8,0 before the one ahead of it moved; 0,1 behind the one at 1,1,
        // which stays.
        let movers = [id(8, 0), id(9, 0), id(0, 1)];
        assert_eq!(
            lat.shift_alone(&movers, (east, d), false, &mut deferred),
            Some(0)
        );
        assert_eq!(deferred, [id(8, 0), id(0, 1)]);
        assert_eq!(lat.pos[id(9, 0) as usize], [10, 0, 0]);
        assert_eq!(lat.cells.get([10, 0, 0]), Some(id(9, 0)));
        assert_eq!(lat.cells.get([9, 0, 0]), None);
        assert_eq!(lat.pos[id(8, 0) as usize], [8, 0, 0]);
        assert_eq!(lat.cells.get([1, 1, 0]), Some(id(1, 1)));
        // The grid has two cells of margin: the agent at 10,0 goes to its rim, and is
        // left there.
        deferred.clear();
        assert_eq!(
            lat.shift_alone(&[id(9, 0)], (east, d), false, &mut deferred),
            Some(0)
        );
        assert_eq!(
            lat.shift_alone(&[id(9, 0)], (east, d), false, &mut deferred),
            Some(1)
        );
        assert_eq!(
            (deferred, lat.pos[id(9, 0) as usize]),
            (vec![id(9, 0)], [11, 0, 0])
        );
        // A bonded mover after one that moved, one deferred and one at the rim.
        lat.attach[id(5, 5) as usize] = 1;
        let before = lat.clone();
        let (mut deferred, movers) = (vec![7], [id(9, 1), id(0, 2), id(9, 0), id(5, 5)]);
        assert_eq!(
            lat.shift_alone(&movers, (east, d), false, &mut deferred),
            None
        );
        assert!(lat == before);
        assert_eq!(deferred, [7, id(0, 2), id(9, 0)]);
    }

    /// Room ahead of movers at the grid's rim is given at once when their steps through it
    /// pay for the grid made again (many movers), not for a few beside many agents at rest
    /// (they go the general way until their work pays: 1,000 walkers beside 10^7 agents
    /// in 3D had a grid of tens of millions of cells made again every few dozen steps).
    #[test]
    fn room_ahead_pays_at_once_for_many_movers_only() {
        let mut lat = LatticeBuilder::block(100, 100).finish();
        let old = lat.cells.grid_box().expect("a grid");
        let east = [1, 0, 0];
        // 10,000 agents and about 10,800 cells, grown by a half: 10 movers through a room
        // of 52 cells weigh 2,080, 1,000 movers 208,000.
        assert!(!lat.room_pays(old, east, 10));
        assert!(lat.room_pays(old, east, 1000));
        assert!(!lat.grow_toward(east, (10, &[])), "a few movers wait");
        assert_eq!(lat.cells.grid_box(), Some(old));
        assert!(
            lat.grow_toward(east, (1000, &[])),
            "many movers get room at once"
        );
        let (lo, size) = lat.cells.grid_box().expect("a grid");
        assert_eq!(lo, old.0);
        assert!(
            size[0] > old.1[0] && size[1] == old.1[1],
            "{size:?} from {old:?}"
        );
        for a in 0..lat.len() as u32 {
            assert_eq!(lat.agent_at(lat.pos[a as usize]), Some(a));
        }
    }

    /// A few agents that walk off the grid beside many at rest (fewer than the count that
    /// makes the grid again at once) get a grid over them once their look-ups in the hash
    /// map add up to what the grid costs to make; a few that stay far away (a grid over
    /// them and the others over budget) are tried again less and less often.
    #[test]
    fn a_few_walkers_beside_many_at_rest_get_the_grid_again() {
        let mut b = LatticeBuilder::block(100, 100);
        // Ten walkers above the block, at its east end.
        for i in 0..10 {
            b.push([90 + i, 101, 0], *b"BBBBB", 0, &[]);
        }
        let mut lat = b.finish();
        let walkers: Vec<u32> = (10_000..10_010).collect();
        assert!(walkers.len() < lat.first_regrow());
        let (mut remade, mut out, mut worst, mut first) = (0, 0, 0, None);
        for step in 0..1000 {
            let moves: Vec<(u32, [i32; 3])> = (walkers.iter())
                .map(|&a| (a, [lat.pos[a as usize][0] + 1, 101, 0]))
                .collect();
            lat.relocate(&moves);
            let now = lat.cells.outside();
            if out > 0 && now == 0 {
                remade += 1;
                first = first.or(Some(step));
            }
            (out, worst) = (now, worst.max(now));
        }
        assert!(remade >= 1, "the grid was never made again");
        // Not before their steps outside, weighed as `SLOW_STEP` cells each, reach the cost
        // of the grid and its 10,010 agents (at least 10,010 + 10,000 cells).
        let paid = ((10_010 + 10_000) / SLOW_STEP as usize).div_ceil(walkers.len());
        assert!(
            first.is_some_and(|f| f >= paid),
            "made again at step {first:?}"
        );
        assert!(worst <= 10);
        for a in 0..lat.len() as u32 {
            assert_eq!(lat.agent_at(lat.pos[a as usize]), Some(a));
        }
        // Far away, over the budget: tries back off (each one at least twice as far apart).
        let far: Vec<(u32, [i32; 3])> = (walkers.iter())
            .map(|&a| (a, [lat.pos[a as usize][0] + 5_000_000, 101, 0]))
            .collect();
        lat.relocate(&far);
        let mut tries = Vec::new();
        for step in 0..12_000 {
            let moves: Vec<(u32, [i32; 3])> = (walkers.iter())
                .map(|&a| (a, [lat.pos[a as usize][0] + 1, 101, 0]))
                .collect();
            let before = lat.off_tries;
            lat.relocate(&moves);
            if lat.off_tries > before {
                tries.push(step);
            }
            assert_eq!(lat.cells.outside(), 10);
        }
        assert!(tries.len() >= 2, "tried {tries:?}");
        let gaps: Vec<i32> = tries.windows(2).map(|w| w[1] - w[0]).collect();
        assert!(
            gaps.windows(2).all(|g| g[1] >= 2 * g[0] - 1),
            "tries at {tries:?}"
        );
    }

    /// A block that walks out of its grid is given a grid again where it is, a few times
    /// over a long walk (the room to grow amortises it); agents that jump far away stay in
    /// the tiles (a box over both places is over budget), and every neighbour still
    /// answers as the cells do.
    #[test]
    fn the_grid_follows_a_block_that_walks_away() {
        let b = LatticeBuilder::block(40, 25);
        let mut lat = b.finish();
        let n = lat.len() as u32;
        assert!(lat.cells.is_grid());
        let (mut remade, mut out) = (0, 0);
        for step in 1..=400 {
            let moves: Vec<(u32, [i32; 3])> = (0..n)
                .map(|a| (a, [lat.pos[a as usize][0] + 1, lat.pos[a as usize][1], 0]))
                .collect();
            lat.relocate(&moves);
            // Agents pile up outside the grid until it is made again (then none is).
            let now = lat.cells.outside();
            remade += (out > 0 && now == 0) as u32;
            out = now;
            assert!(now < lat.first_regrow(), "step {step}");
        }
        assert!(
            (3..40).contains(&remade),
            "the grid was made {remade} times"
        );
        for a in 0..n {
            assert_eq!(lat.agent_at(lat.pos[a as usize]), Some(a));
        }
        // Far away: tiles, with the table of neighbours kept as agents move.
        let moves: Vec<(u32, [i32; 3])> = (0..n)
            .map(|a| {
                (
                    a,
                    [
                        lat.pos[a as usize][0] + 5_000_000,
                        lat.pos[a as usize][1],
                        0,
                    ],
                )
            })
            .filter(|m| m.0 % 3 == 0)
            .collect();
        lat.relocate(&moves);
        lat.refresh_neighbours();
        for k in 0..5 {
            let moves: Vec<(u32, [i32; 3])> = (0..n)
                .filter(|a| a % 3 == 0 && a % 2 == k % 2)
                .map(|a| (a, [lat.pos[a as usize][0], lat.pos[a as usize][1] - 1, 0]))
                .collect();
            lat.relocate(&moves);
            for a in 0..n {
                for d in 0..4 {
                    let cell = lat.cell_at(lat.pos[a as usize], Dir::ALL[d].offset());
                    assert_eq!(lat.neighbour_cell(a, d), cell, "agent {a}, direction {d}");
                }
            }
        }
    }

    /// The plan of senders is the same whatever ranges of agents it is made from: agents
    /// in columns with gaps, some far away (one by one), cut into parts of every size.
    #[test]
    fn plan_does_not_depend_on_the_parts() {
        let mut b = LatticeBuilder::new(Dim::Two, None, 0);
        for x in 0..9 {
            for y in 0..40 {
                if (x * 7 + y * 3) % 37 != 0 && !(x == 4 && y > 30) {
                    b.push([x, y, 0], *b"AAAAA", 0, &[]);
                }
            }
        }
        for k in 0..6 {
            b.push([1000 + k % 2, 500 + k / 2, 0], *b"AAAAA", 0, &[]);
        }
        let lat = b.finish();
        let n = lat.len();
        let whole = Pending::new(&lat, &[], vec![Pending::plan_part(&lat, 0, n)]);
        assert!(whole.plan.iter().all(|p| p.is_some()));
        for size in [1, 2, 3, 7, 40, 64, 100, n - 1] {
            let parts = (0..n.div_ceil(size))
                .map(|c| Pending::plan_part(&lat, c * size, ((c + 1) * size).min(n)))
                .collect();
            let cut = Pending::new(&lat, &[], parts);
            assert_eq!(cut.plan, whole.plan, "parts of {size}");
        }
    }
}
