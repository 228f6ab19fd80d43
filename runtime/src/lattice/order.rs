//! Agents kept in space order. A step visits agents in the order of their ids, and each
//! agent's move and each look at a neighbour reaches the cell index where the agent
//! stands: when the agents file lists agents in no spatial order (as `gen cloud` writes
//! them), every one of those lands somewhere else in memory, and two threads write the same
//! lines of the grid. So the engine may keep its agents in the order of their positions (x,
//! then y, then z: the grid's own layout) and the ids of the file beside them as labels:
//! what users see names agents by their file ids (records, the agents file written,
//! checkpoints), and the results do not depend on the order (docs/running.md, "Agents
//! listed in space order").

use super::Lattice;
use crate::cells::{CellIndex, NO_SLOT};
use latticesim_vm::column::gather;

/// Agents a lattice must have before [`Lattice::listed_scattered`] says yes: below, the
/// cells of all agents stay in the processor's caches whatever their order.
const SPACE_ORDER_FROM: usize = 1 << 16;

/// The file ids of a lattice kept in space order.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Labels {
    /// Per agent of the lattice, its id in the file.
    id: Box<[u32]>,
    /// Per id in the file, the agent of the lattice.
    agent: Box<[u32]>,
}

impl Labels {
    /// Per id in the file, the agent of the lattice.
    pub(crate) fn agents(&self) -> &[u32] {
        &self.agent
    }
}

impl Lattice {
    /// The id in the agents file of agent `a` (`a` itself unless the agents are kept in
    /// space order).
    #[inline]
    pub fn label(&self, a: u32) -> u32 {
        self.labels.as_ref().map_or(a, |l| l.id[a as usize])
    }

    /// The agent whose id in the agents file is `id` (the inverse of [`Lattice::label`]).
    #[inline]
    pub fn agent_of(&self, id: u32) -> u32 {
        self.labels.as_ref().map_or(id, |l| l.agent[id as usize])
    }

    /// Agents `agents` as a record's sentence names them: their ids in the agents file,
    /// ascending, joined by `, `.
    pub(crate) fn ids_text(&self, agents: &[u32]) -> String {
        let mut s = String::with_capacity(agents.len() * 8);
        self.push_ids(&mut s, agents);
        s
    }

    /// [`Lattice::ids_text`] appended to `s` (a record's few agents sorted on the stack:
    /// a jam makes thousands of records a step).
    pub(crate) fn push_ids(&self, s: &mut String, agents: &[u32]) {
        use std::fmt::Write;
        let (mut few, mut many) = ([0u32; 8], Vec::new());
        let ids: &mut [u32] = match agents.len() {
            n if n <= few.len() => &mut few[..n],
            n => {
                many.resize(n, 0);
                &mut many
            }
        };
        for (id, &a) in ids.iter_mut().zip(agents) {
            *id = self.label(a);
        }
        ids.sort_unstable();
        for (i, id) in ids.iter().enumerate() {
            let sep = if i > 0 { ", " } else { "" };
            write!(s, "{sep}{id}").expect("writing to a string");
        }
    }

    /// Whether the agents are kept in space order ([`Lattice::keep_in_space_order`]).
    pub fn in_space_order(&self) -> bool {
        self.labels.is_some()
    }

    /// Whether keeping the agents in space order pays: at least [`SPACE_ORDER_FROM`]
    /// agents, on a grid, listed scattered over it (judged on 16 runs of 65 agents spread
    /// over the list, as the moves judge whether to ask for cells ahead).
    pub fn listed_scattered(&self) -> bool {
        let n = self.len();
        if n < SPACE_ORDER_FROM || self.cells.grid().is_none() || self.labels.is_some() {
            return false;
        }
        let votes = (0..16)
            .filter(|k| {
                let lo = k * (n - 65) / 15;
                crate::cells::scattered(self.code[lo..lo + 65].iter().copied())
            })
            .count();
        votes > 8
    }

    /// Renumbers the agents in the order of their positions (x, then y, then z), keeping
    /// each one's id in the file as its label. The lattice must be as loaded: no messages
    /// pending ([`Lattice::settle_inbox`]), not in space order already.
    pub(crate) fn keep_in_space_order(&mut self) {
        assert!(self.pending.is_none() && self.labels.is_none());
        let n = self.len();
        let pos = &self.pos;
        // The grid's agents in the order of its cells (one pass over them), then the
        // agents off the grid sorted by position (positions are distinct: the order is
        // total); without a grid, all sorted.
        let mut id: Vec<u32> = Vec::with_capacity(n);
        let mut off: Vec<u32> = match self.cells.grid() {
            Some(g) => {
                id.extend(g.agents_in_order());
                (0..n as u32)
                    .filter(|&a| self.code[a as usize] == NO_SLOT)
                    .collect()
            }
            None => (0..n as u32).collect(),
        };
        off.sort_unstable_by_key(|&a| pos[a as usize]);
        id.append(&mut off);
        assert_eq!(id.len(), n, "every agent once");
        self.pos = gather(&self.pos, &id);
        self.state = gather(&self.state, &id);
        self.attach = gather(&self.attach, &id);
        for c in self.counters.iter_mut().chain(&mut self.inbox_num) {
            if c.len() == n {
                *c = c.gather(&id);
            }
        }
        if self.inbox_text_has.len() == n {
            self.inbox_text_has = gather(&self.inbox_text_has, &id);
            let dirs = self.dim.dirs();
            let old = std::mem::take(&mut self.inbox_text);
            self.inbox_text = (id.iter())
                .flat_map(|&a| {
                    old[a as usize * dirs..(a as usize + 1) * dirs]
                        .iter()
                        .copied()
                })
                .collect();
        }
        let (cells, one_each, code) = CellIndex::new_coded(&self.pos, self.shape());
        assert!(one_each, "one agent a cell");
        self.take_index((cells, code));
        let mut agent = vec![0u32; n];
        for (k, &a) in id.iter().enumerate() {
            agent[a as usize] = k as u32;
        }
        self.labels = Some(Labels {
            id: id.into_boxed_slice(),
            agent: agent.into_boxed_slice(),
        });
    }
}
