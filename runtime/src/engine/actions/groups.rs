//! Step 3 of the actions for carried groups ([`Act::move_groups`]): the rigid groups that
//! move, their offsets, those blocked and those that would collide, decided over flat
//! arrays (groups by their roots, members counted into one list) with the marks of the
//! moves (`alone.rs`), and the moves made as the moves alone are.

use super::alone::{slot, MoveScratch, Targets};
use super::moves::{Among, Spares};
use super::*;

/// The moving groups of a step, in the order of their roots (a group's root: the least
/// index among its members, in [`Among`]'s order), each with its members in index order.
struct Groups {
    /// Per group, where its members start in `members` (one more entry: the end).
    starts: Vec<u32>,
    members: Vec<u32>,
    /// Per root (by its index among the agents): its group, or `NONE`.
    by_root: Vec<u32>,
}

const NONE: u32 = u32::MAX;

/// The chunks' lists as one, in order, in the first one's allocation.
fn joined<T: Copy>(parts: Vec<Vec<T>>) -> Vec<T> {
    let mut parts = parts.into_iter();
    let mut all = parts.next().unwrap_or_default();
    for p in parts {
        all.extend_from_slice(&p);
    }
    all
}

/// A chunk's part of [`Groups::of`]: its groups' starts, and the members (root, agent)
/// of groups whose roots lie in earlier chunks.
type Placed = (Vec<u32>, Vec<(u32, u32)>);

/// A mover, its target and the target's slot code.
pub(super) type Mover = (u32, [i32; 3], u32);

impl Groups {
    /// The groups (`root`: per index, its group's root) with a member that asks to move
    /// (or whose rules asked for different moves). Per chunk of indices (on the pool when
    /// there are threads; `th`), each chunk counting and placing the members of the
    /// groups whose roots are its own; a member whose root lies in an earlier chunk (a
    /// root is its group's least index) is listed, and counted and placed after, in
    /// order. The same for any split.
    fn of(among: &Among, root: &[u32], spares: &mut Spares, th: &Threads) -> Groups {
        let m = among.len();
        let (par, size, _) = th.chunks(m);
        let moving = |i: usize| {
            let it = among.intent_at(i);
            it.mv.is_some() || it.mv_bad
        };
        // 1. Per root: whether its group moves (in `group`, for now).
        let mut group = spares.u32s(m, 0);
        let items: Vec<(usize, &mut [u32])> = group.chunks_mut(size).enumerate().collect();
        let across: Vec<Vec<u32>> = map_on(par, items, |(c, mine)| {
            let lo = c * size;
            let mut across = Vec::new();
            for i in (lo..lo + mine.len()).filter(|&i| moving(i)) {
                match root[i] as usize {
                    r if r >= lo => mine[r - lo] = 1,
                    r => across.push(r as u32),
                }
            }
            across
        });
        for r in across.into_iter().flatten() {
            group[r as usize] = 1;
        }
        // 2. Per root: its members counted; per chunk, its groups and their members.
        let mut count = spares.u32s(m, 0);
        let flag = &group;
        let items: Vec<(usize, &mut [u32])> = count.chunks_mut(size).enumerate().collect();
        let parts: Vec<(Vec<u32>, u32, u32)> = map_on(par, items, |(c, mine)| {
            let lo = c * size;
            let (mut across, mut members) = (Vec::new(), 0);
            for i in lo..lo + mine.len() {
                match root[i] as usize {
                    r if flag[r] == 0 => {}
                    r if r >= lo => {
                        mine[r - lo] += 1;
                        members += 1;
                    }
                    r => across.push(r as u32),
                }
            }
            let groups = mine.iter().filter(|&&n| n > 0).count() as u32;
            (across, groups, members)
        });
        // Per chunk: where its groups and their members start.
        let mut totals: Vec<(u32, u32)> = parts.iter().map(|p| (p.1, p.2)).collect();
        for &r in parts.iter().flat_map(|p| &p.0) {
            count[r as usize] += 1;
            totals[r as usize / size].1 += 1;
        }
        let mut bases = Vec::with_capacity(totals.len());
        let (mut g0, mut m0) = (0u32, 0u32);
        for &(g, n) in &totals {
            bases.push((g0, m0));
            (g0, m0) = (g0 + g, m0 + n);
        }
        // 3. Per chunk: its roots' groups and first places, its members placed (but those
        // of roots in earlier chunks, listed).
        let mut at = spares.u32s(m, 0);
        let mut members = spares.u32s(m0 as usize, 0);
        let mut rest: &mut [u32] = &mut members;
        let mut slices = Vec::with_capacity(totals.len());
        for &(_, n) in &totals {
            let (mine, after) = std::mem::take(&mut rest).split_at_mut(n as usize);
            slices.push(mine);
            rest = after;
        }
        let counts = &count;
        let items: Vec<_> = (group.chunks_mut(size).zip(at.chunks_mut(size)))
            .zip(slices.into_iter().zip(bases))
            .enumerate()
            .collect();
        let placed: Vec<Placed> = map_on(par, items, |(c, ((group, at), (slots, (g0, m0))))| {
            let lo = c * size;
            let mut starts = Vec::new();
            let (mut g, mut next) = (g0, m0);
            for (k, &n) in counts[lo..lo + group.len()].iter().enumerate() {
                group[k] = NONE;
                if n > 0 {
                    group[k] = g;
                    at[k] = next;
                    starts.push(next);
                    (g, next) = (g + 1, next + n);
                }
            }
            let mut across = Vec::new();
            for i in lo..lo + group.len() {
                match root[i] as usize {
                    r if counts[r] == 0 => {}
                    r if r >= lo => {
                        slots[(at[r - lo] - m0) as usize] = among.id(i);
                        at[r - lo] += 1;
                    }
                    r => across.push((r as u32, among.id(i))),
                }
            }
            (starts, across)
        });
        let mut starts = Vec::with_capacity(g0 as usize + 1);
        for (s, across) in &placed {
            starts.extend_from_slice(s);
            for &(r, a) in across {
                members[at[r as usize] as usize] = a;
                at[r as usize] += 1;
            }
        }
        starts.push(m0);
        spares.keep_u32s(at);
        spares.keep_u32s(count);
        Groups {
            starts,
            members,
            by_root: group,
        }
    }

