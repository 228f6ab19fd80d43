//! Hand-written, single-threaded native implementations of the benchmark workloads, the
//! baselines the engine is measured against in the same benchmark run. Each returns the
//! workload's checksum (and B2 its step count).

/// B1's state: C00 of an L x L square in a grid with a border of zeros (a missing
/// neighbour sends nothing), and a second buffer; ready for [`b1_run`].
pub struct B1 {
    l: usize,
    cur: Vec<i16>,
    next: Vec<i16>,
}

/// Sets up B1 on an L x L square.
pub fn b1_setup(l: usize) -> B1 {
    let w = l + 2;
    let mut cur = vec![0i16; w * w];
    for x in 0..l {
        for y in 0..l {
            cur[(x + 1) * w + y + 1] =
                (((x as u64 * l as u64 + y as u64) * 7919) % 32749 + 1) as i16;
        }
    }
    let next = cur.clone();
    B1 { l, cur, next }
}

/// Runs B1 for S steps: the sum of C00. What an agent sends is its C00 after the update,
/// so one array holds both; step 1 reads nothing. The inner loop has no branches and
/// vectorises; the two buffers take turns.
pub fn b1_run(s: &mut B1, steps: usize) -> u64 {
    let (l, w) = (s.l, s.l + 2);
    // Step 1 reads only zeros: nothing changes.
    for _ in 1..steps {
        for x in 1..=l {
            let row = x * w;
            let (up, mid, down) = (
                &s.cur[row - w..row],
                &s.cur[row..row + w],
                &s.cur[row + w..row + 2 * w],
            );
            let out = &mut s.next[row + 1..row + 1 + l];
            for (((o, m), u), d) in out
                .iter_mut()
                .zip(mid.windows(3))
                .zip(&up[1..])
                .zip(&down[1..])
            {
                *o = m[0].max(m[1]).max(m[2]).max(*u).max(*d);
            }
        }
        std::mem::swap(&mut s.cur, &mut s.next);
    }
    s.cur.iter().map(|&v| v as u64).sum()
}

/// B1 maxflood on an L x L square for S steps: the sum of C00.
pub fn b1(l: usize, steps: usize) -> u64 {
    b1_run(&mut b1_setup(l), steps)
}

/// B2's agents and occupancy grid, ready for [`b2_run`].
pub struct B2 {
    h: usize,
    /// Agents as (x, y), x-major and bottom up within a column (the generation order,
    /// which falling preserves: agents of a column never pass each other).
    agents: Vec<(u32, u32)>,
    /// Occupancy, `x * h + y`.
    occ: Vec<bool>,
}

/// Sets up B2 on a W x H box.
pub fn b2_setup(w: usize, h: usize) -> B2 {
    let agents: Vec<(u32, u32)> = crate::workloads::b2_cells(w as u64, h as u64)
        .into_iter()
        .map(|(x, y)| (x as u32, y as u32))
        .collect();
    let mut occ = vec![false; w * h];
    for &(x, y) in &agents {
        occ[x as usize * h + y as usize] = true;
    }
    B2 { h, agents, occ }
}

/// Runs B2 until a step without a move: (steps, checksum). Each step visits every agent
/// once: it falls when the cell below was empty at the start of the step (agents are
/// visited bottom up, so the agent just below may already have left its cell: that cell
/// still counts as occupied).
pub fn b2_run(s: &mut B2) -> (u64, u64) {
    let mut steps = 1;
    while b2_step(s) {
        steps += 1;
    }
    (steps, b2_sum(s))
}

/// One step of B2: whether an agent moved.
pub fn b2_step(s: &mut B2) -> bool {
    let h = s.h;
    let mut moved = false;
    // The cell the previous agent left this step.
    let mut left = usize::MAX;
    for a in s.agents.iter_mut() {
        let cell = a.0 as usize * h + a.1 as usize;
        if a.1 > 0 && !s.occ[cell - 1] && left != cell - 1 {
            s.occ[cell] = false;
            s.occ[cell - 1] = true;
            a.1 -= 1;
            moved = true;
            left = cell;
        } else {
            left = usize::MAX;
        }
    }
    moved
}

/// B2's checksum of the agents' current positions.
pub fn b2_sum(s: &B2) -> u64 {
    s.agents
        .iter()
        .map(|&(x, y)| x as u64 * 100003 + y as u64)
        .sum()
}

/// B2 gravity on a W x H box until a step without a move: (steps, checksum).
pub fn b2(w: usize, h: usize) -> (u64, u64) {
    b2_run(&mut b2_setup(w, h))
}

/// B3's states for an L x L square with k rules, ready for [`b3_run`].
pub fn b3_setup(l: usize, k: usize) -> Vec<u16> {
    (0..l * l).map(|i| ((i / l + i % l) % k) as u16).collect()
}

/// Runs B3 for S steps: the sum of the state numbers.
pub fn b3_run(s: &mut [u16], k: usize, steps: usize) -> u64 {
    let k = k as u16;
    for _ in 0..steps {
        for v in s.iter_mut() {
            let next = *v + 1;
            *v = if next == k { 0 } else { next };
        }
    }
    s.iter().map(|&v| v as u64).sum()
}

/// B3 on an L x L square with k rules for S steps: the sum of the state numbers.
pub fn b3(l: usize, k: usize, steps: usize) -> u64 {
    b3_run(&mut b3_setup(l, k), k, steps)
}

#[cfg(test)]
mod tests {
    #[test]
    fn reference_checksums() {
        assert_eq!(super::b1(30, 10), 28364701);
        assert_eq!(super::b1(100, 50), 327428190);
        assert_eq!(super::b2(30, 30), (26, 411013639));
        assert_eq!(super::b2(100, 100), (86, 14720785869));
        assert_eq!(super::b2(316, 316), (238, 473921339434));
        assert_eq!(super::b3(30, 7, 10), 2704);
        assert_eq!(super::b3(100, 256, 5), 1040000);
    }
}
