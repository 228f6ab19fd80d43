//! Rule dispatch by state: per state seen, the list of rules (in priority order) whose
//! state filter it passes, found through a small direct-mapped cache; each agent's list,
//! kept until its state changes; and the hops of state-only rules, taken by whole runs of
//! agents in one state. [`Dispatch`] owns all of it.

use super::*;

/// A candidate list: an index into [`Dispatch`]'s per-list columns, or [`ListId::NONE`]
/// for an agent whose state changed and whose list is to be looked up.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(transparent)]
pub(super) struct ListId(pub(super) u32);

impl ListId {
    pub(super) const NONE: ListId = ListId(u32::MAX);

    #[inline(always)]
    pub(super) fn index(self) -> usize {
        self.0 as usize
    }
}

/// Where the one state-only rule of a candidate list takes an agent: the list of its new
/// state (`to`, [`NO_LIST`] while unknown), that state's one rule when the agent's
/// selection can follow at once (`next`: a rule or [`NO_RULE`]; [`EVALUATE`] when it
/// cannot: the new state's rules need evaluating, or one of the rules calculates), and
/// the new state.
#[derive(Clone, Copy, Debug)]
pub(super) struct Hop {
    pub(super) to: ListId,
    pub(super) next: u32,
    pub(super) state: [u8; 5],
}

impl Hop {
    const UNKNOWN: Hop = Hop {
        to: ListId::NONE,
        next: EVALUATE,
        state: [0; 5],
    };

    /// An agent takes this hop: its new state, candidate list and selection entry (its
    /// old list's count of agents that took the hop is the caller's: their firings are
    /// moved by [`Dispatch::count_hops`]).
    #[inline(always)]
    pub(super) fn take(&self, (list, state, one): (&mut ListId, &mut [u8; 5], &mut u32)) {
        *state = self.state;
        *list = self.to;
        *one = self.next;
    }
}

/// From agent `from` on, each agent takes its candidate list's hop ([`Hop::take`]) until
/// one whose list's hop is not known or needs its rules evaluated, whose index is
/// returned (the number of agents when there is none).
#[inline(never)]
pub(super) fn hop_run(
    from: usize,
    (cand_of, state, one): (&mut [ListId], &mut [[u8; 5]], &mut [u32]),
    hops: &[Hop],
    hopped: &mut [u64],
) -> usize {
    let n = cand_of.len();
    let hopped = &mut hopped[..hops.len()];
    let agents = cand_of[from..].iter_mut().zip(&mut state[from..]);
    for (a, ((list, state), one)) in agents.zip(&mut one[from..]).enumerate() {
        let idx = list.index();
        let hop = hops[idx];
        if hop.to == *list {
            continue;
        }
        if hop.to == ListId::NONE || hop.next == EVALUATE {
            return from + a;
        }
        hop.take((list, state, one));
        hopped[idx] += 1;
    }
    n
}

/// Entries of the direct-mapped cache of candidate lists at first (it grows with the
/// number of distinct states, up to 65536).
pub(super) const CAND_CACHE: usize = 1024;

/// In [`Dispatch::single`]: the agents of this list evaluate their rules.
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
pub(super) fn cached(cache: &[(u64, ListId)], key: u64) -> Option<ListId> {
    match cache[cache_slot(key, cache.len())] {
        (k, idx) if k == key + 1 => Some(idx),
        _ => None,
    }
}

/// Gives agent `j` of `states` the candidate list `idx` in `of`, and the agents after it
/// in the same state too; returns the first agent after them. Agents listed in runs of
/// one state (a file's blocks of agents) are compared 32 at a time, as bytes.
#[inline]
fn same_state_run(states: &[[u8; 5]], j: usize, of: &mut [ListId], idx: ListId) -> usize {
    of[j] = idx;
    let st = states[j];
    let mut k = j + 1;
    if states.get(k) != Some(&st) {
        return k;
    }
    // Agents `k..k + 32` each in the state of the one before: all in `st`.
    const BLOCK: usize = 32;
    let bytes = states.as_flattened();
    while k + BLOCK <= states.len()
        && bytes[5 * k..5 * (k + BLOCK)] == bytes[5 * (k - 1)..5 * (k - 1 + BLOCK)]
    {
        of[k..k + BLOCK].fill(idx);
        k += BLOCK;
    }
    while k < states.len() && states[k] == st {
        of[k] = idx;
        k += 1;
    }
    k
}

