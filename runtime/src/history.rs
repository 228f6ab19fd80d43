//! Going back in a run, and to any step reached. Each step reached is kept backwards as
//! what it changed ([`Delta`]: the earlier values of the agents and inboxes it changed),
//! beside keyframes of the whole configuration every few steps: a step is reached by
//! taking the nearest keyframe at or after it (or the furthest step reached, or the
//! current one) and putting back the deltas down to it, which costs what those steps
//! changed, not steps of the engine. Where deltas were dropped (their memory is bounded)
//! the run is made again from the last keyframe before the step and stepped to it.
//! Either way the step is exactly the earlier one (configuration, records, statistics),
//! because a step depends only on the configuration (the engine's caches are rebuilt from
//! it). Memory stays bounded: deltas past their budget are dropped oldest first, and when
//! keyframes are too many or too large, every other one is dropped and the interval
//! doubles.

use crate::lattice::{Delta, Shadow};
use crate::{Engine, Lattice, Options, Record, Stats, StepReport};
use latticesim_vm::Verified;
use std::collections::VecDeque;

/// A run that can go back.
pub struct History {
    engine: Engine,
    /// The engine was made from a keyframe or deltas and has not stepped since (its
    /// lattice is then in the engine's own form, not a stepped one's: deltas are not put
    /// back on it).
    fresh: bool,
    /// Keyframes: (step, configuration, statistics), in step order, the first at step 0.
    keyframes: Vec<(u64, Lattice, Stats)>,
    /// Steps between keyframes.
    every: u64,
    /// The most keyframes kept, and the most bytes they hold (at least two are kept).
    max_keyframes: usize,
    keyframe_budget: usize,
    /// The configuration at the furthest step reached, kept when the run went back from
    /// it (unless a keyframe is there).
    head: Option<(u64, Lattice, Stats)>,
    /// The steps up to the furthest reached, kept backwards: the last `entries.len()`.
    entries: VecDeque<Entry>,
    /// The columns at the furthest step reached, to find what the next step changes
    /// (`None`: no deltas are kept).
    shadow: Option<Shadow>,
    /// Bytes the entries hold, and the most they may.
    entry_bytes: usize,
    delta_budget: usize,
    /// How the current step was reached last.
    jump: Jump,
    /// The report of the last step done (none at step 0).
    last: Option<StepReport>,
    /// The run's log: every record of the steps reached so far, in step order (a step
    /// done again after going back gives the same records: kept once), at most
    /// [`LOG_MAX`] of them; and how many more there were.
    log: Vec<Record>,
    log_more: u64,
    /// The furthest step reached.
    reached: u64,
}

/// One step kept backwards: what it changed, and the statistics and report at its end.
struct Entry {
    delta: Delta,
    stats: Stats,
    report: StepReport,
}

impl Entry {
    fn bytes(&self) -> usize {
        let records: usize = (self.report.records.iter())
            .map(|r| size_of::<Record>() + r.message.len() + r.agents.len() * 16)
            .sum();
        size_of::<Entry>() + self.delta.bytes() + self.stats.firings.len() * 8 + records
    }
}

/// How the current step was reached last.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Jump {
    /// By stepping (this many steps); or not moved.
    Stepped(u64),
    /// Put back from the configuration at a later step through the steps kept backwards.
    Rewound {
        /// The step put back from.
        from: u64,
        /// The steps put back.
        deltas: u64,
    },
    /// Made again from a keyframe, and steps done again.
    Replayed {
        /// The keyframe's step.
        from: u64,
        /// The steps done again.
        steps: u64,
    },
}

/// What a history holds, for the viewer.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Kept {
    /// Keyframes.
    pub keyframes: usize,
    /// The steps between keyframes.
    pub every: u64,
    /// The steps kept backwards: from this step to the furthest reached (none when it is
    /// past the furthest).
    pub deltas_from: u64,
    /// Bytes the keyframes hold (with the furthest step's configuration and the copy of
    /// its columns).
    pub keyframe_bytes: usize,
    /// Bytes the steps kept backwards hold.
    pub delta_bytes: usize,
    /// Bytes the run's log holds.
    pub log_bytes: usize,
}

/// The most records the run's log keeps (about 100 bytes each, with their messages).
pub const LOG_MAX: usize = 100_000;
/// The most bytes the steps kept backwards hold, by default.
pub const DELTA_BUDGET: usize = 768 << 20;
/// The most bytes the keyframes hold, by default (two are kept whatever their size).
pub const KEYFRAME_BUDGET: usize = 1 << 30;
/// Going forward at most this many steps is done by stepping.
const STEP_AHEAD: u64 = 2;

