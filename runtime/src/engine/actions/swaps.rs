//! Step 6 of the actions: swaps ([`Act::swaps`]), in chunks of requests on the pool when
//! there are many. Each swap is found at the first request that makes it (two agents
//! asking to swap with each other make one, found at the lesser's request), and its
//! agents marked (atomics); a swap sharing an agent with another is cancelled; the swaps of
//! agents without bonds are made per chunk (each changes its own two cells and agents
//! only), then those of bonded agents one at a time, in the order of the swaps (each drops
//! the bonds of its agents' neighbours). What is recorded, counted or listed is joined
//! in the requests' order, so a step is the same for any split.
//!
//! The two kinds of swaps commute: bonds are symmetric, so a bonded swap changes the bonds
//! and cells of bonded agents only, and a swap without bonds moves agents between two
//! cells of agents without bonds.

use super::alone::Twice;
use super::*;
use crate::lattice::{Bits, Placed};

/// A swap: the lesser agent, the other, the direction from the first to the second, and
/// whether it is cancelled because the agent asked is in no swap.
type Pair = (u32, u32, Dir, bool);

/// One chunk of the requests and of the swaps found there.
#[derive(Default)]
struct SwapPart {
    pairs: Vec<Pair>,
    notes: Notes,
    /// The swaps of agents without bonds: their moves (two per swap), the targets' slot
    /// codes, and the cells left (for the activity).
    moves: Vec<(u32, [i32; 3])>,
    codes: Vec<u32>,
    left: Vec<Moved>,
    /// The swaps of bonded agents (every swap, traced), made one at a time after.
    bonded: Vec<Pair>,
    /// Agents from and to cells outside the grid (see
    /// [`crate::lattice::Relocation::part`]).
    outside: Vec<Placed>,
    leaving: Vec<Placed>,
}

impl SwapPart {
    /// The swaps of the requests `mine` (among every request, `links`, in agent order);
    /// `no_swap`: agents in no swap. Marks the agents of each in `paired`.
    fn find(
        &mut self,
        lat: &Lattice,
        (mine, links): (&[Link], &[Link]),
        (no_swap, cap): (&[u32], Option<usize>),
        (paired, shared): (&Twice, bool),
    ) {
        let asks = |b: u32, d: Dir| {
            (links.binary_search_by_key(&b, |l| l.0)).is_ok_and(|k| links[k].2 == Some(d))
        };
        for &(a, _, swap) in mine {
            let Some(d) = swap else { continue };
            let Cell::Agent(b) = lat.cell_at(lat.pos[a as usize], d.offset()) else {
                let msg = || {
                    let (id, to) = (lat.label(a), d.letter());
                    format!("agent {id} cannot swap towards {to}: no agent stands there")
                };
                self.notes.push(cap, (RecordKind::SwapTarget, vec![a]), msg);
                continue;
            };
            let dead = no_swap.binary_search(&b).is_ok();
            if dead {
                let msg = || {
                    format!(
                        "agent {} cannot swap towards {}: agent {} there is asked for different swaps and takes part in none",
                        lat.label(a),
                        d.letter(),
                        lat.label(b)
                    )
                };
                self.notes
                    .push(cap, (RecordKind::SwapTarget, vec![a, b]), msg);
            }
            // Found at the lesser agent's request, or at the other's when the lesser asks
            // for no swap with it.
            let pair = if a < b {
                (a, b, d, dead)
            } else if !asks(b, d.opposite()) {
                (b, a, d.opposite(), dead)
            } else {
                continue;
            };
            paired.mark(pair.0 as usize, shared);
            paired.mark(pair.1 as usize, shared);
            self.pairs.push(pair);
        }
    }

    /// The swaps found, decided: those cancelled (one of them in no swap, or in another
    /// swap too: recorded), those of agents without bonds (their moves), the others
    /// (`bonded`; every one when `one_at_a_time`). `noting`: the cells left are noted.
    fn decide(
        &mut self,
        lat: &Lattice,
        (paired, cap): (&Twice, Option<usize>),
        (one_at_a_time, noting): (bool, bool),
    ) {
        for &(x, y, d, dead) in &self.pairs {
            if dead {
                continue;
            }
            if paired.twice(x as usize) || paired.twice(y as usize) {
                let msg = || {
                    let mut pair = [lat.label(x), lat.label(y)];
                    pair.sort_unstable();
                    format!(
                        "the swap of agents {} and {} shares an agent with another swap; it is cancelled",
                        pair[0], pair[1]
                    )
                };
                self.notes
                    .push(cap, (RecordKind::SwapShared, vec![x, y]), msg);
                continue;
            }
            if one_at_a_time || lat.attach[x as usize] | lat.attach[y as usize] != 0 {
                self.bonded.push((x, y, d, dead));
                continue;
            }
            let (px, py) = (lat.pos[x as usize], lat.pos[y as usize]);
            let (cx, cy) = (lat.code_of(x), lat.code_of(y));
            self.moves.extend([(x, py), (y, px)]);
            self.codes.extend([cy, cx]);
            if noting {
                self.left.extend([(x, px, cx), (y, py, cy)]);
            }
        }
    }
}

