//! The actions of a step: per agent, the combined intent of the rules it executes (a move
//! or swap, attachment letters, a new state), conflicts between them judged, states set,
//! and the movers handed to `moves`.

use super::*;

// The first half of the phase for agents whose actions are their own; the second half:
// moves alone, or carried groups and bonds; swaps.
mod alone;
mod collect;
mod groups;
mod moves;
mod swaps;
use alone::{AlonePart, MoveScratch};
use collect::CollectPart;

/// A record made while the actions are collected, recorded when the chunks are joined.
pub(super) type Note = (RecordKind, Vec<u32>, String);

/// The notes of one chunk, where many may be made (swaps in a crowd): a message is made
/// only for the chunk's first `cap` notes of each kind (see [`Options::records_per_step`]:
/// no later one can be among the step's first of its kind, which are kept).
#[derive(Default)]
pub(super) struct Notes {
    pub(super) list: Vec<Note>,
    made: [usize; RecordKind::ALL.len()],
}

impl Notes {
    pub(super) fn clear(&mut self) {
        self.list.clear();
        self.made = Default::default();
    }

    pub(super) fn push(
        &mut self,
        cap: Option<usize>,
        (kind, ids): (RecordKind, Vec<u32>),
        message: impl FnOnce() -> String,
    ) {
        let made = &mut self.made[kind as usize];
        *made += 1;
        let message = match cap {
            Some(c) if *made > c => String::new(),
            _ => message(),
        };
        self.list.push((kind, ids, message));
    }
}

/// The actions of a step, each list in agent order.
#[derive(Default)]
pub(super) struct Actions {
    /// Agents asked to move, by these offsets (never zero).
    pub(super) moves: Vec<(u32, [i32; 3])>,
    /// Agents whose rules asked for different moves: they do not move, nor their group.
    pub(super) blocked: Vec<u32>,
    /// State patterns (as [`pat_bits`]) to apply.
    pub(super) states: Vec<(u32, (u64, u64))>,
    pub(super) links: Vec<Link>,
    /// Agents whose rules asked for different swaps: they take part in no swap.
    pub(super) no_swap: Vec<u32>,
}

impl Actions {
    pub(super) fn clear(&mut self) {
        self.moves.clear();
        self.blocked.clear();
        self.states.clear();
        self.links.clear();
        self.no_swap.clear();
    }

    /// Moves the actions of `other` (of agents after this one's) to the end of this one.
    pub(super) fn append(&mut self, other: &mut Actions) {
        self.moves.append(&mut other.moves);
        self.blocked.append(&mut other.blocked);
        self.states.append(&mut other.states);
        self.links.append(&mut other.links);
        self.no_swap.append(&mut other.no_swap);
    }

    /// Adds the combined actions `it` of agent `a`.
    pub(super) fn add(&mut self, a: u32, it: &Intent) {
        if it.mv_bad {
            self.blocked.push(a);
        } else if let Some(o) = it.mv {
            self.moves.push((a, o));
        }
        if it.state.iter().any(Option::is_some) {
            self.states.push((a, pat_bits(&it.state)));
        }
        if it.swap.is_some() || it.letters.iter().any(|&l| l != AttachLetter::Keep) {
            self.links.push((a, it.letters, it.swap));
        }
        if it.swap_bad {
            self.no_swap.push(a);
        }
    }

    /// The moves and letters as one intent per agent, into `dense` (whose allocation is
    /// reused), per chunk of agents (on the pool when there are threads): each chunk
    /// takes its agents' entries of the lists (which are in agent order).
    pub(super) fn dense(&self, n: usize, mut dense: Vec<Intent>, th: &Threads) -> Vec<Intent> {
        debug_assert!(self.moves.is_sorted_by_key(|m| m.0));
        debug_assert!(self.blocked.is_sorted());
        debug_assert!(self.links.is_sorted_by_key(|l| l.0));
        // (Each chunk clears its own entries.)
        dense.resize(n, Intent::default());
        let (par, size, _) = th.chunks(n);
        let items: Vec<(usize, &mut [Intent])> = dense.chunks_mut(size).enumerate().collect();
        map_on(par, items, |(c, part)| {
            let lo = (c * size) as u32;
            let hi = lo + part.len() as u32;
            part.fill(Intent::default());
            for &(a, o) in within(&self.moves, (lo, hi), |m| m.0) {
                part[(a - lo) as usize].mv = Some(o);
            }
            for &a in within(&self.blocked, (lo, hi), |&a| a) {
                part[(a - lo) as usize].mv_bad = true;
            }
            for &(a, letters, _) in within(&self.links, (lo, hi), |l| l.0) {
                part[(a - lo) as usize].letters = letters;
            }
        });
        dense
    }
}

