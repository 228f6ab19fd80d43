//! Selection: which rules each agent executes this step, from its candidate rules, their
//! preconditions and, when rules read them, the priorities of its neighbours resolved level
//! by level.

use super::*;

/// The selection part of the engine: the selection of the last step, whether it can be
/// reused, and the firing counts that go with it.
#[derive(Default)]
pub(super) struct Selector {
    /// The rules each agent executes (taken out by the step while its phases read it).
    pub(super) sel: Selection,
    /// The last selection was decided by the agents' states alone (no agent evaluated a
    /// precondition): while no state changes, it holds for the next step too.
    pub(super) by_state: bool,
    /// The last selection was reused (so the firings of the last step repeat).
    reused: bool,
    /// The last selection counted its firings as it was made.
    counted: bool,
    /// Some agent's state changed since the last selection.
    states_changed: bool,
    /// Per rule: how many agents execute it in the current selection; and how many agents
    /// execute any rule. Kept up to date when the selection is reused.
    pub(super) fire_counts: Vec<u64>,
    pub(super) active: u64,
}

impl Selector {
    /// For a program of `rules` rules on `n` agents. The selection's entries are made
    /// (and their memory touched) here, so that no step makes a column of all agents:
    /// the first step costs what evaluating the agents costs, and a fresh column's pages
    /// (on some machines several milliseconds per 2 MB the first time) are the engine's
    /// making.
    pub(super) fn new(rules: usize, n: usize) -> Selector {
        let mut sel = Selection::default();
        sel.reset(n);
        Selector {
            fire_counts: vec![0; rules],
            sel,
            ..Selector::default()
        }
    }

    /// Some agent's state changed (`changed`): the selection is made anew.
    pub(super) fn states_changed(&mut self, changed: bool) {
        self.states_changed |= changed;
    }

    /// Selection: which rules each agent executes this step (into `self.sel`), after the
    /// agents' candidate lists are brought up to date; kept from the last step when that
    /// was decided by states alone and no state changed since. Returns the circles of
    /// priorities found, with their messages.
    /// `listed`: the agents to evaluate (in id order; every other agent is quiet), or
    /// `None` for every agent.
    pub(super) fn select(
        &mut self,
        (prog, plan, lat): (&Program, &Plan, &Lattice),
        dispatch: &mut Dispatch,
        threads: &mut Threads,
        listed: Option<&[u32]>,
    ) -> Vec<(Vec<u32>, String)> {
        // (A list found by the last selection is not this one's: hops may have changed
        // entries since.)
        self.sel.found = false;
        let changed = dispatch.stale(lat.len()) || self.states_changed;
        self.states_changed = false;
        let facts = (
            &plan.trivial[..],
            &plan.pre_columns[..],
            &plan.pre_class[..],
        );
        dispatch.update(prog, facts, lat, threads);
        self.reused = !plan.any_prio && !changed && self.by_state;
        if self.reused {
            return Vec::new();
        }
        let dispatch = &*dispatch;
        let listed = listed.filter(|_| self.sel.one.len() == lat.len());
        let out = threads.tuned(Phase::Select, |th| {
            if plan.any_prio {
                let view = Prio { prog, plan, lat };
                view.select(&mut self.sel, dispatch, th)
            } else if let Some(list) = listed {
                self.select_listed((prog, plan, lat), dispatch, th, list);
                Vec::new()
            } else {
                self.select_plain((prog, plan, lat), dispatch, th);
                Vec::new()
            }
        });
        // (Whichever way it was made: a selection over priorities starts from a reset
        // column too, and writes it.)
        self.sel.fresh = false;
        out
    }

    /// Whether the last selection was kept from the step before.
    pub(super) fn reused(&self) -> bool {
        self.reused
    }

    /// The firing counts of the selection (unless the selection counted them as it was
    /// made, or was reused: then its counts were kept up to date): in chunks of agents on
    /// the pool when there are threads (and rules few enough for a count per chunk).
    pub(super) fn count_firings(&mut self, th: &Threads) {
        if self.reused {
            return;
        }
        let (sel, counts) = (&self.sel, &mut self.fire_counts);
        if !std::mem::take(&mut self.counted) {
            let rules = counts.len();
            let len = if sel.listed {
                sel.list.len()
            } else {
                sel.one.len()
            };
            let count = |(lo, hi): (usize, usize), counts: &mut [u64]| -> u64 {
                if sel.listed {
                    sel.count_listed(&sel.list[lo..hi], counts)
                } else {
                    tally(&sel.one[lo..hi], counts, !sel.many.is_empty())
                }
            };
            counts.fill(0);
            self.active = if th.parallel(len).is_some() && rules <= TALLIED {
                let parts = th.par_chunks(len, &|lo, hi| {
                    let mut c = vec![0; rules];
                    (count((lo, hi), &mut c), c)
                });
                add_tallies(counts, &parts)
            } else {
                count((0, len), counts)
            };
        }
        for &r in &sel.many {
            counts[r as usize] += 1;
        }
    }
}

/// Rules up to which firings are counted per chunk of agents, and the chunks' counts added.
const TALLIED: usize = 64;

/// Entries of the selection a chunk's [`Tally`] takes at once: decided a moment before,
/// they are still in the core's first-level cache (16 KB).
const TALLY_PART: usize = 4096;

/// A run of agents with one rule to test shorter than this, among agents of other lists
/// the column interpreter runs, is evaluated with them in a window ([`eval_window`]):
/// rules of two states that alternate among the agents (`SA` moves and becomes `SB`, and
/// back) made runs of one or two agents, each a call of [`batch_pre`].
const SHORT_RUN: usize = 16;

