//! Bit sets in words of 64, runs of ids, and a vector filled without a branch per value:
//! the small helpers the lattice and the engine share. A leaf: it uses nothing of the
//! crate.

/// The words a range of bits touches, `first..=last`, and the masks of the range in the
/// first word and in the last; `None` for an empty range.
#[inline]
fn edges(range: std::ops::Range<usize>) -> Option<(usize, usize, u64, u64)> {
    if range.is_empty() {
        return None;
    }
    let (first, last) = (range.start >> 6, (range.end - 1) >> 6);
    let head = u64::MAX << (range.start & 63);
    let tail = u64::MAX >> (63 - ((range.end - 1) & 63));
    Some((first, last, head, tail))
}

/// The words a range of bits touches, each with the mask of the range in it.
#[inline]
pub(crate) fn range_words(range: std::ops::Range<usize>) -> impl Iterator<Item = (usize, u64)> {
    let (first, last, head, tail) = edges(range).unwrap_or((1, 0, 0, 0));
    (first..=last).map(move |w| {
        let head = if w == first { head } else { u64::MAX };
        (w, head & if w == last { tail } else { u64::MAX })
    })
}

/// Sets every bit of `range` as in `word` (all zeros or all ones).
#[inline]
fn put_bits(bits: &mut [u64], range: std::ops::Range<usize>, word: u64) {
    let Some((first, last, head, tail)) = edges(range) else {
        return;
    };
    let put = |w: &mut u64, mask: u64| *w = (*w & !mask) | (word & mask);
    if first == last {
        put(&mut bits[first], head & tail);
    } else {
        put(&mut bits[first], head);
        put(&mut bits[last], tail);
        bits[first + 1..last].fill(word);
    }
}

/// The bits set in a word; quick for the full and empty words of dense configurations
/// (a machine without a population-count instruction counts the others in a dozen steps).
#[inline(always)]
pub(crate) fn ones(w: u64) -> u64 {
    match w {
        0 => 0,
        u64::MAX => 64,
        w => w.count_ones() as u64,
    }
}

/// Clears the bits `range` of a bit set.
#[inline]
pub(crate) fn clear_bits(bits: &mut [u64], range: std::ops::Range<usize>) {
    put_bits(bits, range, 0);
}

/// Sets the bits `range` of a bit set.
#[inline]
pub(crate) fn set_bits(bits: &mut [u64], range: std::ops::Range<usize>) {
    put_bits(bits, range, u64::MAX);
}

/// Appends to `out` the values of `items` whose flag is set, and returns how many. Each
/// value is written into the vector's spare room and kept when flagged, without a branch
/// per value (a `push` per value kept waited on the last one's write of the vector's
/// length) and without filling the room first (a million movers a step).
#[inline]
pub(crate) fn extend_kept<T: Copy>(
    out: &mut Vec<T>,
    items: impl ExactSizeIterator<Item = (T, bool)>,
) -> usize {
    let (start, n) = (out.len(), items.len());
    out.reserve(n);
    let room = &mut out.spare_capacity_mut()[..n];
    let mut m = 0;
    for (v, keep) in items {
        // (At most as many values as the iterator said: `room[m]` is checked.)
        room[m].write(v);
        m += keep as usize;
    }
    // SAFETY: the first `m` slots of the spare room were written (`m` counts writes kept,
    // each at the slot after the last kept), within the capacity reserved.
    unsafe { out.set_len(start + m) };
    m
}

/// Appends to `out` the numbers `first + i` of the bits `i` set in `mask`, in rising
/// order: a write per number appended, none per bit clear (where [`extend_kept`] writes
/// one per value).
#[inline]
pub(crate) fn extend_ones(out: &mut Vec<u32>, first: u32, mut mask: u64) {
    let (start, n) = (out.len(), mask.count_ones() as usize);
    out.reserve(n);
    let room = &mut out.spare_capacity_mut()[..n];
    for slot in room.iter_mut() {
        slot.write(first + mask.trailing_zeros());
        mask &= mask - 1;
    }
    // SAFETY: the first `n` slots of the spare room were written, within the capacity
    // reserved.
    unsafe { out.set_len(start + n) };
}

/// The bits of the values of `block` (at most 64) that differ from `v`: bit `i` for
/// `block[i]`. (Built eight values at a time, which vectorises.)
#[inline]
pub(crate) fn mask_ne(block: &[u32], v: u32) -> u64 {
    assert!(block.len() <= 64, "at most 64 values");
    let mut mask = 0u64;
    let mut eights = block.chunks_exact(8);
    for (k, c) in eights.by_ref().enumerate() {
        let byte = (0..8).fold(0u64, |b, j| b | ((c[j] != v) as u64) << j);
        mask |= byte << (8 * k);
    }
    let done = block.len() / 8 * 8;
    for (j, &x) in eights.remainder().iter().enumerate() {
        mask |= ((x != v) as u64) << (done + j);
    }
    mask
}