/// Agents a chunk's first pass of [`Dispatch::known_states`] left without a list: their
/// states were not in the cache.
#[derive(Default)]
struct Unlisted {
    /// At least the first agent of each such state (in agent order), indices in the lattice.
    firsts: Vec<u32>,
    /// The blocks of [`UNLISTED_BLOCK`] agents (counted from the chunk's first) holding any
    /// of them, rising: the second pass visits only these (it read every agent's list again:
    /// 5 ms of the first step beside 10^7 agents at rest).
    blocks: Vec<u32>,
    /// The runs of at least [`LONG_RUN`] agents the pass gave one list (see
    /// [`Dispatch::runs`]).
    runs: Vec<(u32, u32)>,
}

/// The shortest run of agents of one list that [`Dispatch::runs`] keeps.
const LONG_RUN: usize = 1024;

/// Agents in a block of [`Unlisted::blocks`].
const UNLISTED_BLOCK: usize = 1024;

/// Rule dispatch: the candidate lists of the states seen, each agent's list, and the hops.
pub(super) struct Dispatch {
    /// The rules, highest priority first.
    by_prio: Vec<u32>,
    /// Per state seen so far: its candidate list.
    candidates: FxHashMap<u64, ListId>,
    /// A small direct-mapped cache in front of `candidates`: (state key + 1, list).
    cache: Vec<(u64, ListId)>,
    /// The candidate lists: the rules (in `by_prio` order) whose state filter the list's
    /// state passes.
    pub(super) lists: Vec<Vec<u32>>,
    /// Per candidate list: the one rule every agent with it executes, when the list's
    /// first rule needs nothing but the state filter and no other rule shares its
    /// priority; [`NO_RULE`] for an empty list; else [`EVALUATE`].
    pub(super) single: Vec<u32>,
    /// Per candidate list: rules each state-only or with a column program, at most 32 of
    /// one priority: its agents are evaluated list by list over windows of agents
    /// (`select::eval_window`; a list of one rule only where its agents make short runs).
    pub(super) columnar: Vec<bool>,
    /// Per candidate list of one rule with a column program: the rule's class
    /// (`Plan::pre_class`) and the rule; else [`ONE_NONE`].
    pub(super) one_rule: Vec<(u32, u32)>,
    /// Per candidate list: its state as a key ([`state_key`]).
    keys: Vec<u64>,
    /// Per candidate list: where its one state-only rule takes an agent (found when first
    /// needed).
    pub(super) hops: Vec<Hop>,
    /// Per candidate list: how many agents took its hop in this step's actions (their
    /// firing counts are moved after the actions, by [`Dispatch::count_hops`]).
    pub(super) hopped: Vec<u64>,
    /// Per agent: its candidate list ([`ListId::NONE`] after its state changed).
    pub(super) of: Vec<ListId>,
    /// Runs of at least [`LONG_RUN`] agents given one list at once by the last
    /// [`Dispatch::update`] (first and past-the-last agent, rising), valid until the lists
    /// change: the selection after it need not read their lists again.
    runs: Vec<(u32, u32)>,
    /// Some agent's state changed since the lists were looked up, and it has no list yet.
    dirty: bool,
}

/// [`Dispatch::one_rule`] of a list that is not one rule with a column program.
pub(super) const ONE_NONE: (u32, u32) = (u32::MAX, u32::MAX);

/// Per rule: whether its precondition is only its state filter, its column program and
/// the class of that program (`Plan::trivial`, `Plan::pre_columns`, `Plan::pre_class`).
pub(super) type Facts<'a> = (&'a [bool], &'a [Option<ColumnPre>], &'a [u32]);

/// The rules of a candidate list (ordered by priority, highest first) in runs of one
/// priority.
pub(super) fn levels<'a>(prog: &'a Program, list: &'a [u32]) -> impl Iterator<Item = &'a [u32]> {
    let prio = |r: &u32| prog.rules[*r as usize].priority;
    list.chunk_by(move |a, b| prio(a) == prio(b))
}

