//! The synchronous step: selection with priorities, actions, calculations and the post
//! office, exactly as `../shared/SEMANTICS.md` section 5 defines them. Every phase visits
//! agents in id order, so a run is deterministic.

// The step works on parallel columns indexed by agent id and direction; index loops say
// that more plainly than zipped iterators over five columns.
#![allow(clippy::needless_range_loop)]

use crate::bits::{all_bits, clear_bits, is_sequence, no_bits, ones, run_of, set_bits};
use crate::cells::{NO_SLOT, RIM};
use crate::lattice::Lattice;
use crate::lattice::{Pending, Undo, Writes, NO_AGENT, NO_COL};
use crate::record::{Record, RecordKind};
use crate::trace::TraceEvent;
use latticesim_vm::eval::{eval_pre, run_post, CalcEnv, CalcIssue, Cell, Env, Tri};
use latticesim_vm::model::{AttachLetter, CalcOp, CmpOp, Coord, Dir, TextPat};
use latticesim_vm::op::{Op, Target, Val, ANY_DIR};
use latticesim_vm::{Program, Verified};
use rustc_hash::FxHashMap;
use std::collections::BTreeMap;

/// Which of the paper's steps 2 and 3 comes first.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Order {
    /// Actions, then calculations and messages (the paper's order).
    #[default]
    ActionsFirst,
    /// Calculations and messages, then actions.
    MessagesFirst,
}

/// How a run steps.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Options {
    /// The order of actions and messages.
    pub order: Order,
    /// Rules without a position change (no `P`, no `X`) perform their actions before the
    /// rules with one, in a separate pass.
    pub static_first: bool,
    /// Collect trace events.
    pub trace: bool,
    /// Threads for the per-agent work (0 or 1: none); the results do not depend on it.
    pub threads: usize,
}

/// Counts over a run.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct Stats {
    /// Steps done.
    pub steps: u64,
    /// Whether the last step had no selected rule.
    pub quiescent: bool,
    /// Executions per rule (file order).
    pub firings: Vec<u64>,
    /// Agent moves (each agent of a moved group counts).
    pub moves: u64,
    /// Swaps done.
    pub swaps: u64,
    /// Messages sent (each direction of a numeric slot or text counts).
    pub sent: u64,
    /// Messages delivered.
    pub delivered: u64,
    /// Messages dropped (no agent in that direction).
    pub dropped: u64,
    /// Records by kind.
    pub records: BTreeMap<RecordKind, u64>,
}

impl Stats {
    /// Error records so far.
    pub fn errors(&self) -> u64 {
        self.records
            .iter()
            .filter(|(k, _)| k.is_error())
            .map(|(_, n)| n)
            .sum()
    }

    /// Warning records so far.
    pub fn warnings(&self) -> u64 {
        self.records
            .iter()
            .filter(|(k, _)| !k.is_error())
            .map(|(_, n)| n)
            .sum()
    }
}

/// What one step did.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct StepReport {
    /// No agent had a selected rule.
    pub quiescent: bool,
    /// The records of this step.
    pub records: Vec<Record>,
    /// The trace events of this step (when tracing).
    pub trace: Vec<TraceEvent>,
}

/// A program running on a lattice.
pub struct Engine {
    /// The compiled rules.
    pub prog: Verified,
    /// The agents. Their states may be read at any time; change them only through the
    /// engine's steps (the rule dispatch remembers each agent's state).
    pub lat: Lattice,
    /// How it steps.
    pub opts: Options,
    /// Counts so far.
    pub stats: Stats,
    by_prio: Vec<u32>,
    /// Per state seen so far: the index in `cand_lists` of the rules (in `by_prio` order)
    /// whose state filter it passes.
    candidates: FxHashMap<u64, u32>,
    /// A small direct-mapped cache in front of `candidates`: (state key + 1, list).
    cand_cache: Vec<(u64, u32)>,
    /// The candidate lists, indexed by `candidates`' values.
    cand_lists: Vec<Vec<u32>>,
    /// Per candidate list: the one rule every agent with it executes, when the list's
    /// first rule needs nothing but the state filter and no other rule shares its priority.
    cand_single: Vec<u32>,
    /// Per candidate list: its state as a key ([`state_key`]), and where its one
    /// state-only rule takes an agent (found when first needed).
    cand_keys: Vec<u64>,
    cand_hop: Vec<Hop>,
    /// Per candidate list: how many agents took its hop in this step's actions (their
    /// firing counts are moved after the actions).
    cand_hopped: Vec<u64>,
    /// Per agent: its candidate list (`NO_LIST` after its state changed).
    cand_of: Vec<u32>,
    /// Some agent's state changed since the candidate lists were looked up, and it has
    /// no list yet.
    cand_dirty: bool,
    /// Some agent's state changed since the last selection.
    states_changed: bool,
    /// Per rule: its precondition is only its state filter (or nothing).
    trivial: Vec<bool>,
    /// Per rule: its precondition can be evaluated over a run of agents ([`batch_pre`]).
    pre_batch: Vec<bool>,
    /// Some rule reads neighbours' priorities.
    any_prio: bool,
    /// Some rule calculates or sends.
    any_computes: bool,
    /// Messages are left where their senders wrote them (see `Pending` in lattice.rs)
    /// instead of copied into inboxes: no rule moves or swaps, and no rule uses texts.
    /// The outboxes then have one more column per slot, for sends to all directions.
    defer: bool,
    /// With `defer`: per direction, a bit per agent that has a neighbour there (to count
    /// the messages delivered); made at the first delivery.
    has_nbr: Vec<Vec<u64>>,
    /// With `defer`: this step's outboxes as counted by the calculations (see
    /// [`Tally`]).
    counted: Option<Tally>,
    /// The offsets at which `L`/`Q` terms read priorities, when none depends on a counter
    /// (an agent's priority is then read only by its neighbours and by the agents at these
    /// offsets backwards); `None` when one does.
    prio_offsets: Option<Vec<[i32; 3]>>,
    /// Per rule: it has a move, swap, attachment or state action.
    has_actions: Vec<bool>,
    /// What the rules' actions are, taken together.
    acting: Acting,
    /// Per rule whose only action sets the state: that state pattern as [`pat_bits`].
    direct_bits: Vec<Option<(u64, u64)>>,
    /// Per entry of the program's offsets: its value when it has no counter in it.
    literal_offsets: Vec<Option<[i32; 3]>>,
    /// Per rule whose only action is a move by an offset without counters (not zero):
    /// that offset.
    plain_moves: Vec<Option<[i32; 3]>>,
    /// Per rule: its calculations can run on a range of agents at once (no external
    /// counters).
    batchable: Vec<bool>,
    /// The threads that share chunks of agents (see [`Workers`]), when more than one was
    /// asked for.
    pool: Option<Workers>,
    /// Whether the selection, the calculations and the post office run on the pool.
    tuner: Tuner,
    /// The phase running now is to stay on this thread (see [`Tuner`]).
    serial: bool,
    sel: Selection,
    /// The last selection was decided by the agents' states alone (no agent evaluated a
    /// precondition): while no state changes, it holds for the next step too.
    sel_by_state: bool,
    /// The last selection was reused (so the firings of the last step repeat).
    sel_reused: bool,
    /// Per rule: how many agents execute it in the current selection; and how many agents
    /// execute any rule. Kept up to date when the selection is reused.
    fire_counts: Vec<u64>,
    active: u64,
    /// Per rule: it calculates or sends.
    computes: Vec<bool>,
    /// Per-cell and per-agent marks for the moves (allocated at the first move).
    scratch: MoveScratch,
    /// The actions of the step being made (kept for their allocations).
    todo: Actions,
    /// With `--static-first`: the moving half of the combined intents of agents executing
    /// several rules, made in the static pass (where conflicts are judged over all of
    /// them), in agent order.
    later: Vec<(u32, Intent)>,
    /// Numeric outboxes: a column per direction and slot in use (as the inboxes), and a
    /// bit set per column of which agents wrote it.
    out_num: Vec<Vec<i16>>,
    out_has: Vec<Vec<u64>>,
    /// Text outboxes, `dirs` per agent, and which directions were written (empty when no
    /// rule sends texts).
    out_text: Vec<[u8; 5]>,
    out_text_bits: Vec<u8>,
}

/// An agent's attachment letters and swap, for the agents whose rules have either.
type Link = (u32, [AttachLetter; 6], Option<Dir>);

/// The actions of a step, each list in agent order.
#[derive(Default)]
struct Actions {
    /// Agents asked to move, by these offsets (never zero).
    moves: Vec<(u32, [i32; 3])>,
    /// Agents whose rules asked for different moves: they do not move, nor their group.
    blocked: Vec<u32>,
    /// State patterns (as [`pat_bits`]) to apply.
    states: Vec<(u32, (u64, u64))>,
    links: Vec<Link>,
    /// Agents whose rules asked for different swaps: they take part in no swap.
    no_swap: Vec<u32>,
}

impl Actions {
    fn clear(&mut self) {
        self.moves.clear();
        self.blocked.clear();
        self.states.clear();
        self.links.clear();
        self.no_swap.clear();
    }

    /// Adds the combined actions `it` of agent `a`.
    fn add(&mut self, a: u32, it: &Intent) {
        if it.mv_bad {
            self.blocked.push(a);
        } else if let Some(o) = it.mv {
            self.moves.push((a, o));
        }
        if it.state.iter().any(Option::is_some) {
            self.states.push((a, pat_bits(&it.state)));
        }
        if it.swap.is_some() || it.letters.iter().any(|&l| l != AttachLetter::Keep) {
            self.links.push((a, it.letters, it.swap));
        }
        if it.swap_bad {
            self.no_swap.push(a);
        }
    }

    /// The moves and letters as one intent per agent.
    fn dense(&self, n: usize) -> Vec<Intent> {
        let mut dense = vec![Intent::default(); n];
        for &(a, o) in &self.moves {
            dense[a as usize].mv = Some(o);
        }
        for &a in &self.blocked {
            dense[a as usize].mv_bad = true;
        }
        for &(a, letters, _) in &self.links {
            dense[a as usize].letters = letters;
        }
        dense
    }
}

/// The common case of [`Engine::move_alone`] without tracing: every target in the grid (the
/// targets' slot codes are in `sc.codes`), none targeted twice or held by an agent that
/// stays. Then the moves are made and true is returned; otherwise nothing changes.
/// `one_offset`: every mover moves by the same offset.
fn move_free(
    lat: &mut Lattice,
    live: &[(u32, [i32; 3])],
    sc: &mut MoveScratch,
    one_offset: bool,
) -> bool {
    let codes = std::mem::take(&mut sc.codes);
    let mut free = !codes.contains(&NO_SLOT);
    // Movers by one offset have distinct targets; when every target is empty, none is
    // held by an agent that stays and none is a mover's old cell: no marks are needed.
    if free
        && one_offset
        && codes
            .iter()
            .all(|&c| !lat.cells.filled_slot((c & !RIM) as usize))
    {
        lat.relocate_to_slots(live, &codes, |_| false);
        sc.codes = codes;
        return true;
    }
    if free {
        let slots = || codes.iter().map(|&c| (c & !RIM) as usize);
        for (&(a, _), s) in live.iter().zip(slots()) {
            sc.claim(a, Some(s));
        }
        for s in slots() {
            let stays = lat.cells.filled_slot(s) && !sc.moving(lat.cells.at_slot(s));
            free &= !sc.claimed_twice(s) && !stays;
        }
        if free {
            lat.relocate_to_slots(live, &codes, |s| sc.claimed(s));
        }
        for (&(a, _), s) in live.iter().zip(slots()) {
            sc.unclaim(a, Some(s));
        }
    }
    sc.codes = codes;
    free
}

/// Marks for deciding moves, all clear between rounds: per grid cell, a bit when a mover
/// targets it and one when more than one does; per agent, a bit when it is moving.
#[derive(Default)]
struct MoveScratch {
    once: Vec<u64>,
    twice: Vec<u64>,
    moving: Vec<u64>,
    /// The movers' targets as slot codes.
    codes: Vec<u32>,
}

/// The word and the bit of index `i` in a bit set.
#[inline]
fn bit(i: usize) -> (usize, u64) {
    (i / 64, 1 << (i % 64))
}

impl MoveScratch {
    /// Marks agent `a` as moving, and its target's grid slot `s` (if any) as claimed.
    #[inline]
    fn claim(&mut self, a: u32, s: Option<usize>) {
        let (w, b) = bit(a as usize);
        self.moving[w] |= b;
        if let Some(s) = s {
            let (w, b) = bit(s);
            self.twice[w] |= self.once[w] & b;
            self.once[w] |= b;
        }
    }

    #[inline]
    fn moving(&self, a: u32) -> bool {
        let (w, b) = bit(a as usize);
        self.moving[w] & b != 0
    }

    #[inline]
    fn claimed(&self, s: usize) -> bool {
        let (w, b) = bit(s);
        self.once[w] & b != 0
    }

    #[inline]
    fn claimed_twice(&self, s: usize) -> bool {
        let (w, b) = bit(s);
        self.twice[w] & b != 0
    }

    /// Clears what [`MoveScratch::claim`] marked (whole words: nothing else is marked).
    #[inline]
    fn unclaim(&mut self, a: u32, s: Option<usize>) {
        self.moving[a as usize / 64] = 0;
        if let Some(s) = s {
            self.once[s / 64] = 0;
            self.twice[s / 64] = 0;
        }
    }
}

/// What a program's actions are, taken together: none, only moves by literal offsets
/// ([`Engine::plain_moves`]), only state changes ([`Engine::direct_bits`]), or others.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Acting {
    Nothing,
    PlainMoves,
    States,
    Mixed,
}

impl Acting {
    fn of(acts: &[bool], plain: &[Option<[i32; 3]>], direct: &[Option<(u64, u64)>]) -> Acting {
        let acting = |kind: &dyn Fn(usize) -> bool| (0..acts.len()).all(|r| !acts[r] || kind(r));
        if !acts.contains(&true) {
            Acting::Nothing
        } else if acting(&|r| plain[r].is_some()) {
            Acting::PlainMoves
        } else if acting(&|r| direct[r].is_some()) {
            Acting::States
        } else {
            Acting::Mixed
        }
    }
}

