//! The threads of a step: a pool of workers that take chunks of agents beside the thread
//! that steps, and the tuner that decides, per phase, whether waking them pays.

/// Per-agent work is split over threads only for at least this many agents, and a run
/// gains nothing from more threads than one per this many agents.
pub const AGENTS_PER_THREAD: usize = 1024;

/// Per-agent work is cut into this many chunks per thread (fewer for fewer agents), so
/// that a thread done early takes some of another's (see [`Workers::map`]). (4 before;
/// B2F and the cloud on two threads the same with 8 and 16, B1's engine 2 % slower with
/// 16, the same with 8: `profile_b1 1000 2 50 5`, eight runs each.)
const CHUNKS_PER_THREAD: usize = 8;

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
        Some((
            pool,
            n.div_ceil(pool.threads * CHUNKS_PER_THREAD)
                .next_multiple_of(64),
        ))
    }

    /// The split of `n` agents: the pool (with threads), the chunk size and the number of
    /// chunks (one chunk of all agents without threads).
    pub(super) fn chunks(&self, n: usize) -> (Option<(&Workers, usize)>, usize, usize) {
        let par = self.parallel(n);
        let size = par.map_or(n.max(1), |p| p.1);
        (par, size, n.div_ceil(size))
    }

    /// [`Threads::chunks`] of `n` items of light work: on the pool only from `min` items
    /// (waking the workers costs what thousands of such items do).
    pub(super) fn chunks_from(
        &self,
        n: usize,
        min: usize,
    ) -> (Option<(&Workers, usize)>, usize, usize) {
        match n >= min {
            true => self.chunks(n),
            false => (None, n.max(1), usize::from(n > 0)),
        }
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

    /// Sets `out[i]` to `f(i)` for every `i`, in chunks on the pool when there are threads.
    pub(super) fn fill<T: Send>(&self, out: &mut [T], f: impl Fn(usize) -> T + Sync) {
        match self.parallel(out.len()) {
            Some((pool, size)) => {
                let items: Vec<(usize, &mut [T])> = out.chunks_mut(size).enumerate().collect();
                pool.map(items, |(c, part)| {
                    for (k, x) in part.iter_mut().enumerate() {
                        *x = f(c * size + k);
                    }
                });
            }
            None => out.iter_mut().enumerate().for_each(|(i, x)| *x = f(i)),
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

/// `f` of each item, in the items' order: on the pool when the split (`par`, as
/// [`Threads::chunks`] gives it) has one, else on this thread.
pub(super) fn map_on<I: Send, T: Send>(
    par: Option<(&Workers, usize)>,
    items: Vec<I>,
    f: impl Fn(I) -> T + Sync,
) -> Vec<T> {
    match par {
        Some((pool, _)) => pool.map(items, f),
        None => items.into_iter().map(f).collect(),
    }
}

/// The threads that run chunks of agents: `threads - 1` workers and the thread that
/// steps, which takes chunks too (so that a step wakes one worker fewer, and the workers
/// are placed beside a running thread rather than beside a sleeping one: on a machine
/// of two cores, a pool of two workers woken by the stepping thread often shared one
/// core for many steps).
pub(super) struct Workers {
    crew: super::crew::Crew,
    pub(super) threads: usize,
}

impl Workers {
    /// `threads` threads in all (at least two), or `None` when the system cannot start
    /// them.
    pub(super) fn new(threads: usize) -> Option<Workers> {
        Some(Workers {
            crew: super::crew::Crew::new(threads - 1)?,
            threads,
        })
    }

    /// `f` of each item, the results in the items' order. The items are cut into as many
    /// blocks of consecutive items as there are threads, and each thread first takes the
    /// items of the same block, in order (this one the first block, worker `w` the block
    /// after `w` others): chunks of agents cut alike in every phase stay on one core, whose
    /// cache keeps their data from one phase to the next. A thread done with its block
    /// then takes items from the end of the others' blocks, so that no thread waits long
    /// for one that started late (a worker woken from sleep) or had more to do (B2's
    /// movers are not spread evenly over its agents): with two threads, B2F 7-14 % and
    /// the gravity cloud 13 % faster (twelve and four pairs of runs, alternating with the
    /// build before).
    pub(super) fn map<I: Send, T: Send>(&self, items: Vec<I>, f: impl Fn(I) -> T + Sync) -> Vec<T> {
        use super::crew::lock;
        use std::sync::Mutex;
        // (A panic in `f` reaches the caller when every thread is done; the slots stay
        // usable: `lock`.)
        let n = items.len();
        let blocks = Blocks::new(n, self.threads);
        let todo: Vec<Mutex<Option<I>>> = items.into_iter().map(|i| Mutex::new(Some(i))).collect();
        let done: Vec<Mutex<Option<T>>> = (0..n).map(|_| Mutex::new(None)).collect();
        let count = blocks.count();
        self.crew.run(&|b| {
            if b < count {
                for k in blocks.taken_by(b) {
                    let r = f(lock(&todo[k]).take().expect("each item is taken once"));
                    *lock(&done[k]) = Some(r);
                }
            }
        });
        (done.iter())
            .map(|m| lock(m).take().expect("every item ran"))
            .collect()
    }
}

/// The items `0..n` of [`Workers::map`] in blocks of consecutive items, one per thread:
/// per block, the items not taken yet, as `first | end << 32`.
struct Blocks(Vec<std::sync::atomic::AtomicU64>);

impl Blocks {
    /// `n` items in as many blocks as `threads` (fewer when there are fewer items).
    fn new(n: usize, threads: usize) -> Blocks {
        assert!(n <= u32::MAX as usize, "items counted in 32 bits");
        let count = threads.min(n).max(1);
        let span = |b: usize| (b * n / count) as u64 | (((b + 1) * n / count) as u64) << 32;
        Blocks((0..count).map(|b| span(b).into()).collect())
    }

    fn count(&self) -> usize {
        self.0.len()
    }

    /// Takes the first item left in block `b` (`first`), or the last; `None` when none is
    /// left.
    fn take(&self, b: usize, first: bool) -> Option<usize> {
        use std::sync::atomic::Ordering::{AcqRel, Relaxed};
        let left = &self.0[b];
        let mut now = left.load(Relaxed);
        loop {
            let (lo, hi) = (now & 0xffff_ffff, now >> 32);
            if lo >= hi {
                return None;
            }
            let (next, k) = match first {
                true => (now + 1, lo),
                false => (lo | (hi - 1) << 32, hi - 1),
            };
            match left.compare_exchange_weak(now, next, AcqRel, Relaxed) {
                Ok(_) => return Some(k as usize),
                Err(seen) => now = seen,
            }
        }
    }

    /// The items thread `b` runs, as it takes them: those of its own block from the
    /// first, then those left in the other blocks (the next block first) from the last.
    /// Every item is taken by exactly one thread.
    fn taken_by(&self, b: usize) -> impl Iterator<Item = usize> + '_ {
        let count = self.count();
        let own = std::iter::from_fn(move || self.take(b, true));
        let others = (1..count).flat_map(move |j| {
            let o = (b + j) % count;
            std::iter::from_fn(move || self.take(o, false))
        });
        own.chain(others)
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

#[cfg(test)]
mod tests {
    use super::{Blocks, Workers};

    /// A thread takes its own block's items in order, then the others' from their ends;
    /// across threads taking at once, every item is taken exactly once.
    #[test]
    fn blocks_give_every_item_once() {
        let b = Blocks::new(10, 3);
        assert_eq!(b.count(), 3);
        // Blocks 0..3, 3..6, 6..10: thread 1 alone takes all, its own first.
        let order: Vec<usize> = b.taken_by(1).collect();
        assert_eq!(order, [3, 4, 5, 9, 8, 7, 6, 2, 1, 0]);
        assert_eq!(Blocks::new(2, 8).count(), 2, "no empty blocks");
        assert_eq!(Blocks::new(0, 2).taken_by(0).count(), 0);
        for (n, threads) in [(1000, 2), (997, 3), (64, 8)] {
            let b = Blocks::new(n, threads);
            let taken: Vec<Vec<usize>> = std::thread::scope(|s| {
                let b = &b;
                let hs: Vec<_> = (0..b.count())
                    .map(|t| s.spawn(move || b.taken_by(t).collect::<Vec<usize>>()))
                    .collect();
                hs.into_iter().map(|h| h.join().unwrap()).collect()
            });
            let mut all: Vec<usize> = taken.concat();
            all.sort_unstable();
            assert_eq!(
                all,
                (0..n).collect::<Vec<_>>(),
                "{n} items, {threads} threads"
            );
        }
    }

    /// The results come back in the items' order whichever thread ran each, items that
    /// take long or not.
    #[test]
    fn map_keeps_the_items_order() {
        let w = Workers::new(3).expect("threads");
        let items: Vec<u64> = (0..200).collect();
        let out = w.map(items, |i| {
            if i % 7 == 0 {
                std::thread::sleep(std::time::Duration::from_micros(200));
            }
            i * i
        });
        assert_eq!(out, (0..200u64).map(|i| i * i).collect::<Vec<_>>());
    }
}