impl Dispatch {
    /// Dispatch for `n` agents running `prog`; no list is known yet.
    pub(super) fn new(prog: &Program, n: usize) -> Dispatch {
        let mut by_prio: Vec<u32> = (0..prog.rules.len() as u32).collect();
        by_prio.sort_by_key(|&r| std::cmp::Reverse(prog.rules[r as usize].priority));
        Dispatch {
            by_prio,
            candidates: FxHashMap::default(),
            cache: vec![(0, ListId(0)); CAND_CACHE],
            lists: Vec::new(),
            single: Vec::new(),
            columnar: Vec::new(),
            one_rule: Vec::new(),
            keys: Vec::new(),
            hops: Vec::new(),
            hopped: Vec::new(),
            of: vec![ListId::NONE; n],
            runs: Vec::new(),
            dirty: true,
        }
    }

    /// Whether some agent of `n` has no candidate list (its state changed to one the
    /// cache did not know, or the lattice grew).
    pub(super) fn stale(&self, n: usize) -> bool {
        self.dirty || self.of.len() != n
    }

    /// Whether agent `a`'s candidate list has a rule marked in `unbounded` (one whose
    /// offsets depend on counters: its agents are evaluated at every step). False for an
    /// agent whose list is to be looked up (its state changed, which wakes it anyway).
    pub(super) fn always(&self, a: usize, unbounded: &[bool]) -> bool {
        let idx = self.of[a];
        idx != ListId::NONE
            && self.lists[idx.index()]
                .iter()
                .any(|&r| unbounded[r as usize])
    }

    /// The first of [`Dispatch::runs`] that ends after agent `a` (it holds `a` when its
    /// first agent is `a` or before); `at`: a place in the runs, moved forward (agents
    /// asked for in rising order).
    #[inline]
    pub(super) fn run_from(&self, at: &mut usize, a: usize) -> Option<(usize, usize)> {
        while self.runs.get(*at).is_some_and(|r| r.1 as usize <= a) {
            *at += 1;
        }
        let &(first, end) = self.runs.get(*at)?;
        Some((first as usize, end as usize))
    }

    /// Some agents' states changed to states whose lists were not known (`lookups`):
    /// they are looked up at the next [`Dispatch::update`].
    pub(super) fn lookups(&mut self, lookups: bool) {
        self.dirty |= lookups;
    }

    /// Rule dispatch by state: an agent evaluates only the rules whose top-level state
    /// pattern its state matches. The list is computed once per distinct state, and each
    /// agent keeps its list until its state changes, so only those agents look it up again.
    /// `rules`: per rule, whether it is state-only, and its column program.
    pub(super) fn update(&mut self, prog: &Program, rules: Facts<'_>, lat: &Lattice, th: &Threads) {
        let n = lat.len();
        self.runs.clear();
        if self.lists.len() > 1 << 16 {
            self.candidates.clear();
            self.cache.fill((0, ListId(0)));
            self.lists.clear();
            self.single.clear();
            self.columnar.clear();
            self.one_rule.clear();
            self.keys.clear();
            self.hops.clear();
            self.hopped.clear();
            self.of.iter_mut().for_each(|c| *c = ListId::NONE);
            self.dirty = true;
        }
        if !self.stale(n) {
            return;
        }
        self.of.resize(n, ListId::NONE);
        // The first agents one by one (so that a cold cache learns the common states),
        // then the rest in chunks (in parallel with threads): the agents whose state the
        // cache knows get their list; of the others, the first agent of each state (in
        // agent order) makes its state's list, then the rest find theirs in a second pass.
        // Lists are made in the order of their states' first agents, whatever the chunks.
        for a in 0..n.min(1024) {
            if self.of[a] == ListId::NONE {
                self.list_state_of(prog, rules, &lat.state, a);
            }
        }
        let unlisted = self.known_states(&lat.state, th, None);
        let mut runs: Vec<_> = unlisted.iter().flat_map(|u| &u.runs).copied().collect();
        if unlisted.iter().any(|u| !u.firsts.is_empty()) {
            for &a in unlisted.iter().flat_map(|u| &u.firsts) {
                self.list_state_of(prog, rules, &lat.state, a as usize);
            }
            let more = self.known_states(&lat.state, th, Some(&unlisted));
            runs.extend(more.iter().flat_map(|u| &u.runs));
            runs.sort_unstable();
        }
        self.runs = runs;
        debug_assert!(
            self.of.iter().all(|&c| c != ListId::NONE),
            "every agent has its candidate list"
        );
        self.dirty = false;
    }

