//! The engine: the synchronous step (selection with priorities, actions, calculations and
//! the post office, exactly as `../shared/SEMANTICS.md` section 5 defines them) conducted
//! over parts that own their code: the plan of fast paths (`plan`), rule dispatch by state
//! (`dispatch`), the selection (`select`), the actions (`actions`, `moves`), the
//! calculations (`calc`, `batch`), the post office (`post`) and the threads (`threads`).
//! Every phase visits agents in id order, so a run is deterministic.

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

// The parts of the step, each in its own module (docs/architecture.md).
mod actions;
mod batch;
mod calc;
mod dispatch;
mod moves;
mod plan;
mod post;
mod select;
mod threads;
use actions::*;
use batch::*;
use calc::*;
use dispatch::*;
use moves::*;
use plan::Plan;
use post::*;
use select::*;
pub use threads::AGENTS_PER_THREAD;
use threads::*;

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
    /// What the program allows: which fast paths apply (see [`plan`]).
    plan: Plan,
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
    /// With `defer`: per direction, a bit per agent that has a neighbour there (to count
    /// the messages delivered); made at the first delivery.
    has_nbr: Vec<Vec<u64>>,
    /// With `defer`: this step's outboxes as counted by the calculations (see
    /// [`Tally`]).
    counted: Option<Tally>,
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

/// The opposite of each direction index.
const OPPOSITE: [usize; 6] = [3, 2, 1, 0, 5, 4];
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
        let plan = Plan::of(&prog);
        let defer = plan.defer;
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
        Engine {
            plan,
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
            has_nbr: Vec::new(),
            counted: None,
            pool: (opts.threads > 1 && n >= AGENTS_PER_THREAD)
                .then(|| Workers::new(opts.threads))
                .flatten(),
            tuner: Tuner::default(),
            serial: false,
            sel: Selection::default(),
            sel_by_state: false,
            sel_reused: false,
            fire_counts: vec![0; prog.rules.len()],
            active: 0,
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

    /// What a step of this program can change in the lattice (for [`Lattice::undo_point`]).
    pub fn writes(&self) -> Writes {
        self.plan.writes
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
