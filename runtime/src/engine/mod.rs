//! The engine: the synchronous step (selection with priorities, actions, calculations and
//! the post office, exactly as `../shared/SEMANTICS.md` section 5 defines them) conducted
//! over parts that own their code: the plan of fast paths (`plan`), rule dispatch by state
//! (`dispatch`), the selection (`select`), the actions (`actions`, `moves`), the
//! calculations (`calc`, `batch`), the post office (`post`) and the threads (`threads`).
//! Every phase visits agents in id order, so a run is deterministic.

// The step works on parallel columns indexed by agent id and direction; index loops say
// that more plainly than zipped iterators over five columns.
#![allow(clippy::needless_range_loop)]

use crate::bits::{
    all_bits, bit, clear_bits, extend_kept, extend_ones, is_sequence, mask_ne, no_bits, ones,
    range_words, run_of, set_bits,
};
use crate::cells::{NO_SLOT, RIM};
use crate::lattice::Lattice;
use crate::lattice::{Pending, Undo, Writes, NO_AGENT, NO_COL};
use crate::record::{Record, RecordKind};
use crate::trace::{text, TraceEvent};
use latticesim_vm::column::{Column, CutMut, Value, Width};
use latticesim_vm::each_width;
use latticesim_vm::eval::{eval_pre, run_post, CalcEnv, CalcIssue, Cell, Env, Tri};
use latticesim_vm::model::{AttachLetter, CalcOp, CmpOp, Coord, Dir, TextPat};
use latticesim_vm::op::{Op, Target, Val, ANY_DIR};
use latticesim_vm::{Program, Verified};
use rustc_hash::FxHashMap;
use std::collections::BTreeMap;

// The parts of the step, each in its own module (docs/architecture.md).
mod actions;
mod activity;
mod batch;
mod calc;
mod chunk;
mod crew;
mod dispatch;
mod plan;
mod post;
mod select;
mod selection;
mod threads;
use actions::*;
pub use activity::Skip;
use activity::*;
use batch::*;
use chunk::*;
use dispatch::*;
use plan::*;
use post::*;
use select::*;
use selection::*;
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
    /// Whether agents that had no valid rule, and whose inputs did not change since, are
    /// skipped; the results do not depend on it.
    pub skip: Skip,
    /// Whether the engine keeps its agents in space order; the results do not depend on
    /// it, but for the order of one step's records.
    pub space_order: SpaceOrder,
    /// Of each kind of record, at most this many per step are kept in the step's report
    /// (the first ones); the others are only counted (in [`Stats::records`]) and never
    /// written out. `None`: every record (the default). `latticesim run` keeps as many
    /// as it shows, unless it writes a trace: a jam makes thousands of records a step.
    pub records_per_step: Option<usize>,
}

/// Whether an engine keeps its agents in space order (`Lattice::keep_in_space_order`):
/// then `Engine::lat` lists them so, and [`Lattice::label`] gives each one's id in the
/// agents file, by which records name them and the agents file is written
/// ([`Lattice::write_agents_text`]) and checkpoints are. Never with a trace (its events
/// name agents by their place).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum SpaceOrder {
    /// Agents as the lattice lists them (the default: `Engine::lat` is read by id).
    #[default]
    Off,
    /// In space order when that pays ([`Lattice::listed_scattered`]; `latticesim run` and
    /// `sweep`).
    Auto,
    /// In space order whatever the lattice (for tests).
    Always,
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
    /// Of the moves, those of agents carried by their group (not asked to move by a rule
    /// of their own).
    pub carried: u64,
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
    /// How many agents executed a rule.
    pub executing: u64,
    /// The records of this step.
    pub records: Vec<Record>,
    /// The trace events of this step (when tracing).
    pub trace: Vec<TraceEvent>,
}

/// A program running on a lattice: the program and its plan, the lattice, the statistics,
/// and the parts of the step, each owning its data (docs/architecture.md).
pub struct Engine {
    /// The compiled rules.
    pub prog: Verified,
    /// The agents. Their states may be read at any time; change them only through the
    /// engine's steps (the rule dispatch remembers each agent's state). Listed in space
    /// order when [`Options::space_order`] chose it: [`Lattice::label`] gives an agent's id
    /// in the agents file.
    pub lat: Lattice,
    /// How it steps.
    pub opts: Options,
    /// Counts so far.
    pub stats: Stats,
    /// What the program allows: which fast paths apply (see [`plan`]).
    plan: Plan,
    /// Each agent's candidate rules by its state (see [`dispatch`]).
    dispatch: Dispatch,
    /// The rules each agent executes, and whether they hold for the next step.
    selection: Selector,
    /// What the actions phase keeps between steps.
    actions: ActionBufs,
    /// The outboxes and the post office.
    post: Post,
    /// How per-agent work is split over threads.
    threads: Threads,
    /// Which agents the next selection evaluates.
    activity: Activity,
}

/// An agent's attachment letters and swap, for the agents whose rules have either.
type Link = (u32, [AttachLetter; 6], Option<Dir>);

