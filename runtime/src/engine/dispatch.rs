//! Rule dispatch by state: per state seen, the list of rules (in priority order) whose
//! state filter it passes, found through a small direct-mapped cache; and the hops of
//! state-only rules, taken by whole runs of agents in one state.

use super::*;

/// Where the one state-only rule of a candidate list takes an agent: the list of its new
/// state (`to`, [`NO_LIST`] while unknown), that state's one rule when the agent's
/// selection can follow at once (`next`: a rule or [`NO_RULE`]; [`EVALUATE`] when it
/// cannot: the new state's rules need evaluating, or one of the rules calculates), and
/// the new state.
#[derive(Clone, Copy, Debug)]
pub(super) struct Hop {
    pub(super) to: u32,
    pub(super) next: u32,
    pub(super) state: [u8; 5],
}

impl Hop {
    const UNKNOWN: Hop = Hop {
        to: NO_LIST,
        next: EVALUATE,
        state: [0; 5],
    };

    /// An agent takes this hop: its new state, candidate list and selection entry, and
    /// the count of its old list's agents that took the hop (their firings are moved by
    /// [`Engine::count_hops`]).
    #[inline(always)]
    pub(super) fn take(
        &self,
        (list, state, one): (&mut u32, &mut [u8; 5], &mut u32),
        hopped: &mut u64,
    ) {
        *state = self.state;
        *list = self.to;
        *one = self.next;
        *hopped += 1;
    }
}

/// From agent `from` on, each agent takes its candidate list's hop ([`Hop::take`]) until
/// one whose list's hop is not known or needs its rules evaluated, whose index is
/// returned (the number of agents when there is none).
#[inline(never)]
pub(super) fn hop_run(
    from: usize,
    (cand_of, state, one): (&mut [u32], &mut [[u8; 5]], &mut [u32]),
    hops: &[Hop],
    hopped: &mut [u64],
) -> usize {
    let n = cand_of.len();
    let hopped = &mut hopped[..hops.len()];
    let agents = cand_of[from..].iter_mut().zip(&mut state[from..]);
    for (a, ((list, state), one)) in agents.zip(&mut one[from..]).enumerate() {
        let idx = *list as usize;
        let hop = hops[idx];
        if hop.to == *list {
            continue;
        }
        if hop.to == NO_LIST || hop.next == EVALUATE {
            return from + a;
        }
        hop.take((list, state, one), &mut hopped[idx]);
    }
    n
}

pub(super) const NO_LIST: u32 = u32::MAX;

/// Entries of the direct-mapped cache of candidate lists at first (it grows with the
/// number of distinct states, up to 65536).
pub(super) const CAND_CACHE: usize = 1024;

/// In `cand_single`: the agents of this list evaluate their rules.
pub(super) const EVALUATE: u32 = u32::MAX - 1;

/// A state as a number (its five bytes, little-endian).
#[inline]
pub(super) fn state_key(s: &[u8; 5]) -> u64 {
    u32::from_le_bytes([s[0], s[1], s[2], s[3]]) as u64 | (s[4] as u64) << 32
}

/// The slot of a state key in the candidate cache: one multiplication hashes it.
#[inline]
pub(super) fn cache_slot(key: u64, len: usize) -> usize {
    // `len` is a power of two: the top bits of the product index it.
    (key.wrapping_mul(0x9E37_79B9_7F4A_7C15) >> (64 - len.trailing_zeros())) as usize
}

/// The candidate list of a state key, when the candidate cache holds it.
#[inline]
pub(super) fn cached(cache: &[(u64, u32)], key: u64) -> Option<u32> {
    match cache[cache_slot(key, cache.len())] {
        (k, idx) if k == key + 1 => Some(idx),
        _ => None,
    }
}

impl Engine {
    /// Rule dispatch by state: an agent evaluates only the rules whose top-level state
    /// pattern its state matches. The list is computed once per distinct state, and each
    /// agent keeps its list until its state changes, so only those agents look it up again.
    pub(super) fn update_candidates(&mut self) {
        let n = self.lat.len();
        if self.cand_lists.len() > 1 << 16 {
            self.candidates.clear();
            self.cand_cache.fill((0, 0));
            self.cand_lists.clear();
            self.cand_single.clear();
            self.cand_keys.clear();
            self.cand_hop.clear();
            self.cand_hopped.clear();
            self.cand_of.iter_mut().for_each(|c| *c = NO_LIST);
            self.cand_dirty = true;
        }
        if !self.cand_dirty && self.cand_of.len() == n {
            return;
        }
        self.cand_of.resize(n, NO_LIST);
        // The first agents one by one (so that a cold cache learns the common states),
        // then the rest in chunks (in parallel with threads): the agents whose state the
        // cache knows get their list; of the others, the first agent of each state (in
        // agent order) makes its state's list, then the rest find theirs in a second pass.
        // Lists are made in the order of their states' first agents, whatever the chunks.
        for a in 0..n.min(1024) {
            if self.cand_of[a] == NO_LIST {
                self.list_state_of(a);
            }
        }
        let firsts = self.known_states(false);
        if firsts.iter().any(|f| !f.is_empty()) {
            for &a in firsts.iter().flatten() {
                self.list_state_of(a as usize);
            }
            self.known_states(true);
        }
        debug_assert!(
            self.cand_of.iter().all(|&c| c != NO_LIST),
            "every agent has its candidate list"
        );
        self.cand_dirty = false;
    }