    /// Gives agent `a` the candidate list of its state, made if its state is new.
    fn list_state_of(&mut self, prog: &Program, rules: Facts<'_>, states: &[[u8; 5]], a: usize) {
        let (trivial, pre_columns, pre_class) = rules;
        let st = &states[a];
        let key = state_key(st);
        if let Some(idx) = cached(&self.cache, key) {
            self.of[a] = idx;
            return;
        }
        let lists = &mut self.lists;
        let (single, columnar) = (&mut self.single, &mut self.columnar);
        let one_rule = &mut self.one_rule;
        let (keys, hops) = (&mut self.keys, &mut self.hops);
        let hopped = &mut self.hopped;
        let by_prio = &self.by_prio;
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
            let runs = |&r: &u32| trivial[r as usize] || pre_columns[r as usize].is_some();
            let widest = levels(prog, &list).map(<[u32]>::len).max().unwrap_or(0);
            columnar.push(!list.is_empty() && list.iter().all(runs) && widest <= 32);
            one_rule.push(match list[..] {
                [r] if pre_columns[r as usize].is_some() => (pre_class[r as usize], r),
                _ => ONE_NONE,
            });
            lists.push(list);
            keys.push(key);
            hops.push(Hop::UNKNOWN);
            hopped.push(0);
            ListId((lists.len() - 1) as u32)
        });
        let slot = cache_slot(key, self.cache.len());
        self.cache[slot] = (key + 1, idx);
        // Eight slots per known state keep collisions rare.
        if self.candidates.len() * 8 > self.cache.len() && self.cache.len() < 1 << 16 {
            let len = self.cache.len() * 4;
            let mut cache = vec![(0, ListId(0)); len];
            for (&k, &i) in &self.candidates {
                cache[cache_slot(k, len)] = (k + 1, i);
            }
            self.cache = cache;
        }
        self.of[a] = idx;
    }

    /// Gives each agent without a candidate list ([`ListId::NONE`]) the list of its state
    /// when the cache knows it, or (`again`, the first pass's answer) when it is known at
    /// all. The first pass returns per chunk the agents whose state is not in the cache (at
    /// least the first of each such state, in agent order) and the blocks that hold them;
    /// the second visits only those blocks.
    fn known_states(
        &mut self,
        states: &[[u8; 5]],
        th: &Threads,
        again: Option<&[Unlisted]>,
    ) -> Vec<Unlisted> {
        let n = states.len();
        let (par, size, _) = th.chunks(n);
        let (cache, known) = (&self.cache, &self.candidates);
        let pass = |(c, of): (usize, &mut [ListId])| {
            let mut out = Unlisted::default();
            // The states already listed by this chunk (a few may be listed twice).
            let mut listed = [0u64; 256];
            let (len, states) = (of.len(), &states[c * size..][..of.len()]);
            let mut visit = |lo: usize, hi: usize| {
                let mut j = lo;
                while j < hi {
                    if of[j] != ListId::NONE {
                        // (The agents already listed, passed over in blocks: one by one,
                        // 10^7 agents of a known state took 11-14 ms.)
                        j += crate::bits::run_while(&of[j..hi], |c| c != ListId::NONE);
                        continue;
                    }
                    let st = &states[j];
                    let key = state_key(st);
                    let idx = match cached(cache, key) {
                        Some(idx) => idx,
                        None if again.is_some() => known.get(&key).copied().unwrap_or(ListId::NONE),
                        None => {
                            let slot = &mut listed[cache_slot(key, 256)];
                            if *slot != key + 1 {
                                *slot = key + 1;
                                out.firsts.push((c * size + j) as u32);
                            }
                            let block = (j / UNLISTED_BLOCK) as u32;
                            if out.blocks.last() != Some(&block) {
                                out.blocks.push(block);
                            }
                            j += 1;
                            continue;
                        }
                    };
                    // The agents after it in the same state have the same list (an agent's
                    // list is none or its state's): a run of them is given it at once.
                    let end = same_state_run(states, j, of, idx);
                    if end - j >= LONG_RUN {
                        out.runs
                            .push(((c * size + j) as u32, (c * size + end) as u32));
                    }
                    j = end;
                }
            };
            match again {
                None => visit(0, len),
                Some(first) => {
                    for &b in &first[c].blocks {
                        let lo = b as usize * UNLISTED_BLOCK;
                        visit(lo, len.min(lo + UNLISTED_BLOCK));
                    }
                }
            }
            out
        };
        map_on(par, self.of.chunks_mut(size).enumerate().collect(), pass)
    }

    /// Moves the firing counts of the agents that took a hop in this step (see
    /// [`Dispatch::set_state_at_once`]) from their old state's rule to their new one's:
    /// `counts` per rule, and `active`, the agents that execute any rule.
    pub(super) fn count_hops(&mut self, counts: &mut [u64], active: &mut u64) {
        for (idx, m) in self.hopped.iter_mut().enumerate() {
            if *m == 0 {
                continue;
            }
            counts[self.single[idx] as usize] -= *m;
            match self.hops[idx].next {
                NO_RULE => *active -= *m,
                next => counts[next as usize] += *m,
            }
            *m = 0;
        }
    }

    /// Agent `a`, whose one rule `r` only sets the state (as [`pat_bits`] `bits`), takes its
    /// new state now (see [`Known::at_once`], whose answer is returned); the hops found are
    /// remembered; when the agent takes one, it is added to `replaced` with `r`.
    pub(super) fn set_state_at_once(
        &mut self,
        (states, one, replaced): Entries<'_>,
        (a, r, bits): (usize, u32, (u64, u64)),
        keep: bool,
        computes: &[bool],
    ) -> (bool, bool) {
        let (known, hops, hopped, of) = self.split();
        let hop_of = |i: usize| {
            if hops[i].to == ListId::NONE {
                hops[i] = known.hop(i, r, bits, computes);
            }
            hops[i]
        };
        let agent = (&mut of[a], &mut states[a], &mut one[a]);
        let took = |i: usize| {
            hopped[i] += 1;
            replaced.push((a as u32, r));
        };
        known.at_once(agent, (r, bits), keep, hop_of, took)
    }

    /// What setting states reads (every list known, and the hops remembered), and each
    /// agent's candidate list, to write: so that chunks of agents set their own agents'
    /// states at once on the pool (see `actions/collect.rs`).
    pub(super) fn known(&mut self) -> (Known<'_>, &[Hop], &mut [ListId]) {
        let (known, hops, _, of) = self.split();
        (known, hops, of)
    }

    /// What setting states reads ([`Known`]), and the hops, their counts and each agent's
    /// candidate list, to write.
    fn split(&mut self) -> (Known<'_>, &mut [Hop], &mut [u64], &mut [ListId]) {
        let known = Known {
            candidates: &self.candidates,
            cache: &self.cache,
            single: &self.single,
            keys: &self.keys,
        };
        (known, &mut self.hops, &mut self.hopped, &mut self.of)
    }

    /// Remembers hop `hop` of list `i`, found by a chunk (a hop found is the same whoever
    /// finds it, and never changes while the lists stay).
    pub(super) fn learn(&mut self, i: usize, hop: Hop) {
        if self.hops[i].to == ListId::NONE {
            self.hops[i] = hop;
        }
    }

    /// Adds `m` agents to the count of list `i`'s agents that took its hop in this step.
    pub(super) fn add_hopped(&mut self, i: usize, m: u64) {
        self.hopped[i] += m;
    }
}

