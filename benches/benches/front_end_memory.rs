//! Peak heap memory of checking a generated rules file of 100,000 rules, measured with a
//! counting allocator (target: under 200 MB). Prints one line; fails above the target.

use latticesim_benches::generate_rules;
use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering::Relaxed};

struct Counting;

static CURRENT: AtomicUsize = AtomicUsize::new(0);
static PEAK: AtomicUsize = AtomicUsize::new(0);

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, l: Layout) -> *mut u8 {
        let now = CURRENT.fetch_add(l.size(), Relaxed) + l.size();
        PEAK.fetch_max(now, Relaxed);
        unsafe { System.alloc(l) }
    }
    unsafe fn dealloc(&self, p: *mut u8, l: Layout) {
        CURRENT.fetch_sub(l.size(), Relaxed);
        unsafe { System.dealloc(p, l) }
    }
}

#[global_allocator]
static ALLOC: Counting = Counting;

/// Peak heap above the current level while `f` runs, and its result.
fn peak_of<T>(f: impl FnOnce() -> T) -> (usize, T) {
    let before = CURRENT.load(Relaxed);
    PEAK.store(before, Relaxed);
    let out = f();
    (PEAK.load(Relaxed) - before, out)
}

fn main() {
    let text = generate_rules(100_000, 1);
    let (parse_peak, kept) = peak_of(|| {
        let arena = bumpalo::Bump::new();
        let (f, d) =
            latticesim_grammar::parse_rules(&text, latticesim_grammar::FileId(0), &arena, Some(2));
        (f.rules.len(), d.len(), arena.allocated_bytes())
    });
    println!(
        "parse alone: peak heap {:.1} MB, of which the arena holds {:.1} MB ({} rules)",
        parse_peak as f64 / 1e6,
        kept.2 as f64 / 1e6,
        kept.0
    );
    let before = CURRENT.load(Relaxed);
    PEAK.store(before, Relaxed);
    let t = std::time::Instant::now();
    let c = latticesim_compiler::check(
        latticesim_compiler::Input {
            name: "gen.txt",
            bytes: text.as_bytes(),
        },
        None,
        None,
    );
    let took = t.elapsed();
    assert_eq!(c.errors(), 0);
    let peak = PEAK.load(Relaxed) - before;
    let mb = peak as f64 / 1e6;
    println!(
        "check of 100,000 rules ({:.1} MB of text): peak heap {mb:.1} MB above the input ({:.2}x the text), one run {took:.2?}",
        text.len() as f64 / 1e6,
        peak as f64 / text.len() as f64
    );
    assert!(
        mb < 200.0,
        "peak heap {mb:.1} MB is above the 200 MB target"
    );
}
