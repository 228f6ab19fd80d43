//! The plan: what a program allows, decided once when the engine is made, from the program
//! alone. Every fast path beside the evaluator for one agent is listed here; the phases ask
//! the plan (`self.plan`) and do not derive it again. Some paths also depend on the step
//! (whether states changed, whether a trace is kept): those conditions are in the last
//! column's code, named where they are tested.
//!
//! | path | applies when | falls back to | test that guards it |
//! |---|---|---|---|
//! | state-only rules (`trivial`) | a rule's precondition is only its state filter (or nothing): agents in that state execute it without evaluating (`dispatch.rs`, `cand_single`) | evaluating preconditions (`select.rs`) | `differential.rs` `optimisations_agree_with_reference` (chains of state-only rules), `themes_agree_with_reference_*` |
//! | preconditions over runs (`pre_columns`) | every op of the precondition is one the column interpreter runs: `batch::column_pre` translates it into `batch::PreStep`s, which `batch::batch_pre` runs (`E`/`F` at a literal offset of one step as the neighbour pattern it equals, at any other literal offset as one bit of the grid per agent, `Lattice::cells_filled`; the test of the agent's state against the rule's state filter left out, with its conjunction: the dispatch passed it; an op it cannot run makes no column program, so none is met mid-run). A run of agents with one rule to test goes together, with the agents next to them whose lists are one rule of the same column program (`pre_class`: the rules of states that alternate among the agents, `SA` falls and becomes `SB` and back, test the same); agents whose lists have several rules, all run so (or state-only), at most 32 of one priority, and runs of one rule shorter than 16 among them, go list by list over windows of agents (`select::eval_window`) | `eval_pre` one agent at a time | `optimisations_agree_with_reference` (preconditions over runs, runs longer than a batch, `E`/`F` of one step in a bounded universe in 2D and 3D; the bouncing example's lists of five rules and `E`/`F` at diagonals and two steps in a bounded universe; several rules of one priority true together in 3D; a rule per state falling and turning its agents to the other state, their states mixed in long runs and short ones; rules of two states testing different cells mixed one by one) |
//! | priorities (`any_prio`, `prio_offsets`) | no rule reads `P`, `L` or `Q`: the plain selection (`select_plain`); with literal `L`/`Q` offsets, priorities are resolved only where read | `select_with_priorities` over every agent | `semantics.rs` priority tests, `optimisations_agree_with_reference` (priority chains) |
//! | no actions (`acting` = `Nothing`) | no rule moves, swaps, attaches or sets a state: the actions phase is skipped | `actions.rs` | `engine_agrees_with_reference_*` |
//! | plain moves (`acting` = `PlainMoves`, `plain_moves`) | every acting rule only moves by a literal, non-zero offset: movers are collected without intents (`actions.rs`), and a mover without bonds moves alone (`alone.rs`, `Act::move_alone`) | intents per agent and `detach_move_attach` | `optimisations_agree_with_reference` (programs of plain moves only, single-agent moves) |
//! | moves at once (`plain_step`) | every acting rule only moves one step, all in one direction, and in this step no mover is bonded: movers found and moved in two passes over chunks of agents, on the pool (`moves.rs`, `plain_moves_at_once`), each that stands on the grid away from its rim into its target when that is empty as it is tried; also, in any program, a step whose moves (collected with the other actions: rules that move and set the state) are all one step in one direction and whose movers have no bonds (`move_list`) | `move_alone` for the movers left (at the rim, after the grid is made again with room ahead when that pays; target filled); for all when one is bonded (then not tried for 16 steps, nor after a step where most movers were blocked) | `differential.rs` `skipping_agrees_with_reference`, `the_cell_index_follows_the_agents`, `threads_give_the_same_results`; `optimisations_agree_with_reference` and `threads_join_chunks_in_order` (rules that fall or walk and set the state, in a bounded universe and out of the input's box) |
//! | state hops (`acting` = `States`, `direct_bits`) | every acting rule only sets a state: runs of agents in one state take its hop at once (`dispatch.rs`) | `set_state_at_once` per agent | `optimisations_agree_with_reference` (chains of state-only rules taken as hops) |
//! | states of rules that move (`moving_bits`) | a rule moves and sets the state, and neither swaps nor attaches: an agent executing it alone takes its new state while the actions are collected, in the chunk's second pass (no action reads states), rather than after the moves | step 5, `Act::set_states` (several rules, other actions) | `optimisations_agree_with_reference` and `threads_join_chunks_in_order` (a rule per state falling and turning its agents to the other state) |
//! | literal offsets (`literal_offsets`) | an offset has no counter in it: its value is known once | the offset evaluated per agent | `engine_agrees_with_reference_*` |
//! | calculations over runs (`post_columns`) | no calculation of the rule reads an external counter or a message from any direction: `batch::column_post` translates the postcondition into `batch::PostStep`s (chains of in-place `max`/`min` found then), which `batch::run_batch` runs over runs of agents (with `fast_calc` for the most frequent ones); any instruction it does not know makes no column program | `run_post` one agent at a time | `optimisations_agree_with_reference` (runs calculating together, chains of in-place max/min, saturation and division by zero inside runs) |
//! | one in-place add (`masked_add`) | one to four rules calculate or send, and the only calculation of each adds the same literal to the same counter in place (`C00 - C00 0001`); in a step without a list of executing agents, no agent executing several rules, no trace: each chunk adds to the counter of every agent whose entry is one of those rules in one masked pass over the column (`batch::masked_add`), when no result saturates | runs of agents (`run_batch`) | `differential.rs` `optimisations_agree_with_reference` (one rule counting down beside rules that do not calculate, saturation), `threads_join_chunks_in_order` (gravity) |
//! | no calculations (`any_computes`, `computes`) | no rule calculates or sends: the calculation phase is skipped; per rule, agents of rules that do not compute are passed over | `calc.rs` | `engine_agrees_with_reference_*` |
//! | skipping quiet agents (`reads`, `activity.rs`) | an agent that had no valid rule at its last evaluation is evaluated again only when something it reads changed: its own state, counters, bonds or inbox, or a cell at an offset some precondition reads (`reads`: occupancy, states, counters), known here; agents in a state with a rule whose offset depends on a counter (`Reads::unbounded`) are evaluated at every step; no skipping with priority terms, `Skip::Off`, or when more than an eighth of the agents are woken | every agent evaluated (`select_plain` and the dense phases) | `differential.rs` every generated case with `Skip::Eager` and `Skip::Off`, `skipping_agrees_with_reference` |
//! | messages left with their senders (`defer`) | numeric slots are used, no text message, and no rule moves or swaps: sends stay in the outboxes and are read through the plan of senders (`Pending` in lattice.rs, `post.rs`) | copying every message into its recipient's inbox (`post::deliver`) | `optimisations_agree_with_reference` (messages left with their senders, stale outboxes, sends to all and to one direction), `threads_join_chunks_in_order` |

