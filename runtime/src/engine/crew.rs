//! A crew of worker threads that run one job at a time, each beside the calling thread
//! ([`Crew::run`]): the fork and join of a step's phases. Waiting workers spin for a
//! while before they sleep, so that the next phase finds them awake; a job is handed over
//! through one counter, and its end seen through another, with no lock and no system call
//! while they are awake.
//!
//! (rayon's scope and broadcast did the same with 12 us on average from the call to the
//! worker's start and a wait at its end: on B2 with two threads, 0.12 s of the 0.65 s of
//! stepping in about 3,000 calls. See docs/performance.md, stop 58.)

use std::sync::atomic::Ordering::{Acquire, Relaxed, Release, SeqCst};
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// How long a worker spins, waiting for the next job, before it sleeps (a step's phases
/// follow each other within tens or hundreds of microseconds; a worker asleep takes tens
/// of microseconds to wake).
const AWAKE: Duration = Duration::from_micros(500);

/// How long the calling thread spins, waiting for the workers to finish a job, before it
/// sleeps (on a machine with fewer cores than threads, a worker may wait for the core).
const JOIN_SPIN: Duration = Duration::from_micros(100);

/// A job: run by every worker with its index (1, 2, ...; the calling thread is 0).
type Job = *const (dyn Fn(usize) + Sync);

/// What the calling thread and the workers share.
struct Shared {
    /// Bumped for each job (and to stop): a worker runs the job when it changes.
    job_no: AtomicU64,
    /// The job of `job_no`; written by the calling thread while no worker reads it (the
    /// workers are done with the last job).
    job: std::cell::UnsafeCell<Option<Job>>,
    /// Workers done with the job of `job_no`.
    done: AtomicUsize,
    /// The thread that called [`Crew::run`] when it sleeps until the workers are done
    /// (set before it sleeps), and whether it does.
    caller: Mutex<Option<std::thread::Thread>>,
    waiting: AtomicBool,
    /// Per worker: asleep, or about to be (the caller then wakes it).
    asleep: Vec<AtomicBool>,
    /// Set to stop the workers.
    stop: AtomicBool,
    /// A job is running (a call of [`Crew::run`] from within a job, or from another
    /// thread meanwhile, runs its job on its own thread).
    busy: AtomicBool,
    /// How long a waiting worker spins before it sleeps, and the caller: [`AWAKE`] and
    /// [`JOIN_SPIN`] when each thread has a core, else none (a thread spinning would
    /// hold the core another waits for).
    spin: (Duration, Duration),
    /// The first panic of a worker in the last job.
    panic: Mutex<Option<Box<dyn std::any::Any + Send>>>,
}

// SAFETY: `job` is written by the calling thread only while no worker reads it (between
// jobs: every worker done), and read by the workers only after `job_no` says it is new
// (release and acquire); everything else is atomic or locked.
unsafe impl Sync for Shared {}
unsafe impl Send for Shared {}

/// Worker threads (`threads - 1` of them) that run each job beside the calling thread.
pub(super) struct Crew {
    shared: Arc<Shared>,
    handles: Vec<std::thread::JoinHandle<()>>,
}

impl Crew {
    /// `workers` threads, or `None` when the system cannot start them.
    pub(super) fn new(workers: usize) -> Option<Crew> {
        let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
        let spin = match workers < cores {
            true => (AWAKE, JOIN_SPIN),
            false => (Duration::ZERO, Duration::ZERO),
        };
        let shared = Arc::new(Shared {
            job_no: AtomicU64::new(0),
            job: std::cell::UnsafeCell::new(None),
            done: AtomicUsize::new(0),
            caller: Mutex::new(None),
            waiting: AtomicBool::new(false),
            asleep: (0..workers).map(|_| AtomicBool::new(false)).collect(),
            stop: AtomicBool::new(false),
            busy: AtomicBool::new(false),
            spin,
            panic: Mutex::new(None),
        });
        let mut crew = Crew {
            shared,
            handles: Vec::with_capacity(workers),
        };
        for w in 0..workers {
            let shared = Arc::clone(&crew.shared);
            let h = std::thread::Builder::new()
                .name(format!("latticesim-worker-{}", w + 1))
                .spawn(move || work(&shared, w))
                .ok()?;
            crew.handles.push(h);
        }
        Some(crew)
    }

