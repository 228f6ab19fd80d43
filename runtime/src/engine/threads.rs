//! The threads of a step: a pool of workers that take chunks of agents beside the thread
//! that steps, and the tuner that decides, per phase, whether waking them pays.

/// Per-agent work is split over threads only for at least this many agents, and a run
/// gains nothing from more threads than one per this many agents.
pub const AGENTS_PER_THREAD: usize = 1024;

/// The engine's threads: the pool of workers (when more than one thread was asked for and
/// there are enough agents), the tuner, and whether the phase running now stays on this
/// thread. The one place that decides how per-agent work is split.
#[derive(Default)]
pub(super) struct Threads {
    pool: Option<Workers>,
    tuner: Tuner,
    serial: bool,
}

impl Threads {
    /// `threads` threads for a lattice of `n` agents (a pool only from two threads and
    /// [`AGENTS_PER_THREAD`] agents on).
    pub(super) fn new(threads: usize, n: usize) -> Threads {
        Threads {
            pool: (threads > 1 && n >= AGENTS_PER_THREAD)
                .then(|| Workers::new(threads))
                .flatten(),
            ..Threads::default()
        }
    }

    /// How per-agent work on `n` agents is split: the pool and the chunk size when there
    /// are threads and enough agents, else `None`. Chunks are whole multiples of 64 agents,
    /// so that they split bit sets by words.
    pub(super) fn parallel(&self, n: usize) -> Option<(&Workers, usize)> {
        let pool = (self.pool.as_ref()).filter(|_| n >= AGENTS_PER_THREAD && !self.serial)?;
        Some((pool, n.div_ceil(pool.threads * 4).next_multiple_of(64)))
    }

    /// The split of `n` agents: the pool (with threads), the chunk size and the number of
    /// chunks (one chunk of all agents without threads).
    pub(super) fn chunks(&self, n: usize) -> (Option<(&Workers, usize)>, usize, usize) {
        let par = self.parallel(n);
        let size = par.map_or(n.max(1), |p| p.1);
        (par, size, n.div_ceil(size))
    }

    /// Runs `f` over the agents `0..n` in chunks, in parallel when there are threads, and
    /// returns the chunks' results in agent order.
    pub(super) fn par_chunks<T: Send>(
        &self,
        n: usize,
        f: &(dyn Fn(usize, usize) -> T + Sync),
    ) -> Vec<T> {
        match self.parallel(n) {
            Some((pool, size)) => pool.map((0..n.div_ceil(size)).collect(), |c| {
                f(c * size, ((c + 1) * size).min(n))
            }),
            _ => vec![f(0, n)],
        }
    }

    /// Runs phase `f` on the pool or on this thread, as the tuner chooses, and tells the
    /// tuner how long it took.
    pub(super) fn tuned<R>(&mut self, phase: Phase, f: impl FnOnce(&Threads) -> R) -> R {
        if self.pool.is_none() {
            return f(self);
        }
        self.serial = !self.tuner.pooled(phase);
        let t = std::time::Instant::now();
        let r = f(self);
        self.tuner.took(phase, t.elapsed());
        self.serial = false;
        r
    }
}

/// The threads that run chunks of agents: `threads - 1` workers and the thread that
/// steps, which takes chunks too (so that a step wakes one worker fewer, and the workers
/// are placed beside a running thread rather than beside a sleeping one: on a machine
/// of two cores, a pool of two workers woken by the stepping thread often shared one
/// core for many steps).
pub(super) struct Workers {
    pub(super) pool: rayon::ThreadPool,
    pub(super) threads: usize,
}

impl Workers {
    /// `threads` threads in all (at least two), or `None` when the system cannot start
    /// them.
    pub(super) fn new(threads: usize) -> Option<Workers> {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads - 1)
            .build()
            .ok()?;
        Some(Workers { pool, threads })
    }

    /// `f` of each item, the results in the items' order. The items are cut into as many
    /// blocks of consecutive items as there are threads, and each thread always takes the
    /// same block (this one the first, worker `w` the block after `w` others): chunks of
    /// agents cut alike in every phase stay on one core, whose cache keeps their data
    /// from one phase to the next.
    pub(super) fn map<I: Send, T: Send>(&self, items: Vec<I>, f: impl Fn(I) -> T + Sync) -> Vec<T> {
        use std::sync::{Mutex, MutexGuard};
        // (A panic in `f` reaches the caller when the scope ends; the slots stay usable.)
        fn lock<X>(m: &Mutex<X>) -> MutexGuard<'_, X> {
            m.lock().unwrap_or_else(|poisoned| poisoned.into_inner())
        }
        let n = items.len();
        let blocks = self.threads.min(n).max(1);
        let todo: Vec<Mutex<Option<I>>> = items.into_iter().map(|i| Mutex::new(Some(i))).collect();
        let done: Vec<Mutex<Option<T>>> = (0..n).map(|_| Mutex::new(None)).collect();
        let block = |b: usize| {
            for k in b * n / blocks..(b + 1) * n / blocks {
                let r = f(lock(&todo[k]).take().expect("each item is taken once"));
                *lock(&done[k]) = Some(r);
            }
        };
        let block = &block;
        self.pool.in_place_scope(|s| {
            if blocks > 1 {
                s.spawn_broadcast(move |_, ctx| {
                    let b = ctx.index() + 1;
                    if b < blocks {
                        block(b);
                    }
                });
            }
            block(0);
        });
        (done.iter())
            .map(|m| lock(m).take().expect("every item ran"))
            .collect()
    }
}

/// The phases that run in chunks of agents, on the pool when there is one.
#[derive(Clone, Copy)]
pub(super) enum Phase {
    Select,
    Calculate,
    Deliver,
    Act,
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
pub(super) struct Tuner {
    /// Per phase: how often it ran, how long its last run on one thread took, and
    /// whether one thread was faster at the last trial.
    pub(super) phases: [(u64, std::time::Duration, bool); 4],
}

impl Tuner {
    /// Whether the next run of `phase` is on the pool (it is counted).
    pub(super) fn pooled(&mut self, phase: Phase) -> bool {
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
    pub(super) fn took(&mut self, phase: Phase, d: std::time::Duration) {
        let p = &mut self.phases[phase as usize];
        match p.0 % 64 {
            4 => p.1 = d,
            5 => p.2 = p.1 < d,
            6 => p.2 &= p.1 < d,
            _ => {}
        }
    }
}
