//! What a step can change, kept to be put back: the undo point of `--strict`.

use super::*;

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
    counters: Vec<(u8, Column)>,
    #[allow(clippy::type_complexity)]
    messages: Option<(Vec<Column>, Vec<[u8; 5]>, Vec<u8>, Option<Pending>)>,
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
            let (cells, _, code) = CellIndex::new_coded(&self.pos, self.shape());
            self.take_index((cells, code));
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
