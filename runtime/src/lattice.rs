//! The lattice as structure-of-arrays: one column per agent attribute, indexed by agent id,
//! and a cell-to-agent index that serves dense and sparse, unbounded universes alike.

use crate::cells::CellIndex;
use latticesim_vm::eval::Cell;
use latticesim_vm::model::{Bounds, Config, Dim, Dir};
use std::fmt::Write;

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
    /// Counters, `counters()` per agent.
    pub counters: Vec<i16>,
    /// Numeric messages received, `dirs * slots` per agent, by direction then slot.
    pub inbox_num: Vec<i16>,
    /// Text messages received, `dirs` per agent.
    pub inbox_text: Vec<[u8; 5]>,
    /// Which text messages were received: bit i = from direction i.
    pub inbox_text_has: Vec<u8>,
    cells: CellIndex,
    /// What stands next to each agent, `dirs` per agent ([`NO_AGENT`], [`BLOCKED`] or an
    /// id), valid while `nbr_valid`: positions change only in the actions phase, so the
    /// table is rebuilt at most once a step, and only after a move or swap.
    nbr: Vec<u32>,
    nbr_valid: bool,
}

/// In the neighbour table: a free cell.
const NO_AGENT: u32 = u32::MAX;
/// In the neighbour table: a cell outside the universe.
const BLOCKED: u32 = u32::MAX - 1;

impl Lattice {
    /// Builds the lattice of a checked configuration.
    pub fn new(cfg: &Config) -> Lattice {
        let n = cfg.agents.len();
        let d = cfg.dim;
        let nc = d.counters();
        let mut lat = Lattice {
            dim: d,
            universe: cfg.universe,
            pos: Vec::with_capacity(n),
            state: Vec::with_capacity(n),
            attach: Vec::with_capacity(n),
            counters: vec![0; n * nc],
            inbox_num: vec![0; n * d.dirs() * d.slots()],
            inbox_text: vec![[0; 5]; n * d.dirs()],
            inbox_text_has: vec![0; n],
            nbr: Vec::new(),
            nbr_valid: false,
            cells: CellIndex::new(
                &cfg.agents.iter().map(|a| a.pos).collect::<Vec<_>>(),
                d == Dim::Three,
            ),
        };
        for (i, a) in cfg.agents.iter().enumerate() {
            lat.pos.push(a.pos);
            lat.state.push(a.state);
            lat.attach.push(a.attach);
            for &(c, v) in &a.counters {
                lat.counters[i * nc + c as usize] = v;
            }
        }
        lat
    }

    /// Number of agents.
    pub fn len(&self) -> usize {
        self.pos.len()
    }

    /// True when there are no agents.
    pub fn is_empty(&self) -> bool {
        self.pos.is_empty()
    }

    /// Counters per agent.
    pub fn nc(&self) -> usize {
        self.dim.counters()
    }

    /// A counter of an agent.
    pub fn counter(&self, a: u32, i: u8) -> i16 {
        self.counters[a as usize * self.nc() + i as usize]
    }

    /// Whether a position lies inside the universe.
    pub fn inside(&self, p: [i64; 3]) -> bool {
        let in_i32 = p
            .iter()
            .all(|&c| c >= i32::MIN as i64 && c <= i32::MAX as i64);
        in_i32
            && match self.universe {
                None => true,
                Some(b) => {
                    (0..self.dim.coords()).all(|i| p[i] >= b[i].0 as i64 && p[i] <= b[i].1 as i64)
                }
            }
    }

    /// What is at `from + off`.
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
    #[inline]
    pub fn neighbour_cell(&self, a: u32, d: usize) -> Cell {
        if !self.nbr_valid {
            return self.cell_at(self.pos[a as usize], Dir::ALL[d].offset());
        }
        match self.nbr[a as usize * self.dim.dirs() + d] {
            NO_AGENT => Cell::Empty,
            BLOCKED => Cell::Blocked,
            b => Cell::Agent(b),
        }
    }

    /// Rebuilds the neighbour table if a move or swap made it stale.
    pub fn refresh_neighbours(&mut self) {
        if self.nbr_valid {
            return;
        }
        let nd = self.dim.dirs();
        let mut nbr = std::mem::take(&mut self.nbr);
        nbr.clear();
        nbr.reserve(self.len() * nd);
        for a in 0..self.len() {
            for d in Dir::ALL.iter().take(nd) {
                nbr.push(match self.cell_at(self.pos[a], d.offset()) {
                    Cell::Agent(b) => b,
                    Cell::Empty => NO_AGENT,
                    Cell::Blocked => BLOCKED,
                });
            }
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
        }
    }

    /// The configuration in agents.txt syntax: the universe line if there is one, then the
    /// agents in id order with state, attachments (when any) and non-zero counters. It loads
    /// again to the same lattice.
    pub fn to_agents_text(&self) -> String {
        let mut s = String::with_capacity(self.len() * 24);
        let c = self.dim.coords();
        if let Some(b) = self.universe {
            let v: Vec<String> = b[..c]
                .iter()
                .flat_map(|(lo, hi)| [lo.to_string(), hi.to_string()])
                .collect();
            let _ = writeln!(s, "U{}", v.join(","));
        }
        for a in 0..self.len() {
            let p = self.pos[a];
            let _ = write!(s, "{},{}", p[0], p[1]);
            if c == 3 {
                let _ = write!(s, ",{}", p[2]);
            }
            s.push_str(" S");
            s.push_str(&String::from_utf8_lossy(&self.state[a]));
            if self.attach[a] != 0 {
                s.push_str(" A");
                for d in 0..self.dim.dirs() {
                    s.push(if self.attach[a] & (1 << d) != 0 {
                        '1'
                    } else {
                        '0'
                    });
                }
            }
            for i in 0..self.nc() {
                let v = self.counters[a * self.nc() + i];
                if v != 0 {
                    let _ = write!(s, " C{i:02} {v}");
                }
            }
            s.push('\n');
        }
        s
    }
}