impl History {
    /// A run of `prog` on `lat` keeping a keyframe every `every` steps (at least 1) and at
    /// most `max_keyframes` of them (at least 2; the interval doubles when needed), and
    /// every step backwards within [`DELTA_BUDGET`].
    pub fn new(
        prog: Verified,
        lat: Lattice,
        opts: Options,
        every: u64,
        max_keyframes: usize,
    ) -> History {
        let engine = Engine::new(prog, lat, opts);
        History {
            keyframes: vec![(0, engine.lat.clone(), engine.stats.clone())],
            shadow: Some(Shadow::of(&engine.lat)),
            engine,
            fresh: false,
            every: every.max(1),
            max_keyframes: max_keyframes.max(2),
            keyframe_budget: KEYFRAME_BUDGET,
            head: None,
            entries: VecDeque::new(),
            entry_bytes: 0,
            delta_budget: DELTA_BUDGET,
            jump: Jump::Stepped(0),
            last: None,
            log: Vec::new(),
            log_more: 0,
            reached: 0,
        }
    }

    /// Sets the most bytes the steps kept backwards hold (0: none are kept, and going
    /// back steps again from a keyframe), dropping the oldest now if they hold more.
    pub fn set_delta_budget(&mut self, bytes: usize) {
        self.delta_budget = bytes;
        if bytes == 0 {
            self.shadow = None;
        }
        self.trim();
    }

    /// Sets the most bytes the keyframes hold (two are kept whatever their size).
    pub fn set_keyframe_budget(&mut self, bytes: usize) {
        self.keyframe_budget = bytes;
    }

    /// The engine at the current step (its lattice and statistics).
    pub fn engine(&self) -> &Engine {
        &self.engine
    }

    /// The current step.
    pub fn steps(&self) -> u64 {
        self.engine.stats.steps
    }

    /// The furthest step reached.
    pub fn reached(&self) -> u64 {
        self.reached
    }

    /// How the current step was reached last.
    pub fn jump(&self) -> Jump {
        self.jump
    }

    /// The report of the step that led to the current configuration (`None` at step 0).
    pub fn last_report(&self) -> Option<&StepReport> {
        self.last.as_ref()
    }

    /// What the history holds.
    pub fn kept(&self) -> Kept {
        let log = (self.log.iter())
            .map(|r| size_of::<Record>() + r.message.len() + r.agents.len() * 16)
            .sum();
        Kept {
            keyframes: self.keyframes.len(),
            every: self.every,
            deltas_from: self.first_entry(),
            keyframe_bytes: self.keyframe_bytes()
                + self.head.as_ref().map_or(0, |h| h.1.bytes())
                + self.shadow.as_ref().map_or(0, Shadow::bytes),
            delta_bytes: self.entry_bytes,
            log_bytes: log,
        }
    }

    /// Bytes held, about: the engine, the keyframes, the deltas and the log.
    pub fn bytes(&self) -> usize {
        let k = self.kept();
        self.engine.bytes() + k.keyframe_bytes + k.delta_bytes + k.log_bytes
    }

    /// The run's log: the records of every step reached so far, in step order (at most
    /// [`LOG_MAX`]), how many more there were, and the furthest step reached.
    pub fn log(&self) -> (&[Record], u64, u64) {
        (&self.log, self.log_more, self.reached)
    }

    /// Keyframes held now, and the steps between them.
    pub fn keyframes(&self) -> (usize, u64) {
        (self.keyframes.len(), self.every)
    }

    fn keyframe_bytes(&self) -> usize {
        self.keyframes.iter().map(|k| k.1.bytes()).sum()
    }

    /// The first step kept backwards (past the furthest reached when none is).
    fn first_entry(&self) -> u64 {
        self.reached + 1 - self.entries.len() as u64
    }

    /// Drops the oldest deltas past the budget.
    fn trim(&mut self) {
        while self.entry_bytes > self.delta_budget {
            let Some(e) = self.entries.pop_front() else {
                break;
            };
            self.entry_bytes -= e.bytes();
        }
    }

    /// One step forward.
    pub fn step(&mut self) -> &StepReport {
        let rep = self.engine.step();
        self.fresh = false;
        let s = self.engine.stats.steps;
        if s > self.reached {
            // From the furthest step reached: the shadow holds its columns.
            self.reached = s;
            let room = LOG_MAX.saturating_sub(self.log.len());
            self.log.extend(rep.records.iter().take(room).cloned());
            self.log_more += rep.records.len().saturating_sub(room) as u64;
            if let Some(shadow) = &mut self.shadow {
                let e = Entry {
                    delta: shadow.advance(&self.engine.lat),
                    stats: self.engine.stats.clone(),
                    report: rep.clone(),
                };
                self.entry_bytes += e.bytes();
                self.entries.push_back(e);
                self.trim();
            }
        }
        if s.is_multiple_of(self.every) && self.keyframes.last().is_some_and(|k| k.0 < s) {
            self.keyframes
                .push((s, self.engine.lat.clone(), self.engine.stats.clone()));
            while self.keyframes.len() > self.max_keyframes
                || (self.keyframes.len() > 2 && self.keyframe_bytes() > self.keyframe_budget)
            {
                self.every *= 2;
                let every = self.every;
                self.keyframes.retain(|k| k.0 % every == 0);
            }
        }
        self.last.insert(rep)
    }