/// How many of the first values of `s` equal `v` (compared in blocks, which vectorises).
#[inline]
pub(crate) fn run_of<T: Copy + PartialEq>(s: &[T], v: T) -> usize {
    run_while(s, |x| x == v)
}

/// How many of the first values of `s` pass `test` (tested in blocks, which vectorises).
#[inline]
pub(crate) fn run_while<T: Copy>(s: &[T], test: impl Fn(T) -> bool) -> usize {
    let mut n = 0;
    for block in s.chunks(32) {
        if block.iter().fold(true, |ok, &x| ok & test(x)) {
            n += block.len();
        } else {
            return n + block.iter().take_while(|&&x| test(x)).count();
        }
    }
    n
}

/// How many of the first values of `s` are `start, start + 1, ...` (compared in blocks,
/// as [`run_of`]).
#[inline]
pub(crate) fn sequence_len(s: &[u32], start: u32) -> usize {
    let mut n = 0;
    for block in s.chunks(32) {
        let first = start.wrapping_add(n as u32);
        if is_sequence(block, first) {
            n += block.len();
        } else {
            return n
                + (block.iter().zip(0u32..))
                    .take_while(|&(&x, j)| x == first.wrapping_add(j))
                    .count();
        }
    }
    n
}

/// Whether `s` is `start, start + 1, ...` (compared without early exit, which vectorises).
#[inline]
pub(crate) fn is_sequence(s: &[u32], start: u32) -> bool {
    s.iter()
        .enumerate()
        .fold(true, |ok, (j, &x)| ok & (x == start.wrapping_add(j as u32)))
}

/// Whether no bit of `range` is set.
#[inline]
pub(crate) fn no_bits(bits: &[u64], range: std::ops::Range<usize>) -> bool {
    bits_are(bits, range, 0)
}

/// Whether every bit of `range` is set.
#[inline]
pub(crate) fn all_bits(bits: &[u64], range: std::ops::Range<usize>) -> bool {
    bits_are(bits, range, u64::MAX)
}

/// Whether every bit of `range` is as in `word` (all zeros or all ones): the words at both
/// ends under a mask, the ones between whole (or-ed, or and-ed, without early exit, which
/// vectorises).
#[inline(always)]
fn bits_are(bits: &[u64], range: std::ops::Range<usize>, word: u64) -> bool {
    let Some((first, last, head, tail)) = edges(range) else {
        return true;
    };
    if first == last {
        let mask = head & tail;
        return bits[first] & mask == word & mask;
    }
    let between = &bits[first + 1..last];
    bits[first] & head == word & head
        && bits[last] & tail == word & tail
        && if word == 0 {
            between.iter().fold(0, |acc, &w| acc | w) == 0
        } else {
            between.iter().fold(u64::MAX, |acc, &w| acc & w) == u64::MAX
        }
}