/// What setting a state at once writes besides the dispatch: the agents' states, their
/// selection entries, and the log of the hops taken ([`Selection::replaced`]).
pub(super) type Entries<'a> = (&'a mut [[u8; 5]], &'a mut [u32], &'a mut Vec<(u32, u32)>);

/// The part of [`Dispatch`] that setting states reads: the candidate lists known per
/// state (and the cache in front of them), each list's one rule and state.
pub(super) struct Known<'d> {
    candidates: &'d FxHashMap<u64, ListId>,
    cache: &'d [(u64, ListId)],
    single: &'d [u32],
    keys: &'d [u64],
}

impl Known<'_> {
    /// Where rule `r`, the one rule of candidate list `i`, which only sets the state (as
    /// [`pat_bits`] `bits`), takes an agent: [`Hop::UNKNOWN`] while the new state has no
    /// list yet. `computes`: per rule, whether it calculates or sends.
    pub(super) fn hop(&self, i: usize, r: u32, bits: (u64, u64), computes: &[bool]) -> Hop {
        let key = (self.keys[i] & !bits.0) | bits.1;
        let Some(&to) = self.candidates.get(&key) else {
            return Hop::UNKNOWN;
        };
        let next = self.single[to.index()];
        let quiet = |q: u32| q == NO_RULE || !computes[q as usize];
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

    /// Applies a state pattern (as [`pat_bits`]) to an agent (its candidate list and
    /// state). When the state changes: the old and new states, and whether the cache knew
    /// the new state's candidate list (the agent's list is set from it, or marked for
    /// lookup).
    #[inline(always)]
    pub(super) fn apply(
        &self,
        (list, state): (&mut ListId, &mut [u8; 5]),
        (mask, val): (u64, u64),
    ) -> Option<([u8; 5], [u8; 5], bool)> {
        let old = *state;
        let o = state_key(&old);
        let v = (o & !mask) | val;
        if v == o {
            return None;
        }
        let new: [u8; 5] = v.to_le_bytes()[..5].try_into().expect("five bytes");
        *state = new;
        let idx = cached(self.cache, v).or_else(|| self.candidates.get(&v).copied());
        *list = idx.unwrap_or(ListId::NONE);
        Some((old, new, idx.is_some()))
    }

    /// [`Known::apply`] of each state pattern of `states` (agent and pattern, as
    /// [`pat_bits`]) to its agent, among the agents from `lo` whose candidate lists and
    /// states are `of` and `state`; the agents whose state changed pushed to `noted` when
    /// it is given. Returns whether some state changed, and whether some new state's
    /// candidate list was not known.
    pub(super) fn apply_all(
        &self,
        states: &[(u32, (u64, u64))],
        (of, state, lo): (&mut [ListId], &mut [[u8; 5]], usize),
        mut noted: Option<&mut Vec<u32>>,
    ) -> (bool, bool) {
        let (mut changed, mut lookups) = (false, false);
        for &(a, bits) in states {
            let i = a as usize - lo;
            if let Some((_, _, known)) = self.apply((&mut of[i], &mut state[i]), bits) {
                changed = true;
                lookups |= !known;
                if let Some(noted) = noted.as_deref_mut() {
                    noted.push(a);
                }
            }
        }
        (changed, lookups)
    }

    /// An agent (its candidate list, state and selection entry), whose one rule `r` only
    /// sets the state (as [`pat_bits`] `bits`), takes its new state now. With `keep` (the
    /// selection is decided by states alone), an agent whose rule its state alone decides
    /// goes to the state that rule makes of it, remembered per state (`hop_of`: the hop of
    /// a list, found when not known yet), and its selection entry is set to that state's
    /// rule for the next step (when neither rule calculates (`computes`): the
    /// calculations of this step read the entry); `took` is told its old list.
    /// Returns whether the state changed without the selection following, and whether
    /// the new state's rules must be looked up.
    #[inline(always)]
    pub(super) fn at_once(
        &self,
        (list, state, one): (&mut ListId, &mut [u8; 5], &mut u32),
        (r, bits): (u32, (u64, u64)),
        keep: bool,
        mut hop_of: impl FnMut(usize) -> Hop,
        mut took: impl FnMut(usize),
    ) -> (bool, bool) {
        let idx = *list;
        if keep && idx != ListId::NONE && self.single[idx.index()] == r {
            let i = idx.index();
            let hop = hop_of(i);
            if hop.to == idx {
                return (false, false);
            }
            if hop.to != ListId::NONE && hop.next != EVALUATE {
                hop.take((list, state, one));
                took(i);
                return (false, false);
            }
        }
        match self.apply((list, state), bits) {
            Some((_, _, known)) => (true, !known),
            None => (false, false),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A run of agents in one state gets the list of its first, and ends at the first
    /// agent in another state: runs of every length about the blocks of 32 compared at
    /// once, states that differ in any of their five letters.
    #[test]
    fn a_run_of_one_state_ends_where_the_state_changes() {
        for len in [1, 2, 31, 32, 33, 64, 65, 100] {
            for letter in 0..5 {
                let mut states = vec![*b"SREST"; len];
                let mut other = *b"SREST";
                other[letter] = b'X';
                states.extend([other, *b"SREST"]);
                let mut of = vec![ListId::NONE; states.len()];
                let end = same_state_run(&states, 0, &mut of, ListId(3));
                assert_eq!(end, len, "a run of {len}, letter {letter}");
                assert!(of[..len].iter().all(|&l| l == ListId(3)));
                assert!(of[len..].iter().all(|&l| l == ListId::NONE));
                // From within the run, and at its last agent.
                let mut of = vec![ListId::NONE; states.len()];
                assert_eq!(same_state_run(&states, len - 1, &mut of, ListId(1)), len);
                assert_eq!(of[len - 1], ListId(1));
            }
        }
    }
}
