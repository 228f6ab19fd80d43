//! The lattice as structure-of-arrays: one column per agent attribute, indexed by agent id,
//! and a cell-to-agent index that serves dense and sparse, unbounded universes alike.
//!
//! Counters and message slots are stored only for the ones in use: a counter gets a column
//! when the agents file sets it or the rules read or write it, a numeric slot gets one
//! inbox column per direction when the rules send or read it, and text inboxes exist only
//! when the rules use text messages ([`Lattice::ensure_counter`], [`Lattice::ensure_slot`],
//! [`Lattice::ensure_text`]; the engine asks for what its program uses). A counter without
//! a column reads 0, as does a slot without one.

use crate::bits::{all_bits, no_bits, run_of, sequence_len, set_bits};
use crate::cells::{CellIndex, Grid, EMPTY, NO_SLOT, RIM};
use latticesim_vm::eval::Cell;
use latticesim_vm::model::{AgentInit, Bounds, Columns, Config, Dim, Dir};

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
    /// Counter columns, one value per agent each.
    pub(crate) counters: Vec<Vec<i16>>,
    /// Per slot number (0-based): its index among the slots in use, or [`NO_COL`].
    pub(crate) slot_col: [u8; 8],
    /// Slots in use.
    pub(crate) slots: u8,
    /// Numeric messages received: one column per direction and slot in use, at
    /// `dir * slots + slot_col[slot]`.
    pub(crate) inbox_num: Vec<Vec<i16>>,
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
    /// What stands next to each agent when the cell index is a hash map: one column per
    /// direction ([`NO_AGENT`], [`BLOCKED`] or an id), valid while `nbr_valid`. Positions
    /// change only in the actions phase, so the table is rebuilt at most once a step, and
    /// only after a move or swap. A grid answers as fast without it.
    nbr: Vec<Vec<u32>>,
    nbr_valid: bool,
}

/// The numeric messages sent in the last step, kept where the senders wrote them instead of
/// being copied into every recipient's inbox: agent `a` reads slot `s` from direction `d`
/// as what its neighbour in direction `d` sent in the opposite direction. The engine keeps
/// messages this way only while no agent can move (its program has no move or swap), so
/// the neighbours stay those of the step that sent them. While there are pending messages
/// the inbox columns hold nothing.
#[derive(Debug, Clone, PartialEq, Default)]
pub(crate) struct Pending {
    /// Per direction sent in and slot in use (at `dir * slots + slot_col[slot]`): the value
    /// each agent sent.
    pub(crate) num: Vec<Vec<i16>>,
    /// The same columns: a bit per agent that sent.
    pub(crate) has: Vec<Vec<u64>>,
    /// Per direction (of the recipient), who sends from there, as segments of recipients
    /// `(first, its sender)` in which the sender of `first + i` is `sender + i`
    /// ([`NO_AGENT`] for none): a few segments per row of a grid. `None` where that would
    /// take more than one segment per eight agents (agents are then looked at one by one).
    pub(crate) plan: Vec<Option<Vec<(u32, u32)>>>,
    /// Per column, when known: every agent's bit is set (`full`), or none is (`empty`).
    pub(crate) full: Vec<bool>,
    pub(crate) empty: Vec<bool>,
}

impl Pending {
    /// What sender `f` sent in direction column `col` (its own send to that direction,
    /// else its send to all directions in column `all`, else 0).
    #[inline]
    fn value(&self, col: usize, all: Option<usize>, f: usize) -> i16 {
        let bit = |c: usize| self.has[c][f >> 6] & (1 << (f & 63)) != 0;
        if bit(col) {
            self.num[col][f]
        } else if let Some(a) = all.filter(|&a| bit(a)) {
            self.num[a][f]
        } else {
            0
        }
    }

    /// A bit per agent that has a neighbour in direction index `d`.
    pub(crate) fn has_sender(&self, lat: &Lattice, d: usize) -> Vec<u64> {
        let n = lat.len();
        let mut bits = vec![0u64; n.div_ceil(64)];
        match &self.plan[d] {
            Some(segs) => {
                for (k, &(start, sender)) in segs.iter().enumerate() {
                    if sender != NO_AGENT {
                        let end = segs.get(k + 1).map_or(n, |s| s.0 as usize);
                        set_bits(&mut bits, start as usize..end);
                    }
                }
            }
            None => {
                for a in 0..n {
                    if matches!(lat.neighbour_cell(a as u32, d), Cell::Agent(_)) {
                        bits[a >> 6] |= 1 << (a & 63);
                    }
                }
            }
        }
        bits
    }