use super::*;

/// See the module's text.
pub(super) struct Plan {
    /// Per rule: its precondition is only its state filter (or nothing).
    pub(super) trivial: Vec<bool>,
    /// Per rule: its precondition as the column interpreter runs it over a run of agents
    /// ([`batch_pre`]), when it can.
    pub(super) pre_columns: Vec<Option<ColumnPre>>,
    /// Per rule: the first rule whose column program is the same as its own (itself
    /// when none before is, or it has none). Agents whose lists are one rule each, of one
    /// class, are evaluated together: the rules of states that alternate among the agents
    /// (`SA` falls and becomes `SB`, `SB` falls and becomes `SA`) test the same.
    pub(super) pre_class: Vec<u32>,
    /// Some rule reads neighbours' priorities.
    pub(super) any_prio: bool,
    /// The offsets at which `L`/`Q` terms read priorities, when none depends on a counter
    /// (an agent's priority is then read only by its neighbours and by the agents at these
    /// offsets backwards); `None` when one does.
    pub(super) prio_offsets: Option<Vec<[i32; 3]>>,
    /// Per rule: it has a move, swap, attachment or state action.
    pub(super) has_actions: Vec<bool>,
    /// What the rules' actions are, taken together.
    pub(super) acting: Acting,
    /// Per rule whose only action is a move by an offset without counters (not zero):
    /// that offset.
    pub(super) plain_moves: Vec<Option<[i32; 3]>>,
    /// When every rule with an action only moves, all by one step in one direction: that
    /// offset and its direction index (the moves of a step can then be made at once).
    pub(super) plain_step: Option<([i32; 3], usize)>,
    /// Per rule, and one more entry for none: it only moves by a literal offset.
    pub(super) plain_mask: Vec<bool>,
    /// Per rule whose only action sets the state: that state pattern as [`pat_bits`].
    pub(super) direct_bits: Vec<Option<(u64, u64)>>,
    /// Per rule that sets the state: that state pattern as [`pat_bits`].
    pub(super) state_bits: Vec<Option<(u64, u64)>>,
    /// Per rule that moves and sets the state, and neither swaps nor attaches: that state
    /// pattern as [`pat_bits`] (set as the actions are collected: no action reads states).
    pub(super) moving_bits: Vec<Option<(u64, u64)>>,
    /// Per entry of the program's offsets: its value when it has no counter in it.
    pub(super) literal_offsets: Vec<Option<[i32; 3]>>,
    /// Per rule: its calculations as the column interpreter runs them over a run of
    /// agents ([`run_batch`]), when it can (no external counters).
    pub(super) post_columns: Vec<Option<ColumnPost>>,
    /// When one to four rules calculate or send, and the only calculation of each adds one
    /// literal to one counter in place (`C00 - C00 0001`; a rule per state counting down):
    /// those rules (the last repeated to make four), the counter and what is added.
    pub(super) masked_add: Option<([u32; 4], u8, i32)>,
    /// Some rule calculates or sends.
    pub(super) any_computes: bool,
    /// Per rule: it calculates or sends.
    pub(super) computes: Vec<bool>,
    /// Messages are left where their senders wrote them (see `Pending` in lattice.rs)
    /// instead of copied into inboxes: numeric slots are used, no rule moves or swaps, and
    /// no rule uses texts. The outboxes then have one more column per slot, for sends to
    /// all directions.
    pub(super) defer: bool,
    /// What a step can change in the lattice (what `--strict` keeps to undo a step).
    pub(super) writes: Writes,
    /// What the preconditions read around an agent (for skipping quiet agents).
    pub(super) reads: Reads,
}