/// Where the one state-only rule of a candidate list takes an agent: the list of its new
/// state (`to`, [`NO_LIST`] while unknown), that state's one rule when the agent's
/// selection can follow at once (`next`: a rule or [`NO_RULE`]; [`EVALUATE`] when it
/// cannot: the new state's rules need evaluating, or one of the rules calculates), and
/// the new state.
#[derive(Clone, Copy, Debug)]
struct Hop {
    to: u32,
    next: u32,
    state: [u8; 5],
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
    fn take(&self, (list, state, one): (&mut u32, &mut [u8; 5], &mut u32), hopped: &mut u64) {
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
fn hop_run(
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

/// Per-agent work is split over threads only for at least this many agents, and a run
/// gains nothing from more threads than one per this many agents.
pub const AGENTS_PER_THREAD: usize = 1024;

/// The threads that run chunks of agents: `threads - 1` workers and the thread that
/// steps, which takes chunks too (so that a step wakes one worker fewer, and the workers
/// are placed beside a running thread rather than beside a sleeping one: on a machine
/// of two cores, a pool of two workers woken by the stepping thread often shared one
/// core for many steps).
struct Workers {
    pool: rayon::ThreadPool,
    threads: usize,
}

impl Workers {
    /// `threads` threads in all (at least two), or `None` when the system cannot start
    /// them.
    fn new(threads: usize) -> Option<Workers> {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads - 1)
            .build()
            .ok()?;
        Some(Workers { pool, threads })
    }

    /// `f` of each item, the items taken in turn by the workers and this thread; the
    /// results in the items' order.
    fn map<I: Send, T: Send>(&self, items: Vec<I>, f: impl Fn(I) -> T + Sync) -> Vec<T> {
        use std::sync::atomic::{AtomicUsize, Ordering};
        use std::sync::{Mutex, MutexGuard};
        // (A panic in `f` reaches the caller when the scope ends; the slots stay usable.)
        fn lock<X>(m: &Mutex<X>) -> MutexGuard<'_, X> {
            m.lock().unwrap_or_else(|poisoned| poisoned.into_inner())
        }
        let n = items.len();
        let todo: Vec<Mutex<Option<I>>> = items.into_iter().map(|i| Mutex::new(Some(i))).collect();
        let done: Vec<Mutex<Option<T>>> = (0..n).map(|_| Mutex::new(None)).collect();
        let next = AtomicUsize::new(0);
        let work = || loop {
            let k = next.fetch_add(1, Ordering::Relaxed);
            let Some(item) = todo.get(k) else {
                break;
            };
            let r = f(lock(item).take().expect("each item is taken once"));
            *lock(&done[k]) = Some(r);
        };
        let work = &work;
        self.pool.in_place_scope(|s| {
            for _ in 1..self.threads.min(n) {
                s.spawn(move |_| work());
            }
            work();
        });
        (done.iter())
            .map(|m| lock(m).take().expect("every item ran"))
            .collect()
    }
}

/// The phases that run in chunks of agents, on the pool when there is one.
#[derive(Clone, Copy)]
enum Phase {
    Select,
    Calculate,
    Deliver,
}

/// Chooses, per phase, whether it runs on the pool or on the stepping thread alone: every
/// 64 runs of a phase, it runs once on one thread and then twice on the pool (on
/// consecutive steps, which do about the same work), and keeps one thread until the next
/// trial only when it beat both runs on the pool (the first run on the pool after one on
/// one thread may have to wake the pool's threads). The first trial is at a phase's
/// fourth to sixth runs: the first two steps do one-time work (the first touches of new
/// columns, the plan of senders) which would count against whichever way ran then. The
/// results are the same either way (chunks are joined in agent order).
/// One thread wins where a phase is too light to pay for waking the pool and for the
/// data it leaves in the other core's cache (B2's selection between two serial actions
/// phases), or where the other core is busy.
#[derive(Clone, Copy, Debug, Default)]
struct Tuner {
    /// Per phase: how often it ran, how long its last run on one thread took, and
    /// whether one thread was faster at the last trial.
    phases: [(u64, std::time::Duration, bool); 3],
}

impl Tuner {
    /// Whether the next run of `phase` is on the pool (it is counted).
    fn pooled(&mut self, phase: Phase) -> bool {
        let p = &mut self.phases[phase as usize];
        p.0 += 1;
        // The first runs (the first steps, with their one-time work) are not trials.
        match p.0 % 64 {
            4 => false,
            5 | 6 => true,
            _ => !p.2,
        }
    }

    /// The run of `phase` just counted took `d`.
    fn took(&mut self, phase: Phase, d: std::time::Duration) {
        let p = &mut self.phases[phase as usize];
        match p.0 % 64 {
            4 => p.1 = d,
            5 => p.2 = p.1 < d,
            6 => p.2 &= p.1 < d,
            _ => {}
        }
    }
}

/// The rules each agent executes in a step: one entry per agent, either [`NO_RULE`], a
/// rule, or [`MANY`] with an index into `starts`/`many` (in file order).
#[derive(Default)]
struct Selection {
    one: Vec<u32>,
    starts: Vec<u32>,
    many: Vec<u32>,
}

const NO_RULE: u32 = u32::MAX;
/// The opposite of each direction index.
const OPPOSITE: [usize; 6] = [3, 2, 1, 0, 5, 4];
const MANY: u32 = 1 << 31;
const NO_LIST: u32 = u32::MAX;
/// Entries of the direct-mapped cache of candidate lists at first (it grows with the
/// number of distinct states, up to 65536).
const CAND_CACHE: usize = 1024;
/// In `cand_single`: the agents of this list evaluate their rules.
const EVALUATE: u32 = u32::MAX - 1;

impl Selection {
    /// The rules agent `a` executes, in file order.
    #[inline]
    fn of(&self, a: usize) -> &[u32] {
        match self.one[a] {
            NO_RULE => &[],
            v if v & MANY == 0 => std::slice::from_ref(&self.one[a]),
            v => {
                let k = (v & !MANY) as usize;
                &self.many[self.starts[k] as usize..self.starts[k + 1] as usize]
            }
        }
    }

    /// Sets agent `a`'s rules (agents must be set in increasing order for several rules).
    fn set(&mut self, a: usize, rules: &[u32]) {
        self.one[a] = match rules {
            [] => NO_RULE,
            [r] => *r,
            _ => {
                if self.starts.is_empty() {
                    self.starts.push(0);
                }
                self.many.extend_from_slice(rules);
                self.starts.push(self.many.len() as u32);
                MANY | (self.starts.len() - 2) as u32
            }
        };
    }

    fn reset(&mut self, n: usize) {
        self.one.clear();
        self.one.resize(n, NO_RULE);
        self.starts.clear();
        self.many.clear();
    }
}

const OPEN: i32 = -1;

struct PrioView<'a> {
    fixed: &'a [i32],
    cur: &'a [u16],
}

struct SelEnv<'a> {
    lat: &'a Lattice,
    a: u32,
    prio: Option<PrioView<'a>>,
}

