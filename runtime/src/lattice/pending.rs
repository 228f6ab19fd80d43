//! Messages left where their senders wrote them (`Pending`): read through the plan of
//! senders while no agent can move, and settled into inboxes when one may.

use super::*;

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
    pub(crate) num: Vec<Column>,
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
    pub(super) fn value(&self, col: usize, all: Option<usize>, f: usize) -> i32 {
        let bit = |c: usize| self.has[c][f >> 6] & (1 << (f & 63)) != 0;
        if bit(col) {
            self.num[col].get(f)
        } else if let Some(a) = all.filter(|&a| bit(a)) {
            self.num[a].get(f)
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
    pub(crate) fn new(lat: &Lattice, like: &[Column], parts: Vec<PlanPart>) -> Pending {
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
            num: like
                .iter()
                .map(|c| Column::zeros(c.width(), c.len()))
                .collect(),
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

impl Lattice {
    /// What agents `first..first + out.len()` received from direction index `dir` in slot
    /// `slot` (in use): a slice of the inbox column, of the senders' pending messages when
    /// they are consecutive agents that all sent, or else `out` filled one by one. `hint`
    /// remembers, per direction, the segment of the plan where the last call ended (calls
    /// for increasing `first` then find theirs at once). `V` is the lattice's width.
    #[inline]
    pub(crate) fn inbox_run<'a, V: Value>(
        &'a self,
        first: usize,
        (dir, slot): (u8, u8),
        out: &'a mut [V],
        hint: &mut [usize; 6],
    ) -> &'a [V] {
        let m = out.len();
        let s = self.slot_col[slot as usize] as usize;
        let Some(p) = &self.pending else {
            return &V::of_column(&self.inbox_num[dir as usize * self.slots as usize + s])
                [first..first + m];
        };
        let od = Dir::ALL[dir as usize].opposite().index();
        let col = od * self.slots as usize + s;
        let (num, has) = (V::of_column(&p.num[col]), &p.has[col]);
        let all = self
            .all_col(p, s)
            .map(|c| (c, V::of_column(&p.num[c]), &p.has[c]));
        let Some(segs) = &p.plan[dir as usize] else {
            for (j, v) in out.iter_mut().enumerate() {
                *v = V::of(self.inbox((first + j) as u32, dir, slot));
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
                dst.fill(V::default());
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
                            *v = V::of(p.value(col, all_col, f));
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
    pub(super) fn all_col(&self, p: &Pending, s: usize) -> Option<usize> {
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
        let mut cols = vec![Column::zeros(self.width, n); nd * ns];
        for d in 0..nd {
            for &(s, c) in &slots {
                let col = &mut cols[d * ns + c as usize];
                for a in 0..n {
                    col.set(a, self.inbox(a as u32, d as u8, s));
                }
            }
        }
        self.inbox_num = cols;
        self.pending = None;
    }
}
