//! The first half of the actions phase for agents whose actions are their own: each chunk
//! of agents (on the pool when it pays) collects its agents' actions, reading only, then
//! sets the states of its agents whose one rule only sets the state, or moves and sets
//! it, writing only its own agents' entries; the chunks' lists, records and notes are
//! joined in agent order, so the step is the same for any split.

use super::*;

/// One chunk's part of [`Act::collect`] (kept between steps for their allocations).
#[derive(Default)]
pub(super) struct CollectPart {
    todo: Actions,
    /// Agents whose one rule only sets the state (`Plan::direct_bits`): set in the
    /// second pass.
    direct: Vec<u32>,
    /// Agents whose one rule moves and sets the state (`Plan::moving_bits`), with that
    /// state: set in the second pass too (their moves are in `todo`).
    moving: Vec<(u32, (u64, u64))>,
    /// Records of conflicts between an agent's rules, made in the first pass.
    records: Notes,
    /// The agents whose state the second pass changed (for the activity).
    states: Vec<u32>,
    /// Hops of lists found in the second pass, and how many agents of each list took its
    /// hop.
    learned: Vec<(usize, Hop)>,
    hopped: FxHashMap<usize, u64>,
    /// The agents that took a hop, with the rule they executed (see
    /// [`Selection::replaced`]).
    replaced: Vec<(u32, u32)>,
    /// Some state changed without the selection following; some new state's list was not
    /// known.
    changed: bool,
    lookups: bool,
    rs: Vec<u32>,
}

impl CollectPart {
    fn clear(&mut self) {
        self.todo.clear();
        self.direct.clear();
        self.moving.clear();
        self.records.clear();
        self.states.clear();
        self.learned.clear();
        self.hopped.clear();
        self.replaced.clear();
        (self.changed, self.lookups) = (false, false);
    }
}