/// The opposite of each direction index.
const OPPOSITE: [usize; 6] = [3, 2, 1, 0, 5, 4];

/// Adds a record of this step (`stats.steps + 1`) of `kind` about agents `ids` (with their
/// positions in `lat`) to `rep`, and counts it.
fn record(
    (stats, lat, cap): (&mut Stats, &Lattice, Option<usize>),
    rep: &mut StepReport,
    kind: RecordKind,
    ids: &[u32],
    message: String,
) {
    record_with((stats, lat, cap), rep, kind, ids, |_| message);
}

/// [`record`], its message made (from the lattice) only when the record is kept (`cap`:
/// see [`Options::records_per_step`]).
fn record_with(
    (stats, lat, cap): (&mut Stats, &Lattice, Option<usize>),
    rep: &mut StepReport,
    kind: RecordKind,
    ids: &[u32],
    message: impl FnOnce(&Lattice) -> String,
) {
    *stats.records.entry(kind).or_insert(0) += 1;
    if !rep.keeps(kind, cap) {
        return;
    }
    rep.records.push(Record {
        step: stats.steps + 1,
        kind,
        agents: (ids.iter())
            .map(|&a| (lat.label(a), lat.pos[a as usize]))
            .collect(),
        message: message(lat),
        rules: Vec::new(),
    });
}

impl StepReport {
    /// Whether a record of `kind` made now is kept, at most `cap` of each kind being kept
    /// (see [`Options::records_per_step`]). (A step keeps few records when capped: they
    /// are counted here.)
    pub(crate) fn keeps(&self, kind: RecordKind, cap: Option<usize>) -> bool {
        cap.is_none_or(|c| self.records.iter().filter(|r| r.kind == kind).count() < c)
    }
}

impl Engine {
    /// A program ready to run on a lattice. The program must have passed `verify` and match
    /// the lattice's dimension. The lattice gets columns for every counter, message slot
    /// and text inbox the program uses.
    pub fn new(prog: Verified, mut lat: Lattice, opts: Options) -> Engine {
        let uses = prog.uses();
        lat.settle_inbox();
        let keep = match opts.space_order {
            SpaceOrder::Off => false,
            SpaceOrder::Auto => lat.listed_scattered(),
            SpaceOrder::Always => !lat.in_space_order(),
        };
        if keep && !opts.trace {
            lat.keep_in_space_order();
        }
        // Columns of the program's width (a configuration checked with its rules holds
        // only values of it).
        lat.set_width(prog.width);
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
        Engine {
            stats: Stats {
                firings: vec![0; prog.rules.len()],
                ..Stats::default()
            },
            dispatch: Dispatch::new(&prog, n),
            selection: Selector::new(prog.rules.len(), n),
            actions: ActionBufs::new(plan.acting, &lat),
            post: Post::new(&prog, &lat, plan.defer, uses.texts),
            threads: Threads::new(opts.threads, n),
            activity: Activity::new(opts.skip, n),
            plan,
            prog,
            lat,
            opts,
        }
    }