/// Adds to `counts` how many entries of `one` (a part of the selection) name each single
/// rule, and returns how many name any rule; `many`: some entry may be [`MANY`]. With few
/// rules and no agent executing several, one vectorised count per rule (agents alternating
/// between a rule and none would make runs of one); otherwise runs of agents with the same
/// entry are counted at once.
fn tally(one: &[u32], counts: &mut [u64], many: bool) -> u64 {
    if many || counts.len() > 4 {
        return count_runs(one, counts);
    }
    let mut active = 0;
    for (r, c) in counts.iter_mut().enumerate() {
        let k: u64 = one.iter().map(|&v| (v == r as u32) as u64).sum();
        *c += k;
        active += k;
    }
    active
}

/// The [`tally`] of a chunk of the selection, taken part by part as the chunk's entries
/// are decided (while they are in this core's cache: a chunk of 10^7 agents tallied after
/// its evaluation was read back from memory, a sixth of the first step's time), listing
/// the agents that execute a rule into `chosen` while they are at most `cap`. Blocks of 64
/// entries where no agent executes a rule (all of them when a few agents act among many)
/// are passed over with one vectorised test; past `cap`, the rest is tallied.
struct Tally {
    counts: Vec<u64>,
    /// How many execute any rule.
    active: u64,
    cap: usize,
    chosen: Vec<u32>,
    /// Whether `chosen` still lists every agent that executes a rule.
    listing: bool,
}

impl Tally {
    fn new(rules: usize, cap: usize) -> Self {
        let (counts, chosen) = (vec![0; rules], Vec::new());
        Tally {
            counts,
            active: 0,
            cap,
            chosen,
            listing: true,
        }
    }

    /// Adds the next part of the chunk, `one`, whose first entry is agent `lo`'s; `many`:
    /// some entry may be [`MANY`].
    fn add(&mut self, (one, lo): (&[u32], usize), many: bool) {
        const BLOCK: usize = 64;
        if !self.listing {
            self.active += tally(one, &mut self.counts, many);
            return;
        }
        for (b, block) in one.chunks(BLOCK).enumerate() {
            // (`NO_RULE` has every bit set: the block holds nothing else when its AND does.)
            if block.iter().fold(NO_RULE, |m, &v| m & v) == NO_RULE {
                continue;
            }
            let first = b * BLOCK;
            let k = block.iter().filter(|&&v| v != NO_RULE).count();
            if self.chosen.len() + k > self.cap {
                self.listing = false;
                self.active += tally(&one[first..], &mut self.counts, many);
                return;
            }
            for (i, &v) in block.iter().enumerate() {
                if v != NO_RULE {
                    self.chosen.push((lo + first + i) as u32);
                    if v & MANY == 0 {
                        self.counts[v as usize] += 1;
                    }
                }
            }
            self.active += k as u64;
        }
    }
}

/// Adds the chunks' counts per rule (with how many agents execute any rule) to `counts`,
/// and returns how many execute any rule.
fn add_tallies(counts: &mut [u64], parts: &[(u64, Vec<u64>)]) -> u64 {
    for (_, c) in parts {
        counts.iter_mut().zip(c).for_each(|(t, k)| *t += k);
    }
    parts.iter().map(|p| p.0).sum()
}

pub(super) const OPEN: i32 = -1;

pub(super) struct PrioView<'a> {
    pub(super) fixed: &'a [i32],
    pub(super) cur: &'a [u16],
}

pub(super) struct SelEnv<'a> {
    pub(super) lat: &'a Lattice,
    pub(super) a: u32,
    pub(super) prio: Option<PrioView<'a>>,
}

impl Env for SelEnv<'_> {
    #[inline]
    fn counter(&self, i: u8) -> i32 {
        self.lat.counter(self.a, i)
    }
    #[inline]
    fn state(&self) -> [u8; 5] {
        self.lat.state[self.a as usize]
    }
    #[inline]
    fn attach(&self) -> u8 {
        self.lat.attach[self.a as usize]
    }
    #[inline]
    fn cell(&self, off: [i32; 3]) -> Cell {
        self.lat.cell_at(self.lat.pos[self.a as usize], off)
    }
    #[inline]
    fn agent_state(&self, id: u32) -> [u8; 5] {
        self.lat.state[id as usize]
    }
    #[inline]
    fn agent_counter(&self, id: u32, i: u8) -> i32 {
        self.lat.counter(id, i)
    }
    #[inline]
    fn inbox_num(&self, dir: u8, slot: u8) -> i32 {
        self.lat.inbox(self.a, dir, slot)
    }
    #[inline]
    fn inbox_text(&self, dir: u8) -> Option<[u8; 5]> {
        self.lat.inbox_text(self.a, dir)
    }
    #[inline]
    fn priorities_known(&self) -> bool {
        self.prio.is_some()
    }
    #[inline]
    fn prio(&self, other: Option<u32>, p: u16, strict: bool) -> Tri {
        let Some(view) = &self.prio else {
            return Tri::U;
        };
        let Some(b) = other else { return Tri::T };
        let b = b as usize;
        if view.fixed[b] != OPEN {
            let f = view.fixed[b];
            Tri::of(if strict { f < p as i32 } else { f <= p as i32 })
        } else if !strict || view.cur[b] < p {
            // An open neighbour ends at or below its current priority, which is <= p.
            Tri::T
        } else {
            Tri::U
        }
    }
    #[inline]
    fn dirs(&self) -> u8 {
        self.lat.dim.dirs() as u8
    }
    #[inline]
    fn neighbour_cell(&self, d: u8) -> Cell {
        self.lat.neighbour_cell(self.a, d as usize)
    }
}