    /// Runs `f(0)` here and `f(w)` on worker `w` (1 to the number of workers), and
    /// returns when every one has returned. A panic in any reaches the caller (after
    /// all have returned). While another job runs (this call made from within one), every
    /// `f(w)` runs here, in turn.
    pub(super) fn run(&self, f: &(dyn Fn(usize) + Sync)) {
        let s = &*self.shared;
        if s.busy.swap(true, Acquire) {
            (0..=self.handles.len()).for_each(f);
            return;
        }
        let _free = Free(&s.busy);
        s.done.store(0, Relaxed);
        // SAFETY: the workers are done with the last job (the last call waited for every
        // one) and read `job` only after `job_no` changes below; the job outlives its
        // use, as this call waits for every worker (also when `f(0)` panics: `Join`).
        unsafe {
            let f: Job = std::mem::transmute::<&(dyn Fn(usize) + Sync), Job>(f);
            *s.job.get() = Some(f);
        }
        s.job_no.fetch_add(1, SeqCst);
        self.wake();
        let join = Join(s, self.handles.len());
        f(0);
        drop(join);
        let panic = lock(&s.panic).take();
        if let Some(p) = panic {
            std::panic::resume_unwind(p);
        }
    }

    /// Wakes the workers that sleep (or are about to), after `job_no` changed.
    fn wake(&self) {
        for (asleep, h) in self.shared.asleep.iter().zip(&self.handles) {
            if asleep.load(SeqCst) {
                h.thread().unpark();
            }
        }
    }
}

impl Drop for Crew {
    fn drop(&mut self) {
        self.shared.stop.store(true, SeqCst);
        self.shared.job_no.fetch_add(1, SeqCst);
        self.wake();
        for h in self.handles.drain(..) {
            let _ = h.join();
        }
    }
}

/// Locks `m`, whether or not a thread panicked while holding it (for what stays whole
/// through a panic: a handle, a panic's payload, a slot taken or filled at once).
pub(super) fn lock<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|poisoned| poisoned.into_inner())
}

/// Clears the flag that a job runs, when dropped (also by a panic).
struct Free<'a>(&'a AtomicBool);

impl Drop for Free<'_> {
    fn drop(&mut self) {
        self.0.store(false, Release);
    }
}

/// Waits, when dropped, until every worker is done with the job.
struct Join<'a>(&'a Shared, usize);

impl Drop for Join<'_> {
    fn drop(&mut self) {
        let s = self.0;
        let done = || s.done.load(SeqCst) >= self.1;
        // (Each worker reads `waiting` after counting itself done, and wakes the thread
        // set here.)
        let before = || {
            point(s, Side::Caller);
            *lock(&s.caller) = Some(std::thread::current());
        };
        wait(done, (s.spin.1, &s.waiting), before);
    }
}

/// Who waits in [`wait`]: a worker for the next job, or the calling thread for the
/// workers' end.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
enum Side {
    Worker,
    Caller,
}

/// The point where a thread of crew `s` about to sleep in [`wait`] (on `side`) has found
/// it not ready and not yet said that it sleeps: where a wake-up would be lost if it did
/// not look again. The tests hold a thread here while the other makes it ready; nothing
/// happens here outside tests.
#[inline(always)]
fn point(s: &Shared, side: Side) {
    #[cfg(test)]
    tests::held_here(s, side);
    #[cfg(not(test))]
    let _ = (s, side);
}

/// Returns once `ready()`: spinning for up to `spin`, then asleep until woken (and again
/// so, when woken early). `asleep` is set while it may sleep (after `before()`), and
/// whoever makes it ready reads `asleep` after doing so and then wakes it: both this and
/// they store and then load sequentially consistent, so one of them sees the other (an
/// unpark before the park makes the park return at once).
fn wait(ready: impl Fn() -> bool, (spin, asleep): (Duration, &AtomicBool), before: impl Fn()) {
    let mut since = Instant::now();
    let mut spins = 0u32;
    while !ready() {
        spins = spins.wrapping_add(1);
        if spins.is_multiple_of(64) && since.elapsed() > spin {
            before();
            asleep.store(true, SeqCst);
            if !ready() {
                std::thread::park();
            }
            asleep.store(false, SeqCst);
            since = Instant::now();
        }
        std::hint::spin_loop();
    }
}