/// What the rules' preconditions read beyond the agent's own state, counters and inbox,
/// taken together over all rules: the offsets of the cells whose occupancy, occupant's
/// state or occupant's counters some precondition reads (none is `[0, 0, 0]`), whether one
/// reads the agent's own bonds, and per rule whether an offset depends on a counter (the
/// cells it reads are then not known in advance). Priorities are not listed: an agent
/// without a valid rule has priority 0 whatever its neighbours' priorities.
#[derive(Debug, Clone, Default, PartialEq)]
pub(super) struct Reads {
    pub(super) occupancy: Vec<[i32; 3]>,
    pub(super) states: Vec<[i32; 3]>,
    pub(super) counters: Vec<[i32; 3]>,
    pub(super) bonds: bool,
    pub(super) unbounded: Vec<bool>,
    /// The same offsets backwards: where the readers of a cell stand.
    pub(super) back: ReadsBack,
}

/// Per kind of read, the offsets from a cell to the agents that read it ([`Back`]).
#[derive(Debug, Clone, Default, PartialEq)]
pub(super) struct ReadsBack {
    pub(super) occupancy: Vec<Back>,
    pub(super) states: Vec<Back>,
    pub(super) counters: Vec<Back>,
}

/// An offset from a cell to an agent that reads it, and its direction index when it is one
/// step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Back {
    pub(super) off: [i32; 3],
    pub(super) dir: Option<usize>,
}

impl Back {
    fn of(read: &[[i32; 3]], dim: latticesim_vm::model::Dim) -> Vec<Back> {
        (read.iter())
            .map(|o| {
                let off = [-o[0], -o[1], -o[2]];
                let dir = (0..dim.dirs()).find(|&d| Dir::ALL[d].offset() == off);
                Back { off, dir }
            })
            .collect()
    }
}