/// One chunk of [`Act::set_states`]: its new states, its agents' candidate lists and
/// states, and its first agent.
type StatesChunk<'a> = (
    &'a [(u32, (u64, u64))],
    &'a mut [ListId],
    &'a mut [[u8; 5]],
    usize,
);

/// The entries of `list` (in the order of `agent`) of agents `lo..hi`.
fn within<T>(list: &[T], (lo, hi): (u32, u32), agent: impl Fn(&T) -> u32) -> &[T] {
    let from = list.partition_point(|x| agent(x) < lo);
    let to = from + list[from..].partition_point(|x| agent(x) < hi);
    &list[from..to]
}

/// The combined actions of one agent's selected rules.
#[derive(Clone, Copy)]
pub(super) struct Intent {
    pub(super) mv: Option<[i32; 3]>,
    pub(super) mv_bad: bool,
    pub(super) swap: Option<Dir>,
    /// The rules ask for different swaps: the agent takes part in no swap.
    pub(super) swap_bad: bool,
    pub(super) letters: [AttachLetter; 6],
    pub(super) state: TextPat,
}

impl Default for Intent {
    fn default() -> Self {
        Intent {
            mv: None,
            mv_bad: false,
            swap: None,
            swap_bad: false,
            letters: [AttachLetter::Keep; 6],
            state: [None; 5],
        }
    }
}

/// What the actions phase keeps between steps: its lists (for their allocations), the
/// moving halves of `--static-first`'s first pass, and the marks of the moves.
#[derive(Default)]
pub(super) struct ActionBufs {
    /// The actions of the step being made.
    todo: Actions,
    /// With `--static-first`: the moving half of the combined intents of agents executing
    /// several rules, made in the static pass (where conflicts are judged over all of
    /// them), in agent order.
    later: Vec<(u32, Intent)>,
    /// Per-cell and per-agent marks for the moves (allocated at the first move).
    scratch: MoveScratch,
    /// What the actions changed, for the activity (see `activity.rs`).
    pub(super) changes: Changes,
    /// Steps for which [`Act::plain_moves_at_once`] is not tried (it did not hold lately),
    /// and its parts (for their allocations).
    pub(super) fused_pause: u32,
    fused: Vec<moves::FusedPart>,
    /// Steps for which the parts of plain moves on the pool note their bits rather than
    /// own words (more than an eighth of the movers crossed between parts lately).
    owned_pause: u32,
    /// Every rule with an action only moves (`Acting::PlainMoves`), and no agent held a
    /// bond when the engine was made ([`ActionBufs::new`]): no step makes one (a bond
    /// forms only where an `A` action asks, or again where one was), nor does going back
    /// to an earlier step of the run, so the moves need not look for bonded movers (B2 on
    /// two threads: 2 % of its time). (Bonds may go during such a run, so this is found
    /// before its first step, not at a later one.)
    pub(super) bondless: bool,
    /// The chunks' parts of [`Act::collect`] (for their allocations).
    collect: Vec<CollectPart>,
    /// The chunks' parts of [`Act::move_alone`] (for their allocations).
    alone: Vec<AlonePart>,
    /// The intents and partners of [`Act::detach_move_attach`] (for their allocations).
    intents: Vec<Intent>,
    partners: Vec<moves::Partners>,
    spares: moves::Spares,
}

impl ActionBufs {
    /// The buffers of an engine whose rules act as `acting` says, on `lat` as it is made.
    pub(super) fn new(acting: Acting, lat: &Lattice) -> ActionBufs {
        ActionBufs {
            bondless: acting == Acting::PlainMoves && lat.attach.iter().all(|&b| b == 0),
            ..ActionBufs::default()
        }
    }
}

