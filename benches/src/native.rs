//! Hand-written, single-threaded native implementations of the benchmark workloads, the
//! baselines the engine is measured against in the same benchmark run. Each returns the
//! workload's checksum (and B2 its step count).

/// B1 maxflood on an L x L square for S steps: the sum of C00. What an agent sends is its
/// C00 after the update, so one array holds both; step 1 reads nothing. The grids carry a
/// border of zeros (a missing neighbour sends nothing), so the inner loop has no branches
/// and vectorises, and two buffers take turns.
pub fn b1(l: usize, steps: usize) -> u64 {
    let w = l + 2;
    let mut cur = vec![0i16; w * w];
    for x in 0..l {
        for y in 0..l {
            cur[(x + 1) * w + y + 1] =
                (((x as u64 * l as u64 + y as u64) * 7919) % 32749 + 1) as i16;
        }
    }
    let mut next = cur.clone();
    // Step 1 reads only zeros: nothing changes.
    for _ in 1..steps {
        for x in 1..=l {
            let row = x * w;
            let (up, mid, down) = (
                &cur[row - w..row],
                &cur[row..row + w],
                &cur[row + w..row + 2 * w],
            );
            let out = &mut next[row + 1..row + 1 + l];
            for (((o, m), u), d) in out
                .iter_mut()
                .zip(mid.windows(3))
                .zip(&up[1..])
                .zip(&down[1..])
            {
                *o = m[0].max(m[1]).max(m[2]).max(*u).max(*d);
            }
        }
        std::mem::swap(&mut cur, &mut next);
    }
    cur.iter().map(|&v| v as u64).sum()
}

/// B2 gravity on a W x H box until a step without a move: (steps, checksum).
pub fn b2(w: usize, h: usize) -> (u64, u64) {
    let mut occ = vec![false; w * h];
    for (x, y) in crate::workloads::b2_cells(w as u64, h as u64) {
        occ[x as usize * h + y as usize] = true;
    }
    let mut steps = 0;
    loop {
        steps += 1;
        let mut moved = false;
        for x in 0..w {
            let col = &mut occ[x * h..(x + 1) * h];
            // Bottom up: an agent falls when the cell below was empty at the start of the
            // step; the cell it leaves stays "occupied at the start" for the one above.
            let mut below_was_empty = false;
            for y in 0..h {
                let here = col[y];
                if here && y > 0 && below_was_empty {
                    col[y - 1] = true;
                    col[y] = false;
                    moved = true;
                }
                below_was_empty = !here;
            }
        }
        if !moved {
            break;
        }
    }
    let mut sum = 0u64;
    for x in 0..w {
        for y in 0..h {
            if occ[x * h + y] {
                sum += x as u64 * 100003 + y as u64;
            }
        }
    }
    (steps, sum)
}

/// B3 on an L x L square with k rules for S steps: the sum of the state numbers.
pub fn b3(l: usize, k: usize, steps: usize) -> u64 {
    let mut s: Vec<u16> = (0..l * l).map(|i| ((i / l + i % l) % k) as u16).collect();
    for _ in 0..steps {
        for v in s.iter_mut() {
            *v = if *v as usize + 1 == k { 0 } else { *v + 1 };
        }
    }
    s.iter().map(|&v| v as u64).sum()
}

#[cfg(test)]
mod tests {
    #[test]
    fn reference_checksums() {
        assert_eq!(super::b1(30, 10), 28364701);
        assert_eq!(super::b1(100, 50), 327428190);
        assert_eq!(super::b2(30, 30), (26, 411013639));
        assert_eq!(super::b2(100, 100), (86, 14720785869));
        assert_eq!(super::b3(30, 7, 10), 2704);
        assert_eq!(super::b3(100, 256, 5), 1040000);
    }
}