    /// Empty outboxes shaped as `like` (a column only where it has one) for the agents of
    /// `lat`, with the plan of who sends to whom (positions must not change while it is
    /// used), made from the [`Pending::plan_part`]s of consecutive ranges of agents that
    /// cover them all, in order.
    pub(crate) fn new(lat: &Lattice, like: &[Vec<i16>], parts: Vec<PlanPart>) -> Pending {
        let n = lat.len();
        let nd = lat.dim.dirs();
        let mut plan: Vec<Option<Vec<(u32, u32)>>> = vec![Some(Vec::new()); nd];
        let mut next = [NO_AGENT; 6];
        for part in parts {
            for (d, segs) in part.segs.into_iter().enumerate().take(nd) {
                let (Some(all), Some(segs)) = (&mut plan[d], segs) else {
                    plan[d] = None;
                    continue;
                };
                // A part's first segment goes on from the last part's when its sender
                // is the one predicted.
                let skip = segs
                    .first()
                    .is_some_and(|s| !all.is_empty() && s.1 == next[d]);
                all.extend(&segs[skip as usize..]);
                if all.len() > n / 8 + 1 {
                    plan[d] = None;
                }
            }
            next = part.next;
        }
        Pending {
            num: like.iter().map(|c| vec![0; c.len()]).collect(),
            has: vec![vec![0; n.div_ceil(64)]; like.len()],
            plan,
            full: Vec::new(),
            empty: Vec::new(),
        }
    }

    /// The plan of senders for agents `lo..hi` alone: one pass over them for every
    /// direction; a direction whose segments grow past one per eight agents (of all) is
    /// given up.
    pub(crate) fn plan_part(lat: &Lattice, lo: usize, hi: usize) -> PlanPart {
        let n = lat.len();
        let nd = lat.dim.dirs();
        let mut plan: Vec<Option<Vec<(u32, u32)>>> = vec![Some(Vec::new()); 6];
        let mut next = [NO_AGENT; 6]; // the sender each current segment predicts
                                      // Agents `a..a + m` whose senders in direction `d` are `f..f + m` (or none).
        let add = |plan: &mut Vec<Option<Vec<(u32, u32)>>>,
                   next: &mut [u32; 6],
                   (d, a): (usize, u32),
                   (f, m): (u32, usize)| {
            if let Some(segs) = &mut plan[d] {
                if segs.is_empty() || f != next[d] {
                    segs.push((a, f));
                    if segs.len() > n / 8 + 1 {
                        plan[d] = None;
                    }
                }
            }
            next[d] = if f == NO_AGENT {
                NO_AGENT
            } else {
                f.wrapping_add(m as u32)
            };
        };
        let mut nb = [NO_AGENT; 6];
        let mut a = lo;
        while a < hi {
            // Runs of agents on consecutive grid cells: a run whose neighbours go on the
            // current segment is passed over at once.
            if let Some((r, runs)) = lat.neighbour_run(a, hi - a) {
                for (d, from) in runs.iter().enumerate().take(nd) {
                    // Per stretch of consecutive senders (or of none, as at the grid's
                    // edge): what one agent at a time would find.
                    let mut j = 0;
                    while j < from.len() {
                        let f = from[j];
                        let m = if f == NO_AGENT {
                            run_of(&from[j..], NO_AGENT)
                        } else {
                            sequence_len(&from[j..], f)
                        };
                        add(&mut plan, &mut next, (d, (a + j) as u32), (f, m));
                        j += m;
                    }
                }
                a += r;
            } else {
                lat.neighbours(a as u32, &mut nb);
                for (d, &f) in nb.iter().enumerate().take(nd) {
                    add(&mut plan, &mut next, (d, a as u32), (f, 1));
                }
                a += 1;
            }
        }
        PlanPart { segs: plan, next }
    }
}

/// The plan of senders of a range of agents ([`Pending::plan_part`]): per direction its
/// segments (`None`: given up), and the sender its last segment predicts for the agent
/// after the range.
pub(crate) struct PlanPart {
    segs: Vec<Option<Vec<(u32, u32)>>>,
    next: [u32; 6],
}