impl Reads {
    /// The reads of `prog`'s preconditions.
    pub(super) fn of(prog: &Program) -> Reads {
        let mut r = Reads {
            unbounded: vec![false; prog.rules.len()],
            ..Reads::default()
        };
        fn add(set: &mut Vec<[i32; 3]>, o: [i32; 3]) {
            if o != [0, 0, 0] && !set.contains(&o) {
                set.push(o);
            }
        }
        for (k, rule) in prog.rules.iter().enumerate() {
            for op in &prog.code[rule.pre.start as usize..rule.pre.end as usize] {
                let (off, state, counter) = match *op {
                    Op::Nbr { mask, .. } => {
                        for d in (0..prog.dim.dirs()).filter(|d| mask & (1 << d) != 0) {
                            add(&mut r.occupancy, Dir::ALL[d].offset());
                        }
                        continue;
                    }
                    Op::Att { .. } => {
                        r.bonds = true;
                        continue;
                    }
                    Op::Empty { off }
                    | Op::Filled { off }
                    | Op::Less { off }
                    | Op::LessEq { off } => (off, false, false),
                    Op::RState { off, .. } => (off, true, false),
                    Op::RCmp { off, .. } => (off, false, true),
                    _ => continue,
                };
                match literal(&prog.offsets[off as usize]) {
                    Some(o) => {
                        add(&mut r.occupancy, o);
                        if state {
                            add(&mut r.states, o);
                        }
                        if counter {
                            add(&mut r.counters, o);
                        }
                    }
                    None => r.unbounded[k] = true,
                }
            }
        }
        r.back = ReadsBack {
            occupancy: Back::of(&r.occupancy, prog.dim),
            states: Back::of(&r.states, prog.dim),
            counters: Back::of(&r.counters, prog.dim),
        };
        r
    }

    /// Some rule reads cells at offsets that depend on counters.
    pub(super) fn any_unbounded(&self) -> bool {
        self.unbounded.contains(&true)
    }
}

impl Plan {
    /// The plan of a program.
    pub(super) fn of(prog: &Program) -> Plan {
        let uses = prog.uses();
        let pre =
            |r: &latticesim_vm::RuleInfo| &prog.code[r.pre.start as usize..r.pre.end as usize];
        let post =
            |r: &latticesim_vm::RuleInfo| &prog.code[r.post.start as usize..r.post.end as usize];
        let trivial = (prog.rules.iter())
            .map(|r| match pre(r) {
                [Op::True {}] => true,
                [Op::State { pat }] => r.state_filter == Some(*pat),
                _ => false,
            })
            .collect();
        let pre_columns: Vec<Option<ColumnPre>> = (prog.rules.iter())
            .map(|r| column_pre(prog, pre(r), r.state_filter))
            .collect();
        let pre_class = (0..pre_columns.len())
            .map(|r| match &pre_columns[r] {
                Some(p) => pre_columns.iter().position(|q| q.as_ref() == Some(p)),
                None => None,
            })
            .enumerate()
            .map(|(r, first)| first.unwrap_or(r) as u32)
            .collect();
        let post_columns: Vec<_> = (prog.rules.iter())
            .map(|r| column_post(prog, post(r)))
            .collect();
        let has_actions: Vec<bool> = (prog.rules.iter())
            .map(|i| {
                i.moves.is_some()
                    || i.swaps.is_some()
                    || i.attaches.is_some()
                    || i.sets_state.is_some()
            })
            .collect();
        let plain_moves: Vec<Option<[i32; 3]>> = (prog.rules.iter())
            .map(|i| match (i.moves, i.sets_state, i.swaps, i.attaches) {
                (Some(o), None, None, None) => {
                    literal(&prog.offsets[o as usize]).filter(|&o| o != [0, 0, 0])
                }
                _ => None,
            })
            .collect();
        let direct_bits: Vec<Option<(u64, u64)>> = (prog.rules.iter())
            .map(|i| match (i.sets_state, i.moves, i.swaps, i.attaches) {
                (Some(p), None, None, None) => Some(pat_bits(&prog.pats[p as usize])),
                _ => None,
            })
            .collect();
        let state_bits: Vec<Option<(u64, u64)>> = (prog.rules.iter())
            .map(|i| i.sets_state.map(|p| pat_bits(&prog.pats[p as usize])))
            .collect();
        let moving_bits = (prog.rules.iter().zip(&state_bits))
            .map(|(i, &bits)| match (i.moves, i.swaps, i.attaches) {
                (Some(_), None, None) => bits,
                _ => None,
            })
            .collect();
        let prio_offsets = (prog.code.iter())
            .filter_map(|op| match op {
                Op::Less { off } | Op::LessEq { off } => Some(*off),
                _ => None,
            })
            .map(|off| literal(&prog.offsets[off as usize]))
            .collect();
        let acting = Acting::of(&has_actions, &plain_moves, &direct_bits);
        let mut offsets = plain_moves.iter().flatten();
        let plain_step = match (acting, offsets.next()) {
            (Acting::PlainMoves, Some(&o)) if offsets.all(|&p| p == o) => (0..prog.dim.dirs())
                .find(|&d| Dir::ALL[d].offset() == o)
                .map(|d| (o, d)),
            _ => None,
        };
        let plain_mask = (plain_moves.iter().map(Option::is_some))
            .chain([false])
            .collect();
        let masked_add = masked_add(prog, &post_columns);
        Plan {
            writes: writes(prog),
            reads: Reads::of(prog),
            plain_step,
            plain_mask,
            trivial,
            pre_columns,
            pre_class,
            any_prio: prog.rules.iter().any(|r| r.reads_priorities),
            prio_offsets,
            acting,
            has_actions,
            plain_moves,
            direct_bits,
            state_bits,
            moving_bits,
            literal_offsets: prog.offsets.iter().map(literal).collect(),
            post_columns,
            masked_add,
            any_computes: prog.rules.iter().any(|r| r.computes),
            computes: prog.rules.iter().map(|r| r.computes).collect(),
            defer: uses.slots != 0
                && !uses.texts
                && (prog.rules.iter()).all(|r| r.moves.is_none() && r.swaps.is_none()),
        }
    }
}