    /// Gives agent `a` the candidate list of its state, made if its state is new.
    pub(super) fn list_state_of(&mut self, a: usize) {
        let prog = &self.prog;
        let st = &self.lat.state[a];
        let key = state_key(st);
        if let Some(idx) = cached(&self.cand_cache, key) {
            self.cand_of[a] = idx;
            return;
        }
        let lists = &mut self.cand_lists;
        let single = &mut self.cand_single;
        let (keys, hops) = (&mut self.cand_keys, &mut self.cand_hop);
        let hopped = &mut self.cand_hopped;
        let (by_prio, trivial) = (&self.by_prio, &self.plan.trivial);
        let idx = *self.candidates.entry(key).or_insert_with(|| {
            let list: Vec<u32> = by_prio
                .iter()
                .copied()
                .filter(|&r| {
                    prog.rules[r as usize]
                        .state_filter
                        .is_none_or(|p| latticesim_vm::eval::matches(&prog.pats[p as usize], st))
                })
                .collect();
            let prio = |r: u32| prog.rules[r as usize].priority;
            single.push(match list[..] {
                [] => NO_RULE,
                [r, ..]
                    if trivial[r as usize] && list.get(1).is_none_or(|&q| prio(q) < prio(r)) =>
                {
                    r
                }
                _ => EVALUATE,
            });
            lists.push(list);
            keys.push(key);
            hops.push(Hop::UNKNOWN);
            hopped.push(0);
            (lists.len() - 1) as u32
        });
        let slot = cache_slot(key, self.cand_cache.len());
        self.cand_cache[slot] = (key + 1, idx);
        // Eight slots per known state keep collisions rare.
        if self.candidates.len() * 8 > self.cand_cache.len() && self.cand_cache.len() < 1 << 16 {
            let len = self.cand_cache.len() * 4;
            let mut cache = vec![(0, 0); len];
            for (&k, &i) in &self.candidates {
                cache[cache_slot(k, len)] = (k + 1, i);
            }
            self.cand_cache = cache;
        }
        self.cand_of[a] = idx;
    }

    /// Gives each agent without a candidate list ([`NO_LIST`]) the list of its state when
    /// the cache knows it, or (with `all`) when it is known at all. Without `all`, returns
    /// per chunk the agents whose state is not in the cache, at least the first of each
    /// such state (in agent order).
    pub(super) fn known_states(&mut self, all: bool) -> Vec<Vec<u32>> {
        let n = self.lat.len();
        let mut of = std::mem::take(&mut self.cand_of);
        let (par, size, _) = self.chunks(n);
        let (cache, states, known) = (&self.cand_cache, &self.lat.state, &self.candidates);
        let pass = |(c, of): (usize, &mut [u32])| {
            let mut firsts = Vec::new();
            // The states already listed by this chunk (a few may be listed twice).
            let mut listed = [0u64; 256];
            for (j, (o, st)) in of.iter_mut().zip(&states[c * size..]).enumerate() {
                if *o != NO_LIST {
                    continue;
                }
                let key = state_key(st);
                match cached(cache, key) {
                    Some(idx) => *o = idx,
                    None if all => *o = known.get(&key).copied().unwrap_or(NO_LIST),
                    None => {
                        let slot = &mut listed[cache_slot(key, 256)];
                        if *slot != key + 1 {
                            *slot = key + 1;
                            firsts.push((c * size + j) as u32);
                        }
                    }
                }
            }
            firsts
        };
        let firsts: Vec<Vec<u32>> = match par {
            Some((pool, _)) => pool.map(of.chunks_mut(size).enumerate().collect(), pass),
            None => of.chunks_mut(size).enumerate().map(pass).collect(),
        };
        self.cand_of = of;
        firsts
    }

    /// Moves the firing counts of the agents that took a hop in this step (see
    /// [`Engine::set_state_at_once`]) from their old state's rule to their new one's.
    pub(super) fn count_hops(&mut self) {
        for (idx, m) in self.cand_hopped.iter_mut().enumerate() {
            if *m == 0 {
                continue;
            }
            self.fire_counts[self.cand_single[idx] as usize] -= *m;
            match self.cand_hop[idx].next {
                NO_RULE => self.active -= *m,
                next => self.fire_counts[next as usize] += *m,
            }
            *m = 0;
        }
    }

    /// Where rule `r`, the one rule of candidate list `idx`, which only sets the state (as
    /// [`pat_bits`] `bits`), takes an agent: [`Hop::UNKNOWN`] while the new state has no
    /// list yet.
    pub(super) fn hop(&self, idx: u32, r: u32, bits: (u64, u64)) -> Hop {
        let key = (self.cand_keys[idx as usize] & !bits.0) | bits.1;
        let Some(&to) = self.candidates.get(&key) else {
            return Hop::UNKNOWN;
        };
        let next = self.cand_single[to as usize];
        let quiet = |q: u32| q == NO_RULE || !self.plan.computes[q as usize];
        Hop {
            to,
            next: if next != EVALUATE && quiet(r) && quiet(next) {
                next
            } else {
                EVALUATE
            },
            state: key.to_le_bytes()[..5].try_into().expect("five bytes"),
        }
    }
}