/// The selection with priorities in the making: per agent its valid rules (`rule`, `tri`,
/// from `start[a]` to `start[a + 1]`), its fixed priority ([`OPEN`] while open) and the
/// priority it is tried at (`cur`); the open agents per level; which are queued.
pub(super) struct Entries {
    rule: Vec<u32>,
    tri: Vec<Tri>,
    start: Vec<u32>,
    fixed: Vec<i32>,
    cur: Vec<u16>,
    levels: BTreeMap<u16, Vec<u32>>,
    queued: Vec<bool>,
}

/// The message of a circle of priorities: its agents (by their ids in the agents file,
/// ascending), its level and its rules.
fn circle_message(lat: &Lattice, circle: &[u32], names: &[String], p: u16) -> String {
    format!(
        "the priorities of agents {} depend on each other in a circle at priority {p}; their rules {} are not executed",
        lat.ids_text(circle),
        names.iter().map(|n| format!("`{n}`")).collect::<Vec<_>>().join(", ")
    )
}

/// An open agent left with no rule at its level drops to its next valid priority `next`
/// (to be resolved at that level), or, with none left, is fixed at priority 0.
pub(super) fn drop_to(
    a: u32,
    next: Option<u16>,
    fixed: &mut [i32],
    cur: &mut [u16],
    levels: &mut BTreeMap<u16, Vec<u32>>,
) {
    let ai = a as usize;
    match next {
        Some(q) => {
            cur[ai] = q;
            levels.entry(q).or_default().push(a);
        }
        None => {
            fixed[ai] = 0;
            cur[ai] = 0;
        }
    }
}

impl Selector {
    /// Selection when no rule reads priorities: each agent executes its true rules of the
    /// highest priority among its true rules. Agents whose candidate list decides alone are
    /// not evaluated at all.
    fn select_plain(
        &mut self,
        (prog, plan, lat): (&Program, &Plan, &Lattice),
        dispatch: &Dispatch,
        th: &Threads,
    ) {
        let n = lat.len();
        let mut one = std::mem::take(&mut self.sel.one);
        // Every entry is written below (a new column is zeroed lazily by the system, and
        // its pages are touched by the chunks, in parallel), but those of a fresh
        // selection that stay `NO_RULE`: the first step over many agents at rest does not
        // write their entries back to memory.
        let fresh = self.sel.fresh && one.len() == n;
        if one.len() != n {
            one = vec![0; n];
        }
        let trivial = &plan.trivial;
        let (lists, single, of) = (&dispatch.lists, &dispatch.single, &dispatch.of);
        let (par, chunk, _) = th.chunks(n);
        let pre_columns = &plan.pre_columns;
        let rules = self.fire_counts.len();
        // Listed only when few executed a rule in the last selection too: a step of many
        // would list the first eighth of each chunk in vain (2.5 % of B2's time).
        let few = self.active as usize <= n / SPARSE_SHARE;
        let (columnar, one_rule) = (&dispatch.columnar, &dispatch.one_rule);
        let work = |(c, one): (usize, &mut [u32])| {
            let lo = c * chunk;
            let mut multi: Vec<(u32, Vec<u32>)> = Vec::new();
            let mut buf: Vec<u32> = Vec::new();
            let mut evaluated = false;
            let mut truth = [false; BATCH];
            let mut bufs = Kept::<PreBufs>::take();
            let mut win = Window::default();
            let hi = lo + one.len();
            // The chunk's firings, counted part by part, and its agents that execute a
            // rule when they are few (the phases after visit only those: see
            // `Selection::found`).
            let cap = if few { one.len() / SPARSE_SHARE } else { 0 };
            let mut tally = (rules <= TALLIED).then(|| Tally::new(rules, cap));
            let (mut k, mut tallied) = (0, 0);
            let mut at = 0;
            // Whether an entry of the part not yet tallied may not be `NO_RULE` (a fresh
            // selection's part of none is not read to be tallied).
            let mut touched = !fresh;
            while k < one.len() {
                if k - tallied >= TALLY_PART {
                    if let Some(t) = tally.as_mut().filter(|_| touched) {
                        t.add((&one[tallied..k], lo + tallied), !multi.is_empty());
                    }
                    (tallied, touched) = (k, !fresh);
                }
                // The agents whose candidate list decides alone, in a tight loop up to
                // the next agent to evaluate (or the next part to tally).
                let mut limit = (tallied + 2 * TALLY_PART).min(one.len());
                // A run the dispatch gave one list this step, decided by it alone: its
                // entries at once, its lists not read again (agents in a state no rule
                // tests, beside others); the loop below stops where the next run starts.
                match dispatch.run_from(&mut at, lo + k) {
                    Some((first, end)) if first <= lo + k => {
                        let r = single[of[lo + k].index()];
                        if r != EVALUATE {
                            let end = (end - lo).min(limit);
                            if !fresh || r != NO_RULE {
                                one[k..end].fill(r);
                                touched = true;
                            }
                            k = end;
                            continue;
                        }
                    }
                    Some((first, _)) => limit = limit.min(first - lo),
                    None => {}
                }
                let run = one[k..limit].iter_mut().zip(&of[lo + k..lo + limit]);
                let decided = if fresh {
                    run.into_iter()
                        .position(|(slot, &idx)| match single[idx.index()] {
                            EVALUATE => true,
                            NO_RULE => false,
                            r => {
                                (*slot, touched) = (r, true);
                                false
                            }
                        })
                } else {
                    run.into_iter()
                        .position(|(slot, &idx)| match single[idx.index()] {
                            EVALUATE => true,
                            r => {
                                *slot = r;
                                false
                            }
                        })
                };
                let Some(skip) = decided else {
                    k = limit;
                    continue;
                };
                k += skip;
                let a = lo + k;
                let idx = of[a].index();
                evaluated = true;
                // A run of agents with the same one rule to test: evaluated together.
                if let [r] = lists[idx][..] {
                    if let Some(pre) = &pre_columns[r as usize] {
                        // The agents next in line with this list, or another state's
                        // list of just this rule or one that tests the same (agents of
                        // several states mixed in any order still go together).
                        let class = one_rule[idx].0;
                        let next = &of[a..(a + BATCH).min(hi)];
                        // (A run the dispatch gave one list this step is not read again.)
                        let same = match dispatch.run_from(&mut at, a) {
                            Some((first, end)) if first <= a => (end - a).min(next.len()),
                            _ => run_of(next, of[a]),
                        };
                        let m = same
                            + (next[same..].iter())
                                .take_while(|&&o| one_rule[o.index()].0 == class)
                                .count();
                        // (A short run among agents of other lists, in states mixed
                        // one by one, goes with them in a window, below.)
                        if m >= SHORT_RUN || !columnar[idx] {
                            let rows = (&pre[..], Rows::Run(a));
                            batch_pre(prog, rows, lat, &mut bufs, &mut truth[..m]);
                            let run = one[k..k + m].iter_mut().zip(&truth[..m]);
                            if fresh && !truth[..m].contains(&true) {
                                // (Entries that stay `NO_RULE`.)
                            } else if same == m {
                                touched = true;
                                // (One list: a loop the compiler vectorises.)
                                for (slot, &t) in run {
                                    *slot = if t { r } else { NO_RULE };
                                }
                            } else {
                                touched = true;
                                for ((slot, &t), &o) in run.zip(next) {
                                    *slot = if t { one_rule[o.index()].1 } else { NO_RULE };
                                }
                            }
                            k += m;
                            continue;
                        }
                    }
                }
                // A window of agents whose lists of several rules the column interpreter
                // runs (and agents decided alone among them): each list's agents together.
                if columnar[idx] {
                    let rules = (prog, plan, dispatch);
                    let agents = (|j: usize| (lo + j) as u32, k, (hi - lo).min(k + BATCH));
                    let set = |a: u32, e| one[a as usize - lo] = e;
                    let scratch = (&mut *bufs, &mut win);
                    k = eval_window(rules, lat, agents, set, scratch, &mut multi);
                    touched = true;
                    continue;
                }
                one[k] = eval_one(prog, (trivial, &lists[idx]), lat, a, (&mut buf, &mut multi));
                (k, touched) = (k + 1, true);
            }
            let (counted, chosen) = match tally {
                Some(mut t) => {
                    if touched {
                        t.add((&one[tallied..], lo + tallied), !multi.is_empty());
                    }
                    (Some(((t.active, t.counts), t.listing)), t.chosen)
                }
                None => (None, Vec::new()),
            };
            (multi, evaluated, counted, chosen)
        };
        let parts: Vec<_> = map_on(par, one.chunks_mut(chunk).enumerate().collect(), work);
        self.sel.one = one;
        self.sel.starts.clear();
        self.sel.many.clear();
        self.sel.listed = false;
        self.by_state = true;
        let mut counted = Vec::with_capacity(parts.len());
        let mut found = Vec::with_capacity(parts.len());
        let mut all_found = rules <= TALLIED;
        for (multi, evaluated, count, chosen) in parts {
            self.by_state &= !evaluated;
            for (a, rules) in multi {
                self.sel.set(a as usize, &rules);
            }
            if let Some((count, all)) = count {
                counted.push(count);
                all_found &= all;
            }
            found.push(chosen);
        }
        self.sel.list.clear();
        if all_found {
            found
                .iter()
                .for_each(|c| self.sel.list.extend_from_slice(c));
        }
        self.sel.found = all_found;
        if rules <= TALLIED {
            self.fire_counts.fill(0);
            self.active = add_tallies(&mut self.fire_counts, &counted);
            self.counted = true;
        }
    }
}