/// The word and the bit of index `i` in a bit set.
#[inline]
pub(crate) fn bit(i: usize) -> (usize, u64) {
    (i / 64, 1 << (i % 64))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Keeping the flagged values appends what a filter would, after what the vector held,
    /// whatever its spare room: none kept, all kept, every other.
    #[test]
    fn extend_kept_appends_the_flagged_values() {
        for len in [0usize, 1, 7, 64, 1000] {
            for every in [1, 2, 3, usize::MAX] {
                let items: Vec<(u32, bool)> = (0..len as u32)
                    .map(|v| (v, (v as usize).is_multiple_of(every)))
                    .collect();
                let want: Vec<u32> = [9, 9]
                    .into_iter()
                    .chain(items.iter().filter(|i| i.1).map(|i| i.0))
                    .collect();
                for cap in [2, 5000] {
                    let mut out = Vec::with_capacity(cap);
                    out.extend([9, 9]);
                    let kept = extend_kept(&mut out, items.iter().copied());
                    assert_eq!((kept, &out), (want.len() - 2, &want), "{len} {every} {cap}");
                }
            }
        }
    }

    /// The mask of the values that differ from one, and the numbers of its bits appended,
    /// against a filter, for blocks of every length up to 64 (whole eights and a rest) and
    /// values of every kind.
    #[test]
    fn masks_and_their_numbers_agree_with_a_filter() {
        let mut seed = 7u64;
        let mut next = move || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            seed >> 33
        };
        for len in 0..=64usize {
            for odds in [0, 1, 2, 4] {
                let block: Vec<u32> = (0..len)
                    .map(|_| match odds > 0 && next() % odds == 0 {
                        true => next() as u32 % 3,
                        false => u32::MAX,
                    })
                    .collect();
                let mask = mask_ne(&block, u32::MAX);
                let want: Vec<u32> = (0..len as u32)
                    .filter(|&i| block[i as usize] != u32::MAX)
                    .map(|i| 1000 + i)
                    .collect();
                assert_eq!(mask.count_ones() as usize, want.len(), "{block:?}");
                let mut out = vec![5];
                extend_ones(&mut out, 1000, mask);
                assert_eq!(out[1..], want[..], "{block:?}");
                assert_eq!(out[0], 5);
            }
        }
        let mut out = Vec::new();
        extend_ones(&mut out, u32::MAX - 64, u64::MAX);
        assert_eq!(out, (u32::MAX - 64..u32::MAX).collect::<Vec<u32>>());
    }

    /// Setting and clearing ranges of bits against single bits, on every range across
    /// four words.
    #[test]
    fn bit_writes_agree_with_single_bits() {
        for start in 0..256 {
            for end in start..=256 {
                let mut bits = [0x5555_5555_5555_5555u64; 4];
                set_bits(&mut bits, start..end);
                let mut cleared = bits;
                clear_bits(&mut cleared, start..end);
                for i in 0..256 {
                    let (w, b) = (i >> 6, 1u64 << (i & 63));
                    let inside = (start..end).contains(&i);
                    assert_eq!(
                        bits[w] & b != 0,
                        inside || i % 2 == 0,
                        "set {start}..{end}: {i}"
                    );
                    assert_eq!(
                        cleared[w] & b != 0,
                        !inside && i % 2 == 0,
                        "clear {start}..{end}: {i}"
                    );
                }
            }
        }
    }

    /// `all_bits` and `no_bits` against a bit-by-bit reading, on every range of a
    /// pattern of ones and zeros across four words.
    #[test]
    fn bit_tests_agree_with_single_bits() {
        let mut bits = vec![0u64; 4];
        set_bits(&mut bits, 5..70);
        set_bits(&mut bits, 128..192);
        set_bits(&mut bits, 200..201);
        let bit = |i: usize| bits[i >> 6] & (1 << (i & 63)) != 0;
        for start in 0..256 {
            for end in start..=256 {
                assert_eq!(
                    all_bits(&bits, start..end),
                    (start..end).all(bit),
                    "{start}..{end}"
                );
                assert_eq!(
                    no_bits(&bits, start..end),
                    !(start..end).any(bit),
                    "{start}..{end}"
                );
            }
        }
    }

    /// The words of a range and their masks hold exactly the range's bits, on every
    /// range across four words.
    #[test]
    fn range_words_cover_the_range() {
        for start in 0..256 {
            for end in start..=256 {
                let mut bits = vec![0u64; 4];
                for (w, mask) in range_words(start..end) {
                    assert_eq!(bits[w] & mask, 0, "{start}..{end}: word {w} twice");
                    bits[w] |= mask;
                }
                let mut want = vec![0u64; 4];
                set_bits(&mut want, start..end);
                assert_eq!(bits, want, "{start}..{end}");
            }
        }
    }

    #[test]
    fn runs_and_sequences_across_blocks() {
        for len in [0usize, 1, 31, 32, 33, 64, 100] {
            for cut in [0usize, 1, 5, 31, 32, 33, 63, 70, 99] {
                // `len` values, the run (or sequence) broken at `cut` when inside.
                let same: Vec<u32> = (0..len).map(|j| if j == cut { 5 } else { 9 }).collect();
                // (Counting up through u32::MAX and 0; a break is one more than due.)
                let seq: Vec<u32> = (0..len as u32)
                    .map(|j| (u32::MAX - 40).wrapping_add(j + (j as usize == cut) as u32))
                    .collect();
                let want = cut.min(len);
                assert_eq!(run_of(&same, 9), want, "run_of, len {len}, cut {cut}");
                assert_eq!(
                    sequence_len(&seq, u32::MAX - 40),
                    want,
                    "sequence_len, len {len}, cut {cut}"
                );
            }
        }
    }

    #[test]
    fn bit_ranges_across_words() {
        for (start, end) in [
            (0, 0),
            (3, 3),
            (0, 64),
            (5, 70),
            (63, 65),
            (64, 192),
            (10, 200),
        ] {
            let mut bits = vec![0u64; 4];
            set_bits(&mut bits, start..end);
            for i in 0..256 {
                let set = bits[i >> 6] & (1 << (i & 63)) != 0;
                assert_eq!(set, (start..end).contains(&i), "{start}..{end}: bit {i}");
            }
            assert!(all_bits(&bits, start..end));
            if start > 0 {
                assert!(!all_bits(&bits, start - 1..end));
            }
            assert!(!all_bits(&bits, start..end + 1));
        }
    }
}