impl Env for SelEnv<'_> {
    #[inline]
    fn counter(&self, i: u8) -> i16 {
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
    fn agent_counter(&self, id: u32, i: u8) -> i16 {
        self.lat.counter(id, i)
    }
    #[inline]
    fn inbox_num(&self, dir: u8, slot: u8) -> i16 {
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

/// An open agent left with no rule at its level drops to its next valid priority `next`
/// (to be resolved at that level), or, with none left, is fixed at priority 0.
fn drop_to(
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

/// The combined actions of one agent's selected rules.
#[derive(Clone, Copy)]
struct Intent {
    mv: Option<[i32; 3]>,
    mv_bad: bool,
    swap: Option<Dir>,
    /// The rules ask for different swaps: the agent takes part in no swap.
    swap_bad: bool,
    letters: [AttachLetter; 6],
    state: TextPat,
}

impl Default for Intent {
    fn default() -> Self {
        Intent {
            mv: None,
            mv_bad: false,
            swap: None,
            swap_bad: false,
            letters: [AttachLetter::Keep; 6],
            state: [None; 5],
        }
    }
}

/// Applies a state pattern (as [`pat_bits`]) to agent `a`. When the state changes: the
/// old and new states, and whether the cache knew the new state's candidate list (the
/// agent's list is set from it, or marked for lookup).
#[inline(always)]
fn apply_state(
    lat: &mut Lattice,
    cand_of: &mut [u32],
    (cache, known_states): (&[(u64, u32)], &FxHashMap<u64, u32>),
    a: usize,
    (mask, val): (u64, u64),
) -> Option<([u8; 5], [u8; 5], bool)> {
    let old = lat.state[a];
    let o = state_key(&old);
    let v = (o & !mask) | val;
    if v == o {
        return None;
    }
    let new: [u8; 5] = v.to_le_bytes()[..5].try_into().expect("five bytes");
    lat.state[a] = new;
    let idx = cached(cache, v).or_else(|| known_states.get(&v).copied());
    cand_of[a] = idx.unwrap_or(NO_LIST);
    Some((old, new, idx.is_some()))
}

/// A state as a number (its five bytes, little-endian).
#[inline]
fn state_key(s: &[u8; 5]) -> u64 {
    u32::from_le_bytes([s[0], s[1], s[2], s[3]]) as u64 | (s[4] as u64) << 32
}

/// The slot of a state key in the candidate cache: one multiplication hashes it.
#[inline]
fn cache_slot(key: u64, len: usize) -> usize {
    // `len` is a power of two: the top bits of the product index it.
    (key.wrapping_mul(0x9E37_79B9_7F4A_7C15) >> (64 - len.trailing_zeros())) as usize
}

/// The candidate list of a state key, when the candidate cache holds it.
#[inline]
fn cached(cache: &[(u64, u32)], key: u64) -> Option<u32> {
    match cache[cache_slot(key, cache.len())] {
        (k, idx) if k == key + 1 => Some(idx),
        _ => None,
    }
}

/// A state pattern as (mask of the characters it sets, their values) over state keys.
fn pat_bits(pat: &TextPat) -> (u64, u64) {
    let (mut mask, mut val) = ([0u8; 8], [0u8; 8]);
    for (i, p) in pat.iter().enumerate() {
        if let Some(p) = p {
            mask[i] = 0xff;
            val[i] = *p;
        }
    }
    (u64::from_le_bytes(mask), u64::from_le_bytes(val))
}

/// An offset's value when it has no counter in it.
fn literal(o: &latticesim_vm::model::Offset) -> Option<[i32; 3]> {
    let lit = |c: &Coord| match *c {
        Coord::Lit(v) => Some(v),
        Coord::Counter(_) => None,
    };
    Some([lit(&o[0])?, lit(&o[1])?, lit(&o[2])?])
}

fn find(parent: &mut [u32], mut x: u32) -> u32 {
    while parent[x as usize] != x {
        parent[x as usize] = parent[parent[x as usize] as usize];
        x = parent[x as usize];
    }
    x
}

fn text(s: &[u8; 5]) -> String {
    String::from_utf8_lossy(s).into_owned()
}

impl Engine {
    /// A program ready to run on a lattice. The program must have passed `verify` and match
    /// the lattice's dimension. The lattice gets columns for every counter, message slot
    /// and text inbox the program uses.
    pub fn new(prog: Verified, mut lat: Lattice, opts: Options) -> Engine {
        let mut by_prio: Vec<u32> = (0..prog.rules.len() as u32).collect();
        by_prio.sort_by_key(|&r| std::cmp::Reverse(prog.rules[r as usize].priority));
        let uses = prog.uses();
        lat.settle_inbox();
        for c in 0..lat.nc() as u8 {
            if uses.counters & (1 << c) != 0 {
                lat.ensure_counter(c);
            }
        }
        for slot in 0..lat.dim.slots() as u8 {
            if uses.slots & (1 << slot) != 0 {
                lat.ensure_slot(slot);
            }
        }
        if uses.texts {
            lat.ensure_text();
        }
        let n = lat.len();
        let defer = uses.slots != 0
            && !uses.texts
            && prog
                .rules
                .iter()
                .all(|r| r.moves.is_none() && r.swaps.is_none());
        // With `defer`, a send to all directions writes one more column per slot.
        let cols = lat.inbox_num.len() + if defer { lat.slots as usize } else { 0 };
        // With `defer`, only the columns some send writes hold values (the others are
        // read only where their bits are set, which they never are).
        let mut written = vec![!defer; cols];
        for op in &prog.code {
            if let Op::Calc {
                target: Target::Msg { dir, slot },
                ..
            } = *op
            {
                let (ns, sc) = (lat.slots as usize, lat.slot_col[slot as usize] as usize);
                let d = if dir == ANY_DIR {
                    lat.dim.dirs()
                } else {
                    dir as usize
                };
                if let Some(w) = written.get_mut(d * ns + sc) {
                    *w = true;
                }
            }
        }
        let trivial = prog
            .rules
            .iter()
            .map(
                |r| match &prog.code[r.pre.start as usize..r.pre.end as usize] {
                    [Op::True {}] => true,
                    [Op::State { pat }] => r.state_filter == Some(*pat),
                    _ => false,
                },
            )
            .collect();
        let pre_batch = prog
            .rules
            .iter()
            .map(|r| pre_batchable(&prog.code[r.pre.start as usize..r.pre.end as usize]))
            .collect();
        let batchable = prog
            .rules
            .iter()
            .map(|r| {
                prog.code[r.post.start as usize..r.post.end as usize]
                    .iter()
                    .all(|op| {
                        !matches!(op, Op::Calc { a, b, .. }
                            if matches!(a, Val::Ext(_)) || matches!(b, Val::Ext(_)))
                    })
            })
            .collect();
        let has_actions: Vec<bool> = (prog.rules.iter())
            .map(|i| {
                i.moves.is_some()
                    || i.swaps.is_some()
                    || i.attaches.is_some()
                    || i.sets_state.is_some()
            })
            .collect();
        let plain_moves: Vec<Option<[i32; 3]>> = (prog.rules.iter())
            .map(|i| match (i.moves, i.sets_state, i.swaps, i.attaches) {
                (Some(o), None, None, None) => {
                    literal(&prog.offsets[o as usize]).filter(|&o| o != [0, 0, 0])
                }
                _ => None,
            })
            .collect();
        let direct_bits: Vec<Option<(u64, u64)>> = (prog.rules.iter())
            .map(|i| match (i.sets_state, i.moves, i.swaps, i.attaches) {
                (Some(p), None, None, None) => Some(pat_bits(&prog.pats[p as usize])),
                _ => None,
            })
            .collect();
        Engine {
            stats: Stats {
                firings: vec![0; prog.rules.len()],
                ..Stats::default()
            },
            by_prio,
            candidates: FxHashMap::default(),
            cand_cache: vec![(0, 0); CAND_CACHE],
            cand_lists: Vec::new(),
            cand_single: Vec::new(),
            cand_keys: Vec::new(),
            cand_hop: Vec::new(),
            cand_hopped: Vec::new(),
            cand_of: vec![NO_LIST; n],
            cand_dirty: true,
            states_changed: true,
            trivial,
            pre_batch,
            any_prio: prog.rules.iter().any(|r| r.reads_priorities),
            any_computes: prog.rules.iter().any(|r| r.computes),
            defer,
            has_nbr: Vec::new(),
            counted: None,
            prio_offsets: prog
                .code
                .iter()
                .filter_map(|op| match op {
                    Op::Less { off } | Op::LessEq { off } => Some(*off),
                    _ => None,
                })
                .map(|off| literal(&prog.offsets[off as usize]))
                .collect(),
            batchable,
            pool: (opts.threads > 1 && n >= AGENTS_PER_THREAD)
                .then(|| Workers::new(opts.threads))
                .flatten(),
            tuner: Tuner::default(),
            serial: false,
            acting: Acting::of(&has_actions, &plain_moves, &direct_bits),
            has_actions,
            literal_offsets: prog.offsets.iter().map(literal).collect(),
            plain_moves,
            direct_bits,
            sel: Selection::default(),
            sel_by_state: false,
            sel_reused: false,
            fire_counts: vec![0; prog.rules.len()],
            active: 0,
            computes: prog.rules.iter().map(|r| r.computes).collect(),
            scratch: MoveScratch::default(),
            todo: Actions::default(),
            later: Vec::new(),
            out_num: written
                .iter()
                .map(|&w| if w { vec![0; n] } else { Vec::new() })
                .collect(),
            out_has: vec![vec![0; n.div_ceil(64)]; cols],
            out_text: if uses.texts {
                vec![[0; 5]; n * lat.dim.dirs()]
            } else {
                Vec::new()
            },
            out_text_bits: if uses.texts { vec![0; n] } else { Vec::new() },
            prog,
            lat,
            opts,
        }
    }

    /// Bytes the engine holds per agent beyond the lattice's columns (outboxes, rule
    /// dispatch, the selection), for reports.
    pub fn bytes(&self) -> usize {
        self.lat.bytes()
            + self.out_num.iter().map(|c| c.capacity() * 2).sum::<usize>()
            + self.out_has.iter().map(|c| c.capacity() * 8).sum::<usize>()
            + self.out_text.capacity() * 5
            + self.out_text_bits.capacity()
            + self.cand_of.capacity() * 4
            + self.sel.one.capacity() * 4
            + (self.sel.starts.capacity() + self.sel.many.capacity()) * 4
    }

    /// How per-agent work on `n` agents is split: the thread pool and the chunk size when
    /// there are threads and enough agents (the one place that decides), else `None`.
    /// Chunks are whole multiples of 64 agents, so that they split bit sets by words.
    fn parallel(&self, n: usize) -> Option<(&Workers, usize)> {
        let pool = (self.pool.as_ref()).filter(|_| n >= AGENTS_PER_THREAD && !self.serial)?;
        Some((pool, n.div_ceil(pool.threads * 4).next_multiple_of(64)))
    }

    /// The split of `n` agents: the pool (with threads), the chunk size and the number of
    /// chunks (one chunk of all agents without threads).
    fn chunks(&self, n: usize) -> (Option<(&Workers, usize)>, usize, usize) {
        let par = self.parallel(n);
        let size = par.map_or(n.max(1), |p| p.1);
        (par, size, n.div_ceil(size))
    }

    /// Runs `f` over the agents `0..n` in chunks, in parallel when the engine has threads,
    /// and returns the chunks' results in agent order.
    fn par_chunks<T: Send>(&self, n: usize, f: &(dyn Fn(usize, usize) -> T + Sync)) -> Vec<T> {
        match self.parallel(n) {
            Some((pool, size)) => pool.map((0..n.div_ceil(size)).collect(), |c| {
                f(c * size, ((c + 1) * size).min(n))
            }),
            _ => vec![f(0, n)],
        }
    }

    fn agents_of(&self, ids: &[u32]) -> Vec<(u32, [i32; 3])> {
        ids.iter().map(|&a| (a, self.lat.pos[a as usize])).collect()
    }

    fn record(&mut self, rep: &mut StepReport, kind: RecordKind, ids: &[u32], message: String) {
        *self.stats.records.entry(kind).or_insert(0) += 1;
        rep.records.push(Record {
            step: self.stats.steps + 1,
            kind,
            agents: self.agents_of(ids),
            message,
        });
    }

    fn rule_name(&self, r: u32) -> &str {
        &self.prog.rules[r as usize].name
    }

    /// Rule dispatch by state: an agent evaluates only the rules whose top-level state
    /// pattern its state matches. The list is computed once per distinct state, and each
    /// agent keeps its list until its state changes, so only those agents look it up again.
    fn update_candidates(&mut self) {
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
    fn list_state_of(&mut self, a: usize) {
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
        let (by_prio, trivial) = (&self.by_prio, &self.trivial);
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
    fn known_states(&mut self, all: bool) -> Vec<Vec<u32>> {
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

    /// Selection when no rule reads priorities: each agent executes its true rules of the
    /// highest priority among its true rules. Agents whose candidate list decides alone are
    /// not evaluated at all.
    fn select_plain(&mut self) {
        let n = self.lat.len();
        let mut one = std::mem::take(&mut self.sel.one);
        // Every entry is written below (a new column is zeroed lazily by the system, and
        // its pages are touched by the chunks, in parallel).
        if one.len() != n {
            one = vec![0; n];
        }
        let (prog, lat, trivial) = (&self.prog, &self.lat, &self.trivial);
        let (lists, single, of) = (&self.cand_lists, &self.cand_single, &self.cand_of);
        let (par, chunk, _) = self.chunks(n);
        let pre_batch = &self.pre_batch;
        let work = |(c, one): (usize, &mut [u32])| {
            let lo = c * chunk;
            let mut multi: Vec<(u32, Vec<u32>)> = Vec::new();
            let mut buf: Vec<u32> = Vec::new();
            let mut evaluated = false;
            let mut truth = [false; BATCH];
            let mut bufs = PreBufs::new();
            let hi = lo + one.len();
            let mut k = 0;
            while k < one.len() {
                // The agents whose candidate list decides alone, in a tight loop up to
                // the next agent to evaluate.
                let decided = (one[k..].iter_mut().zip(&of[lo + k..hi])).position(
                    |(slot, &idx)| match single[idx as usize] {
                        EVALUATE => true,
                        r => {
                            *slot = r;
                            false
                        }
                    },
                );
                let Some(skip) = decided else {
                    break;
                };
                k += skip;
                let a = lo + k;
                let idx = of[a] as usize;
                evaluated = true;
                // A run of agents with the same one rule to test: evaluated together.
                if let [r] = lists[idx][..] {
                    if pre_batch[r as usize] {
                        let m = run_of(&of[a..(a + BATCH).min(hi)], idx as u32);
                        batch_pre(prog, (r, a), lat, &mut bufs, &mut truth[..m]);
                        for (slot, &t) in one[k..k + m].iter_mut().zip(&truth[..m]) {
                            *slot = if t { r } else { NO_RULE };
                        }
                        k += m;
                        continue;
                    }
                }
                let slot = &mut one[k];
                k += 1;
                let env = SelEnv {
                    lat,
                    a: a as u32,
                    prio: None,
                };
                buf.clear();
                let mut top = None;
                for &r in &lists[idx] {
                    let p = prog.rules[r as usize].priority;
                    if top.is_some_and(|t| p < t) {
                        break;
                    }
                    if trivial[r as usize] || eval_pre(prog, r as usize, &env) == Tri::T {
                        top = Some(p);
                        buf.push(r);
                    }
                }
                *slot = match buf[..] {
                    [] => NO_RULE,
                    [r] => r,
                    _ => {
                        buf.sort_unstable();
                        multi.push((a as u32, buf.clone()));
                        MANY
                    }
                };
            }
            (multi, evaluated)
        };
        let parts: Vec<_> = match par {
            Some((pool, _)) => pool.map(one.chunks_mut(chunk).enumerate().collect(), work),
            None => one.chunks_mut(chunk).enumerate().map(work).collect(),
        };
        self.sel.one = one;
        self.sel.starts.clear();
        self.sel.many.clear();
        self.sel_by_state = true;
        for (multi, evaluated) in parts {
            self.sel_by_state &= !evaluated;
            for (a, rules) in multi {
                self.sel.set(a as usize, &rules);
            }
        }
    }

    /// Selection: which rules each agent executes this step (into `self.sel`).
    fn select(&mut self, rep: &mut StepReport) {
        let changed =
            self.cand_dirty || self.states_changed || self.cand_of.len() != self.lat.len();
        self.states_changed = false;
        self.update_candidates();
        self.sel_reused = !self.any_prio && !changed && self.sel_by_state;
        if self.sel_reused {
            return;
        }
        self.tuned(Phase::Select, |e| {
            if e.any_prio {
                e.select_with_priorities(rep);
            } else {
                e.select_plain();
            }
        });
    }

    /// Runs phase `f` on the pool or on this thread, as the tuner chooses, and tells the
    /// tuner how long it took.
    fn tuned(&mut self, phase: Phase, f: impl FnOnce(&mut Engine)) {
        if self.pool.is_none() {
            return f(self);
        }
        let pooled = self.tuner.pooled(phase);
        self.serial = !pooled;
        let t = std::time::Instant::now();
        f(self);
        self.tuner.took(phase, t.elapsed());
        self.serial = false;
    }

    /// Selection when rules read neighbours' priorities: a first pass with priorities
    /// unknown, then the levels from the top down (SEMANTICS section 5).
    fn select_with_priorities(&mut self, rep: &mut StepReport) {
        let n = self.lat.len();
        let prog = &self.prog;
        let mut ent_rule: Vec<u32> = Vec::with_capacity(n);
        let mut ent_tri: Vec<Tri> = Vec::with_capacity(n);
        let mut ent_start: Vec<u32> = Vec::with_capacity(n + 1);
        let mut fixed = vec![OPEN; n];
        let mut cur = vec![0u16; n];
        let mut levels: BTreeMap<u16, Vec<u32>> = BTreeMap::new();
        let mut queued = vec![false; n];
        ent_start.push(0);
        let (lists, of) = (&self.cand_lists, &self.cand_of);
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
                for &r in &lists[of[a] as usize] {
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
        let parts = self.par_chunks(n, &pass1);
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
                if !at_level(ai, &fixed, &cur) {
                    continue;
                }
                let before = (fixed[ai], cur[ai]);
                let (s, e) = (ent_start[ai] as usize, ent_start[ai + 1] as usize);
                let mut alive = false;
                for k in s..e {
                    if prio_of(k) != p {
                        continue;
                    }
                    if ent_tri[k] == Tri::U {
                        let env = SelEnv {
                            lat: &self.lat,
                            a,
                            prio: Some(PrioView {
                                fixed: &fixed,
                                cur: &cur,
                            }),
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
                if fixed[ai] == OPEN && !alive {
                    let next = (s..e)
                        .find(|&k| prio_of(k) < p && ent_tri[k] != Tri::F)
                        .map(prio_of);
                    drop_to(a, next, &mut fixed, &mut cur, &mut levels);
                }
                if (fixed[ai], cur[ai]) != before {
                    let mut wake = |b: u32| {
                        let bi = b as usize;
                        if b != NO_AGENT && !queued[bi] && at_level(bi, &fixed, &cur) {
                            queued[bi] = true;
                            queue.push_back(b);
                        }
                    };
                    match &self.prio_offsets {
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
                if !at_level(ai, &fixed, &cur) {
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
                        drop_to(a, next, &mut fixed, &mut cur, &mut levels);
                    }
                }
            }
            if !circle.is_empty() {
                let ids: Vec<String> = circle.iter().map(|a| a.to_string()).collect();
                let msg = format!(
                    "the priorities of agents {} depend on each other in a circle at priority {p}; their rules {} are not executed",
                    ids.join(", "),
                    names.iter().map(|n| format!("`{n}`")).collect::<Vec<_>>().join(", ")
                );
                circles.push((circle, msg));
            }
        }
        // Each agent executes its rules that are true at its final priority, in file order.
        let mut sel = std::mem::take(&mut self.sel);
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
        self.sel = sel;
        for (circle, msg) in circles {
            self.record(rep, RecordKind::CircularPriority, &circle, msg);
        }
    }

    /// What a step of this program can change in the lattice (for [`Lattice::undo_point`]).
    pub fn writes(&self) -> Writes {
        let mut w = Writes::default();
        for r in &self.prog.rules {
            w.positions |= r.moves.is_some() || r.swaps.is_some();
            w.states |= r.sets_state.is_some();
            w.bonds |= r.attaches.is_some();
        }
        for op in &self.prog.code {
            match *op {
                Op::Calc { target, .. } => match target {
                    Target::Counter(c) => w.counters |= 1 << c,
                    Target::Msg { .. } => w.messages = true,
                },
                Op::Send { .. } => w.messages = true,
                _ => {}
            }
        }
        w
    }

    /// What [`Engine::undo`] needs to go back to the state before the next step: only
    /// the parts of the lattice a step can change, and the statistics.
    pub fn undo_point(&self) -> (Undo, Stats) {
        (self.lat.undo_point(&self.writes()), self.stats.clone())
    }

    /// Goes back to the state of an [`Engine::undo_point`] taken before the last step (an
    /// engine made anew, so that nothing it kept of that step remains).
    pub fn undo(self, (u, stats): (Undo, Stats)) -> Engine {
        let Engine {
            prog,
            mut lat,
            opts,
            ..
        } = self;
        lat.undo(u);
        let mut e = Engine::new(prog, lat, opts);
        e.stats = stats;
        e
    }

    /// One step. Returns what happened; `stats` is updated.
    pub fn step(&mut self) -> StepReport {
        let mut rep = StepReport::default();
        self.lat.refresh_neighbours();
        self.select(&mut rep);
        let mut sel = std::mem::take(&mut self.sel);
        // Firings: runs of agents with the same single rule are counted at once; a reused
        // selection's counts were kept up to date.
        if !self.sel_reused {
            let counts = &mut self.fire_counts;
            counts.fill(0);
            self.active = 0;
            // With few rules and no agent executing several, one vectorised count per rule
            // (agents alternating between a rule and none would make runs of one);
            // otherwise runs of agents with the same entry are counted at once.
            if sel.many.is_empty() && counts.len() <= 4 {
                for (r, c) in counts.iter_mut().enumerate() {
                    *c = sel.one.iter().map(|&v| (v == r as u32) as u64).sum();
                    self.active += *c;
                }
            } else {
                self.active = count_runs(&sel.one, counts);
            }
            for &r in &sel.many {
                counts[r as usize] += 1;
            }
        }
        rep.quiescent = self.active == 0;
        for (f, &k) in self.stats.firings.iter_mut().zip(&self.fire_counts) {
            *f += k;
        }
        if self.opts.trace {
            for a in 0..self.lat.len() {
                let rs = sel.of(a);
                if !rs.is_empty() {
                    rep.trace.push(TraceEvent::Fire {
                        agent: a as u32,
                        rules: rs.iter().map(|&r| self.rule_name(r).to_string()).collect(),
                        priority: self.prog.rules[rs[0] as usize].priority,
                    });
                }
            }
        }
        match self.opts.order {
            Order::ActionsFirst => {
                self.all_actions(&mut sel, &mut rep);
                self.tuned(Phase::Calculate, |e| e.calculations(&sel, &mut rep));
                self.tuned(Phase::Deliver, |e| e.deliver(&mut rep));
            }
            Order::MessagesFirst => {
                self.tuned(Phase::Calculate, |e| e.calculations(&sel, &mut rep));
                self.tuned(Phase::Deliver, |e| e.deliver(&mut rep));
                self.all_actions(&mut sel, &mut rep);
            }
        }
        self.sel = sel;
        self.stats.steps += 1;
        self.stats.quiescent = rep.quiescent;
        rep
    }

    fn all_actions(&mut self, sel: &mut Selection, rep: &mut StepReport) {
        if self.opts.static_first {
            let prog = &self.prog;
            let still: Vec<bool> = prog
                .rules
                .iter()
                .map(|r| r.moves.is_none() && r.swaps.is_none())
                .collect();
            let moving: Vec<bool> = still.iter().map(|s| !s).collect();
            self.later.clear();
            self.actions(sel, rep, Some((&still, true)));
            self.actions(sel, rep, Some((&moving, false)));
        } else {
            self.actions(sel, rep, None);
        }
    }

    /// Paper step 2 for all selected rules, or with `--static-first` for the rules one
    /// pass takes (`pass`: which rules, and whether it is the first, static one). An agent
    /// executing several rules has its conflicts judged over all of them in the first pass
    /// ([`Engine::split_intent`]), whose second half waits in `later` for the second.
    fn actions(
        &mut self,
        sel: &mut Selection,
        rep: &mut StepReport,
        pass: Option<(&[bool], bool)>,
    ) {
        let every = pass.is_none();
        let pick = |r: u32| pass.is_none_or(|p| p.0[r as usize]);
        let n = self.lat.len();
        // Rules with nothing to do in this phase (only calculations and sends) are left out;
        // only the agents with something to do get an intent.
        if self.acting == Acting::Nothing {
            return;
        }
        let mut todo = std::mem::take(&mut self.todo);
        todo.clear();
        // Without tracing (which reports state changes after moves), an agent whose one
        // rule only sets the state does so at once: no other action of the step reads
        // states. When the selection is decided by states alone, its entry is also set at
        // once to the rule of its new state (see `set_state_at_once`).
        let direct = !self.opts.trace;
        let keep = self.sel_by_state && !self.any_prio && !self.opts.static_first;
        let (mut changed, mut lookups) = (false, false);
        let mut rs: Vec<u32> = Vec::new();
        let simple = every && sel.many.is_empty();
        // When every rule's actions are a plain move (or none) and no agent executes several
        // rules, the step's actions are the list of moves, collected in one tight loop.
        let plain_moves = simple && self.acting == Acting::PlainMoves;
        // When the selection is kept (decided by states alone) and every rule's actions
        // only set the state, each agent takes its candidate list's hop, known per list,
        // in one tight loop (`hop_run`); the loop stops at each agent whose list has no hop
        // yet (or whose new state's rules need evaluating), which goes the general way.
        let hops = simple && keep && direct && self.acting == Acting::States;
        if plain_moves {
            let plain = &self.plain_moves;
            for (a, &r) in sel.one.iter().enumerate() {
                if let Some(&Some(o)) = plain.get(r as usize) {
                    todo.moves.push((a as u32, o));
                }
            }
        } else if hops {
            let mut a = 0;
            loop {
                a = hop_run(
                    a,
                    (&mut self.cand_of, &mut self.lat.state, &mut sel.one),
                    &self.cand_hop,
                    &mut self.cand_hopped,
                );
                if a >= n {
                    break;
                }
                let r = sel.one[a];
                if r != NO_RULE {
                    let (c, l) = self.one_rule(&mut todo, a, r, (direct, keep), sel);
                    changed |= c;
                    lookups |= l;
                }
                a += 1;
            }
        }
        // Otherwise, every agent in turn.
        let agents = if plain_moves || hops { 0 } else { n };
        for a in 0..agents {
            let r = sel.one[a];
            if r == NO_RULE {
                continue;
            }
            if r & MANY == 0 {
                // One rule: nothing can conflict.
                if pick(r) {
                    let (c, l) = self.one_rule(&mut todo, a, r, (direct, keep), sel);
                    changed |= c;
                    lookups |= l;
                }
                continue;
            }
            let acts = &self.has_actions;
            rs.clear();
            if let Some((still, first)) = pass {
                let it = if first {
                    rs.extend((sel.of(a).iter().copied()).filter(|&r| acts[r as usize]));
                    let (now, later) = self.split_intent(a, &rs, still, rep);
                    self.later.push((a as u32, later));
                    now
                } else {
                    match self.later.binary_search_by_key(&(a as u32), |l| l.0) {
                        Ok(k) => self.later[k].1,
                        Err(_) => continue,
                    }
                };
                todo.add(a as u32, &it);
                continue;
            }
            rs.extend((sel.of(a).iter().copied()).filter(|&r| pick(r) && acts[r as usize]));
            match rs[..] {
                [] => {}
                [r] => self.add_rule_actions(&mut todo, a as u32, r),
                _ => {
                    let it = self.combined_intent(a, &rs, rep);
                    todo.add(a as u32, &it);
                }
            }
        }
        self.count_hops();
        let letters = todo
            .links
            .iter()
            .any(|l| l.1.iter().any(|&l| l != AttachLetter::Keep));
        let moves = !todo.moves.is_empty() || !todo.blocked.is_empty();
        // Bonds change only with attachment letters, or when attached agents move.
        // (A fold rather than `any`: it runs over whole vectors of bonds.)
        let attached = || self.lat.attach.iter().fold(0, |acc, &b| acc | b) != 0;
        if letters || (moves && attached()) {
            let dense = todo.dense(n);
            self.detach_move_attach(&dense, rep);
        } else if moves {
            self.move_alone(&mut todo.moves, rep);
        }
        // 5. State updates, in agent order.
        for &(a, bits) in &todo.states {
            let Some((old, new, known)) = apply_state(
                &mut self.lat,
                &mut self.cand_of,
                (&self.cand_cache, &self.candidates),
                a as usize,
                bits,
            ) else {
                continue;
            };
            changed = true;
            lookups |= !known;
            if self.opts.trace {
                rep.trace.push(TraceEvent::State {
                    agent: a,
                    from: text(&old),
                    to: text(&new),
                });
            }
        }
        // Agents whose state changed and whose rules the cache did not know look them up
        // again; any change of state ends the reuse of the selection.
        self.cand_dirty |= lookups;
        self.states_changed |= changed;
        if todo.links.iter().any(|l| l.2.is_some()) {
            self.swaps(&todo.links, &todo.no_swap, rep);
        }
        self.todo = todo;
    }

    /// The combined actions of agent `a` executing several rules `rs`: where they ask for
    /// different things, a conflict is recorded and that part is left out.
    fn combined_intent(&mut self, a: usize, rs: &[u32], rep: &mut StepReport) -> Intent {
        let nd = self.lat.dim.dirs();
        let mut it = Intent::default();
        let mut moves: Vec<(u32, [i32; 3])> = Vec::new();
        let mut swaps: Vec<(u32, Dir)> = Vec::new();
        let mut letters: Vec<Option<(u32, AttachLetter)>> = vec![None; nd];
        let mut conflict_dirs = 0u8;
        let mut chars: [Option<(u32, u8)>; 5] = [None; 5];
        let mut conflict_chars = 0u8;
        for &r in rs {
            let info = &self.prog.rules[r as usize];
            if let Some(off) = info.moves {
                let env = SelEnv {
                    lat: &self.lat,
                    a: a as u32,
                    prio: None,
                };
                let o = latticesim_vm::eval::resolve(&self.prog.offsets[off as usize], &env);
                if o != [0, 0, 0] && !moves.iter().any(|m| m.1 == o) {
                    moves.push((r, o));
                }
            }
            if let Some(d) = info.swaps {
                if !swaps.iter().any(|s| s.1 == d) {
                    swaps.push((r, d));
                }
            }
            if let Some(l) = info.attaches {
                let ls = self.prog.letters[l as usize];
                for d in 0..nd {
                    match letters[d] {
                        None => letters[d] = Some((r, ls[d])),
                        Some((_, prev)) if prev != ls[d] => conflict_dirs |= 1 << d,
                        _ => {}
                    }
                }
            }
            if let Some(p) = info.sets_state {
                let pat = self.prog.pats[p as usize];
                for (i, c) in pat.iter().enumerate() {
                    if let Some(c) = *c {
                        match chars[i] {
                            None => chars[i] = Some((r, c)),
                            Some((_, prev)) if prev != c => conflict_chars |= 1 << i,
                            _ => {}
                        }
                    }
                }
            }
        }
        let a32 = a as u32;
        match moves.len() {
            0 => {}
            1 => it.mv = Some(moves[0].1),
            _ => {
                it.mv_bad = true;
                let msg = format!(
                    "agent {a} is asked for different moves by rules {}; its group does not move",
                    moves
                        .iter()
                        .map(|(r, o)| format!("`{}` ({},{})", self.rule_name(*r), o[0], o[1]))
                        .collect::<Vec<_>>()
                        .join(" and ")
                );
                self.record(rep, RecordKind::MoveConflict, &[a32], msg);
            }
        }
        match swaps.len() {
            0 => {}
            1 => it.swap = Some(swaps[0].1),
            _ => {
                it.swap_bad = true;
                let msg = format!(
                    "agent {a} is asked to swap in different directions by rules {}; it takes part in no swap",
                    swaps.iter().map(|(r, d)| format!("`{}` (X{})", self.rule_name(*r), d.letter())).collect::<Vec<_>>().join(" and ")
                );
                self.record(rep, RecordKind::SwapConflict, &[a32], msg);
            }
        }
        for d in 0..nd {
            if conflict_dirs & (1 << d) != 0 {
                let msg = format!(
                    "agent {a}'s rules give different attachment letters towards {}; that direction counts as `*`",
                    Dir::ALL[d].letter()
                );
                self.record(rep, RecordKind::AttachConflict, &[a32], msg);
            } else if let Some((_, l)) = letters[d] {
                it.letters[d] = l;
            }
        }
        for i in 0..5 {
            if conflict_chars & (1 << i) != 0 {
                let msg = format!(
                    "agent {a}'s rules set character {} of the state differently; it is left unchanged",
                    i + 1
                );
                self.record(rep, RecordKind::StateConflict, &[a32], msg);
            } else if let Some((_, c)) = chars[i] {
                it.state[i] = Some(c);
            }
        }
        it
    }

    /// With `--static-first`: the combined intent of agent `a` executing rules `rs` (its
    /// conflicts judged and recorded over all of them), split into what its static rules
    /// (`still`) do in the first pass and what its moving rules do in the second.
    fn split_intent(
        &mut self,
        a: usize,
        rs: &[u32],
        still: &[bool],
        rep: &mut StepReport,
    ) -> (Intent, Intent) {
        let all = self.combined_intent(a, rs, rep);
        let mut now = Intent::default();
        let mut later = Intent {
            mv: all.mv,
            mv_bad: all.mv_bad,
            swap: all.swap,
            swap_bad: all.swap_bad,
            ..Intent::default()
        };
        for &r in rs {
            let info = &self.prog.rules[r as usize];
            let half = if still[r as usize] {
                &mut now
            } else {
                &mut later
            };
            if let Some(l) = info.attaches {
                let ls = &self.prog.letters[l as usize];
                for d in 0..self.lat.dim.dirs() {
                    if ls[d] != AttachLetter::Keep {
                        half.letters[d] = all.letters[d];
                    }
                }
            }
            if let Some(p) = info.sets_state {
                for (i, c) in self.prog.pats[p as usize].iter().enumerate() {
                    if c.is_some() {
                        half.state[i] = all.state[i];
                    }
                }
            }
        }
        (now, later)
    }

    /// Agent `a`, whose one rule `r` only sets the state (as [`pat_bits`] `bits`), takes its
    /// new state now. With `keep` (the selection is decided by states alone), an agent whose
    /// rule its state alone decides goes to the state that rule makes of it, remembered per
    /// state, and its selection entry is set to that state's rule for the next step (when
    /// neither rule calculates: the calculations of this step read the entry). Returns
    /// whether the state changed without the selection following, and whether the new
    /// state's rules must be looked up.
    fn set_state_at_once(
        &mut self,
        a: usize,
        r: u32,
        bits: (u64, u64),
        keep: bool,
        sel: &mut Selection,
    ) -> (bool, bool) {
        let idx = self.cand_of[a];
        if keep && idx != NO_LIST && self.cand_single[idx as usize] == r {
            let i = idx as usize;
            if self.cand_hop[i].to == NO_LIST {
                self.cand_hop[i] = self.hop(idx, r, bits);
            }
            let hop = self.cand_hop[i];
            if hop.to == idx {
                return (false, false);
            }
            if hop.to != NO_LIST && hop.next != EVALUATE {
                let agent = (
                    &mut self.cand_of[a],
                    &mut self.lat.state[a],
                    &mut sel.one[a],
                );
                hop.take(agent, &mut self.cand_hopped[i]);
                return (false, false);
            }
        }
        match apply_state(
            &mut self.lat,
            &mut self.cand_of,
            (&self.cand_cache, &self.candidates),
            a,
            bits,
        ) {
            Some((_, _, known)) => (true, !known),
            None => (false, false),
        }
    }

    /// The actions of agent `a` executing rule `r` alone: a plain move listed, a state set
    /// at once (with `direct`; `keep` as for [`Engine::set_state_at_once`], whose answer
    /// is returned), or the rule's actions added to `todo`.
    #[inline(always)]
    fn one_rule(
        &mut self,
        todo: &mut Actions,
        a: usize,
        r: u32,
        (direct, keep): (bool, bool),
        sel: &mut Selection,
    ) -> (bool, bool) {
        if let Some(o) = self.plain_moves[r as usize] {
            todo.moves.push((a as u32, o));
        } else if self.has_actions[r as usize] {
            match self.direct_bits[r as usize] {
                Some(bits) if direct => return self.set_state_at_once(a, r, bits, keep, sel),
                _ => self.add_rule_actions(todo, a as u32, r),
            }
        }
        (false, false)
    }

    /// Moves the firing counts of the agents that took a hop in this step (see
    /// [`Engine::set_state_at_once`]) from their old state's rule to their new one's.
    fn count_hops(&mut self) {
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
    fn hop(&self, idx: u32, r: u32, bits: (u64, u64)) -> Hop {
        let key = (self.cand_keys[idx as usize] & !bits.0) | bits.1;
        let Some(&to) = self.candidates.get(&key) else {
            return Hop::UNKNOWN;
        };
        let next = self.cand_single[to as usize];
        let quiet = |q: u32| q == NO_RULE || !self.computes[q as usize];
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

    /// Adds the actions of agent `a` executing rule `r` alone to `todo`.
    #[inline(always)]
    fn add_rule_actions(&self, todo: &mut Actions, a: u32, r: u32) {
        let info = &self.prog.rules[r as usize];
        if let Some(off) = info.moves {
            let o = match self.literal_offsets[off as usize] {
                Some(o) => o,
                None => {
                    let env = SelEnv {
                        lat: &self.lat,
                        a,
                        prio: None,
                    };
                    latticesim_vm::eval::resolve(&self.prog.offsets[off as usize], &env)
                }
            };
            if o != [0, 0, 0] {
                todo.moves.push((a, o));
            }
        }
        if info.attaches.is_some() || info.swaps.is_some() {
            let letters = info
                .attaches
                .map_or([AttachLetter::Keep; 6], |l| self.prog.letters[l as usize]);
            todo.links.push((a, letters, info.swaps));
        }
        if let Some(p) = info.sets_state {
            todo.states.push((a, pat_bits(&self.prog.pats[p as usize])));
        }
    }

    /// Counts the moves about to be made (agent, target), and traces them.
    fn count_moves(&mut self, moves: &[(u32, [i32; 3])], rep: &mut StepReport) {
        if self.opts.trace {
            for &(m, to) in moves {
                rep.trace.push(TraceEvent::Move {
                    agent: m,
                    from: self.lat.pos[m as usize],
                    to,
                });
            }
        }
        self.stats.moves += moves.len() as u64;
    }

    /// Steps 1 to 4 when no agent is attached and no rule attaches: every group is one
    /// agent, so only the movers are looked at (the same decisions and records as
    /// [`Engine::detach_move_attach`]).
    fn move_alone(&mut self, live: &mut Vec<(u32, [i32; 3])>, rep: &mut StepReport) {
        // Movers in agent order, with their targets (in place of their offsets) and the
        // targets' slot codes.
        let mut sc = std::mem::take(&mut self.scratch);
        sc.codes.clear();
        let mut blocked = Vec::new();
        let mut kept = 0;
        let one_offset = live.iter().all(|m| m.1 == live[0].1);
        for i in 0..live.len() {
            let (a, o) = live[i];
            if let Some(t) = self.lat.moved(self.lat.pos[a as usize], o) {
                live[kept] = (a, t);
                kept += 1;
            } else {
                blocked.push((a, o));
            }
        }
        live.truncate(kept);
        let cells = &self.lat.cells;
        sc.codes.extend(live.iter().map(|&(_, t)| cells.code(t)));
        for (a, o) in blocked {
            let msg = format!("agent {a} cannot move by ({},{},{}): the target cell is blocked; its group does not move", o[0], o[1], o[2]);
            self.record(rep, RecordKind::MoveBlocked, &[a], msg);
        }
        // Collisions: cancel every move involved, until none is left. Targets are counted
        // in bits per grid cell (claimed once, claimed more than once) where the grid covers
        // them, in a hash map elsewhere; movers are marked in bits per agent. Each round
        // clears the bits it set.
        let cells = self.lat.cells.slots();
        let words = |bits: usize| bits.div_ceil(64);
        if sc.once.len() != words(cells) || sc.moving.len() != words(self.lat.len()) {
            sc.once = vec![0; words(cells)];
            sc.twice = vec![0; words(cells)];
            sc.moving = vec![0; words(self.lat.len())];
        }
        if !self.opts.trace && move_free(&mut self.lat, live, &mut sc, one_offset) {
            self.scratch = sc;
            self.count_moves(live, rep);
            return;
        }
        loop {
            let mut count: FxHashMap<[i32; 3], u32> = FxHashMap::default();
            for &(a, t) in live.iter() {
                let s = self.lat.cells.slot(t);
                sc.claim(a, s);
                if s.is_none() {
                    *count.entry(t).or_insert(0) += 1;
                }
            }
            let moving = |s: u32| sc.moving(s);
            let claimed_again = |t: [i32; 3]| match self.lat.cells.slot(t) {
                Some(s) => sc.claimed_twice(s),
                None => count[&t] > 1,
            };
            let mut bad: BTreeMap<[i32; 3], Vec<u32>> = BTreeMap::new();
            for (a, t) in live.iter() {
                let stay = self.lat.agent_at(*t).filter(|&s| !moving(s));
                if claimed_again(*t) || stay.is_some() {
                    bad.entry(*t).or_default().push(*a);
                }
            }
            let clear = |sc: &mut MoveScratch,
                         live: &[(u32, [i32; 3])],
                         cells: &crate::cells::CellIndex| {
                for &(a, t) in live {
                    sc.unclaim(a, cells.slot(t));
                }
            };
            if bad.is_empty() {
                clear(&mut sc, live, &self.lat.cells);
                break;
            }
            let mut cancel: Vec<(u32, [i32; 3], Vec<u32>)> = Vec::new();
            for (cell, ms) in bad {
                let mut involved = ms.clone();
                involved.extend(self.lat.agent_at(cell).filter(|&s| !moving(s)));
                for m in ms {
                    cancel.push((m, cell, involved.clone()));
                }
            }
            cancel.sort_by_key(|c| c.0);
            clear(&mut sc, live, &self.lat.cells);
            for (a, cell, involved) in cancel {
                let i = live.binary_search_by_key(&a, |m| m.0).expect("a mover");
                live.remove(i);
                let msg = format!(
                    "a move of agent {} would put agents {} on the cell ({},{},{}); the moves are cancelled",
                    a,
                    involved.iter().map(|m| m.to_string()).collect::<Vec<_>>().join(", "),
                    cell[0],
                    cell[1],
                    cell[2]
                );
                self.record(rep, RecordKind::MoveCollision, &[a], msg);
            }
        }
        self.scratch = sc;
        self.count_moves(live, rep);
        self.lat.relocate(live);
    }

    /// Steps 1 to 4: detach, decide, move rigid groups, attach.
    fn detach_move_attach(&mut self, intents: &[Intent], rep: &mut StepReport) {
        let n = self.lat.len();
        let nd = self.lat.dim.dirs();
        let old_attach = self.lat.attach.clone();
        // Partner before detaching, per agent and direction.
        let partner = |lat: &Lattice, a: usize, d: usize| -> Option<u32> {
            (old_attach[a] & (1 << d) != 0)
                .then(|| lat.neighbour(a as u32, Dir::ALL[d]))
                .flatten()
        };
        // 1. Detach: keep rigid bonds only.
        let mut rigid = vec![0u8; n];
        for a in 0..n {
            for d in 0..nd {
                let Some(b) = partner(&self.lat, a, d) else {
                    continue;
                };
                let od = Dir::ALL[d].opposite().index();
                let (la, lb) = (intents[a].letters[d], intents[b as usize].letters[od]);
                if la != AttachLetter::Detach
                    && lb != AttachLetter::Detach
                    && (la == AttachLetter::Rigid || lb == AttachLetter::Rigid)
                {
                    rigid[a] |= 1 << d;
                }
            }
        }
        // 3. Move: groups of rigid bonds.
        let mut parent: Vec<u32> = (0..n as u32).collect();
        for a in 0..n {
            for d in 0..nd {
                if rigid[a] & (1 << d) != 0 {
                    if let Some(b) = partner(&self.lat, a, d) {
                        let (x, y) = (find(&mut parent, a as u32), find(&mut parent, b));
                        if x != y {
                            parent[x.max(y) as usize] = x.min(y);
                        }
                    }
                }
            }
        }
        let mut members: BTreeMap<u32, Vec<u32>> = BTreeMap::new();
        let movers: Vec<usize> = (0..n)
            .filter(|&a| intents[a].mv.is_some() || intents[a].mv_bad)
            .collect();
        for &a in &movers {
            let root = find(&mut parent, a as u32);
            members.entry(root).or_default();
        }
        if !members.is_empty() {
            for a in 0..n as u32 {
                let root = find(&mut parent, a);
                if let Some(m) = members.get_mut(&root) {
                    m.push(a);
                }
            }
        }
        // Group offsets.
        let mut group_off: BTreeMap<u32, [i32; 3]> = BTreeMap::new();
        for (&root, ms) in &members {
            let mut off: Option<[i32; 3]> = None;
            let mut bad = false;
            let mut differ = false;
            for &m in ms {
                let it = &intents[m as usize];
                bad |= it.mv_bad;
                if let Some(o) = it.mv {
                    match off {
                        None => off = Some(o),
                        Some(p) if p != o => differ = true,
                        _ => {}
                    }
                }
            }
            if differ && !bad {
                let msg = format!(
                    "the rigid group of agents {} is asked for different moves by its members; it does not move",
                    ms.iter().map(|m| m.to_string()).collect::<Vec<_>>().join(", ")
                );
                self.record(rep, RecordKind::GroupConflict, ms, msg);
            }
            if let (Some(o), false, false) = (off, bad, differ) {
                group_off.insert(root, o);
            }
        }
        // Blocked targets.
        let roots: Vec<u32> = group_off.keys().copied().collect();
        for root in roots {
            let o = group_off[&root];
            let ms = &members[&root];
            let blocked = ms.iter().find(|&&m| {
                let p = self.lat.pos[m as usize];
                !self.lat.inside([
                    p[0] as i64 + o[0] as i64,
                    p[1] as i64 + o[1] as i64,
                    p[2] as i64 + o[2] as i64,
                ])
            });
            if let Some(&m) = blocked {
                let ms = ms.clone();
                group_off.remove(&root);
                let msg = format!("agent {m} cannot move by ({},{},{}): the target cell is blocked; its group does not move", o[0], o[1], o[2]);
                self.record(rep, RecordKind::MoveBlocked, &ms, msg);
            }
        }
        // Collisions: cancel every group involved, until none is left.
        loop {
            let mut target: rustc_hash::FxHashMap<[i32; 3], Vec<u32>> = Default::default();
            for (&root, o) in &group_off {
                for &m in &members[&root] {
                    let p = self.lat.pos[m as usize];
                    target
                        .entry([p[0] + o[0], p[1] + o[1], p[2] + o[2]])
                        .or_default()
                        .push(m);
                }
            }
            let moving = |a: u32, parent: &mut Vec<u32>| group_off.contains_key(&find(parent, a));
            let mut cancel: Vec<(u32, [i32; 3], Vec<u32>)> = Vec::new();
            let mut cells: Vec<&[i32; 3]> = target.keys().collect();
            cells.sort();
            for cell in cells {
                let ms = &target[cell];
                let stay = self
                    .lat
                    .agent_at(*cell)
                    .filter(|&s| !moving(s, &mut parent));
                if ms.len() > 1 || stay.is_some() {
                    let mut involved = ms.clone();
                    involved.extend(stay);
                    for &m in ms {
                        let root = find(&mut parent, m);
                        if !cancel.iter().any(|c| c.0 == root) {
                            cancel.push((root, *cell, involved.clone()));
                        }
                    }
                }
            }
            if cancel.is_empty() {
                break;
            }
            cancel.sort_by_key(|c| c.0);
            for (root, cell, involved) in cancel {
                group_off.remove(&root);
                let msg = format!(
                    "a move of agent {} would put agents {} on the cell ({},{},{}); the moves are cancelled",
                    root,
                    involved.iter().map(|m| m.to_string()).collect::<Vec<_>>().join(", "),
                    cell[0],
                    cell[1],
                    cell[2]
                );
                self.record(rep, RecordKind::MoveCollision, &members[&root].clone(), msg);
            }
        }
        let mut moves: Vec<(u32, [i32; 3])> = Vec::new();
        for (root, o) in &group_off {
            for &m in &members[root] {
                let p = self.lat.pos[m as usize];
                moves.push((m, [p[0] + o[0], p[1] + o[1], p[2] + o[2]]));
            }
        }
        moves.sort_unstable();
        self.count_moves(&moves, rep);
        // Partners for `*` must be read before the moves.
        let mut keep_partner: Vec<[Option<u32>; 6]> = vec![[None; 6]; n];
        for a in 0..n {
            for d in 0..nd {
                keep_partner[a][d] = partner(&self.lat, a, d);
            }
        }
        self.lat.relocate(&moves);
        // 4. Attach: rigid bonds stay; a bond forms where one side decided to attach and
        // neither side said 0.
        let mut new_attach = rigid;
        for a in 0..n {
            for d in 0..nd {
                if new_attach[a] & (1 << d) != 0 {
                    continue;
                }
                let la = intents[a].letters[d];
                // Only `1`, or `*`/`+` towards a former partner, can form a bond: look up
                // the neighbour only then.
                let wants = match la {
                    AttachLetter::Attach => true,
                    AttachLetter::Keep | AttachLetter::Rigid => keep_partner[a][d].is_some(),
                    AttachLetter::Detach => false,
                };
                if !wants {
                    continue;
                }
                let Some(b) = self.lat.neighbour(a as u32, Dir::ALL[d]) else {
                    continue;
                };
                if la != AttachLetter::Attach && keep_partner[a][d] != Some(b) {
                    continue;
                }
                let od = Dir::ALL[d].opposite().index();
                let lb = intents[b as usize].letters[od];
                if lb == AttachLetter::Detach {
                    if la == AttachLetter::Attach {
                        let msg = format!(
                            "agent {a} wants to attach towards {} to agent {b}, which says 0; no bond",
                            Dir::ALL[d].letter()
                        );
                        self.record(rep, RecordKind::AttachRefused, &[a as u32, b], msg);
                    }
                    continue;
                }
                new_attach[a] |= 1 << d;
                new_attach[b as usize] |= 1 << od;
            }
        }
        if self.opts.trace {
            for a in 0..n {
                for d in 0..nd {
                    let was = old_attach[a] & (1 << d) != 0;
                    let now = new_attach[a] & (1 << d) != 0;
                    let b_now = self.lat.neighbour(a as u32, Dir::ALL[d]);
                    let b_was = keep_partner[a][d];
                    if was && (!now || b_now != b_was) {
                        if let Some(b) = b_was.filter(|&b| b > a as u32) {
                            rep.trace.push(TraceEvent::Bond {
                                a: a as u32,
                                b,
                                formed: false,
                            });
                        }
                    }
                    if now && (!was || b_now != b_was) {
                        if let Some(b) = b_now.filter(|&b| b > a as u32) {
                            rep.trace.push(TraceEvent::Bond {
                                a: a as u32,
                                b,
                                formed: true,
                            });
                        }
                    }
                }
            }
        }
        self.lat.attach = new_attach;
    }

    /// Step 6: swaps. `no_swap` (in agent order) take part in none: a request towards one
    /// is cancelled with a record, but still counts when pairs are judged.
    fn swaps(&mut self, links: &[Link], no_swap: &[u32], rep: &mut StepReport) {
        // (x, y, direction from x to y, cancelled because one of them takes no swap)
        let mut pairs: Vec<(u32, u32, Dir, bool)> = Vec::new();
        for &(a, _, swap) in links {
            let Some(d) = swap else { continue };
            match self.lat.cell_at(self.lat.pos[a as usize], d.offset()) {
                Cell::Agent(b) => {
                    // Two agents asking to swap with each other make one swap.
                    let (x, y, dd) = if a < b {
                        (a, b, d)
                    } else {
                        (b, a, d.opposite())
                    };
                    let dead = no_swap.binary_search(&b).is_ok();
                    if dead {
                        let msg = format!(
                            "agent {a} cannot swap towards {}: agent {b} there is asked for different swaps and takes part in none",
                            d.letter()
                        );
                        self.record(rep, RecordKind::SwapTarget, &[a], msg);
                    }
                    if !pairs.iter().any(|p| p.0 == x && p.1 == y) {
                        pairs.push((x, y, dd, dead));
                    }
                }
                _ => {
                    let msg = format!(
                        "agent {a} cannot swap towards {}: no agent stands there",
                        d.letter()
                    );
                    self.record(rep, RecordKind::SwapTarget, &[a], msg);
                }
            }
        }
        let mut count: rustc_hash::FxHashMap<u32, u32> = Default::default();
        for p in &pairs {
            *count.entry(p.0).or_default() += 1;
            *count.entry(p.1).or_default() += 1;
        }
        for (x, y, d, dead) in pairs {
            if dead {
                continue;
            }
            if count[&x] > 1 || count[&y] > 1 {
                let msg = format!("the swap of agents {x} and {y} shares an agent with another swap; it is cancelled");
                self.record(rep, RecordKind::SwapShared, &[x, y], msg);
                continue;
            }
            let (px, py) = (self.lat.pos[x as usize], self.lat.pos[y as usize]);
            // Bonds other than the one between them are dropped.
            let nd = self.lat.dim.dirs();
            let bonded = self.lat.attach[x as usize] & (1 << d.index()) != 0;
            for &(s, _) in &[(x, px), (y, py)] {
                for k in 0..nd {
                    if self.lat.attach[s as usize] & (1 << k) != 0 {
                        if let Some(o) = self.lat.neighbour(s, Dir::ALL[k]) {
                            if o != x && o != y {
                                self.lat.attach[o as usize] &=
                                    !(1 << Dir::ALL[k].opposite().index());
                            }
                        }
                    }
                }
                self.lat.attach[s as usize] = 0;
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

    /// Paper step 3, first half: every selected rule's calculations and sends.
    ///
    /// Each agent writes only its own counters and outbox, so the agents are split into
    /// chunks (worked on in parallel with --threads) whose issues and trace events are
    /// joined in agent order afterwards. Within a chunk, a run of consecutive agents that
    /// execute the same single rule runs that rule's calculations one instruction at a
    /// time over the whole run ([`run_batch`]), which amortises the dispatch and lets the
    /// compiler vectorise; other agents run the rule alone ([`run_post`]).
    fn calculations(&mut self, sel: &Selection, rep: &mut StepReport) {
        if !self.any_computes {
            return;
        }
        self.lat.refresh_neighbours();
        let n = self.lat.len();
        let nd = self.lat.dim.dirs();
        // External counters read the values at the start of this phase.
        let snapshot = if self.prog.externals.is_empty() {
            Vec::new()
        } else {
            self.lat.counters.clone()
        };
        let mut counters = std::mem::take(&mut self.lat.counters);
        let mut out_num = std::mem::take(&mut self.out_num);
        let mut out_has = std::mem::take(&mut self.out_has);
        let mut out_text = std::mem::take(&mut self.out_text);
        let mut out_text_bits = std::mem::take(&mut self.out_text_bits);
        let (par, size, chunks) = self.chunks(n);
        let mut ctr = split_columns(&mut counters, size, chunks).into_iter();
        let mut onum = split_columns(&mut out_num, size, chunks).into_iter();
        let mut ohas = split_columns(&mut out_has, size.div_ceil(64), chunks).into_iter();
        let mut otext = parts(&mut out_text, size * nd, chunks).into_iter();
        let mut otbits = parts(&mut out_text_bits, size, chunks).into_iter();
        let items: Vec<CalcChunk<'_>> = (0..chunks)
            .map(|c| CalcChunk {
                lo: c * size,
                len: size.min(n - c * size),
                counters: ctr.next().unwrap_or_default(),
                out_num: onum.next().unwrap_or_default(),
                out_has: ohas.next().unwrap_or_default(),
                out_text: otext.next().unwrap_or_default(),
                out_text_bits: otbits.next().unwrap_or_default(),
            })
            .collect();
        let (prog, lat, trace) = (&self.prog, &self.lat, self.opts.trace);
        let batchable = &self.batchable;
        // When every agent executes the same one rule, runs need no search.
        let uniform = sel.many.is_empty() && self.fire_counts.contains(&(n as u64));
        // The neighbour bits are made at the first delivery; until then it counts.
        let (defer, has_nbr) = (self.defer, &self.has_nbr);
        let count = defer && has_nbr.len() == nd;
        let work = |mut ch: CalcChunk<'_>| {
            // With messages left with their senders, the outboxes come back from the
            // lattice holding the step before last's bits.
            if defer {
                ch.out_has.iter_mut().for_each(|c| c.fill(0));
            }
            let mut issues: Vec<(u32, u32, CalcIssue)> = Vec::new();
            let mut events = Vec::new();
            let mut bufs = CalcBufs::new();
            let mut k = 0;
            while k < ch.len {
                let a = ch.lo + k;
                if sel.one[a] == NO_RULE {
                    // A run of agents executing nothing.
                    k += run_of(&sel.one[a..ch.lo + ch.len], NO_RULE);
                    continue;
                }
                let rs = sel.of(a);
                if let [r] = *rs {
                    if !prog.rules[r as usize].computes {
                        k += 1;
                        continue;
                    }
                    if batchable[r as usize] && !trace {
                        let end = if uniform {
                            ch.len
                        } else {
                            k + run_of(&sel.one[ch.lo + k..ch.lo + ch.len], r)
                        };
                        run_batch(prog, r, lat, (&mut ch, &mut bufs), k..end, &mut issues);
                        k = end;
                        continue;
                    }
                }
                for &r in rs {
                    if !prog.rules[r as usize].computes {
                        continue;
                    }
                    let before: Vec<i16> = if trace {
                        (0..lat.nc() as u8).map(|i| ch.counter(lat, k, i)).collect()
                    } else {
                        Vec::new()
                    };
                    let mut env = CalcCtx {
                        lat,
                        a,
                        k,
                        ch: &mut ch,
                        snapshot: &snapshot,
                        issues: Vec::new(),
                    };
                    run_post(prog, r as usize, &mut env);
                    issues.extend(env.issues.into_iter().map(|(_, i)| (a as u32, r, i)));
                    if trace {
                        for (i, &old) in before.iter().enumerate() {
                            let new = ch.counter(lat, k, i as u8);
                            if old != new {
                                events.push(TraceEvent::Counter {
                                    agent: a as u32,
                                    counter: i as u8,
                                    value: new,
                                });
                            }
                        }
                    }
                }
                k += 1;
            }
            let counted = if count {
                Tally::of(&ch.out_has, has_nbr, ch.lo / 64, nd, ch.len)
            } else {
                Tally::default()
            };
            (issues, events, counted)
        };
        let results: Vec<_> = match par {
            Some((pool, _)) => pool.map(items, work),
            _ => items.into_iter().map(work).collect(),
        };
        self.lat.counters = counters;
        self.out_num = out_num;
        self.out_has = out_has;
        self.out_text = out_text;
        self.out_text_bits = out_text_bits;
        if count {
            let mut tallies = results.iter().map(|r| &r.2);
            let first = tallies.next().cloned().unwrap_or_default();
            self.counted = Some(tallies.fold(first, |t, u| t.and(u)));
        }
        for (issues, events, _) in results {
            for (a, r, issue) in issues {
                let name = self.rule_name(r).to_string();
                let (kind, msg) = match issue {
                    CalcIssue::Saturated { exact } => (
                        RecordKind::Saturation,
                        format!("agent {a}, rule `{name}`: the result {exact} is saturated to the 16-bit range"),
                    ),
                    CalcIssue::DivisionByZero => (
                        RecordKind::DivisionByZero,
                        format!("agent {a}, rule `{name}`: division by zero; the target is unchanged"),
                    ),
                    CalcIssue::NoExternalAgent { off } => (
                        RecordKind::NoExternalAgent,
                        format!(
                            "agent {a}, rule `{name}`: no agent at ({},{}) to read an external counter from; the calculation is skipped",
                            off[0], off[1]
                        ),
                    ),
                };
                self.record(rep, kind, &[a], msg);
            }
            rep.trace.extend(events);
        }
    }

    /// Paper step 3, second half: every inbox is emptied and filled with what this step's
    /// outboxes hold, each agent pulling from the neighbour in each direction what that
    /// neighbour sent towards it (in chunks of agents, in parallel with --threads).
    fn deliver(&mut self, rep: &mut StepReport) {
        self.lat.refresh_neighbours();
        let d = self.lat.dim;
        let (n, nd, ns) = (self.lat.len(), d.dirs(), self.lat.slots as usize);
        if self.opts.trace {
            self.trace_messages(rep);
        }
        let texts = !self.out_text_bits.is_empty();
        if ns == 0 && !texts {
            // No rule sends or reads messages: there is nothing to deliver.
            return;
        }
        if self.defer {
            self.deliver_deferred();
            return;
        }
        let sent: u64 = self.out_has.iter().flatten().map(|&w| ones(w)).sum::<u64>()
            + self
                .out_text_bits
                .iter()
                .map(|t| t.count_ones() as u64)
                .sum::<u64>();
        let mut inbox_num = std::mem::take(&mut self.lat.inbox_num);
        let mut inbox_text = std::mem::take(&mut self.lat.inbox_text);
        let mut inbox_has = std::mem::take(&mut self.lat.inbox_text_has);
        let (par, size, chunks) = self.chunks(n);
        let mut num = split_columns(&mut inbox_num, size, chunks).into_iter();
        let mut text = parts(&mut inbox_text, size * nd, chunks).into_iter();
        let mut has = parts(&mut inbox_has, size, chunks).into_iter();
        let items: Vec<InboxChunk<'_>> = (0..chunks)
            .map(|c| InboxChunk {
                lo: c * size,
                len: size.min(n - c * size),
                num: num.next().unwrap_or_default(),
                text: text.next().unwrap_or_default(),
                has: has.next().unwrap_or_default(),
            })
            .collect();
        let (lat, out_num, out_has) = (&self.lat, &self.out_num, &self.out_has);
        let (out_text, out_text_bits) = (&self.out_text, &self.out_text_bits);
        // Fills one chunk of recipients; returns how many messages arrived.
        let pull = |ch: InboxChunk<'_>| {
            let mut got = 0u64;
            let InboxChunk {
                lo,
                len,
                mut num,
                text,
                has,
            } = ch;
            if texts {
                has.fill(0);
            }
            // In batches: first every recipient's neighbours, then one tight loop per
            // direction and slot.
            // Agents on consecutive cells of a grid read their neighbours straight from it.
            let mut nb = [[NO_AGENT; BATCH]; 6];
            let mut one = [NO_AGENT; 6];
            let mut base = 0;
            while base < len {
                let mut m = BATCH.min(len - base);
                let run = lat.neighbour_run(lo + base, m);
                if let Some((r, _)) = run {
                    m = r;
                } else {
                    for j in 0..m {
                        lat.neighbours((lo + base + j) as u32, &mut one);
                        for (col, &v) in nb.iter_mut().zip(&one).take(nd) {
                            col[j] = v;
                        }
                    }
                }
                for dir in 0..nd {
                    let from = match &run {
                        Some((_, r)) => r[dir],
                        None => &nb[dir][..m],
                    };
                    let od = OPPOSITE[dir];
                    // The senders are themselves consecutive agents.
                    let f0 = from[0] as usize;
                    let dense = from[0] != NO_AGENT && is_sequence(from, from[0]);
                    for sc in 0..ns {
                        let cout = od * ns + sc;
                        let (out, bits) = (&out_num[cout][..], &out_has[cout][..]);
                        let inb = &mut num[dir * ns + sc][base..base + m];
                        if dense && all_bits(bits, f0..f0 + m) {
                            inb.copy_from_slice(&out[f0..f0 + m]);
                            got += m as u64;
                            continue;
                        }
                        for (v, &f) in inb.iter_mut().zip(from) {
                            let f = f as usize;
                            *v = if f != NO_AGENT as usize && bits[f >> 6] & (1 << (f & 63)) != 0 {
                                got += 1;
                                out[f]
                            } else {
                                0
                            };
                        }
                    }
                    if texts {
                        for (j, &f) in from.iter().enumerate() {
                            let f = f as usize;
                            if f != NO_AGENT as usize && out_text_bits[f] & (1 << od) != 0 {
                                let k = base + j;
                                text[k * nd + dir] = out_text[f * nd + od];
                                has[k] |= 1 << dir;
                                got += 1;
                            }
                        }
                    }
                }
                base += m;
            }
            got
        };
        let delivered: u64 = match par {
            Some((pool, _)) => pool.map(items, pull).into_iter().sum(),
            None => items.into_iter().map(pull).sum(),
        };
        self.lat.inbox_num = inbox_num;
        self.lat.inbox_text = inbox_text;
        self.lat.inbox_text_has = inbox_has;
        self.out_has.iter_mut().for_each(|c| c.fill(0));
        self.out_text_bits.fill(0);
        self.stats.sent += sent;
        self.stats.delivered += delivered;
        self.stats.dropped += sent - delivered;
    }

    /// Delivery without copying: this step's outboxes become the lattice's pending
    /// messages (and the last step's pending columns the next outboxes). A message is
    /// delivered when its sender has a neighbour in the direction it was sent.
    fn deliver_deferred(&mut self) {
        // Counted by the calculations (see [`Tally`]), but for the first time.
        let tally = match self.counted.take() {
            Some(c) => c,
            None => {
                self.prepare_deferred();
                let (n, nd) = (self.lat.len(), self.lat.dim.dirs());
                Tally::of(&self.out_has, &self.has_nbr, 0, nd, n)
            }
        };
        let (sent, delivered) = (tally.sent, tally.delivered);
        let p = self
            .lat
            .pending
            .as_mut()
            .expect("made at the first delivery");
        std::mem::swap(&mut p.num, &mut self.out_num);
        std::mem::swap(&mut p.has, &mut self.out_has);
        (p.full, p.empty) = (tally.full, tally.empty);
        // The inbox columns are not read while messages are pending. The outboxes' bits
        // are cleared by the next calculations.
        self.lat.inbox_num.iter_mut().for_each(|c| *c = Vec::new());
        self.stats.sent += sent;
        self.stats.delivered += delivered;
        self.stats.dropped += sent - delivered;
    }

    /// With `defer`: the pending columns (and plan) and the neighbour bits, made once.
    fn prepare_deferred(&mut self) {
        if self.lat.pending.is_none() {
            let lat = &self.lat;
            let parts = self.par_chunks(lat.len(), &|lo, hi| Pending::plan_part(lat, lo, hi));
            self.lat.pending = Some(Pending::new(&self.lat, &self.out_num, parts));
        }
        let nd = self.lat.dim.dirs();
        if self.has_nbr.len() != nd {
            let p = self.lat.pending.as_ref().expect("just made");
            self.has_nbr = (0..nd).map(|d| p.has_sender(&self.lat, d)).collect();
        }
    }

    /// One trace event per message of this step's outboxes, senders in id order.
    fn trace_messages(&self, rep: &mut StepReport) {
        let d = self.lat.dim;
        let (nd, ns) = (d.dirs(), d.slots());
        let bit = |col: usize, a: usize| self.out_has[col][a >> 6] & (1 << (a & 63)) != 0;
        // With a column for sends to all directions (see `defer`), its bit counts too.
        let cols = nd * self.lat.slots as usize;
        let all =
            |col: usize| (self.out_has.len() > cols).then(|| cols + col % self.lat.slots as usize);
        let has = |col: usize, a: usize| bit(col, a) || all(col).is_some_and(|c| bit(c, a));
        for a in 0..self.lat.len() {
            for dir in 0..nd {
                let slots: Vec<usize> = (0..ns)
                    .filter(|&s| {
                        let c = self.lat.slot_col[s];
                        c != NO_COL && has(dir * self.lat.slots as usize + c as usize, a)
                    })
                    .collect();
                let has_text = self
                    .out_text_bits
                    .get(a)
                    .is_some_and(|t| t & (1 << dir) != 0);
                if slots.is_empty() && !has_text {
                    continue;
                }
                let to = self.lat.neighbour(a as u32, Dir::ALL[dir]);
                let letter = Dir::ALL[dir].letter();
                for s in slots {
                    let col = dir * self.lat.slots as usize + self.lat.slot_col[s] as usize;
                    rep.trace.push(TraceEvent::Message {
                        from: a as u32,
                        to,
                        dir: letter,
                        slot: Some(s as u8 + 1),
                        value: Some(match all(col) {
                            Some(c) if !bit(col, a) => self.out_num[c][a],
                            _ => self.out_num[col][a],
                        }),
                        text: None,
                    });
                }
                if has_text {
                    rep.trace.push(TraceEvent::Message {
                        from: a as u32,
                        to,
                        dir: letter,
                        slot: None,
                        value: None,
                        text: Some(text(&self.out_text[a * nd + dir])),
                    });
                }
            }
        }
    }
}

/// Splits each column into `chunks` parts of `size` (the last may be shorter) and returns,
/// per part, that part of every column.
fn split_columns<T>(cols: &mut [Vec<T>], size: usize, chunks: usize) -> Vec<Vec<&mut [T]>> {
    let mut out: Vec<Vec<&mut [T]>> = (0..chunks)
        .map(|_| Vec::with_capacity(cols.len()))
        .collect();
    for col in cols {
        for (k, part) in parts(col, size, chunks).into_iter().enumerate() {
            out[k].push(part);
        }
    }
    out
}

/// `chunks` parts of `size` of a column (empty parts when the column is empty or short).
fn parts<T>(col: &mut [T], size: usize, chunks: usize) -> Vec<&mut [T]> {
    let mut out: Vec<&mut [T]> = col.chunks_mut(size.max(1)).collect();
    out.resize_with(chunks, Default::default);
    out
}

/// One chunk of recipients: `len` agents from `lo`, their numeric inbox columns, text
/// inboxes and text bits.
struct InboxChunk<'a> {
    lo: usize,
    len: usize,
    num: Vec<&'a mut [i16]>,
    text: &'a mut [[u8; 5]],
    has: &'a mut [u8],
}

/// One chunk of agents as the calculation phase splits them: `len` agents from `lo` (a
/// multiple of 64), their counter columns, numeric outbox columns and bits, text outbox.
struct CalcChunk<'a> {
    lo: usize,
    len: usize,
    counters: Vec<&'a mut [i16]>,
    out_num: Vec<&'a mut [i16]>,
    out_has: Vec<&'a mut [u64]>,
    out_text: &'a mut [[u8; 5]],
    out_text_bits: &'a mut [u8],
}

impl CalcChunk<'_> {
    /// Counter `i` of the chunk's `k`-th agent.
    fn counter(&self, lat: &Lattice, k: usize, i: u8) -> i16 {
        match lat.counter_col[i as usize] {
            NO_COL => 0,
            c => self.counters[c as usize][k],
        }
    }

    /// The outbox columns a send towards `dir` (or all directions) in `slot` writes, and
    /// those whose bits it clears: where the outboxes have a column for sends to all
    /// directions (see `Engine::defer`), such a send writes that one and clears the
    /// direction columns (a value there would be taken before it).
    fn send_cols(&self, lat: &Lattice, dir: u8, slot: u8) -> SendCols {
        let (nd, ns, sc) = (
            lat.dim.dirs(),
            lat.slots as usize,
            lat.slot_col[slot as usize] as usize,
        );
        let mut c = SendCols {
            write: [0; 6],
            nw: 0,
            clear: [0; 6],
            nc: 0,
        };
        if dir != ANY_DIR {
            c.write[0] = dir as usize * ns + sc;
            c.nw = 1;
        } else if self.out_num.len() > nd * ns {
            c.write[0] = nd * ns + sc;
            c.nw = 1;
            for d in 0..nd {
                c.clear[d] = d * ns + sc;
            }
            c.nc = nd;
        } else {
            for d in 0..nd {
                c.write[d] = d * ns + sc;
            }
            c.nw = nd;
        }
        c
    }

    /// The text outbox directions of a send towards `dir` (or all directions).
    fn text_dirs(lat: &Lattice, dir: u8) -> std::ops::Range<usize> {
        if dir == ANY_DIR {
            0..lat.dim.dirs()
        } else {
            dir as usize..dir as usize + 1
        }
    }
}

/// The outbox columns of a send: see [`CalcChunk::send_cols`].
struct SendCols {
    write: [usize; 6],
    nw: usize,
    clear: [usize; 6],
    nc: usize,
}

impl SendCols {
    fn write(&self) -> &[usize] {
        &self.write[..self.nw]
    }
    fn clear(&self) -> &[usize] {
        &self.clear[..self.nc]
    }
}

/// With messages left with their senders: how many messages the outbox bits `cols` (the
/// words from `w0` of every column, the columns for sends to all directions last) hold,
/// and how many of them have a recipient. A send to all directions is one message per
/// direction (one sent later towards one direction replaces that one). `empty` tells the
/// columns without a bit set, which are not read.
fn count_messages<C: AsRef<[u64]>>(
    cols: &[C],
    has_nbr: &[Vec<u64>],
    (w0, nd): (usize, usize),
    empty: &[bool],
) -> (u64, u64) {
    let ns = cols.len() / (nd + 1);
    let (mut sent, mut delivered) = (0u64, 0u64);
    for s in 0..ns {
        let all = cols[nd * ns + s].as_ref();
        let none_to_all = empty[nd * ns + s];
        if !none_to_all {
            sent += nd as u64 * all.iter().map(|&a| ones(a)).sum::<u64>();
        }
        for (d, nbr) in has_nbr.iter().enumerate().take(nd) {
            let col = d * ns + s;
            let (one, nbr) = (cols[col].as_ref(), &nbr[w0..w0 + all.len()]);
            match (empty[col], none_to_all) {
                (true, true) => {}
                (true, false) => {
                    delivered += all.iter().zip(nbr).map(|(a, b)| ones(a & b)).sum::<u64>();
                }
                (false, _) => {
                    for ((h, a), b) in one.iter().zip(all).zip(nbr) {
                        sent += ones(h & !a);
                        delivered += ones((h | a) & b);
                    }
                }
            }
        }
    }
    (sent, delivered)
}

/// With messages left with their senders, what a step's outboxes (or a chunk of agents'
/// part of them) hold: the messages sent and delivered ([`count_messages`]), and per
/// outbox column whether every agent's bit is set (`full`) and whether none is (`empty`),
/// so that the post office need not test ranges of bits in such columns.
#[derive(Clone, Debug, Default)]
struct Tally {
    sent: u64,
    delivered: u64,
    full: Vec<bool>,
    empty: Vec<bool>,
}

impl Tally {
    /// The tally of the outbox bits `cols` of `len` agents (from word `w0` of the
    /// neighbour bits).
    fn of<C: AsRef<[u64]>>(
        cols: &[C],
        has_nbr: &[Vec<u64>],
        w0: usize,
        nd: usize,
        len: usize,
    ) -> Tally {
        let full = cols.iter().map(|c| all_bits(c.as_ref(), 0..len)).collect();
        let empty: Vec<bool> = cols.iter().map(|c| no_bits(c.as_ref(), 0..len)).collect();
        let (sent, delivered) = count_messages(cols, has_nbr, (w0, nd), &empty);
        Tally {
            sent,
            delivered,
            full,
            empty,
        }
    }

    /// The tally of two chunks together.
    fn and(self, other: &Tally) -> Tally {
        let both = |a: Vec<bool>, b: &[bool]| a.iter().zip(b).map(|(&x, &y)| x && y).collect();
        Tally {
            sent: self.sent + other.sent,
            delivered: self.delivered + other.delivered,
            full: both(self.full, &other.full),
            empty: both(self.empty, &other.empty),
        }
    }
}

/// Stack depth of [`batch_pre`].
const PRE_STACK: usize = 6;

/// The working space of [`batch_pre`], made once for a chunk of agents rather than at
/// each call (a call may evaluate a run of a few agents): its stack of truth values and
/// its two operands.
struct PreBufs {
    stack: [[bool; BATCH]; PRE_STACK],
    x: [i32; BATCH],
    y: [i32; BATCH],
}

impl PreBufs {
    fn new() -> Box<PreBufs> {
        Box::new(PreBufs {
            stack: [[false; BATCH]; PRE_STACK],
            x: [0; BATCH],
            y: [0; BATCH],
        })
    }
}

/// Whether a precondition can be evaluated by [`batch_pre`]: only terms about the agent
/// itself and its neighbours (no priorities, offsets, texts or remote counters), within
/// its stack depth.
fn pre_batchable(code: &[Op]) -> bool {
    let mut depth = 0usize;
    for op in code {
        match op {
            Op::True {} | Op::Nbr { .. } | Op::Att { .. } | Op::State { .. } => depth += 1,
            Op::Cmp { a, b, .. }
                if ![a, b]
                    .iter()
                    .any(|v| matches!(v, Val::Ext(_) | Val::Msg { dir: ANY_DIR, .. })) =>
            {
                depth += 1
            }
            Op::Not {} | Op::Jf { .. } => {}
            Op::And {} => depth = depth.saturating_sub(1),
            _ => return false,
        }
        if depth > PRE_STACK {
            return false;
        }
    }
    true
}

/// Evaluates rule `r`'s precondition (which [`pre_batchable`] accepted, in a program
/// without priority terms) for agents `first..first + out.len()` at once, one instruction
/// over all of them. Short-circuit jumps are not taken: the terms have no side effects and
/// a false left operand makes the conjunction false either way.
fn batch_pre(
    prog: &Program,
    (r, first): (u32, usize),
    lat: &Lattice,
    bufs: &mut PreBufs,
    out: &mut [bool],
) {
    let m = out.len();
    let info = &prog.rules[r as usize];
    let code = &prog.code[info.pre.start as usize..info.pre.end as usize];
    let PreBufs { stack, x, y } = bufs;
    let mut sp = 0;
    let nd = lat.dim.dirs();
    let load = |v: Val, into: &mut [i32]| match v {
        Val::Lit(c) => into.fill(c as i32),
        Val::Counter(c) => match lat.counter_col[c as usize] {
            NO_COL => into.fill(0),
            col => {
                for (t, &s) in into
                    .iter_mut()
                    .zip(&lat.counters[col as usize][first..first + m])
                {
                    *t = s as i32;
                }
            }
        },
        Val::Msg { dir, slot } => {
            for (j, t) in into.iter_mut().enumerate() {
                *t = lat.inbox((first + j) as u32, dir, slot) as i32;
            }
        }
        Val::Ext(_) => unreachable!("not batched"),
    };
    for op in code {
        match *op {
            Op::True {} => {
                stack[sp][..m].fill(true);
                sp += 1;
            }
            Op::Nbr { mask, want } => {
                // Only the directions the term asks about are looked at.
                let top = &mut stack[sp][..m];
                top.fill(true);
                for d in (0..nd).filter(|d| mask & (1 << d) != 0) {
                    let filled = want & (1 << d) != 0;
                    lat.keep_if_filled(first, d, filled, top);
                }
                sp += 1;
            }
            Op::Att { mask, want } => {
                for (t, &at) in stack[sp][..m].iter_mut().zip(&lat.attach[first..first + m]) {
                    *t = at & mask == want & mask;
                }
                sp += 1;
            }
            Op::State { pat } => {
                let p = &prog.pats[pat as usize];
                for (t, st) in stack[sp][..m].iter_mut().zip(&lat.state[first..first + m]) {
                    *t = latticesim_vm::eval::matches(p, st);
                }
                sp += 1;
            }
            // A counter against a literal: compared straight from its column.
            Op::Cmp {
                op,
                a: Val::Counter(c),
                b: Val::Lit(v),
            } if lat.counter_col[c as usize] != NO_COL => {
                let col = &lat.counters[lat.counter_col[c as usize] as usize][first..first + m];
                let top = stack[sp][..m].iter_mut().zip(col);
                match op {
                    CmpOp::Lt => top.for_each(|(t, &p)| *t = p < v),
                    CmpOp::Gt => top.for_each(|(t, &p)| *t = p > v),
                    CmpOp::Eq => top.for_each(|(t, &p)| *t = p == v),
                }
                sp += 1;
            }
            Op::Cmp { op, a, b } => {
                load(a, &mut x[..m]);
                load(b, &mut y[..m]);
                let top = stack[sp][..m].iter_mut().zip(&x[..m]).zip(&y[..m]);
                // One loop per operator, so that each is a vector compare.
                match op {
                    CmpOp::Lt => top.for_each(|((t, &p), &q)| *t = p < q),
                    CmpOp::Gt => top.for_each(|((t, &p), &q)| *t = p > q),
                    CmpOp::Eq => top.for_each(|((t, &p), &q)| *t = p == q),
                }
                sp += 1;
            }
            Op::Not {} => stack[sp - 1][..m].iter_mut().for_each(|t| *t = !*t),
            Op::And {} => {
                sp -= 1;
                let (low, high) = stack.split_at_mut(sp);
                for (t, &u) in low[sp - 1][..m].iter_mut().zip(&high[0][..m]) {
                    *t &= u;
                }
            }
            Op::Jf { .. } => {}
            _ => unreachable!("not batched"),
        }
    }
    out.copy_from_slice(&stack[0][..m]);
}

/// Adds to `counts` how many agents of the selection `one` execute each single rule,
/// counting runs of equal entries at once, and returns how many execute any rule.
fn count_runs(one: &[u32], counts: &mut [u64]) -> u64 {
    let mut active = 0;
    let mut run = (NO_RULE, 0u64);
    for &v in one.iter().chain([&NO_RULE]) {
        if v != run.0 {
            if run.0 != NO_RULE {
                active += run.1;
            }
            if run.0 & MANY == 0 {
                counts[run.0 as usize] += run.1;
            }
            run = (v, 0);
        }
        run.1 += 1;
    }
    active
}

/// The most frequent calculations over a run of agents, without a detour through 32-bit
/// temporaries: `Cxx = Cxx max/min (message or literal)` in place (cannot saturate),
/// `Cxx = Cxx +/- literal` in place when no result saturates, and sending a counter as it
/// is (`x + 0`, `x - 0`). Returns false for anything else.
#[allow(clippy::too_many_arguments)]
#[inline]
fn fast_calc(
    lat: &Lattice,
    ch: &mut CalcChunk<'_>,
    ks: std::ops::Range<usize>,
    first: usize,
    (target, op, a, b): (Target, CalcOp, Val, Val),
    buf: &mut ([i16; BATCH], [usize; 6]),
) -> bool {
    let len = ks.len();
    match (target, op, a, b) {
        (Target::Counter(c), CalcOp::Max | CalcOp::Min, Val::Counter(ca), b) if ca == c => {
            let col = &mut ch.counters[lat.counter_col[c as usize] as usize][ks];
            let max = op == CalcOp::Max;
            match b {
                Val::Lit(v) if max => col.iter_mut().for_each(|t| *t = (*t).max(v)),
                Val::Lit(v) => col.iter_mut().for_each(|t| *t = (*t).min(v)),
                Val::Msg { dir, slot } if dir != ANY_DIR => {
                    let src = lat.inbox_run(first, (dir, slot), &mut buf.0[..len], &mut buf.1);
                    if max {
                        col.iter_mut().zip(src).for_each(|(t, &v)| *t = (*t).max(v));
                    } else {
                        col.iter_mut().zip(src).for_each(|(t, &v)| *t = (*t).min(v));
                    }
                }
                _ => return false,
            }
            true
        }
        // `Cxx = Cxx + v` or `Cxx = Cxx - v` in place, when no result saturates.
        (Target::Counter(c), CalcOp::Add | CalcOp::Sub, Val::Counter(ca), Val::Lit(v))
            if ca == c =>
        {
            let col = &mut ch.counters[lat.counter_col[c as usize] as usize][ks];
            let v = if op == CalcOp::Add {
                v as i32
            } else {
                -(v as i32)
            };
            let fits = |t: i16| (-32767..=32767).contains(&(t as i32 + v));
            if !col.iter().fold(true, |ok, &t| ok & fits(t)) {
                return false;
            }
            col.iter_mut().for_each(|t| *t = (*t as i32 + v) as i16);
            true
        }
        (Target::Msg { dir, slot }, CalcOp::Add | CalcOp::Sub, Val::Counter(c), Val::Lit(0)) => {
            let src = lat.counter_col[c as usize] as usize;
            let cols = ch.send_cols(lat, dir, slot);
            for &col in cols.write() {
                let (counters, out) = (
                    &ch.counters[src][ks.clone()],
                    &mut ch.out_num[col][ks.clone()],
                );
                out.copy_from_slice(counters);
                set_bits(ch.out_has[col], ks.clone());
            }
            for &col in cols.clear() {
                clear_bits(ch.out_has[col], ks.clone());
            }
            true
        }
        _ => false,
    }
}

/// How many instructions at the start of `code` (none, or two to six) are a chain of
/// `Cxx = Cxx max #Dss` on one counter (or of `min`, not mixed), each with a message
/// from one direction, which [`chain_in_place`] runs in one pass.
#[inline]
fn max_chain(code: &[Op]) -> usize {
    let link = |op: &Op| match *op {
        Op::Calc {
            target: Target::Counter(c),
            op: op @ (CalcOp::Max | CalcOp::Min),
            a: Val::Counter(ca),
            b: Val::Msg { dir, .. },
        } if ca == c && dir != ANY_DIR => Some((c, op)),
        _ => None,
    };
    let Some(first) = code.first().and_then(link) else {
        return 0;
    };
    let n = code
        .iter()
        .take(6)
        .take_while(|op| link(op) == Some(first))
        .count();
    if n >= 2 {
        n
    } else {
        0
    }
}

/// Runs a chain of in-place max/min with messages ([`max_chain`]) over agents `ks` of the
/// chunk: the messages of each link are read first (the first into `buf`, the others into
/// `more`), then the counter is read and written once. Max and min of values within
/// +-32767 cannot saturate, so nothing is recorded.
fn chain_in_place(
    lat: &Lattice,
    (ch, more): (&mut CalcChunk<'_>, &mut Vec<[i16; BATCH]>),
    (chain, ks): (&[Op], std::ops::Range<usize>),
    (first_buf, hint): &mut ([i16; BATCH], [usize; 6]),
) {
    let (len, first) = (ks.len(), ch.lo + ks.start);
    if more.len() < chain.len() - 1 {
        more.resize(chain.len() - 1, [0; BATCH]);
    }
    let mut bufs = std::iter::once(first_buf).chain(more.iter_mut());
    let mut srcs: [&[i16]; 6] = [&[]; 6];
    let (mut c, mut max) = (0, true);
    for (k, op) in chain.iter().enumerate() {
        let Op::Calc {
            target: Target::Counter(t),
            op,
            b: Val::Msg { dir, slot },
            ..
        } = *op
        else {
            unreachable!("a chain holds only max/min of a counter with a message");
        };
        (c, max) = (t, op == CalcOp::Max);
        let out = &mut bufs.next().expect("a buffer for each link")[..len];
        srcs[k] = lat.inbox_run(first, (dir, slot), out, hint);
    }
    let col = &mut ch.counters[lat.counter_col[c as usize] as usize][ks];
    if max {
        fold_in_place(col, &srcs[..chain.len()], i16::max);
    } else {
        fold_in_place(col, &srcs[..chain.len()], i16::min);
    }
}

/// `col[j] = f(...f(f(col[j], srcs[0][j]), srcs[1][j])...)` in passes of up to four
/// sources each (vectorised).
#[inline(always)]
fn fold_in_place(col: &mut [i16], srcs: &[&[i16]], f: impl Fn(i16, i16) -> i16 + Copy) {
    let n = col.len();
    match *srcs {
        [] => {}
        [a] => col
            .iter_mut()
            .zip(&a[..n])
            .for_each(|(t, &x)| *t = f(*t, x)),
        [a, b] => {
            let ab = a[..n].iter().zip(&b[..n]);
            col.iter_mut()
                .zip(ab)
                .for_each(|(t, (&x, &y))| *t = f(f(*t, x), y));
        }
        [a, b, c] => {
            let abc = a[..n].iter().zip(&b[..n]).zip(&c[..n]);
            col.iter_mut()
                .zip(abc)
                .for_each(|(t, ((&x, &y), &z))| *t = f(f(f(*t, x), y), z));
        }
        [a, b, c, d, ref rest @ ..] => {
            let abcd = a[..n].iter().zip(&b[..n]).zip(&c[..n]).zip(&d[..n]);
            col.iter_mut()
                .zip(abcd)
                .for_each(|(t, (((&x, &y), &z), &w))| *t = f(f(f(f(*t, x), y), z), w));
            fold_in_place(col, rest, f);
        }
    }
}

/// Agents per inner batch of [`run_batch`], [`batch_pre`] and the post office.
const BATCH: usize = 1024;

/// The working space of [`run_batch`], made once for a chunk of agents rather than at each
/// call (a call may run a few agents): the two operands, whether each agent's result
/// stands (all true between instructions), and the messages read with the post office's
/// hints (see [`Lattice::inbox_run`]).
struct CalcBufs {
    x: [i32; BATCH],
    y: [i32; BATCH],
    ok: [bool; BATCH],
    msgs: ([i16; BATCH], [usize; 6]),
    /// The messages of a chain of in-place max/min beyond the first (see [`max_chain`]),
    /// made at the first chain.
    more: Vec<[i16; BATCH]>,
}

impl CalcBufs {
    fn new() -> Box<CalcBufs> {
        Box::new(CalcBufs {
            x: [0; BATCH],
            y: [0; BATCH],
            ok: [true; BATCH],
            msgs: ([0; BATCH], [0; 6]),
            more: Vec::new(),
        })
    }
}

/// Runs rule `r`'s calculations and sends for the chunk's agents `range` (all of which
/// execute `r` alone), one instruction at a time over up to [`BATCH`] agents. The results,
/// and the issues (in agent order, then instruction order), are those of [`run_post`] run
/// for each agent in turn: an agent's instructions touch only its own counters and outbox.
fn run_batch(
    prog: &Program,
    r: u32,
    lat: &Lattice,
    (ch, bufs): (&mut CalcChunk<'_>, &mut CalcBufs),
    range: std::ops::Range<usize>,
    issues: &mut Vec<(u32, u32, CalcIssue)>,
) {
    let info = &prog.rules[r as usize];
    let code = &prog.code[info.post.start as usize..info.post.end as usize];
    let nd = lat.dim.dirs();
    let mut found: Vec<(u32, CalcIssue)> = Vec::new();
    let CalcBufs {
        x,
        y,
        ok,
        msgs: buf,
        more,
    } = bufs;
    let mut start = range.start;
    while start < range.end {
        let len = (range.end - start).min(BATCH);
        let ks = start..start + len;
        let first = ch.lo + start;
        let mut i = 0;
        while i < code.len() {
            // A chain of in-place max (or min) with messages: one pass over the counter.
            let chain = max_chain(&code[i..]);
            if chain >= 2 {
                chain_in_place(
                    lat,
                    (ch, &mut *more),
                    (&code[i..i + chain], ks.clone()),
                    buf,
                );
                i += chain;
                continue;
            }
            i += 1;
            match code[i - 1] {
                Op::Send { dir, text } => {
                    let t = prog.texts[text as usize];
                    for d in CalcChunk::text_dirs(lat, dir) {
                        for k in ks.clone() {
                            ch.out_text[k * nd + d] = t;
                            ch.out_text_bits[k] |= 1 << d;
                        }
                    }
                }
                Op::Calc { target, op, a, b }
                    if fast_calc(lat, ch, ks.clone(), first, (target, op, a, b), buf) => {}
                Op::Calc { target, op, a, b } => {
                    let mut load = |v: Val, into: &mut [i32], ch: &CalcChunk<'_>| match v {
                        Val::Lit(c) => into.fill(c as i32),
                        Val::Counter(c) => {
                            let col = &ch.counters[lat.counter_col[c as usize] as usize];
                            for (t, &s) in into.iter_mut().zip(&col[ks.clone()]) {
                                *t = s as i32;
                            }
                        }
                        Val::Msg { dir, slot } => {
                            let src =
                                lat.inbox_run(first, (dir, slot), &mut buf.0[..len], &mut buf.1);
                            for (t, &s) in into.iter_mut().zip(src) {
                                *t = s as i32;
                            }
                        }
                        Val::Ext(_) => unreachable!("rules with external counters are not batched"),
                    };
                    load(a, &mut x[..len], ch);
                    load(b, &mut y[..len], ch);
                    let (xs, ys) = (&mut x[..len], &y[..len]);
                    let mut all_ok = true;
                    match op {
                        CalcOp::Max => xs.iter_mut().zip(ys).for_each(|(p, &q)| *p = (*p).max(q)),
                        CalcOp::Min => xs.iter_mut().zip(ys).for_each(|(p, &q)| *p = (*p).min(q)),
                        CalcOp::Add => xs.iter_mut().zip(ys).for_each(|(p, &q)| *p += q),
                        CalcOp::Sub => xs.iter_mut().zip(ys).for_each(|(p, &q)| *p -= q),
                        CalcOp::Mul => xs.iter_mut().zip(ys).for_each(|(p, &q)| *p *= q),
                        CalcOp::Div | CalcOp::Mod => {
                            for (j, (p, &q)) in xs.iter_mut().zip(ys).enumerate() {
                                ok[j] = q != 0;
                                all_ok &= q != 0;
                                if q == 0 {
                                    found.push(((first + j) as u32, CalcIssue::DivisionByZero));
                                } else if op == CalcOp::Div {
                                    *p /= q;
                                } else {
                                    *p %= q;
                                }
                            }
                        }
                    }
                    // Saturation (operands are within +-32767, so i32 holds every result).
                    if xs.iter().any(|&v| !(-32767..=32767).contains(&v)) {
                        for (j, v) in xs.iter_mut().enumerate() {
                            if ok[j] && !(-32767..=32767).contains(v) {
                                found.push((
                                    (first + j) as u32,
                                    CalcIssue::Saturated { exact: *v as i64 },
                                ));
                                *v = (*v).clamp(-32767, 32767);
                            }
                        }
                    }
                    let xs = &x[..len];
                    let keep = |j: usize| all_ok || ok[j];
                    match target {
                        Target::Counter(c) => {
                            let col =
                                &mut ch.counters[lat.counter_col[c as usize] as usize][ks.clone()];
                            if all_ok {
                                col.iter_mut().zip(xs).for_each(|(t, &v)| *t = v as i16);
                            } else {
                                for (j, (t, &v)) in col.iter_mut().zip(xs).enumerate() {
                                    if keep(j) {
                                        *t = v as i16;
                                    }
                                }
                            }
                        }
                        Target::Msg { dir, slot } => {
                            let cols = ch.send_cols(lat, dir, slot);
                            for &c in cols.clear() {
                                let bits = &mut *ch.out_has[c];
                                if all_ok {
                                    clear_bits(bits, ks.clone());
                                } else {
                                    for k in ks.clone().filter(|&k| keep(k - start)) {
                                        bits[k >> 6] &= !(1 << (k & 63));
                                    }
                                }
                            }
                            for &c in cols.write() {
                                let col = &mut ch.out_num[c][ks.clone()];
                                let bits = &mut *ch.out_has[c];
                                if all_ok {
                                    col.iter_mut().zip(xs).for_each(|(t, &v)| *t = v as i16);
                                    set_bits(bits, ks.clone());
                                } else {
                                    for (j, (t, &v)) in col.iter_mut().zip(xs).enumerate() {
                                        if keep(j) {
                                            *t = v as i16;
                                            let k = start + j;
                                            bits[k >> 6] |= 1 << (k & 63);
                                        }
                                    }
                                }
                            }
                        }
                    }
                    if !all_ok {
                        ok[..len].fill(true);
                    }
                }
                _ => {}
            }
        }
        // Issues in agent order, then instruction order (the sort is stable).
        found.sort_by_key(|f| f.0);
        issues.extend(found.drain(..).map(|(a, i)| (a, r, i)));
        start += len;
    }
}

/// What the calculations of agent `a` (the `k`-th of its chunk) read and write: the
/// lattice for positions and inboxes, and the chunk's own counters and outbox.
struct CalcCtx<'a, 'c, 'd> {
    lat: &'a Lattice,
    a: usize,
    k: usize,
    ch: &'c mut CalcChunk<'d>,
    snapshot: &'a [Vec<i16>],
    issues: Vec<(usize, CalcIssue)>,
}

impl CalcEnv for CalcCtx<'_, '_, '_> {
    fn counter(&self, i: u8) -> i16 {
        self.ch.counter(self.lat, self.k, i)
    }
    fn set_counter(&mut self, i: u8, v: i16) {
        let c = self.lat.counter_col[i as usize] as usize;
        self.ch.counters[c][self.k] = v;
    }
    fn inbox_num(&self, dir: u8, slot: u8) -> i16 {
        self.lat.inbox(self.a as u32, dir, slot)
    }
    fn external(&self, off: [i32; 2], counter: u8) -> Option<i16> {
        match self.lat.cell_at(self.lat.pos[self.a], [off[0], off[1], 0]) {
            Cell::Agent(b) => Some(match self.lat.counter_col[counter as usize] {
                NO_COL => 0,
                c => self.snapshot[c as usize][b as usize],
            }),
            _ => None,
        }
    }
    fn send_num(&mut self, dir: u8, slot: u8, v: i16) {
        let k = self.k;
        let cols = self.ch.send_cols(self.lat, dir, slot);
        for &c in cols.clear() {
            self.ch.out_has[c][k >> 6] &= !(1 << (k & 63));
        }
        for &c in cols.write() {
            self.ch.out_num[c][k] = v;
            self.ch.out_has[c][k >> 6] |= 1 << (k & 63);
        }
    }
    fn send_text(&mut self, dir: u8, text: [u8; 5]) {
        let nd = self.lat.dim.dirs();
        for d in CalcChunk::text_dirs(self.lat, dir) {
            self.ch.out_text[self.k * nd + d] = text;
            self.ch.out_text_bits[self.k] |= 1 << d;
        }
    }
    fn issue(&mut self, pc: usize, issue: CalcIssue) {
        self.issues.push((pc, issue));
    }
}

#[cfg(test)]
mod tests {
    use super::{Phase, Tuner};
    use std::time::Duration;

    /// The tuner tries one thread on a phase's fourth run and the pool on its fifth and
    /// sixth, keeps one thread until the next trial 64 runs later only when it beat both,
    /// and keeps phases apart.
    #[test]
    fn tuner_keeps_the_faster_way() {
        let mut t = Tuner::default();
        let run = |t: &mut Tuner, phase, ms: u64| {
            let pooled = t.pooled(phase);
            t.took(phase, Duration::from_millis(ms));
            pooled
        };
        // The first three runs on the pool; one thread 5 ms, the pool 9 and 12 ms: one
        // thread until the next trial.
        let ways: Vec<bool> = [7, 30, 2, 5, 9, 12, 1, 1]
            .iter()
            .map(|&ms| run(&mut t, Phase::Select, ms))
            .collect();
        assert_eq!(ways, [true, true, true, false, true, true, false, false]);
        assert!(
            run(&mut t, Phase::Calculate, 1),
            "another phase starts on the pool"
        );
        for _ in 9..68 {
            run(&mut t, Phase::Select, 1);
        }
        // Runs 68 to 70 are the next trial: one thread 8 ms, the pool 9 ms once and 3 ms
        // once, so the pool is kept.
        assert!(!run(&mut t, Phase::Select, 8));
        assert!(run(&mut t, Phase::Select, 9));
        assert!(run(&mut t, Phase::Select, 3));
        assert!(run(&mut t, Phase::Select, 3));
    }
}