impl Act<'_> {
    /// Paper step 2's first half for every agent that executes a rule (each in one pass:
    /// not with `--static-first`): the moves, bonds, swaps and states asked for, into
    /// `todo`, and the states of agents whose one rule only sets the state set at once
    /// (`keep` as for [`Dispatch::set_state_at_once`]). Returns whether some state changed
    /// without the selection following, and whether some new state's rules must be
    /// looked up.
    pub(super) fn collect(
        &mut self,
        sel: &mut Selection,
        todo: &mut Actions,
        keep: bool,
        rep: &mut StepReport,
    ) -> (bool, bool) {
        let (n, listed) = (sel.one.len(), sel.listed);
        let len = if listed { sel.list.len() } else { n };
        let (par, size, chunks) = self.threads.chunks(len);
        let mut parts = std::mem::take(&mut self.bufs.collect);
        parts.resize_with(chunks, CollectPart::default);
        // The agents of chunk `c`: items `lo..hi` of the list, or agents `lo..hi`.
        let range = |c: usize| (c * size, ((c + 1) * size).min(len));
        // 1. Reading only. (One chunk collects into `todo` itself.)
        if chunks == 1 {
            std::mem::swap(todo, &mut parts[0].todo);
        }
        {
            let (this, sel) = (&*self, &*sel);
            let first = |(c, part): (usize, &mut CollectPart)| {
                let (lo, hi) = range(c);
                part.clear();
                if listed {
                    for &a in &sel.list[lo..hi] {
                        this.collect_one(part, sel, a as usize);
                    }
                } else {
                    for a in lo..hi {
                        this.collect_one(part, sel, a);
                    }
                }
            };
            map_on(par, parts.iter_mut().enumerate().collect(), first);
        }
        if chunks == 1 {
            std::mem::swap(todo, &mut parts[0].todo);
        }
        // 2. States at once, each chunk writing its own agents' entries: chunk `c` holds
        // the agents from its first one to the next chunk's first.
        if parts
            .iter()
            .any(|p| !p.direct.is_empty() || !p.moving.is_empty())
        {
            let start = |c: usize| match (c, listed) {
                (0, _) => 0,
                (c, true) => sel.list[range(c).0] as usize,
                (c, false) => range(c).0,
            };
            let bounds: Vec<usize> = (0..chunks).map(start).chain([n]).collect();
            let (plan, on) = (self.plan, self.bufs.changes.on);
            let (known, hops, of) = self.dispatch.known();
            let items: Vec<_> = (parts.iter_mut())
                .zip(cut(of, &bounds))
                .zip(cut(&mut self.lat.state, &bounds))
                .zip(cut(&mut sel.one, &bounds))
                .zip(bounds.iter().copied())
                .collect();
            let second = |((((part, of), state), one), lo): Item<'_>| {
                let CollectPart {
                    direct,
                    moving,
                    states,
                    learned,
                    hopped,
                    replaced,
                    changed,
                    lookups,
                    ..
                } = part;
                for &a in direct.iter() {
                    let i = a as usize - lo;
                    let r = one[i];
                    let bits = plan.direct_bits[r as usize].expect("a rule that sets the state");
                    let before = state[i];
                    // A hop not remembered yet is found here, once per chunk.
                    let hop_of = |l: usize| match hops[l] {
                        h if h.to != ListId::NONE => h,
                        _ => match learned.iter().find(|h| h.0 == l) {
                            Some(h) => h.1,
                            None => {
                                let h = known.hop(l, r, bits, &plan.computes);
                                learned.push((l, h));
                                h
                            }
                        },
                    };
                    let took = |l: usize| {
                        *hopped.entry(l).or_insert(0) += 1;
                        replaced.push((a, r));
                    };
                    let agent = (&mut of[i], &mut state[i], &mut one[i]);
                    let (c, l) = known.at_once(agent, (r, bits), keep, hop_of, took);
                    *changed |= c;
                    *lookups |= l;
                    if on && state[i] != before {
                        states.push(a);
                    }
                }
                // (Their selection entries are not kept: they move.)
                let (c, l) = known.apply_all(moving, (of, state, lo), on.then_some(states));
                *changed |= c;
                *lookups |= l;
            };
            map_on(par, items, second);
        }
        // Joined in agent order.
        let (mut changed, mut lookups) = (false, false);
        for part in &mut parts {
            self.record_notes(part.records.list.drain(..), rep);
            todo.append(&mut part.todo);
            (self.bufs.changes.states).extend_from_slice(&part.states);
            sel.replaced.extend_from_slice(&part.replaced);
            for &(l, h) in &part.learned {
                self.dispatch.learn(l, h);
            }
            for (&l, &m) in &part.hopped {
                self.dispatch.add_hopped(l, m);
            }
            changed |= part.changed;
            lookups |= part.lookups;
        }
        self.bufs.collect = parts;
        (changed, lookups)
    }

    /// The actions of agent `a` (when it executes a rule) into `part`: a plain move, a
    /// rule that only sets the state (its agent kept for the second pass), a rule's
    /// actions, or the combined actions of several rules (their conflicts recorded).
    #[inline(always)]
    fn collect_one(&self, part: &mut CollectPart, sel: &Selection, a: usize) {
        let r = sel.one[a];
        if r == NO_RULE {
            return;
        }
        let plan = self.plan;
        if r & MANY == 0 {
            if let Some(o) = plan.plain_moves[r as usize] {
                part.todo.moves.push((a as u32, o));
            } else if plan.has_actions[r as usize] {
                match (plan.direct_bits[r as usize], plan.moving_bits[r as usize]) {
                    (Some(_), _) => part.direct.push(a as u32),
                    (None, Some(bits)) => {
                        self.add_rule_move(&mut part.todo, a as u32, r);
                        part.moving.push((a as u32, bits));
                    }
                    (None, None) => self.add_rule_actions(&mut part.todo, a as u32, r),
                }
            }
            return;
        }
        part.rs.clear();
        let acts = &plan.has_actions;
        (part.rs).extend((sel.of(a).iter().copied()).filter(|&r| acts[r as usize]));
        match part.rs[..] {
            [] => {}
            [r] => self.add_rule_actions(&mut part.todo, a as u32, r),
            _ => {
                let it = self.combined_intent(a, &part.rs, &mut part.records);
                part.todo.add(a as u32, &it);
            }
        }
    }
}

/// One chunk of the second pass: its part, its agents' candidate lists, states and
/// selection entries, and its first agent.
type Item<'a> = (
    (
        ((&'a mut CollectPart, &'a mut [ListId]), &'a mut [[u8; 5]]),
        &'a mut [u32],
    ),
    usize,
);

/// `col` cut at `bounds` (increasing, the first 0 and the last `col.len()`): one part per
/// pair of neighbouring bounds.
pub(super) fn cut<'a, T>(mut col: &'a mut [T], bounds: &[usize]) -> Vec<&'a mut [T]> {
    let mut out = Vec::with_capacity(bounds.len().saturating_sub(1));
    for w in bounds.windows(2) {
        let (part, rest) = col.split_at_mut(w[1] - w[0]);
        out.push(part);
        col = rest;
    }
    out
}