/// A worker's loop: waits for a new job (spinning for a while, then asleep), runs it.
fn work(s: &Shared, w: usize) {
    let mut seen = 0;
    loop {
        // (The caller reads `asleep` after changing `job_no`.)
        wait(
            || s.job_no.load(SeqCst) != seen,
            (s.spin.0, &s.asleep[w]),
            || point(s, Side::Worker),
        );
        seen = s.job_no.load(Acquire);
        if s.stop.load(SeqCst) {
            return;
        }
        // SAFETY: written before `job_no` changed (release, read above with acquire), and
        // not written again before this worker counts itself done.
        let job = unsafe { (*s.job.get()).expect("a job with its number") };
        // SAFETY: the caller of `run` waits for this worker before the job ends.
        let r = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| unsafe { (*job)(w + 1) }));
        if let Err(p) = r {
            lock(&s.panic).get_or_insert(p);
        }
        s.done.fetch_add(1, SeqCst);
        if s.waiting.load(SeqCst) {
            if let Some(caller) = &*lock(&s.caller) {
                caller.unpark();
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::{lock, Crew, Shared, Side};
    use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering::Relaxed, Ordering::SeqCst};
    use std::sync::mpsc::{channel, Receiver, Sender};
    use std::sync::{Arc, Mutex};
    use std::time::Duration;

    /// A thread to hold at [`super::point`]: of the crew whose shared part is at this
    /// address, on this side; it says when it is there, and goes on when told.
    struct Hold {
        crew: usize,
        side: Side,
        there: Sender<()>,
        go: Receiver<()>,
    }

    /// The holds asked for (by tests that may run at once).
    static HOLDS: Mutex<Vec<Hold>> = Mutex::new(Vec::new());

    /// At [`super::point`]: holds the thread when a test asked for it (once).
    pub(super) fn held_here(s: &Shared, side: Side) {
        let mut holds = lock(&HOLDS);
        let crew = s as *const Shared as usize;
        if let Some(k) = holds.iter().position(|h| h.crew == crew && h.side == side) {
            let h = holds.swap_remove(k);
            drop(holds);
            let _ = h.there.send(());
            let _ = h.go.recv();
        }
    }

    /// Asks to hold crew `crew`'s thread on `side` at [`super::point`]: a receiver told
    /// when it is there, and a sender that lets it go on.
    fn hold(crew: &Crew, side: Side) -> (Receiver<()>, Sender<()>) {
        let ((there, is_there), (go, on_go)) = (channel(), channel());
        lock(&HOLDS).push(Hold {
            crew: Arc::as_ptr(&crew.shared) as usize,
            side,
            there,
            go: on_go,
        });
        (is_there, go)
    }

    /// Long enough for anything but a thread that sleeps for good.
    const BOUND: Duration = Duration::from_secs(20);

    /// A worker found no job and is about to sleep when the job comes and the caller,
    /// seeing it awake, does not wake it: it must see the job before it sleeps (else the
    /// call never returns).
    #[test]
    fn a_worker_about_to_sleep_sees_the_job_that_came_meanwhile() {
        let crew = Arc::new(Crew::new(1).expect("threads"));
        // (Asked for from the worker's part of a job: it then waits for the next one.)
        let asked = Mutex::new(None);
        crew.run(&|w| {
            if w == 1 {
                *lock(&asked) = Some(hold(&crew, Side::Worker));
            }
        });
        let (there, go) = lock(&asked).take().expect("asked for");
        there
            .recv_timeout(BOUND)
            .expect("the worker looks for a job, then would sleep");
        let (started, is_started) = channel();
        let (returned, has_returned) = channel();
        let runs = Arc::new(AtomicUsize::new(0));
        let (c, r) = (Arc::clone(&crew), Arc::clone(&runs));
        std::thread::spawn(move || {
            c.run(&|w| {
                if w == 0 {
                    // (After the job's number changed and the sleepers were woken.)
                    let _ = started.send(());
                }
                r.fetch_add(1, Relaxed);
            });
            let _ = returned.send(());
        });
        is_started
            .recv_timeout(BOUND)
            .expect("the caller runs its part");
        go.send(()).expect("the worker held");
        has_returned
            .recv_timeout(BOUND)
            .expect("the call returns: the worker ran the job that came as it went to sleep");
        assert_eq!(runs.load(Relaxed), 2);
    }

    /// The caller is about to sleep until the workers are done when the last one ends and,
    /// seeing the caller awake, does not wake it: it must see them done before it sleeps.
    #[test]
    fn a_caller_about_to_sleep_sees_the_workers_that_ended_meanwhile() {
        let crew = Arc::new(Crew::new(1).expect("threads"));
        let (there, go) = hold(&crew, Side::Caller);
        let end = Arc::new(AtomicBool::new(false));
        let (returned, has_returned) = channel();
        let (c, e) = (Arc::clone(&crew), Arc::clone(&end));
        std::thread::spawn(move || {
            c.run(&|w| {
                while w == 1 && !e.load(SeqCst) {
                    std::thread::sleep(Duration::from_millis(1));
                }
            });
            let _ = returned.send(());
        });
        there
            .recv_timeout(BOUND)
            .expect("the caller waits for the worker, then would sleep");
        end.store(true, SeqCst);
        // The worker is done, has looked whether the caller sleeps (it does not yet) and
        // waits for the next job: it says so before it sleeps.
        let s = &crew.shared;
        let t = std::time::Instant::now();
        while !(s.done.load(SeqCst) == 1 && s.asleep[0].load(SeqCst)) {
            assert!(t.elapsed() < BOUND, "the worker ends its part");
            std::thread::sleep(Duration::from_millis(1));
        }
        go.send(()).expect("the caller held");
        has_returned
            .recv_timeout(BOUND)
            .expect("the call returns: the caller saw the worker done as it went to sleep");
    }

    #[test]
    fn every_thread_runs_each_job_once() {
        // One worker spins while it waits on a machine of two cores or more; three, on a
        // machine of fewer than four, sleep at once.
        for workers in [1, 3] {
            let crew = Crew::new(workers).expect("threads");
            for round in 0..2000 {
                let runs: Vec<AtomicUsize> = (0..=workers).map(|_| AtomicUsize::new(0)).collect();
                crew.run(&|w| {
                    runs[w].fetch_add(1, Relaxed);
                    if round % 400 == 1 && w == workers {
                        // The calling thread, done first, sleeps until this one ends.
                        std::thread::sleep(std::time::Duration::from_millis(1));
                    }
                });
                assert!(
                    runs.iter().all(|r| r.load(Relaxed) == 1),
                    "{workers} workers, round {round}"
                );
                if round % 500 == 0 {
                    // Long enough for the workers to sleep.
                    std::thread::sleep(std::time::Duration::from_millis(2));
                }
            }
        }
    }

    #[test]
    fn a_job_run_from_within_a_job_runs_on_its_thread() {
        let crew = Crew::new(2).expect("threads");
        let inner: Vec<AtomicUsize> = (0..3).map(|_| AtomicUsize::new(0)).collect();
        crew.run(&|_| {
            crew.run(&|w| {
                inner[w].fetch_add(1, Relaxed);
            })
        });
        assert!(inner.iter().all(|r| r.load(Relaxed) == 3));
    }

    #[test]
    fn a_workers_panic_reaches_the_caller_after_every_thread_returned() {
        let crew = Crew::new(2).expect("threads");
        let finished = AtomicUsize::new(0);
        let r = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
            crew.run(&|w| {
                if w == 2 {
                    panic!("worker 2");
                }
                std::thread::sleep(std::time::Duration::from_millis(5));
                finished.fetch_add(1, Relaxed);
            })
        }));
        assert!(r.is_err());
        assert_eq!(finished.load(Relaxed), 2, "the others ran to their end");
        // The crew goes on.
        let runs = AtomicUsize::new(0);
        crew.run(&|_| {
            runs.fetch_add(1, Relaxed);
        });
        assert_eq!(runs.load(Relaxed), 3);
    }
}
