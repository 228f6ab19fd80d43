//! Going back in a run: keyframes of the configuration every few steps, and re-simulation
//! from the nearest one. Stepping back gives exactly the earlier configuration, records and
//! statistics, because a step depends only on the configuration (the engine's caches are
//! rebuilt from it). Memory stays bounded: when there are too many keyframes, every other
//! one is dropped and the interval doubles.

use crate::{Engine, Lattice, Options, Record, Stats, StepReport};
use latticesim_vm::Verified;

/// A run that can go back.
pub struct History {
    engine: Engine,
    /// Keyframes: (step, configuration, statistics), in step order, the first at step 0.
    keyframes: Vec<(u64, Lattice, Stats)>,
    /// Steps between keyframes.
    every: u64,
    /// The most keyframes kept.
    max_keyframes: usize,
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

/// The most records the run's log keeps (about 100 bytes each, with their messages).
pub const LOG_MAX: usize = 100_000;

impl History {
    /// A run of `prog` on `lat` keeping a keyframe every `every` steps (at least 1) and at
    /// most `max_keyframes` of them (at least 2; the interval doubles when needed).
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
            engine,
            every: every.max(1),
            max_keyframes: max_keyframes.max(2),
            last: None,
            log: Vec::new(),
            log_more: 0,
            reached: 0,
        }
    }

    /// The engine at the current step (its lattice and statistics).
    pub fn engine(&self) -> &Engine {
        &self.engine
    }

    /// The current step.
    pub fn steps(&self) -> u64 {
        self.engine.stats.steps
    }

    /// The report of the step that led to the current configuration (`None` at step 0).
    pub fn last_report(&self) -> Option<&StepReport> {
        self.last.as_ref()
    }

    /// Bytes held, about: the engine, every keyframe's lattice and the log.
    pub fn bytes(&self) -> usize {
        let log: usize = (self.log.iter())
            .map(|r| std::mem::size_of::<Record>() + r.message.len() + r.agents.len() * 16)
            .sum();
        self.engine.bytes() + self.keyframes.iter().map(|k| k.1.bytes()).sum::<usize>() + log
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

    /// One step forward.
    pub fn step(&mut self) -> &StepReport {
        let rep = self.engine.step();
        let s = self.engine.stats.steps;
        if s > self.reached {
            self.reached = s;
            let room = LOG_MAX.saturating_sub(self.log.len());
            self.log.extend(rep.records.iter().take(room).cloned());
            self.log_more += rep.records.len().saturating_sub(room) as u64;
        }
        if s.is_multiple_of(self.every) && self.keyframes.last().is_some_and(|k| k.0 < s) {
            self.keyframes
                .push((s, self.engine.lat.clone(), self.engine.stats.clone()));
            if self.keyframes.len() > self.max_keyframes {
                self.every *= 2;
                let every = self.every;
                self.keyframes.retain(|k| k.0 % every == 0);
            }
        }
        self.last.insert(rep)
    }

    /// Goes to step `target`: forwards by stepping; backwards by restarting from the last
    /// keyframe before it and stepping again (so that the report of the step that led to
    /// `target` is there too).
    pub fn goto(&mut self, target: u64) {
        if target < self.steps() {
            let k = if target == 0 {
                0
            } else {
                self.keyframes
                    .iter()
                    .rposition(|k| k.0 < target)
                    .expect("the keyframe at step 0")
            };
            let (_, lat, stats) = &self.keyframes[k];
            let (prog, opts) = (self.engine.prog.clone(), self.engine.opts);
            self.engine = Engine::new(prog, lat.clone(), opts);
            self.engine.stats = stats.clone();
            self.last = None;
            // Keyframes after the target stay valid: the run is deterministic.
        }
        while self.steps() < target {
            self.step();
        }
    }

    /// Goes back `n` steps (to step 0 at the earliest).
    pub fn back(&mut self, n: u64) {
        self.goto(self.steps().saturating_sub(n));
    }
}