    /// Keeps the lists for a later step.
    fn keep(self, spares: &mut Spares) {
        spares.keep_u32s(self.members);
        spares.keep_u32s(self.by_root);
    }

    /// The group of mover `a` (`root` as for [`Groups::of`]).
    fn of_mover(&self, among: &Among, root: &[u32], a: u32) -> u32 {
        let i = among.local(a).expect("a mover is among them");
        self.by_root[root[i as usize] as usize]
    }

    fn count(&self) -> usize {
        self.starts.len() - 1
    }

    fn members(&self, g: usize) -> &[u32] {
        &self.members[self.starts[g] as usize..self.starts[g + 1] as usize]
    }
}

impl Act<'_> {
    /// Step 3 for the rigid groups (`root`: per index among the agents, its group's root):
    /// a group with a member asking to move moves by that offset when its members agree
    /// (else it stays, with a record when they ask for different ones), unless an agent
    /// of it would leave the universe or collide (cancelling every group involved, round
    /// after round, as [`Act::move_alone`] does). Returns the moves (agent, target, the
    /// target's slot code) in agent order, and the movers cancelled by collisions (agent,
    /// the target's slot code); the marks of the moves (`sc`) keep the targets of both
    /// claimed, for the caller to clear.
    pub(super) fn move_groups(
        &mut self,
        among: &Among,
        root: &[u32],
        (sc, spares): (&mut MoveScratch, &mut Spares),
        rep: &mut StepReport,
    ) -> (Vec<Mover>, Vec<(u32, u32)>) {
        let groups = Groups::of(among, root, spares, self.threads);
        // The groups' offsets, in the order of their roots, per chunk of groups (on the
        // pool when there are threads): a group whose members ask for different moves
        // stays (noted), as does a group whose move would take an agent out of the
        // universe (noted after every group's conflict, as they are recorded).
        let (lat, cap) = (&*self.lat, self.opts.records_per_step);
        let (par, size, chunks) = self.threads.chunks(groups.count());
        let parts = map_on(par, (0..chunks).collect(), |c| {
            let gs = c * size..((c + 1) * size).min(groups.count());
            let mut off = Vec::with_capacity(gs.len());
            let (mut conflicts, mut blocked) = (Notes::default(), Notes::default());
            for g in gs {
                let ms = groups.members(g);
                let (mut o, mut bad, mut differ) = (None, false, false);
                for &a in ms {
                    let it = among.intent(a);
                    bad |= it.mv_bad;
                    match (o, it.mv) {
                        (None, p) => o = p,
                        (Some(q), Some(p)) if q != p => differ = true,
                        _ => {}
                    }
                }
                if differ && !bad {
                    let msg = || {
                        format!(
                            "the rigid group of agents {} is asked for different moves by its members; it does not move",
                            lat.ids_text(ms)
                        )
                    };
                    conflicts.push(cap, (RecordKind::GroupConflict, ms.to_vec()), msg);
                }
                if bad || differ {
                    o = None;
                }
                if let Some(d) = o {
                    let out = |&&m: &&u32| lat.moved(lat.pos[m as usize], d).is_none();
                    if let Some(&m) = ms.iter().find(out) {
                        o = None;
                        let msg = || {
                            format!("agent {} cannot move by {}: the target cell is blocked; its group does not move", lat.label(m), lat.cell_text(d))
                        };
                        blocked.push(cap, (RecordKind::MoveBlocked, ms.to_vec()), msg);
                    }
                }
                off.push(o);
            }
            (off, conflicts, blocked)
        });
        let mut off: Vec<Option<[i32; 3]>> = Vec::with_capacity(groups.count());
        let mut blocked = Vec::new();
        for (o, conflicts, b) in parts {
            off.extend(o);
            self.record_notes(conflicts.list, rep);
            blocked.extend(b.list);
        }
        self.record_notes(blocked, rep);
        // The movers, group by group, with their targets and the targets' slot codes,
        // claimed; per chunk of the members (on the pool when there are threads).
        sc.size(self.lat.cells.slots(), self.lat.len());
        let all = &groups.members[..];
        let (par, size, chunks) = self.threads.chunks(all.len());
        let shared = par.is_some();
        let (lat, marks, offsets) = (&*self.lat, &*sc, &off[..]);
        // (The first chunk's list in the allocation of the last step's movers.)
        let items = (0..chunks)
            .map(|c| {
                (
                    c,
                    if c == 0 {
                        std::mem::take(&mut spares.movers)
                    } else {
                        Vec::new()
                    },
                )
            })
            .collect();
        let parts: Vec<(Vec<Mover>, Vec<[i32; 3]>)> = map_on(par, items, |(c, mut live)| {
            let (lo, hi) = (c * size, ((c + 1) * size).min(all.len()));
            // (The group of the member at `lo`, then of each in turn.)
            let mut g = groups.starts.partition_point(|&s| s as usize <= lo) - 1;
            live.clear();
            live.reserve(hi - lo);
            let mut outside = Vec::new();
            for (i, &a) in all.iter().enumerate().take(hi).skip(lo) {
                while groups.starts[g + 1] as usize <= i {
                    g += 1;
                }
                if let Some(d) = offsets[g] {
                    let p = lat.pos[a as usize];
                    let t = [p[0] + d[0], p[1] + d[1], p[2] + d[2]];
                    let code = lat.cells.code(t);
                    marks.claim(a, slot(code), shared);
                    live.push((a, t, code));
                    if code == NO_SLOT {
                        outside.push(t);
                    }
                }
            }
            (live, outside)
        });
        // Collisions: the first round over every mover, per chunk (movers per target off
        // the grid counted first).
        let mut count: FxHashMap<[i32; 3], u32> = FxHashMap::default();
        for &t in parts.iter().flat_map(|p| &p.1) {
            *count.entry(t).or_insert(0) += 1;
        }
        let parts: Vec<Vec<Mover>> = parts.into_iter().map(|p| p.0).collect();
        let collides = |&(_, t, c): &Mover| match slot(c) {
            Some(s) => {
                marks.claimed_twice(s)
                    || (lat.cells.filled_slot(s) && !marks.moving(lat.cells.at_slot(s)))
            }
            None => count[&t] > 1 || lat.cells.get(t).is_some_and(|b| !marks.moving(b)),
        };
        let rounds: Vec<Vec<([i32; 3], u32)>> = map_on(par, parts.iter().collect(), |live| {
            (live.iter().filter(|m| collides(m)))
                .map(|&(a, t, _)| (t, a))
                .collect()
        });
        let mut live: Vec<Mover> = joined(parts);
        let round: Vec<([i32; 3], u32)> = joined(rounds);
        let mut cancelled = Vec::new();
        if !round.is_empty() {
            let groups_root = (among, &groups, root);
            self.cancel_group_collisions(round, groups_root, &live, (&mut off, &*sc), rep);
            // The moves of the groups left, per chunk of movers (on the pool when there
            // are threads); the claims of the others cleared (every mover that claimed
            // their targets is cancelled too).
            let (par, size, _) = self.threads.chunks(live.len());
            let off = &off;
            let parts = map_on(par, live.chunks(size).collect(), |ms: &[Mover]| {
                let moves = |m: &&Mover| off[groups.of_mover(among, root, m.0) as usize].is_some();
                let (kept, gone): (Vec<Mover>, Vec<Mover>) = ms.iter().partition(moves);
                (
                    kept,
                    gone.iter().map(|&(a, _, c)| (a, c)).collect::<Vec<_>>(),
                )
            });
            live.clear();
            for (kept, gone) in parts {
                live.extend(kept);
                for &(_, c) in &gone {
                    if let Some(s) = slot(c) {
                        sc.unmark(s);
                    }
                }
                cancelled.extend(gone);
            }
        }
        live.sort_unstable_by_key(|m| m.0);
        groups.keep(spares);
        (live, cancelled)
    }

    /// The collision rounds of the groups, from the first round's movers that would
    /// collide (`round`: target and mover, in the movers' order): one record per cell
    /// where agents would meet, naming them all, round by round in the order of the
    /// cells; every group with a mover there stays (its `off` cleared). A later round
    /// looks only at the movers whose targets the members of the groups cancelled in the
    /// round before stand on.
    fn cancel_group_collisions(
        &mut self,
        mut round: Vec<([i32; 3], u32)>,
        (among, groups, root): (&Among, &Groups, &[u32]),
        live: &[Mover],
        (off, marks): (&mut [Option<[i32; 3]>], &MoveScratch),
        rep: &mut StepReport,
    ) {
        let group_of = |a: u32| groups.of_mover(among, root, a);
        let targets = Targets::of(self.lat, live.iter().map(|&(a, t, _)| (a, t)));
        while !round.is_empty() {
            // Agents that stay: not moving from the start, or in a group cancelled before.
            let stays = |s: u32| !marks.moving(s) || off[group_of(s) as usize].is_none();
            let movers = self.record_collisions(&mut round, stays, rep);
            let mut now: Vec<usize> = Vec::new();
            for a in movers {
                let g = group_of(a) as usize;
                if off[g].take().is_some() {
                    now.push(g);
                }
            }
            // The next round: the movers whose targets those cancelled now stand on.
            round.clear();
            for &g in &now {
                for &a in groups.members(g) {
                    let p = self.lat.pos[a as usize];
                    if let Some(m) = (targets.at(self.lat, marks, p))
                        .filter(|&m| off[group_of(m) as usize].is_some())
                    {
                        round.push((p, m));
                    }
                }
            }
        }
    }
}