/// Why agents read as columns do not make a lattice as they are ([`Lattice::from_columns`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Defect {
    /// Two agents (ids in file order) on one cell.
    SharedCell {
        /// The earlier agent.
        first: u32,
        /// The later one.
        second: u32,
        /// The cell.
        pos: [i32; 3],
    },
    /// A bond towards a direction where no agent declares it back (or none stands).
    OneSidedBond {
        /// The agent that declares it.
        agent: u32,
        /// Its direction.
        dir: Dir,
    },
}

/// What a step of some program can change in a lattice ([`crate::Engine::writes`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Writes {
    /// Positions (moves, swaps); bonds with them.
    pub positions: bool,
    /// States.
    pub states: bool,
    /// Bonds.
    pub bonds: bool,
    /// Bit i: counter i.
    pub counters: u64,
    /// Messages are sent (so the inboxes change).
    pub messages: bool,
}

/// The parts of a lattice a step can change, as they were ([`Lattice::undo_point`]).
#[derive(Debug, Clone)]
pub struct Undo {
    pos: Option<Vec<[i32; 3]>>,
    state: Option<Vec<[u8; 5]>>,
    attach: Option<Vec<u8>>,
    counters: Vec<(u8, Vec<i16>)>,
    #[allow(clippy::type_complexity)]
    messages: Option<(Vec<Vec<i16>>, Vec<[u8; 5]>, Vec<u8>, Option<Pending>)>,
}

impl Lattice {
    /// A copy of only what a step with these writes can change, to put back with
    /// [`Lattice::undo`].
    pub fn undo_point(&self, w: &Writes) -> Undo {
        Undo {
            pos: w.positions.then(|| self.pos.clone()),
            state: w.states.then(|| self.state.clone()),
            attach: (w.bonds || w.positions).then(|| self.attach.clone()),
            counters: (0..self.nc() as u8)
                .filter(|&i| w.counters & (1 << i) != 0 && self.counter_col[i as usize] != NO_COL)
                .map(|i| {
                    (
                        i,
                        self.counters[self.counter_col[i as usize] as usize].clone(),
                    )
                })
                .collect(),
            messages: w.messages.then(|| {
                (
                    self.inbox_num.clone(),
                    self.inbox_text.clone(),
                    self.inbox_text_has.clone(),
                    self.pending.clone(),
                )
            }),
        }
    }

    /// Puts back what [`Lattice::undo_point`] kept (the columns a step made since are
    /// dropped; the cell index is made again when positions come back).
    pub fn undo(&mut self, u: Undo) {
        if let Some(p) = u.pos {
            self.pos = p;
            self.cells = CellIndex::new(&self.pos, self.dim == Dim::Three);
            self.code = self.pos.iter().map(|&p| self.cells.code(p)).collect();
            self.nbr_valid = false;
        }
        if let Some(s) = u.state {
            self.state = s;
        }
        if let Some(a) = u.attach {
            self.attach = a;
        }
        for (i, col) in u.counters {
            self.counters[self.counter_col[i as usize] as usize] = col;
        }
        if let Some((num, text, has, pending)) = u.messages {
            (
                self.inbox_num,
                self.inbox_text,
                self.inbox_text_has,
                self.pending,
            ) = (num, text, has, pending);
        }
    }
}

/// In the neighbour table and in [`Lattice::neighbours`]: a free cell.
pub const NO_AGENT: u32 = crate::cells::EMPTY;
/// In the neighbour table: a cell outside the universe.
const BLOCKED: u32 = u32::MAX - 1;

/// Builds a lattice one agent at a time, without holding a whole [`Config`] in memory.
pub struct LatticeBuilder {
    lat: Lattice,
}

impl LatticeBuilder {
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
                counters: Vec::new(),
                slot_col: [NO_COL; 8],
                slots: 0,
                inbox_num: Vec::new(),
                inbox_text: Vec::new(),
                inbox_text_has: Vec::new(),
                pending: None,
                cells: CellIndex::new(&[], false),
                code: Vec::new(),
                nbr: Vec::new(),
                nbr_valid: false,
            },
        }
    }

    /// Adds an agent (the caller guarantees a free cell and valid counters).
    pub fn push(&mut self, pos: [i32; 3], state: [u8; 5], attach: u8, counters: &[(u8, i16)]) {
        let lat = &mut self.lat;
        let a = lat.pos.len();
        lat.pos.push(pos);
        lat.state.push(state);
        lat.attach.push(attach);
        for &(c, v) in counters {
            if v != 0 {
                let col = lat.ensure_counter(c);
                let column = &mut lat.counters[col];
                column.resize(a + 1, 0);
                column[a] = v;
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
            col.resize(n, 0);
            col.shrink_to_fit();
        }
        let lat = &mut self.lat;
        let (cells, one_each, code) = CellIndex::new_coded(&lat.pos, lat.dim == Dim::Three);
        (lat.cells, lat.code) = (cells, code);
        (self.lat, one_each)
    }
}