impl Act<'_> {
    /// Step 6: swaps, of the requests in `links` (in agent order). `no_swap` (in agent
    /// order) take part in none: a request towards one is cancelled with a record, but
    /// still counts when pairs are judged.
    pub(super) fn swaps(&mut self, links: &[Link], no_swap: &[u32], rep: &mut StepReport) {
        debug_assert!(links.windows(2).all(|w| w[0].0 < w[1].0));
        let mut sc = std::mem::take(&mut self.bufs.scratch);
        sc.paired.size(self.lat.len());
        let paired = &sc.paired;
        let (par, size, chunks) = self.threads.chunks_from(links.len(), 4096);
        let cap = self.opts.records_per_step;
        let shared = par.is_some();
        let lat = &*self.lat;
        let mut parts: Vec<SwapPart> = map_on(par, (0..chunks).collect(), |c| {
            let mine = &links[c * size..((c + 1) * size).min(links.len())];
            let mut part = SwapPart::default();
            part.find(lat, (mine, links), (no_swap, cap), (paired, shared));
            part
        });
        self.record_notes(parts.iter_mut().flat_map(|p| p.notes.list.drain(..)), rep);
        let how = (self.opts.trace, self.bufs.changes.on);
        let lat = &*self.lat;
        map_on(par, parts.iter_mut().collect(), |p| {
            p.decide(lat, (paired, cap), how)
        });
        self.record_notes(parts.iter_mut().flat_map(|p| p.notes.list.drain(..)), rep);
        for &(x, y, ..) in parts.iter().flat_map(|p| &p.pairs) {
            paired.clear_around(x as usize);
            paired.clear_around(y as usize);
        }
        self.bufs.scratch = sc;
        // The swaps of agents without bonds, per chunk; then the others.
        let moved: usize = parts.iter().map(|p| p.moves.len()).sum();
        if moved > 0 {
            // (The cells left wake the agents that moved: their bonds, none, stay.)
            for part in &mut parts {
                self.bufs.changes.moved.append(&mut part.left);
            }
            self.stats.swaps += moved as u64 / 2;
            match self.lat.relocation() {
                Some(r) => {
                    let r = &r;
                    map_on(par, parts.iter_mut().collect(), |part| {
                        let (moves, codes) = (&part.moves[..], &part.codes[..]);
                        let places = (&mut part.outside, &mut part.leaving);
                        // SAFETY: each agent is in one swap, whose two cells are its own
                        // (a swap sharing an agent with another is cancelled); each old
                        // cell is the other agent's target (`targeted`), so every cell
                        // written stays filled (its bit kept); nothing else uses the
                        // lattice meanwhile; one part at a time without the pool.
                        unsafe { r.part((moves, codes), |_| true, places, Bits::Keep) };
                    });
                    let outside = parts.iter().flat_map(|p| &p.outside);
                    let leaving = parts.iter().flat_map(|p| &p.leaving);
                    self.lat.relocated(outside, leaving);
                }
                None => {
                    let all: Vec<_> = parts.iter().flat_map(|p| p.moves.iter().copied()).collect();
                    self.lat.relocate(&all);
                }
            }
        }
        for &(x, y, d, _) in parts.iter().flat_map(|p| &p.bonded) {
            self.swap_bonded(x, y, d, rep);
        }
    }

    /// Agents `x` and `y` (`y` towards `d` from `x`) swap: bonds other than the one between
    /// them are dropped.
    fn swap_bonded(&mut self, x: u32, y: u32, d: Dir, rep: &mut StepReport) {
        let (px, py) = (self.lat.pos[x as usize], self.lat.pos[y as usize]);
        let nd = self.lat.dim.dirs();
        let bonded = self.lat.attach[x as usize] & (1 << d.index()) != 0;
        for s in [x, y] {
            for k in 0..nd {
                if self.lat.attach[s as usize] & (1 << k) != 0 {
                    if let Some(o) = self.lat.neighbour(s, Dir::ALL[k]) {
                        if o != x && o != y {
                            self.lat.attach[o as usize] &= !(1 << Dir::ALL[k].opposite().index());
                            self.bufs.changes.bonds(o);
                        }
                    }
                }
            }
            self.lat.attach[s as usize] = 0;
        }
        for s in [x, y] {
            self.bufs.changes.moved(self.lat, s);
            self.bufs.changes.bonds(s);
        }
        self.lat.relocate(&[(x, py), (y, px)]);
        if bonded {
            // x is now where y was: y lies opposite to d from x.
            self.lat.attach[x as usize] |= 1 << d.opposite().index();
            self.lat.attach[y as usize] |= 1 << d.index();
        }
        self.stats.swaps += 1;
        if self.opts.trace {
            rep.trace.push(TraceEvent::Swap { a: x, b: y });
        }
    }
}