/// Scratch of [`eval_window`], kept for a chunk: per candidate list met, its agents; per
/// agent of one list, its entry and which rules of a priority level are true.
#[derive(Default)]
struct Window {
    groups: Vec<(usize, Vec<u32>)>,
    entry: Vec<u32>,
    mask: Vec<u32>,
    several: Vec<(u32, Vec<u32>)>,
    /// The agents of a group no level has decided yet, and their places in the group.
    open: Vec<u32>,
    at: Vec<u32>,
    /// Per candidate list, its group (or `u32::MAX`): the lists do not change during a
    /// selection, which this window is made for.
    slot: Vec<u32>,
}

/// Evaluates the agents `agent(k)`, ..., `agent(end - 1)` (of a chunk of agents, or of a
/// list of them), each entry written by `set(agent, entry)`, from the first, as far as each
/// is decided by its candidate list alone (the dispatch's `single`) or has a `columnar` list: the agents of each list together, priority level by level (each
/// rule's precondition over them by [`batch_pre`], state-only rules true), each agent
/// taking its true rules of the first level that has any, as [`eval_one`] does (agents of
/// several states with several rules each, mixed in any order: the bouncing example's
/// dots were evaluated one at a time). Returns where it stopped.
fn eval_window(
    (prog, plan, dispatch): (&Program, &Plan, &Dispatch),
    lat: &Lattice,
    (agent, k, end): (impl Fn(usize) -> u32, usize, usize),
    mut set: impl FnMut(u32, u32),
    (bufs, w): (&mut PreBufs, &mut Window),
    multi: &mut Vec<(u32, Vec<u32>)>,
) -> usize {
    let (lists, single, columnar, of) = (
        &dispatch.lists,
        &dispatch.single,
        &dispatch.columnar,
        &dispatch.of,
    );
    let (trivial, pre_columns) = (&plan.trivial, &plan.pre_columns);
    // (Lists are looked up among at most `GROUPS`: a window ends at one more.)
    const GROUPS: usize = 64;
    if w.groups.len() > GROUPS {
        for g in &w.groups {
            w.slot[g.0] = u32::MAX;
        }
        w.groups.clear();
    }
    if w.slot.len() < lists.len() {
        w.slot.resize(lists.len(), u32::MAX);
    }
    w.groups.iter_mut().for_each(|g| g.1.clear());
    let mut stop = end;
    for j in k..end {
        let a = agent(j);
        let idx = of[a as usize].index();
        match single[idx] {
            EVALUATE if columnar[idx] => match w.slot[idx] {
                u32::MAX if j > k && w.groups.len() >= GROUPS => {
                    stop = j;
                    break;
                }
                u32::MAX => {
                    w.slot[idx] = w.groups.len() as u32;
                    w.groups.push((idx, vec![a]));
                }
                g => w.groups[g as usize].1.push(a),
            },
            EVALUATE => {
                stop = j;
                break;
            }
            r => set(a, r),
        }
    }
    let mut truth = [false; BATCH];
    for (idx, ids) in &w.groups {
        let m = ids.len();
        if m == 0 {
            continue;
        }
        w.entry.clear();
        w.entry.resize(m, NO_RULE);
        // Each level evaluates only the agents the levels before left open (the bouncing
        // example's dots mostly fly: its first level decides about half of them), listed
        // (`open`, with their places in the group, `at`) from the first level that decides
        // any: all of `ids` until then.
        let mut listed = false;
        for level in levels(prog, &lists[*idx]) {
            let k = if listed { w.open.len() } else { m };
            if k == 0 {
                break;
            }
            let open: &[u32] = if listed { &w.open } else { ids };
            w.mask.clear();
            w.mask.resize(k, 0);
            for (b, &r) in level.iter().enumerate() {
                match &pre_columns[r as usize] {
                    _ if trivial[r as usize] => truth[..k].fill(true),
                    Some(pre) => {
                        batch_pre(prog, (pre, Rows::Ids(open)), lat, bufs, &mut truth[..k])
                    }
                    None => unreachable!("a columnar list's rules run as columns"),
                }
                for (mask, &t) in w.mask.iter_mut().zip(&truth[..k]) {
                    *mask |= (t as u32) << b;
                }
            }
            let decided = w.mask.iter().filter(|&&mask| mask != 0).count();
            if decided == 0 {
                continue;
            }
            if !listed {
                w.open.clear();
                w.open.extend_from_slice(ids);
                w.at.clear();
                w.at.extend(0..m as u32);
                listed = true;
            }
            // Where a level decides many agents (in states mixed at random), without a
            // branch on whether an agent is decided, which would be mispredicted; where it
            // decides few, with one (predicted).
            let (mut kept, last, many) = (0, level.len() - 1, decided * 4 >= k);
            for i in 0..k {
                let (mask, j) = (w.mask[i], w.at[i] as usize);
                (w.open[kept], w.at[kept]) = (w.open[i], w.at[i]);
                kept += usize::from(mask == 0);
                if many {
                    let r = level[(mask.trailing_zeros() as usize).min(last)];
                    // (`NO_RULE` has every bit set: or-ed in when no rule is true.)
                    w.entry[j] = r | u32::from(mask == 0).wrapping_neg();
                } else if mask != 0 {
                    w.entry[j] = level[(mask.trailing_zeros() as usize).min(last)];
                }
                if mask & mask.wrapping_sub(1) != 0 {
                    let mut rs: Vec<u32> = (0..level.len())
                        .filter(|&b| mask >> b & 1 != 0)
                        .map(|b| level[b])
                        .collect();
                    rs.sort_unstable();
                    w.several.push((ids[j], rs));
                    w.entry[j] = MANY;
                }
            }
            w.open.truncate(kept);
            w.at.truncate(kept);
        }
        for (&a, &e) in ids.iter().zip(&w.entry) {
            set(a, e);
        }
    }
    // (In agent order, as the selection sets them.)
    w.several.sort_unstable_by_key(|s| s.0);
    multi.append(&mut w.several);
    stop
}