    /// Goes to step `target`: to a step reached, by putting back the steps kept backwards
    /// from the nearest configuration at or after it, or else by making the run again from
    /// the last keyframe before it and stepping; past the furthest step reached (or a step
    /// or two ahead), by stepping. Either way the report of the step that led to `target`
    /// is there too.
    pub fn goto(&mut self, target: u64) {
        let cur = self.steps();
        if target == cur {
            return;
        }
        if cur == self.reached && target < cur && !self.fresh {
            self.keep_head();
        }
        let ahead = target > cur && target - cur <= STEP_AHEAD;
        if target <= self.reached && !ahead {
            if let Some(jump) = self.rewind_to(target) {
                self.jump = jump;
                return;
            }
        }
        let mut jump = Jump::Stepped(target.saturating_sub(cur));
        if target < cur {
            let k = if target == 0 {
                0
            } else {
                self.keyframes
                    .iter()
                    .rposition(|k| k.0 < target)
                    .expect("the keyframe at step 0")
            };
            let (from, lat, stats) = &self.keyframes[k];
            jump = Jump::Replayed {
                from: *from,
                steps: target - from,
            };
            let (prog, opts) = (self.engine.prog.clone(), self.engine.opts);
            self.engine = Engine::new(prog, lat.clone(), opts);
            self.engine.stats = stats.clone();
            self.last = None;
            self.fresh = true;
            // Keyframes after the target stay valid: the run is deterministic.
        }
        while self.steps() < target {
            self.step();
        }
        self.jump = jump;
    }

    /// Goes back `n` steps (to step 0 at the earliest).
    pub fn back(&mut self, n: u64) {
        self.goto(self.steps().saturating_sub(n));
    }

    /// Keeps the configuration at the furthest step reached, which the run is leaving,
    /// unless a keyframe is there.
    fn keep_head(&mut self) {
        let s = self.reached;
        let kept = self.head.as_ref().is_some_and(|h| h.0 == s)
            || self.keyframes.last().is_some_and(|k| k.0 == s);
        if !kept && self.shadow.is_some() {
            self.head = Some((s, self.engine.lat.clone(), self.engine.stats.clone()));
        }
    }

    /// Step `t` (at most the furthest reached, with its delta kept) from the nearest
    /// configuration at or after it whose deltas down to `t` are kept: a keyframe, the
    /// furthest step's, or the current one. `None` when there is none (or a delta did not
    /// fit, which leaves the engine to be made again).
    fn rewind_to(&mut self, t: u64) -> Option<Jump> {
        let first = self.first_entry();
        let (stats, report) = if t == 0 {
            (self.keyframes[0].2.clone(), None)
        } else if t >= first {
            let e = &self.entries[(t - first) as usize];
            (e.stats.clone(), Some(e.report.clone()))
        } else {
            return None;
        };
        // Deltas t+1..=k are kept when k == t or t + 1 >= first (k <= reached).
        let usable = |k: u64| k >= t && (k == t || t + 1 >= first);
        let cur = self.steps();
        let from_keyframe = (self.keyframes.iter().map(|k| (k.0, false)))
            .chain(self.head.as_ref().map(|h| (h.0, true)))
            .filter(|&(k, _)| usable(k))
            .min_by_key(|&(k, _)| k);
        let from_engine = (!self.fresh && usable(cur)).then_some(cur);
        let (k, mut lat) = match (from_keyframe, from_engine) {
            (Some((k, _)), Some(e)) if e < k => (e, self.take_lattice()),
            (None, Some(e)) => (e, self.take_lattice()),
            (Some((k, true)), _) => (k, self.head.as_ref()?.1.clone()),
            (Some((k, false)), _) => {
                let i = self.keyframes.iter().position(|f| f.0 == k)?;
                (k, self.keyframes[i].1.clone())
            }
            (None, None) => return None,
        };
        let deltas = (t + 1..=k)
            .rev()
            .map(|s| &self.entries[(s - first) as usize].delta);
        lat.rewind(deltas).ok()?;
        let (prog, opts) = (self.engine.prog.clone(), self.engine.opts);
        self.engine = Engine::new(prog, lat, opts);
        self.engine.stats = stats;
        self.last = report;
        self.fresh = true;
        Some(Jump::Rewound {
            from: k,
            deltas: k - t,
        })
    }

    /// The engine's lattice, taken (the engine is made again after).
    fn take_lattice(&mut self) -> Lattice {
        let empty = crate::LatticeBuilder::new(self.engine.lat.dim, None, 0).finish();
        self.fresh = true;
        std::mem::replace(&mut self.engine.lat, empty)
    }
}