/// The actions phase (paper step 2) with the parts of the engine it borrows: it reads the
/// program, its plan and the options; it writes the lattice, the agents' candidate lists
/// (when states change), the firing counts (`counts`, `active`: when agents hop to a
/// state's rule), the statistics and its buffers.
pub(super) struct Act<'e> {
    pub(super) prog: &'e Program,
    pub(super) plan: &'e Plan,
    pub(super) opts: Options,
    pub(super) lat: &'e mut Lattice,
    pub(super) dispatch: &'e mut Dispatch,
    pub(super) counts: &'e mut [u64],
    pub(super) active: &'e mut u64,
    pub(super) stats: &'e mut Stats,
    pub(super) bufs: &'e mut ActionBufs,
    /// The selection was decided by states alone (see [`Selector::by_state`]).
    pub(super) by_state: bool,
    /// How per-agent work is split.
    pub(super) threads: &'e Threads,
}

impl Act<'_> {
    pub(super) fn record(
        &mut self,
        rep: &mut StepReport,
        kind: RecordKind,
        ids: &[u32],
        message: String,
    ) {
        self.record_with(rep, kind, ids, |_| message);
    }

    /// [`Act::record`], the message made (from the lattice) only when the record is kept.
    pub(super) fn record_with(
        &mut self,
        rep: &mut StepReport,
        kind: RecordKind,
        ids: &[u32],
        message: impl FnOnce(&Lattice) -> String,
    ) {
        let cap = self.opts.records_per_step;
        record_with((self.stats, self.lat, cap), rep, kind, ids, message);
    }

    /// Records `notes` (made while the actions were decided), in their order.
    pub(super) fn record_notes(
        &mut self,
        notes: impl IntoIterator<Item = Note>,
        rep: &mut StepReport,
    ) {
        for (kind, ids, msg) in notes {
            self.record(rep, kind, &ids, msg);
        }
    }

    pub(super) fn rule_name(&self, r: u32) -> &str {
        &self.prog.rules[r as usize].name
    }

    /// Returns whether some agent's state changed without its selection following (see
    /// [`Dispatch::set_state_at_once`]).
    pub(super) fn all_actions(&mut self, sel: &mut Selection, rep: &mut StepReport) -> bool {
        sel.replaced.clear();
        if self.opts.static_first {
            let prog = &self.prog;
            let still: Vec<bool> = prog
                .rules
                .iter()
                .map(|r| r.moves.is_none() && r.swaps.is_none())
                .collect();
            let moving: Vec<bool> = still.iter().map(|s| !s).collect();
            self.bufs.later.clear();
            let first = self.actions(sel, rep, Some((&still, true)));
            first | self.actions(sel, rep, Some((&moving, false)))
        } else {
            self.actions(sel, rep, None)
        }
    }

    /// Paper step 2 for all selected rules, or with `--static-first` for the rules one
    /// pass takes (`pass`: which rules, and whether it is the first, static one). An agent
    /// executing several rules has its conflicts judged over all of them in the first pass
    /// ([`Act::split_intent`]), whose second half waits in `later` for the second.
    pub(super) fn actions(
        &mut self,
        sel: &mut Selection,
        rep: &mut StepReport,
        pass: Option<(&[bool], bool)>,
    ) -> bool {
        let every = pass.is_none();
        let n = self.lat.len();
        // Rules with nothing to do in this phase (only calculations and sends) are left out;
        // only the agents with something to do get an intent.
        if self.plan.acting == Acting::Nothing {
            return false;
        }
        let mut todo = std::mem::take(&mut self.bufs.todo);
        todo.clear();
        // An agent whose one rule only sets the state does so at once: no other action of
        // the step reads states. When the selection is decided by states alone, its entry
        // is also set at once to the rule of its new state (see `set_state_at_once`).
        // Traced, the states before are kept, and the changes reported after the moves
        // (where the trace has them) from the difference: the same path either way.
        let states_before = self.opts.trace.then(|| self.lat.state.clone());
        let keep = self.by_state && !self.plan.any_prio && !self.opts.static_first;
        let (mut changed, mut lookups) = (false, false);
        let simple = every && sel.many.is_empty();
        // When every rule's actions are a plain move (or none) and no agent executes several
        // rules, the step's actions are the list of moves, collected in one tight loop.
        let plain_moves = simple && self.plan.acting == Acting::PlainMoves;
        // When the selection is kept (decided by states alone) and every rule's actions
        // only set the state, each agent takes its candidate list's hop, known per list,
        // in one tight loop (`hop_run`); the loop stops at each agent whose list has no hop
        // yet (or whose new state's rules need evaluating), which goes the general way.
        let hops = simple && keep && self.plan.acting == Acting::States;
        if plain_moves && self.plain_moves_at_once(sel, rep) {
            // Plain moves change no state, bond or selection.
            self.bufs.todo = todo;
            return false;
        }
        if plain_moves {
            let plain = &self.plan.plain_moves;
            if sel.listed {
                for &a in &sel.list {
                    if let Some(&Some(o)) = plain.get(sel.one[a as usize] as usize) {
                        todo.moves.push((a, o));
                    }
                }
            } else {
                for (a, &r) in sel.one.iter().enumerate() {
                    if let Some(&Some(o)) = plain.get(r as usize) {
                        todo.moves.push((a as u32, o));
                    }
                }
            }
        } else if hops {
            let mut a = 0;
            loop {
                a = hop_run(
                    a,
                    (&mut self.dispatch.of, &mut self.lat.state, &mut sel.one),
                    &self.dispatch.hops,
                    &mut self.dispatch.hopped,
                );
                if a >= n {
                    break;
                }
                let r = sel.one[a];
                if r != NO_RULE {
                    let (c, l) = self.one_rule(&mut todo, a, r, keep, sel);
                    changed |= c;
                    lookups |= l;
                }
                a += 1;
            }
        }
        // Otherwise, with `--static-first`, every agent in turn (or every listed one: the
        // others execute nothing), for the rules of the pass; else in chunks.
        match pass {
            _ if plain_moves || hops => {}
            Some(pass) => (changed, lookups) = self.pass_actions(sel, &mut todo, pass, rep),
            None => (changed, lookups) = self.collect(sel, &mut todo, keep, rep),
        }
        self.dispatch.count_hops(self.counts, self.active);
        self.carry_out(todo, states_before, (changed, lookups), rep)
    }

    /// With `--static-first`, the actions of the rules of one pass (`rules`: which rules;
    /// `first`: whether it is the first, static one) of every agent in turn (or every
    /// listed one) into `todo`, as [`Act::actions`] says. Returns what
    /// [`Act::one_rule`] does, over the agents.
    fn pass_actions(
        &mut self,
        sel: &mut Selection,
        todo: &mut Actions,
        (rules, first): (&[bool], bool),
        rep: &mut StepReport,
    ) -> (bool, bool) {
        let (mut changed, mut lookups) = (false, false);
        let list = sel.listed.then(|| std::mem::take(&mut sel.list));
        let agents = list.as_ref().map_or(sel.one.len(), |l| l.len());
        let mut rs: Vec<u32> = Vec::new();
        for i in 0..agents {
            let a = list.as_ref().map_or(i, |l| l[i] as usize);
            let r = sel.one[a];
            if r == NO_RULE {
                continue;
            }
            if r & MANY == 0 {
                // One rule: nothing can conflict.
                if rules[r as usize] {
                    let (c, l) = self.one_rule(todo, a, r, false, sel);
                    changed |= c;
                    lookups |= l;
                }
                continue;
            }
            let acts = &self.plan.has_actions;
            rs.clear();
            let it = if first {
                rs.extend((sel.of(a).iter().copied()).filter(|&r| acts[r as usize]));
                let (now, later) = self.split_intent(a, &rs, rules, rep);
                self.bufs.later.push((a as u32, later));
                now
            } else {
                match self.bufs.later.binary_search_by_key(&(a as u32), |l| l.0) {
                    Ok(k) => self.bufs.later[k].1,
                    Err(_) => continue,
                }
            };
            todo.add(a as u32, &it);
        }
        if let Some(l) = list {
            sel.list = l;
        }
        (changed, lookups)
    }

    /// Carries out the actions collected in `todo`: moves (alone, or with bonds and
    /// groups), the new states in agent order (traced from the difference with
    /// `states_before`), swaps. `changed`, `lookups`: states were already set at once (and
    /// some had no known candidate list). Returns whether some state changed.
    pub(super) fn carry_out(
        &mut self,
        mut todo: Actions,
        states_before: Option<Vec<[u8; 5]>>,
        (mut changed, mut lookups): (bool, bool),
        rep: &mut StepReport,
    ) -> bool {
        let letters = todo
            .links
            .iter()
            .any(|l| l.1.iter().any(|&l| l != AttachLetter::Keep));
        let moves = !todo.moves.is_empty() || !todo.blocked.is_empty();
        // Bonds change only with attachment letters, or when an agent with bonds is asked
        // to move (a group is then more than one agent; otherwise every group is its
        // mover alone, and no bond is broken or made).
        let bonded = || {
            let attach = &self.lat.attach;
            (todo.moves.iter().map(|m| m.0))
                .chain(todo.blocked.iter().copied())
                .any(|a| attach[a as usize] != 0)
        };
        if letters || (moves && bonded()) {
            self.detach_move_attach(&todo, rep);
        } else if moves {
            self.move_list(&mut todo.moves, rep);
        }
        // 5. State updates, in agent order.
        let (c, l) = self.set_states(&todo.states);
        changed |= c;
        lookups |= l;
        if let Some(before) = states_before {
            for (a, (old, new)) in before.iter().zip(&self.lat.state).enumerate() {
                if old != new {
                    rep.trace.push(TraceEvent::State {
                        agent: a as u32,
                        from: text(old),
                        to: text(new),
                    });
                }
            }
        }
        // Agents whose state changed and whose rules the cache did not know look them up
        // again; any change of state ends the reuse of the selection.
        self.dispatch.lookups(lookups);
        if todo.links.iter().any(|l| l.2.is_some()) {
            self.swaps(&todo.links, &todo.no_swap, rep);
        }
        self.bufs.todo = todo;
        changed
    }

    /// Step 5: the new states `states` (agent and state pattern, as [`pat_bits`], in
    /// agent order, one per agent), per chunk of them (on the pool from 4,096, each chunk
    /// writing only its own agents' entries: from its first agent to the next chunk's
    /// first); the agents whose state changed noted in agent order. Returns whether some
    /// state changed, and whether some new state's rules must be looked up.
    fn set_states(&mut self, states: &[(u32, (u64, u64))]) -> (bool, bool) {
        let (par, size, chunks) = self.threads.chunks_from(states.len(), 4096);
        let n = self.lat.len();
        let (known, _, of) = self.dispatch.known();
        let on = self.bufs.changes.on;
        let one = |(states, of, state, lo): StatesChunk<'_>| {
            let mut noted = Vec::new();
            let (changed, lookups) =
                known.apply_all(states, (of, state, lo), on.then_some(&mut noted));
            (noted, changed, lookups)
        };
        let ordered = || states.windows(2).all(|w| w[0].0 < w[1].0);
        let parts = match par {
            Some(_) if chunks > 1 && ordered() => {
                let start = |c: usize| {
                    if c == 0 {
                        0
                    } else {
                        states[c * size].0 as usize
                    }
                };
                let bounds: Vec<usize> = (0..chunks).map(start).chain([n]).collect();
                let items: Vec<_> = (states.chunks(size))
                    .zip(collect::cut(of, &bounds))
                    .zip(collect::cut(&mut self.lat.state, &bounds))
                    .zip(bounds.iter().copied())
                    .map(|(((s, o), st), lo)| (s, o, st, lo))
                    .collect();
                map_on(par, items, one)
            }
            _ => vec![one((states, of, &mut self.lat.state[..], 0))],
        };
        let (mut changed, mut lookups) = (false, false);
        for (noted, c, l) in parts {
            changed |= c;
            lookups |= l;
            self.bufs.changes.states.extend_from_slice(&noted);
        }
        (changed, lookups)
    }

    /// The combined actions of agent `a` executing several rules `rs`: where they ask for
    /// different things, a conflict is noted in `notes` (to be recorded) and that part is
    /// left out.
    pub(super) fn combined_intent(&self, a: usize, rs: &[u32], notes: &mut Notes) -> Intent {
        let cap = self.opts.records_per_step;
        let nd = self.lat.dim.dirs();
        let mut it = Intent::default();
        let mut moves: Vec<(u32, [i32; 3])> = Vec::new();
        let mut swaps: Vec<(u32, Dir)> = Vec::new();
        let mut letters: Vec<Option<(u32, AttachLetter)>> = vec![None; nd];
        let mut conflict_dirs = 0u8;
        let mut chars: [Option<(u32, u8)>; 5] = [None; 5];
        let mut conflict_chars = 0u8;
        for &r in rs {
            let info = &self.prog.rules[r as usize];
            if let Some(off) = info.moves {
                let env = SelEnv {
                    lat: self.lat,
                    a: a as u32,
                    prio: None,
                };
                let o = latticesim_vm::eval::resolve(&self.prog.offsets[off as usize], &env);
                if o != [0, 0, 0] && !moves.iter().any(|m| m.1 == o) {
                    moves.push((r, o));
                }
            }
            if let Some(d) = info.swaps {
                if !swaps.iter().any(|s| s.1 == d) {
                    swaps.push((r, d));
                }
            }
            if let Some(l) = info.attaches {
                let ls = self.prog.letters[l as usize];
                for d in 0..nd {
                    match letters[d] {
                        None => letters[d] = Some((r, ls[d])),
                        Some((_, prev)) if prev != ls[d] => conflict_dirs |= 1 << d,
                        _ => {}
                    }
                }
            }
            if let Some(p) = info.sets_state {
                let pat = self.prog.pats[p as usize];
                for (i, c) in pat.iter().enumerate() {
                    if let Some(c) = *c {
                        match chars[i] {
                            None => chars[i] = Some((r, c)),
                            Some((_, prev)) if prev != c => conflict_chars |= 1 << i,
                            _ => {}
                        }
                    }
                }
            }
        }
        let a32 = a as u32;
        // Records name agents by their ids in the agents file.
        let id = self.lat.label(a32);
        match moves.len() {
            0 => {}
            1 => it.mv = Some(moves[0].1),
            _ => {
                it.mv_bad = true;
                let msg = || {
                    format!(
                        "agent {id} is asked for different moves by rules {}; its group does not move",
                        moves
                            .iter()
                            .map(|(r, o)| format!("`{}` ({},{})", self.rule_name(*r), o[0], o[1]))
                            .collect::<Vec<_>>()
                            .join(" and ")
                    )
                };
                notes.push(cap, (RecordKind::MoveConflict, vec![a32]), msg);
            }
        }
        match swaps.len() {
            0 => {}
            1 => it.swap = Some(swaps[0].1),
            _ => {
                it.swap_bad = true;
                let msg = || {
                    format!(
                        "agent {id} is asked to swap in different directions by rules {}; it takes part in no swap",
                        swaps.iter().map(|(r, d)| format!("`{}` (X{})", self.rule_name(*r), d.letter())).collect::<Vec<_>>().join(" and ")
                    )
                };
                notes.push(cap, (RecordKind::SwapConflict, vec![a32]), msg);
            }
        }
        for d in 0..nd {
            if conflict_dirs & (1 << d) != 0 {
                let msg = || {
                    format!(
                        "agent {id}'s rules give different attachment letters towards {}; that direction counts as `*`",
                        Dir::ALL[d].letter()
                    )
                };
                notes.push(cap, (RecordKind::AttachConflict, vec![a32]), msg);
            } else if let Some((_, l)) = letters[d] {
                it.letters[d] = l;
            }
        }
        for i in 0..5 {
            if conflict_chars & (1 << i) != 0 {
                let msg = || {
                    format!(
                        "agent {id}'s rules set character {} of the state differently; it is left unchanged",
                        i + 1
                    )
                };
                notes.push(cap, (RecordKind::StateConflict, vec![a32]), msg);
            } else if let Some((_, c)) = chars[i] {
                it.state[i] = Some(c);
            }
        }
        it
    }

    /// With `--static-first`: the combined intent of agent `a` executing rules `rs` (its
    /// conflicts judged and recorded over all of them), split into what its static rules
    /// (`still`) do in the first pass and what its moving rules do in the second.
    pub(super) fn split_intent(
        &mut self,
        a: usize,
        rs: &[u32],
        still: &[bool],
        rep: &mut StepReport,
    ) -> (Intent, Intent) {
        let mut notes = Notes::default();
        let all = self.combined_intent(a, rs, &mut notes);
        self.record_notes(notes.list, rep);
        let mut now = Intent::default();
        let mut later = Intent {
            mv: all.mv,
            mv_bad: all.mv_bad,
            swap: all.swap,
            swap_bad: all.swap_bad,
            ..Intent::default()
        };
        for &r in rs {
            let info = &self.prog.rules[r as usize];
            let half = if still[r as usize] {
                &mut now
            } else {
                &mut later
            };
            if let Some(l) = info.attaches {
                let ls = &self.prog.letters[l as usize];
                for d in 0..self.lat.dim.dirs() {
                    if ls[d] != AttachLetter::Keep {
                        half.letters[d] = all.letters[d];
                    }
                }
            }
            if let Some(p) = info.sets_state {
                for (i, c) in self.prog.pats[p as usize].iter().enumerate() {
                    if c.is_some() {
                        half.state[i] = all.state[i];
                    }
                }
            }
        }
        (now, later)
    }

    /// The actions of agent `a` executing rule `r` alone: a plain move listed, a state set
    /// at once (`keep` as for [`Dispatch::set_state_at_once`], whose answer is returned), or
    /// the rule's actions added to `todo`.
    #[inline(always)]
    pub(super) fn one_rule(
        &mut self,
        todo: &mut Actions,
        a: usize,
        r: u32,
        keep: bool,
        sel: &mut Selection,
    ) -> (bool, bool) {
        if let Some(o) = self.plan.plain_moves[r as usize] {
            todo.moves.push((a as u32, o));
        } else if self.plan.has_actions[r as usize] {
            match self.plan.direct_bits[r as usize] {
                Some(bits) => {
                    let before = self.lat.state[a];
                    let agent = (&mut self.lat.state[..], &mut sel.one[..], &mut sel.replaced);
                    let computes = &self.plan.computes;
                    let done =
                        (self.dispatch).set_state_at_once(agent, (a, r, bits), keep, computes);
                    if self.lat.state[a] != before {
                        self.bufs.changes.state(a as u32);
                    }
                    return done;
                }
                _ => self.add_rule_actions(todo, a as u32, r),
            }
        }
        (false, false)
    }

    /// Adds the move of agent `a` executing rule `r` alone (if any, and not by zero) to
    /// `todo`.
    #[inline(always)]
    pub(super) fn add_rule_move(&self, todo: &mut Actions, a: u32, r: u32) {
        let Some(off) = self.prog.rules[r as usize].moves else {
            return;
        };
        let o = match self.plan.literal_offsets[off as usize] {
            Some(o) => o,
            None => {
                let env = SelEnv {
                    lat: self.lat,
                    a,
                    prio: None,
                };
                latticesim_vm::eval::resolve(&self.prog.offsets[off as usize], &env)
            }
        };
        if o != [0, 0, 0] {
            todo.moves.push((a, o));
        }
    }

    /// Adds the actions of agent `a` executing rule `r` alone to `todo`.
    #[inline(always)]
    pub(super) fn add_rule_actions(&self, todo: &mut Actions, a: u32, r: u32) {
        let info = &self.prog.rules[r as usize];
        self.add_rule_move(todo, a, r);
        if info.attaches.is_some() || info.swaps.is_some() {
            let letters = info
                .attaches
                .map_or([AttachLetter::Keep; 6], |l| self.prog.letters[l as usize]);
            todo.links.push((a, letters, info.swaps));
        }
        if let Some(bits) = self.plan.state_bits[r as usize] {
            todo.states.push((a, bits));
        }
    }
}