/// The entry of agent `a` whose candidate list `list` must be evaluated: its true rules of
/// the highest priority among them ([`MANY`] with the rules pushed to `multi`, in file
/// order, when there are several; `buf` is scratch).
#[inline]
fn eval_one(
    prog: &Program,
    (trivial, list): (&[bool], &[u32]),
    lat: &Lattice,
    a: usize,
    (buf, multi): (&mut Vec<u32>, &mut Vec<(u32, Vec<u32>)>),
) -> u32 {
    let env = SelEnv {
        lat,
        a: a as u32,
        prio: None,
    };
    buf.clear();
    let mut top = None;
    for &r in list {
        let p = prog.rules[r as usize].priority;
        if top.is_some_and(|t| p < t) {
            break;
        }
        if trivial[r as usize] || eval_pre(prog, r as usize, &env) == Tri::T {
            top = Some(p);
            buf.push(r);
        }
    }
    match buf[..] {
        [] => NO_RULE,
        [r] => r,
        _ => {
            buf.sort_unstable();
            multi.push((a as u32, buf.clone()));
            MANY
        }
    }
}

/// Entries of a column written from several threads, each at its own indices (the column
/// stays borrowed while the `Scatter` lives).
struct Scatter<'a, T>(*mut T, usize, std::marker::PhantomData<&'a mut [T]>);

// SAFETY: a `Scatter` is only written through `set`, whose callers write distinct indices
// from different threads (each index is one agent of a list without repeats).
unsafe impl<T: Send> Sync for Scatter<'_, T> {}
unsafe impl<T: Send> Send for Scatter<'_, T> {}