impl Lattice {
    /// Builds the lattice of agents read as columns (the fast path of agents files),
    /// without copying them; `Err` when two agents stand on one cell or a bond is not
    /// declared by both agents (the checker then reads the file and says so).
    pub fn from_columns(
        dim: Dim,
        universe: Option<Bounds>,
        cols: Columns,
    ) -> Result<Lattice, Defect> {
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
        for (i, col) in counters.into_iter().enumerate() {
            if !col.is_empty() {
                debug_assert_eq!(col.len(), n);
                lat.counter_col[i] = lat.counters.len() as u8;
                lat.counters.push(col);
            }
        }
        let (lat, one_each) = b.finish_checked();
        if !one_each {
            // A later agent on an earlier one's cell took its place in the index.
            let first = (0..n)
                .find(|&a| lat.cells.get(lat.pos[a]) != Some(a as u32))
                .expect("an agent lost its cell");
            let pos = lat.pos[first];
            let second = lat.cells.get(pos).expect("the cell is taken");
            return Err(Defect::SharedCell {
                first: first as u32,
                second,
                pos,
            });
        }
        for a in (0..n).filter(|&a| lat.attach[a] != 0) {
            for d in Dir::ALL.iter().take(dim.dirs()) {
                let declared = lat.attach[a] & (1 << d.index()) != 0;
                let back = lat
                    .neighbour(a as u32, *d)
                    .is_some_and(|b| lat.attach[b as usize] & (1 << d.opposite().index()) != 0);
                if declared && !back {
                    return Err(Defect::OneSidedBond {
                        agent: a as u32,
                        dir: *d,
                    });
                }
            }
        }
        Ok(lat)
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

    /// The column of counter `i`, creating it (all zero) if needed.
    pub fn ensure_counter(&mut self, i: u8) -> usize {
        if self.counter_col[i as usize] == NO_COL {
            self.counter_col[i as usize] = self.counters.len() as u8;
            self.counters.push(vec![0; self.len()]);
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
                    vec![0; n]
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
    pub fn counter(&self, a: u32, i: u8) -> i16 {
        match self.counter_col[i as usize] {
            NO_COL => 0,
            c => self.counters[c as usize][a as usize],
        }
    }

    /// Sets counter `i` of agent `a`.
    pub fn set_counter(&mut self, a: u32, i: u8, v: i16) {
        let c = self.ensure_counter(i);
        self.counters[c][a as usize] = v;
    }

    /// The numeric message agent `a` received from direction index `dir` in slot `slot`
    /// (0-based), 0 when none.
    #[inline]
    pub fn inbox(&self, a: u32, dir: u8, slot: u8) -> i16 {
        match (self.slot_col[slot as usize], &self.pending) {
            (NO_COL, _) => 0,
            (s, None) => {
                self.inbox_num[dir as usize * self.slots as usize + s as usize][a as usize]
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

    /// What agents `first..first + out.len()` received from direction index `dir` in slot
    /// `slot` (in use): a slice of the inbox column, of the senders' pending messages when
    /// they are consecutive agents that all sent, or else `out` filled one by one. `hint`
    /// remembers, per direction, the segment of the plan where the last call ended (calls
    /// for increasing `first` then find theirs at once).
    #[inline]
    pub(crate) fn inbox_run<'a>(
        &'a self,
        first: usize,
        (dir, slot): (u8, u8),
        out: &'a mut [i16],
        hint: &mut [usize; 6],
    ) -> &'a [i16] {
        let m = out.len();
        let s = self.slot_col[slot as usize] as usize;
        let Some(p) = &self.pending else {
            return &self.inbox_num[dir as usize * self.slots as usize + s][first..first + m];
        };
        let od = Dir::ALL[dir as usize].opposite().index();
        let col = od * self.slots as usize + s;
        let (num, has) = (&p.num[col], &p.has[col]);
        let all = self.all_col(p, s).map(|c| (c, &p.num[c], &p.has[c]));
        let Some(segs) = &p.plan[dir as usize] else {
            for (j, v) in out.iter_mut().enumerate() {
                *v = self.inbox((first + j) as u32, dir, slot);
            }
            return out;
        };
        // Segments of consecutive senders are copied whole when they all sent (or lent
        // when one covers every recipient asked for).
        let within = |k: usize| {
            segs.get(k).is_some_and(|s| s.0 as usize <= first)
                && segs.get(k + 1).is_none_or(|s| s.0 as usize > first)
        };
        let h = hint[dir as usize];
        let mut k = if within(h) {
            h
        } else if within(h + 1) {
            h + 1
        } else {
            segs.partition_point(|s| s.0 as usize <= first) - 1
        };
        let mut j = 0;
        while j < m {
            let (start, sender) = segs[k];
            let end = segs.get(k + 1).map_or(self.len(), |s| s.0 as usize);
            let a = first + j;
            let len = (end - a).min(m - j);
            let dst = &mut out[j..j + len];
            if sender == NO_AGENT {
                dst.fill(0);
            } else {
                let f0 = sender as usize + (a - start as usize);
                let seg = f0..f0 + len;
                // All sent to every direction (and not to this one after), or all to this one
                // (known for whole columns, else tested on the senders' bits).
                let full = |c: usize, bits: &[u64]| {
                    p.full.get(c).is_some_and(|&f| f) || all_bits(bits, seg.clone())
                };
                let empty = |c: usize, bits: &[u64]| {
                    p.empty.get(c).is_some_and(|&e| e) || no_bits(bits, seg.clone())
                };
                let whole = match all {
                    Some((ac, an, ah)) if full(ac, ah) && empty(col, has) => Some(an),
                    _ => full(col, has).then_some(num),
                };
                match whole {
                    Some(src) if len == m => return &src[seg],
                    Some(src) => dst.copy_from_slice(&src[seg]),
                    None => {
                        let all_col = self.all_col(p, s);
                        for (v, f) in dst.iter_mut().zip(seg) {
                            *v = p.value(col, all_col, f);
                        }
                    }
                }
            }
            j += len;
            hint[dir as usize] = k;
            k += 1;
        }
        out
    }

    /// The column of pending sends to all directions in slot column `s`, if there is one.
    #[inline]
    fn all_col(&self, p: &Pending, s: usize) -> Option<usize> {
        let cols = self.dim.dirs() * self.slots as usize;
        (p.num.len() > cols).then_some(cols + s)
    }

    /// Copies pending messages into the inbox columns (which are made again), so that the
    /// lattice can be run by a program whose agents move.
    pub(crate) fn settle_inbox(&mut self) {
        if self.pending.is_none() {
            return;
        }
        let (n, nd, ns) = (self.len(), self.dim.dirs(), self.slots as usize);
        let slots: Vec<(u8, u8)> = (0..8u8)
            .filter(|&s| self.slot_col[s as usize] != NO_COL)
            .map(|s| (s, self.slot_col[s as usize]))
            .collect();
        let mut cols = vec![vec![0i16; n]; nd * ns];
        for d in 0..nd {
            for &(s, c) in &slots {
                let col = &mut cols[d * ns + c as usize];
                for (a, v) in col.iter_mut().enumerate() {
                    *v = self.inbox(a as u32, d as u8, s);
                }
            }
        }
        self.inbox_num = cols;
        self.pending = None;
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
        let cols: usize = self
            .counters
            .iter()
            .map(|c| c.capacity() * 2)
            .sum::<usize>()
            + self
                .inbox_num
                .iter()
                .map(|c| c.capacity() * 2)
                .sum::<usize>()
            + self.pending.as_ref().map_or(0, |p| {
                p.num.iter().map(|c| c.capacity() * 2).sum::<usize>()
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

    /// The agent at a cell, if any.
    pub fn agent_at(&self, p: [i32; 3]) -> Option<u32> {
        self.cells.get(p)
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
        if s < RIM && self.universe.is_none() {
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
        if !self.nbr_valid && s < RIM && self.universe.is_none() {
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
            Some(g) if !self.nbr_valid && self.universe.is_none() => {
                let step = g.step(d);
                // Away from the grid's rim (the common case): one bit read per agent.
                if codes.iter().fold(true, |ok, &s| ok & (s < RIM)) {
                    for (t, &s) in out.iter_mut().zip(codes) {
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
        if s < RIM && self.universe.is_none() {
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

    /// For agents from `first` (at most `len`) standing on consecutive cells of a grid with
    /// no universe walls: how many do, and per direction the ids next to them
    /// (`u32::MAX` for none), read straight from the grid. `None` when the grid cannot
    /// answer for a run of them at once.
    #[inline]
    pub fn neighbour_run(&self, first: usize, len: usize) -> Option<(usize, [&[u32]; 6])> {
        if self.nbr_valid || self.universe.is_some() {
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
    /// index is a hash map; a grid answers directly).
    pub fn refresh_neighbours(&mut self) {
        if self.nbr_valid || self.cells.is_grid() {
            return;
        }
        let nd = self.dim.dirs();
        let mut nbr = std::mem::take(&mut self.nbr);
        nbr.resize(nd, Vec::new());
        for (d, col) in nbr.iter_mut().enumerate() {
            col.clear();
            col.reserve(self.len());
            let off = Dir::ALL[d].offset();
            col.extend(self.pos.iter().map(|&p| match self.cell_at(p, off) {
                Cell::Agent(b) => b,
                Cell::Empty => NO_AGENT,
                Cell::Blocked => BLOCKED,
            }));
        }
        self.nbr = nbr;
        self.nbr_valid = true;
    }

    /// Moves agents to new positions all at once (the caller guarantees no two share a cell).
    pub fn relocate(&mut self, moves: &[(u32, [i32; 3])]) {
        if !moves.is_empty() {
            self.nbr_valid = false;
        }
        for &(a, _) in moves {
            let old = self.pos[a as usize];
            self.cells.remove(old, a);
        }
        for &(a, p) in moves {
            self.pos[a as usize] = p;
            self.cells.insert(p, a);
            self.code[a as usize] = self.cells.code(p);
        }
    }

    /// Moves agents to their targets in the grid, given as slot codes
    /// ([`CellIndex::code`], none [`NO_SLOT`]), which no two share and which are empty or
    /// left by movers: the same as [`Lattice::relocate`]. `targeted` tells whether a slot
    /// is one of the targets: a mover's old cell is emptied only when it is not, without
    /// reading the grid.
    pub(crate) fn relocate_to_slots(
        &mut self,
        moves: &[(u32, [i32; 3])],
        codes: &[u32],
        targeted: impl Fn(usize) -> bool,
    ) {
        if !moves.is_empty() {
            self.nbr_valid = false;
        }
        // Movers that come from outside the grid leave the hash map after the loop.
        let mut outside = Vec::new();
        let (pos, code) = (&mut self.pos, &mut self.code);
        if let Some(g) = self.cells.grid_mut() {
            let mut g = g.cells_mut();
            for (&(a, p), &c) in moves.iter().zip(codes) {
                let old = std::mem::replace(&mut pos[a as usize], p);
                let was = std::mem::replace(&mut code[a as usize], c);
                let o = (was & !RIM) as usize;
                if was == NO_SLOT {
                    outside.push((old, a));
                } else if !targeted(o) {
                    g.vacate(o);
                }
                g.occupy((c & !RIM) as usize, a);
            }
        }
        for (old, a) in outside {
            self.cells.remove(old, a);
        }
    }

    /// The configuration in agents.txt syntax: the universe line if there is one, then the
    /// agents in id order with state, attachments (when any) and non-zero counters. It loads
    /// again to the same lattice.
    pub fn to_agents_text(&self) -> String {
        let mut out = Vec::with_capacity(self.len() * 24);
        self.write_agents_text(&mut out, 1)
            .expect("writing to memory does not fail");
        String::from_utf8(out).expect("states are ASCII")
    }

    /// Writes [`Lattice::to_agents_text`] into `w` as it is made, a block of agents at a
    /// time. With `threads` above one, a second thread formats the next blocks while this
    /// one writes (formatting itself on several threads was slower on two cores).
    pub fn write_agents_text(
        &self,
        w: &mut impl std::io::Write,
        threads: usize,
    ) -> std::io::Result<()> {
        /// Agents formatted at a time.
        const BLOCK: usize = 1 << 15;
        let c = self.dim.coords();
        if let Some(b) = self.universe {
            let v: Vec<String> = b[..c]
                .iter()
                .flat_map(|(lo, hi)| [lo.to_string(), hi.to_string()])
                .collect();
            writeln!(w, "U{}", v.join(","))?;
        }
        // Counter columns in number order, so that a line lists its counters so.
        let cols: Vec<(u8, &[i16])> = (0..self.nc() as u8)
            .filter(|&i| self.counter_col[i as usize] != NO_COL)
            .map(|i| (i, &self.counters[self.counter_col[i as usize] as usize][..]))
            .collect();
        let n = self.len();
        let room = BLOCK * self.longest_line(&cols);
        if threads < 2 || n <= BLOCK {
            let mut buf = vec![0u8; room.min(n * self.longest_line(&cols))];
            for a in (0..n).step_by(BLOCK) {
                let len = self.format_agents(a..(a + BLOCK).min(n), &cols, &mut buf);
                w.write_all(&buf[..len])?;
            }
            return Ok(());
        }
        use std::sync::mpsc::sync_channel;
        let (full_tx, full_rx) = sync_channel::<(Vec<u8>, usize)>(3);
        let (empty_tx, empty_rx) = sync_channel::<Vec<u8>>(4);
        for _ in 0..4 {
            let _ = empty_tx.send(vec![0u8; room]);
        }
        std::thread::scope(|s| {
            let cols = &cols;
            s.spawn(move || {
                for a in (0..n).step_by(BLOCK) {
                    // The writer gave up (an error): stop.
                    let Ok(mut buf) = empty_rx.recv() else {
                        return;
                    };
                    let len = self.format_agents(a..(a + BLOCK).min(n), cols, &mut buf);
                    if full_tx.send((buf, len)).is_err() {
                        return;
                    }
                }
            });
            for (buf, len) in full_rx.iter() {
                w.write_all(&buf[..len])?;
                let _ = empty_tx.send(buf);
            }
            Ok(())
        })
    }

    /// The longest line [`Lattice::format_agents`] can make with these counter columns.
    fn longest_line(&self, cols: &[(u8, &[i16])]) -> usize {
        3 * 12 + 7 + 8 + cols.len() * 11 + 1
    }

    /// The lines of agents `range` (see [`Lattice::to_agents_text`]), written into `line`
    /// (room for the longest line per agent): their length. Each line is written in place
    /// (a copy of a line would be a call to `memcpy`).
    fn format_agents(
        &self,
        range: std::ops::Range<usize>,
        cols: &[(u8, &[i16])],
        line: &mut [u8],
    ) -> usize {
        let (three, dirs) = (self.dim == Dim::Three, self.dim.dirs());
        let mut at = 0;
        for a in range {
            let p = self.pos[a];
            at = put_int(line, at, p[0] as i64);
            line[at] = b',';
            at = put_int(line, at + 1, p[1] as i64);
            if three {
                line[at] = b',';
                at = put_int(line, at + 1, p[2] as i64);
            }
            line[at] = b' ';
            line[at + 1] = b'S';
            let st = self.state[a];
            line[at + 2] = st[0];
            line[at + 3] = st[1];
            line[at + 4] = st[2];
            line[at + 5] = st[3];
            line[at + 6] = st[4];
            at += 7;
            let bonds = self.attach[a];
            if bonds != 0 {
                line[at] = b' ';
                line[at + 1] = b'A';
                at += 2;
                for d in 0..dirs {
                    line[at] = b'0' + (bonds >> d & 1);
                    at += 1;
                }
            }
            for &(i, col) in cols {
                let v = col[a];
                if v != 0 {
                    line[at] = b' ';
                    line[at + 1] = b'C';
                    line[at + 2] = b'0' + i / 10;
                    line[at + 3] = b'0' + i % 10;
                    line[at + 4] = b' ';
                    at = put_int(line, at + 5, v as i64);
                }
            }
            line[at] = b'\n';
            at += 1;
        }
        at
    }
}

/// Writes the decimal digits of `v` into `buf` at `at`: where they end. (Digit by digit
/// from the end: a copy of a few bytes would be a call to `memcpy`.)
#[inline]
fn put_int(buf: &mut [u8], mut at: usize, v: i64) -> usize {
    if v < 0 {
        buf[at] = b'-';
        at += 1;
    }
    let mut u = v.unsigned_abs();
    let end = at + u.checked_ilog10().map_or(1, |l| l as usize + 1);
    let mut i = end;
    loop {
        i -= 1;
        buf[i] = b'0' + (u % 10) as u8;
        u /= 10;
        if u == 0 {
            break;
        }
    }
    end
}

#[cfg(test)]
mod tests {
    use super::*;

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