/// See [`Plan::masked_add`].
fn masked_add(prog: &Program, post_columns: &[Option<ColumnPost>]) -> Option<([u32; 4], u8, i32)> {
    let computing: Vec<usize> = (prog.rules.iter().enumerate())
        .filter(|(_, r)| r.computes)
        .map(|(r, _)| r)
        .collect();
    if computing.is_empty() || computing.len() > 4 {
        return None;
    }
    let add = |r: usize| match post_columns[r].as_deref()? {
        [PostStep::Calc {
            target: Target::Counter(c),
            op: op @ (CalcOp::Add | CalcOp::Sub),
            a: ColVal::Counter(ca),
            b: ColVal::Lit(v),
        }] if c == ca => match op {
            CalcOp::Add => Some((*c, *v)),
            _ => Some((*c, v.checked_neg()?)),
        },
        _ => None,
    };
    let (c, v) = add(computing[0])?;
    if computing.iter().any(|&r| add(r) != Some((c, v))) {
        return None;
    }
    // (Padded with the last: the test of an entry against the four stays one.)
    let rules = [0, 1, 2, 3].map(|i| computing[i.min(computing.len() - 1)] as u32);
    Some((rules, c, v))
}

/// What a step of `prog` can change in the lattice: positions (and bonds) when a rule moves
/// or swaps, states and bonds when a rule sets them, the counters calculations write, and
/// the inboxes when a rule sends.
fn writes(prog: &Program) -> Writes {
    let mut w = Writes::default();
    for r in &prog.rules {
        w.positions |= r.moves.is_some() || r.swaps.is_some();
        w.states |= r.sets_state.is_some();
        w.bonds |= r.attaches.is_some();
    }
    for op in &prog.code {
        match *op {
            Op::Calc { target, .. } => match target {
                Target::Counter(c) => w.counters |= 1 << c,
                Target::Msg { .. } => w.messages = true,
            },
            Op::Send { .. } => w.messages = true,
            _ => {}
        }
    }
    w
}

/// What a program's actions are, taken together: none, only moves by literal offsets
/// ([`Plan::plain_moves`]), only state changes ([`Plan::direct_bits`]), or others.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum Acting {
    Nothing,
    PlainMoves,
    States,
    Mixed,
}

impl Acting {
    pub(super) fn of(
        acts: &[bool],
        plain: &[Option<[i32; 3]>],
        direct: &[Option<(u64, u64)>],
    ) -> Acting {
        let acting = |kind: &dyn Fn(usize) -> bool| (0..acts.len()).all(|r| !acts[r] || kind(r));
        if !acts.contains(&true) {
            Acting::Nothing
        } else if acting(&|r| plain[r].is_some()) {
            Acting::PlainMoves
        } else if acting(&|r| direct[r].is_some()) {
            Acting::States
        } else {
            Acting::Mixed
        }
    }
}

/// A state pattern as (mask of the characters it sets, their values) over state keys.
pub(super) fn pat_bits(pat: &TextPat) -> (u64, u64) {
    let (mut mask, mut val) = ([0u8; 8], [0u8; 8]);
    for (i, p) in pat.iter().enumerate() {
        if let Some(p) = p {
            mask[i] = 0xff;
            val[i] = *p;
        }
    }
    (u64::from_le_bytes(mask), u64::from_le_bytes(val))
}