impl<'a, T> Scatter<'a, T> {
    fn new(v: &'a mut [T]) -> Scatter<'a, T> {
        Scatter(v.as_mut_ptr(), v.len(), std::marker::PhantomData)
    }

    /// Entry `i`.
    ///
    /// # Safety
    /// No other thread writes entry `i` while the `Scatter` lives.
    #[inline]
    unsafe fn get(&self, i: usize) -> T
    where
        T: Copy,
    {
        assert!(i < self.1, "an index inside the column");
        // SAFETY: in bounds (checked), and no other thread writes entry `i` (the caller's
        // promise).
        unsafe { self.0.add(i).read() }
    }

    /// Writes entry `i`.
    ///
    /// # Safety
    /// No other thread reads or writes entry `i` while the `Scatter` lives.
    #[inline]
    unsafe fn set(&self, i: usize, v: T) {
        assert!(i < self.1, "an index inside the column");
        // SAFETY: in bounds (checked), and no other thread touches entry `i` (the caller's
        // promise).
        unsafe { self.0.add(i).write(v) }
    }
}

impl Selector {
    /// [`Selector::select_plain`] for the agents of `list` (in id order) alone: every other
    /// agent keeps its entry, which is [`NO_RULE`] (see `activity.rs`). Makes the
    /// selection's list of the agents that execute a rule.
    fn select_listed(
        &mut self,
        (prog, plan, lat): (&Program, &Plan, &Lattice),
        dispatch: &Dispatch,
        th: &Threads,
        list: &[u32],
    ) {
        let trivial = &plan.trivial;
        let (lists, single, of) = (&dispatch.lists, &dispatch.single, &dispatch.of);
        let (pre_columns, one_rule) = (&plan.pre_columns, &dispatch.one_rule);
        let columnar = &dispatch.columnar;
        let one = Scatter::new(&mut self.sel.one);
        let work = |lo: usize, hi: usize| {
            let ids = &list[lo..hi];
            let mut multi: Vec<(u32, Vec<u32>)> = Vec::new();
            let mut chosen: Vec<u32> = Vec::new();
            let mut buf: Vec<u32> = Vec::new();
            let mut truth = [false; BATCH];
            let mut bufs = Kept::<PreBufs>::take();
            let mut win = Window::default();
            let mut k = 0;
            // SAFETY (every `set` below): the agents of `list` are distinct, and each
            // chunk writes only its own agents' entries.
            while k < ids.len() {
                let a = ids[k] as usize;
                let idx = of[a].index();
                match single[idx] {
                    EVALUATE => {}
                    r => {
                        unsafe { one.set(a, r) };
                        if r != NO_RULE {
                            chosen.push(a as u32);
                        }
                        k += 1;
                        continue;
                    }
                }
                // Agents next in the list with the same one rule to test: evaluated
                // together, their columns gathered.
                if let [r] = lists[idx][..] {
                    if let Some(pre) = &pre_columns[r as usize] {
                        let next = &ids[k..(k + BATCH).min(ids.len())];
                        // Consecutive ids of one list (a row of walkers): one entry for all,
                        // found without reading each agent's list (the list is in id order
                        // without repeats). Else, with the lists of one rule that tests the
                        // same, agent by agent.
                        let last = next.len() - 1;
                        let list = of[a].0;
                        let same = next[last] as usize - a == last
                            && of[a..=a + last].iter().fold(true, |s, l| s & (l.0 == list));
                        let class = one_rule[idx].0;
                        let m = match same {
                            true => next.len(),
                            false => (next.iter())
                                .take_while(|&&b| one_rule[of[b as usize].index()].0 == class)
                                .count(),
                        };
                        // (Agents of consecutive ids are read as a run, without gathering.)
                        let rows = if next[m - 1] as usize - a == m - 1 {
                            Rows::Run(a)
                        } else {
                            Rows::Ids(&next[..m])
                        };
                        batch_pre(prog, (pre, rows), lat, &mut bufs, &mut truth[..m]);
                        let entry = one_rule[idx].1;
                        let valid = next[..m].iter().zip(&truth[..m]).map(|(&b, &t)| {
                            // (Without a branch on the agent's list: states mixed one by one
                            // would mislead its prediction.)
                            let e = match (t, same) {
                                (false, _) => NO_RULE,
                                (true, true) => entry,
                                (true, false) => one_rule[of[b as usize].index()].1,
                            };
                            unsafe { one.set(b as usize, e) };
                            (b, t)
                        });
                        extend_kept(&mut chosen, valid);
                        k += m;
                        continue;
                    }
                }
                // A window of agents whose lists of several rules the column interpreter
                // runs, as in `select_plain` (one by one, 29 ns an agent where a window
                // of walkers took 6), and in id order into `chosen`.
                if columnar[idx] {
                    let rules = (prog, plan, dispatch);
                    let agents = (|j: usize| ids[j], k, ids.len().min(k + BATCH));
                    let set = |b: u32, e| unsafe { one.set(b as usize, e) };
                    let scratch = (&mut *bufs, &mut win);
                    let stop = eval_window(rules, lat, agents, set, scratch, &mut multi);
                    // SAFETY: this chunk's own agents, just written.
                    let chosen_now = ids[k..stop]
                        .iter()
                        .filter(|&&b| unsafe { one.get(b as usize) } != NO_RULE);
                    chosen.extend(chosen_now);
                    k = stop;
                    continue;
                }
                let e = eval_one(prog, (trivial, &lists[idx]), lat, a, (&mut buf, &mut multi));
                unsafe { one.set(a, e) };
                if e != NO_RULE {
                    chosen.push(a as u32);
                }
                k += 1;
            }
            (multi, chosen)
        };
        let parts = th.par_chunks(list.len(), &work);
        let sel = &mut self.sel;
        sel.starts.clear();
        sel.many.clear();
        sel.list.clear();
        for (multi, chosen) in parts {
            for (a, rules) in multi {
                sel.set(a as usize, &rules);
            }
            sel.list.extend(chosen);
        }
        sel.listed = true;
        self.by_state = false;
    }
}

/// The program, its plan and the lattice, as the selection with priorities reads them.
struct Prio<'a> {
    prog: &'a Program,
    plan: &'a Plan,
    lat: &'a Lattice,
}