    /// Bytes the engine holds per agent beyond the lattice's columns (outboxes, rule
    /// dispatch, the selection), for reports.
    pub fn bytes(&self) -> usize {
        let sel = &self.selection.sel;
        self.lat.bytes()
            + self.post.bytes()
            + self.dispatch.of.capacity() * 4
            + sel.one.capacity() * 4
            + (sel.starts.capacity() + sel.many.capacity() + sel.list.capacity()) * 4
            + self.activity.bytes()
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

    /// One step (SEMANTICS section 5): 1. every agent's rules are selected; then, in the
    /// order the options give, 2. the actions are carried out, and 3. the calculations
    /// run and the post office delivers. Returns what happened; `stats` is updated.
    pub fn step(&mut self) -> StepReport {
        let mut rep = StepReport::default();
        self.lat.refresh_neighbours();
        self.activity.begin(self.plan.any_prio);
        self.select(&mut rep);
        let mut sel = std::mem::take(&mut self.selection.sel);
        // The phases after the selection visit only the agents that execute a rule when
        // they are few (and the activity needs them listed).
        let active = self.selection.active;
        let listing = self.activity.lists(active);
        if listing && !sel.listed && !self.selection.by_state {
            sel.make_list();
        }
        rep.executing = self.selection.active;
        rep.quiescent = rep.executing == 0;
        for (f, &k) in self
            .stats
            .firings
            .iter_mut()
            .zip(&self.selection.fire_counts)
        {
            *f += k;
        }
        if self.opts.trace {
            self.trace_firings(&sel, &mut rep);
        }
        match self.opts.order {
            Order::ActionsFirst => {
                self.act(&mut sel, &mut rep);
                self.calculate(&sel, &mut rep);
                self.deliver(&sel, &mut rep);
            }
            Order::MessagesFirst => {
                self.calculate(&sel, &mut rep);
                self.deliver(&sel, &mut rep);
                self.act(&mut sel, &mut rep);
            }
        }
        // Each record names the rules its agents executed.
        for r in &mut rep.records {
            let lat = &self.lat;
            let mut rules: Vec<u32> = (r.agents.iter())
                .flat_map(|&(id, _)| sel.executed(lat.agent_of(id) as usize).iter().copied())
                .collect();
            rules.sort_unstable();
            rules.dedup();
            r.rules = rules;
        }
        let view = (&self.plan, &self.lat, &self.threads);
        let how = (&sel, self.selection.active, self.selection.reused());
        self.activity.after_step(view, how, &self.dispatch);
        self.selection.sel = sel;
        self.stats.steps += 1;
        self.stats.quiescent = rep.quiescent;
        rep
    }

    /// The rules agent `a` executes in the next step (by name) and their priority, `None`
    /// when it executes none: the next step's selection alone (the engine is used up). The
    /// viewer's inspector asks this; it ran a traced step on a copy, 0.9 s at 10^6 agents.
    pub fn next_rules(mut self, a: u32) -> Option<(Vec<String>, u16)> {
        let mut rep = StepReport::default();
        self.lat.refresh_neighbours();
        self.activity.begin(self.plan.any_prio);
        self.select(&mut rep);
        let rs = self.selection.sel.of(a as usize);
        let rule = |r: &u32| &self.prog.rules[*r as usize];
        let first = rs.first()?;
        Some((
            rs.iter().map(|r| rule(r).name.clone()).collect(),
            rule(first).priority,
        ))
    }

    /// 1. Selection: the rules each agent executes, and how many execute each rule.
    fn select(&mut self, rep: &mut StepReport) {
        let view = (&*self.prog, &self.plan, &self.lat);
        let listed = self.activity.listed.then_some(&self.activity.list[..]);
        let circles = (self.selection).select(view, &mut self.dispatch, &mut self.threads, listed);
        for (circle, msg) in circles {
            let kind = RecordKind::CircularPriority;
            record(
                (&mut self.stats, &self.lat, self.opts.records_per_step),
                rep,
                kind,
                &circle,
                msg,
            );
        }
        self.selection.count_firings(&self.threads);
    }

    /// 2. Actions: moves, bonds, states and swaps.
    fn act(&mut self, sel: &mut Selection, rep: &mut StepReport) {
        let on = self.activity.wanted();
        let changed = (self.threads).tuned(Phase::Act, |th| {
            let mut act = Act {
                prog: &self.prog,
                plan: &self.plan,
                opts: self.opts,
                lat: &mut self.lat,
                dispatch: &mut self.dispatch,
                counts: &mut self.selection.fire_counts,
                active: &mut self.selection.active,
                stats: &mut self.stats,
                bufs: &mut self.actions,
                by_state: self.selection.by_state,
                threads: th,
            };
            act.bufs.changes.on = on;
            act.bufs.changes.grid = act.lat.cells.grid_box();
            act.all_actions(sel, rep)
        });
        self.selection.states_changed(changed);
        let view = (&self.lat, &self.threads);
        (self.activity).after_actions(view, &self.plan.reads, &mut self.actions.changes);
    }

    /// 3. (first half) Calculations and sends, into the outboxes.
    fn calculate(&mut self, sel: &Selection, rep: &mut StepReport) {
        let (post, stats) = (&mut self.post, &mut self.stats);
        let cx = (&*self.prog, &self.plan, self.opts.trace);
        let (lat, counts) = (&mut self.lat, &self.selection.fire_counts[..]);
        let cap = self.opts.records_per_step;
        (self.threads).tuned(Phase::Calculate, |th| {
            post.calculate(cx, (lat, th), (sel, counts), (stats, cap), rep)
        });
    }

    /// 3. (second half) The post office: the outboxes into the inboxes.
    fn deliver(&mut self, sel: &Selection, rep: &mut StepReport) {
        let mut known = false;
        if self.post.sends() {
            let senders = sel.listed.then_some(&sel.list[..]);
            let post = &self.post;
            known = (self.activity)
                .before_delivery(&self.lat, senders, |a| post.sent_dirs(&self.lat, a));
        }
        // When every sender is listed and the last recipients are known, only their
        // inboxes and the senders' outboxes are visited.
        if known && sel.listed && !self.plan.defer && !self.opts.trace {
            let senders = &sel.list[..];
            (self.post).deliver_listed(
                &mut self.lat,
                (senders, self.activity.emptied()),
                &mut self.stats,
            );
            return;
        }
        let (post, stats, lat) = (&mut self.post, &mut self.stats, &mut self.lat);
        let how = (self.plan.defer, self.opts.trace);
        (self.threads).tuned(Phase::Deliver, |th| {
            post.deliver((lat, th), how, stats, rep)
        });
    }

    /// The trace's firing events: per agent executing rules, their names and priority.
    fn trace_firings(&self, sel: &Selection, rep: &mut StepReport) {
        for a in 0..self.lat.len() {
            let rs = sel.of(a);
            if !rs.is_empty() {
                rep.trace.push(TraceEvent::Fire {
                    agent: a as u32,
                    rules: (rs.iter())
                        .map(|&r| self.prog.rules[r as usize].name.clone())
                        .collect(),
                    priority: self.prog.rules[rs[0] as usize].priority,
                });
            }
        }
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
