//! The program's allocator: the system's for blocks under 2 MB; larger blocks are mapped
//! on their own, aligned to 2 MB and backed by huge pages where the kernel gives them on
//! request (Linux's transparent huge pages in `madvise` mode, the common default).
//!
//! A run of millions of agents touches hundreds of megabytes of fresh columns; in pages of
//! 4 KB that is a page fault per 4 KB: a fifth of the time of a run from file to file of a
//! million agents (docs/performance.md, "From file to file"). In huge pages of 2 MB it is
//! one per 2 MB: that run takes about a tenth less time. Elsewhere than on Linux the system
//! allocator does everything.
//!
//! Small blocks: the system allocator (glibc's, on Linux) maps blocks above a threshold
//! (128 KB at first) one by one and gives the free top of its heap back to the system;
//! the next step's lists of as many agents then touch fresh pages again. [`tune`] keeps
//! them in the heap.

use std::alloc::{GlobalAlloc, Layout, System};

/// Sets the system allocator for a run (call it first, before any thread starts): on
/// Linux with glibc, every block under [`LARGE`] comes from its heap, and the heap's free
/// top stays (up to 1 GB). A step that makes and drops lists of every agent (carried
/// groups: their bonds, roots and moves; a jam's records) otherwise faults fresh pages in
/// every step: 25,000 bars against a wall, two threads, 0.72x the actions' time with it
/// (a sixth of it was page faults). The peak is the same: B1 at 10^8 agents 4,111,452
/// KiB against 4,109,900.
pub fn tune() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: `mallopt` only sets the allocator's parameters; called before other threads.
    unsafe {
        libc::mallopt(libc::M_MMAP_THRESHOLD, LARGE as libc::c_int);
        libc::mallopt(libc::M_TRIM_THRESHOLD, 1 << 30);
    }
}

/// See the module's text.
pub struct HugePages;

/// The size of a huge page; also the alignment of large blocks.
#[cfg(target_os = "linux")]
const HUGE: usize = 2 << 20;
/// The smallest block mapped on its own.
#[cfg(target_os = "linux")]
const LARGE: usize = HUGE;

#[cfg(target_os = "linux")]
fn large(layout: &Layout) -> bool {
    layout.size() >= LARGE && layout.align() <= HUGE
}

/// The length of the mapping of a large block of `size` bytes.
#[cfg(target_os = "linux")]
fn mapped(size: usize) -> usize {
    size.next_multiple_of(HUGE)
}

/// Maps a zeroed block of `len` bytes (a multiple of [`HUGE`]) aligned to [`HUGE`], with
/// huge pages asked for; null when the system has no room.
#[cfg(target_os = "linux")]
fn map(len: usize) -> *mut u8 {
    // SAFETY: an anonymous private mapping of fresh memory; the parts outside the aligned
    // block are unmapped at once, and only the block is handed out.
    unsafe {
        let p = libc::mmap(
            std::ptr::null_mut(),
            len + HUGE,
            libc::PROT_READ | libc::PROT_WRITE,
            libc::MAP_PRIVATE | libc::MAP_ANONYMOUS,
            -1,
            0,
        );
        if p == libc::MAP_FAILED {
            return std::ptr::null_mut();
        }
        let start = p as usize;
        let aligned = start.next_multiple_of(HUGE);
        if aligned > start {
            libc::munmap(p, aligned - start);
        }
        let tail = start + len + HUGE - (aligned + len);
        if tail > 0 {
            libc::munmap((aligned + len) as *mut libc::c_void, tail);
        }
        libc::madvise(aligned as *mut libc::c_void, len, libc::MADV_HUGEPAGE);
        aligned as *mut u8
    }
}

// SAFETY: small blocks go to the system allocator with the same arguments. A large block
// is a mapping of its own, of `mapped(size)` bytes (so its alignment, at most 2 MB, holds),
// unmapped by `dealloc` with the same length, which the layout given back tells; `realloc`
// keeps a block large or small as its new size says, copying what it held.
unsafe impl GlobalAlloc for HugePages {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        #[cfg(target_os = "linux")]
        if large(&layout) {
            return map(mapped(layout.size()));
        }
        unsafe { System.alloc(layout) }
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        #[cfg(target_os = "linux")]
        if large(&layout) {
            // Fresh mappings are zero.
            return map(mapped(layout.size()));
        }
        unsafe { System.alloc_zeroed(layout) }
    }

    unsafe fn dealloc(&self, p: *mut u8, layout: Layout) {
        #[cfg(target_os = "linux")]
        if large(&layout) {
            unsafe { libc::munmap(p as *mut libc::c_void, mapped(layout.size())) };
            return;
        }
        unsafe { System.dealloc(p, layout) }
    }

    unsafe fn realloc(&self, p: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        #[cfg(target_os = "linux")]
        {
            // SAFETY: the caller guarantees a valid layout for the new size.
            let new = unsafe { Layout::from_size_align_unchecked(new_size, layout.align()) };
            match (large(&layout), large(&new)) {
                (false, false) => {}
                (true, true) if mapped(layout.size()) == mapped(new_size) => return p,
                _ => {
                    let q = unsafe { self.alloc(new) };
                    if !q.is_null() {
                        let keep = layout.size().min(new_size);
                        unsafe { std::ptr::copy_nonoverlapping(p, q, keep) };
                        unsafe { self.dealloc(p, layout) };
                    }
                    return q;
                }
            }
        }
        unsafe { System.realloc(p, layout, new_size) }
    }
}