impl Prio<'_> {
    /// Selection when rules read neighbours' priorities: a first pass with priorities
    /// unknown, then the levels from the top down (SEMANTICS section 5).
    /// Returns the circles of priorities found, with their messages.
    fn select(
        &self,
        sel: &mut Selection,
        dispatch: &Dispatch,
        th: &Threads,
    ) -> Vec<(Vec<u32>, String)> {
        let n = self.lat.len();
        let mut entries = self.priority_entries(dispatch, th);
        let circles = self.resolve_levels(&mut entries);
        let prog = &self.prog;
        let Entries {
            rule: ent_rule,
            tri: ent_tri,
            start: ent_start,
            fixed,
            ..
        } = entries;
        // Each agent executes its rules that are true at its final priority, in file order.
        sel.reset(n);
        let mut rules = Vec::new();
        for a in 0..n {
            let f = fixed[a];
            if f > 0 {
                rules.clear();
                for k in ent_start[a] as usize..ent_start[a + 1] as usize {
                    if prog.rules[ent_rule[k] as usize].priority as i32 == f && ent_tri[k] == Tri::T
                    {
                        rules.push(ent_rule[k]);
                    }
                }
                rules.sort_unstable();
                sel.set(a, &rules);
            }
        }
        circles
    }

    /// Pass 1 of the selection with priorities: every agent's valid rules with priority
    /// terms unknown, the agents whose priority is fixed at once, and the levels of the
    /// others.
    fn priority_entries(&self, dispatch: &Dispatch, th: &Threads) -> Entries {
        let n = self.lat.len();
        let prog = &self.prog;
        let mut ent_rule: Vec<u32> = Vec::with_capacity(n);
        let mut ent_tri: Vec<Tri> = Vec::with_capacity(n);
        let mut ent_start: Vec<u32> = Vec::with_capacity(n + 1);
        let mut fixed = vec![OPEN; n];
        let mut cur = vec![0u16; n];
        let mut levels: BTreeMap<u16, Vec<u32>> = BTreeMap::new();
        let queued = vec![false; n];
        ent_start.push(0);
        let (lists, of) = (&dispatch.lists, &dispatch.of);
        // Pass 1: every agent's valid rules with priority terms unknown, in chunks of
        // agents (in parallel with --threads), joined in agent order.
        let lat = &self.lat;
        let pass1 = |lo: usize, hi: usize| {
            let mut rules_out = Vec::new();
            let mut tris = Vec::new();
            let mut ends = Vec::with_capacity(hi - lo);
            for a in lo..hi {
                let env = SelEnv {
                    lat,
                    a: a as u32,
                    prio: None,
                };
                for &r in &lists[of[a].index()] {
                    let t = eval_pre(prog, r as usize, &env);
                    if t != Tri::F {
                        rules_out.push(r);
                        tris.push(t);
                    }
                }
                ends.push(rules_out.len() as u32);
            }
            (rules_out, tris, ends)
        };
        let parts = th.par_chunks(n, &pass1);
        for (rules_out, tris, ends) in parts {
            let base = ent_rule.len() as u32;
            ent_start.extend(ends.iter().map(|e| base + e));
            ent_rule.extend(rules_out);
            ent_tri.extend(tris);
        }
        for a in 0..n {
            let (start, end) = (ent_start[a] as usize, ent_start[a + 1] as usize);
            if start == end {
                fixed[a] = 0;
                continue;
            }
            let p = prog.rules[ent_rule[start] as usize].priority;
            cur[a] = p;
            let top = (start..end).take_while(|&e| prog.rules[ent_rule[e] as usize].priority == p);
            let mut any_t = false;
            let mut any_u = false;
            for e in top {
                any_t |= ent_tri[e] == Tri::T;
                any_u |= ent_tri[e] == Tri::U;
            }
            if any_t {
                fixed[a] = p as i32;
            }
            if any_u {
                levels.entry(p).or_default().push(a as u32);
            }
        }
        Entries {
            rule: ent_rule,
            tri: ent_tri,
            start: ent_start,
            fixed,
            cur,
            levels,
            queued,
        }
    }

    /// Agent `a`'s rules at level `p` (its entries `range`) evaluated again with the
    /// priorities known so far; its priority fixed at `p` when one is true. Whether any of
    /// them may still hold.
    #[inline]
    fn eval_at_level(
        &self,
        (a, p): (u32, u16),
        (ent_rule, ent_tri, range): (&[u32], &mut [Tri], std::ops::Range<usize>),
        fixed: &mut [i32],
        cur: &[u16],
    ) -> bool {
        let prog = &self.prog;
        let ai = a as usize;
        let mut alive = false;
        for k in range {
            if prog.rules[ent_rule[k] as usize].priority != p {
                continue;
            }
            if ent_tri[k] == Tri::U {
                let env = SelEnv {
                    lat: self.lat,
                    a,
                    prio: Some(PrioView { fixed, cur }),
                };
                let v = eval_pre(prog, ent_rule[k] as usize, &env);
                if v != Tri::U {
                    ent_tri[k] = v;
                }
            }
            if ent_tri[k] == Tri::T && fixed[ai] == OPEN {
                fixed[ai] = p as i32;
            }
            alive |= ent_tri[k] != Tri::F;
        }
        alive
    }

    /// The levels from the top down (SEMANTICS section 5): each open agent's priority
    /// fixed; the circles of priorities found, with their messages.
    fn resolve_levels(&self, e: &mut Entries) -> Vec<(Vec<u32>, String)> {
        let Entries {
            rule: ent_rule,
            tri: ent_tri,
            start: ent_start,
            fixed,
            cur,
            levels,
            queued,
        } = e;
        let (ent_rule, ent_start) = (&*ent_rule, &*ent_start);
        let prog = &self.prog;
        let prio_of = |e: usize| prog.rules[ent_rule[e] as usize].priority;
        let mut circles: Vec<(Vec<u32>, String)> = Vec::new();
        while let Some((p, mut list)) = levels.pop_last() {
            list.sort_unstable();
            list.dedup();
            let at_level = |a: usize, fixed: &[i32], cur: &[u16]| {
                (fixed[a] == OPEN && cur[a] == p) || fixed[a] == p as i32
            };
            // A worklist: every agent of the level once, then again only when an agent
            // whose priority it may read was fixed or dropped (the same fixpoint as
            // re-evaluating the whole level until nothing changes).
            let mut queue: std::collections::VecDeque<u32> = list.iter().copied().collect();
            for &a in &list {
                queued[a as usize] = true;
            }
            while let Some(a) = queue.pop_front() {
                let ai = a as usize;
                queued[ai] = false;
                if !at_level(ai, fixed, cur) {
                    continue;
                }
                let before = (fixed[ai], cur[ai]);
                let (s, e) = (ent_start[ai] as usize, ent_start[ai + 1] as usize);
                let alive = self.eval_at_level((a, p), (ent_rule, ent_tri, s..e), fixed, cur);
                if fixed[ai] == OPEN && !alive {
                    let next = (s..e)
                        .find(|&k| prio_of(k) < p && ent_tri[k] != Tri::F)
                        .map(prio_of);
                    drop_to(a, next, fixed, cur, levels);
                }
                if (fixed[ai], cur[ai]) != before {
                    let mut wake = |b: u32| {
                        let bi = b as usize;
                        if b != NO_AGENT && !queued[bi] && at_level(bi, fixed, cur) {
                            queued[bi] = true;
                            queue.push_back(b);
                        }
                    };
                    match &self.plan.prio_offsets {
                        Some(offs) => {
                            let mut nb = [NO_AGENT; 6];
                            self.lat.neighbours(a, &mut nb);
                            nb.iter().for_each(|&b| wake(b));
                            for off in offs {
                                let back = [-off[0], -off[1], -off[2]];
                                if let Cell::Agent(b) = self.lat.cell_at(self.lat.pos[ai], back) {
                                    wake(b);
                                }
                            }
                        }
                        None => list.iter().for_each(|&b| wake(b)),
                    }
                }
            }
            // What is still unknown depends on itself in a circle: remove it all.
            let mut circle: Vec<u32> = Vec::new();
            let mut names: Vec<String> = Vec::new();
            for &a in &list {
                let ai = a as usize;
                if !at_level(ai, fixed, cur) {
                    continue;
                }
                let (s, e) = (ent_start[ai] as usize, ent_start[ai + 1] as usize);
                let mut hit = false;
                for k in s..e {
                    if prio_of(k) == p && ent_tri[k] == Tri::U {
                        ent_tri[k] = Tri::F;
                        hit = true;
                        let name = &prog.rules[ent_rule[k] as usize].name;
                        if !names.contains(name) {
                            names.push(name.clone());
                        }
                    }
                }
                if hit {
                    circle.push(a);
                    if fixed[ai] == OPEN {
                        let next = (s..e)
                            .find(|&k| prio_of(k) < p && ent_tri[k] != Tri::F)
                            .map(prio_of);
                        drop_to(a, next, fixed, cur, levels);
                    }
                }
            }
            if !circle.is_empty() {
                let msg = circle_message(self.lat, &circle, &names, p);
                circles.push((circle, msg));
            }
        }
        circles
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Listing while tallying, part by part, gives the counts of [`tally`], and, when the
    /// agents that execute a rule are at most the cap, exactly those agents: whatever the
    /// rules, the agents executing several ([`MANY`]), the parts, the first agent and the
    /// cap.
    #[test]
    fn tally_in_parts_lists_and_counts_as_tally_does() {
        let mut rng = crate::shapes::Rng::new(0x9E37_79B9_7F4A_7C15u64);
        let mut next = move || rng.next_u64();
        for case in 0..400 {
            let (len, rules) = (next() as usize % 700, 1 + case % 6);
            let share = 1 + next() % 40;
            let many = case % 3 == 0;
            let one: Vec<u32> = (0..len)
                .map(|_| match next() % 100 {
                    k if k >= share => NO_RULE,
                    _ if many && next() % 4 == 0 => MANY | (next() % 8) as u32,
                    _ => (next() % rules as u64) as u32,
                })
                .collect();
            let lo = next() as usize % 1000;
            let cap = next() as usize % (len / 4 + 2);
            let mut want = vec![0; rules];
            let active = tally(&one, &mut want, many);
            // Taken in parts of any lengths, as a chunk's entries are decided.
            let mut t = Tally::new(rules, cap);
            let mut at = 0;
            while at < len {
                let end = (at + next() as usize % 90).min(len);
                t.add((&one[at..end], lo + at), many);
                at = end;
            }
            let (k, got, all, chosen) = (t.active, t.counts, t.listing, t.chosen);
            assert_eq!((k, &got), (active, &want), "case {case}");
            let executing: Vec<u32> = (0..len)
                .filter(|&i| one[i] != NO_RULE)
                .map(|i| (lo + i) as u32)
                .collect();
            assert_eq!(all, executing.len() <= cap, "case {case}");
            if all {
                assert_eq!(chosen, executing, "case {case}");
            }
        }
    }
}
