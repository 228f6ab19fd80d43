//! SEMANTICS.md sections 3 to 5, point by point, on small hand-made configurations. Every
//! expected outcome below was worked out by hand from the rules (see the comment on each).

mod common;

use latticesim_runtime::{Engine, Options, Order, StepReport};

fn engine_with(rules: &str, agents: &str, opts: Options) -> Engine {
    let (prog, lat) = common::compile(rules, agents);
    Engine::new(prog, lat, opts)
}

fn engine(rules: &str, agents: &str) -> Engine {
    engine_with(rules, agents, Options::default())
}

/// An engine per number of `threads` and per way of skipping (off, eager), with a label
/// naming both.
fn engines<'a>(
    rules: &'a str,
    agents: &'a str,
    threads: &'a [usize],
) -> impl Iterator<Item = (String, Engine)> + 'a {
    let skips = [
        latticesim_runtime::Skip::Off,
        latticesim_runtime::Skip::Eager,
    ];
    threads.iter().flat_map(move |&threads| {
        skips.into_iter().map(move |skip| {
            let opts = Options {
                threads,
                skip,
                ..Options::default()
            };
            let at = format!("{threads} threads, {skip:?}");
            (at, engine_with(rules, agents, opts))
        })
    })
}

fn pos(e: &Engine, a: usize) -> [i32; 3] {
    e.lat.pos[a]
}

fn xy(e: &Engine, a: usize) -> (i32, i32) {
    (e.lat.pos[a][0], e.lat.pos[a][1])
}

fn state(e: &Engine, a: usize) -> String {
    String::from_utf8_lossy(&e.lat.state[a]).into_owned()
}

fn ctr(e: &Engine, a: usize, i: usize) -> i32 {
    e.lat.counter(a as u32, i as u8)
}

fn kinds(r: &StepReport) -> Vec<&'static str> {
    r.records.iter().map(|r| r.kind.name()).collect()
}

// ---- Section 3: preconditions -------------------------------------------------------------

#[test]
fn reads_see_the_start_of_the_step() {
    // Two neighbours each copy the other's state: they swap states, not both end as one.
    let mut e = engine(
        "a\n1\nSAAAAA T1,0,BBBBB\nSBBBBB\nb\n1\nSBBBBB T-1,0,AAAAA\nSAAAAA\n",
        "0,0 SAAAAA\n1,0 SBBBBB\n",
    );
    e.step();
    assert_eq!(
        (state(&e, 0).as_str(), state(&e, 1).as_str()),
        ("BBBBB", "AAAAA")
    );
}

#[test]
fn neighbours_attachments_state_and_negated_groups() {
    // Agent 0 has north filled (agent 1), east empty, is attached north. Rule `yes` holds;
    // `no` fails on its negated group (N1*** is true inside it).
    let mut e = engine(
        "yes\n1\nN1*0* A1*** S*B*** !(E0,1)\nSXXXXX\nno\n2\n!(N1*** SAB***)\nSNNNNN\n",
        "0,0 SAB000 A1000\n0,1 A0001\n",
    );
    e.step();
    assert_eq!(state(&e, 0), "XXXXX");
    assert_eq!(
        state(&e, 1),
        "NNNNN",
        "agent 1 has no north neighbour, so `no` holds for it"
    );
}

#[test]
fn blocked_cells_are_neither_empty_nor_filled() {
    // Agent 0 stands on the universe's north edge: N with 0 fails, N with 1 fails, E fails,
    // F fails. Agent 1 is inside: its north is empty, so `n0` and `e` hold for it.
    let mut e = engine(
        "n0\n1\nN0***\nSN****\nn1\n1\nN1***\nS*X***\ne\n1\nE0,1\nS**E**\nf\n1\nF0,1\nS***F*\n",
        "U0,3,0,3\n0,3 S00000\n2,1 S11111\n",
    );
    let r = e.step();
    assert!(r.records.is_empty());
    assert_eq!(
        state(&e, 0),
        "00000",
        "nothing holds towards a blocked cell"
    );
    assert_eq!(state(&e, 1), "N1E11");
}

#[test]
fn messages_and_wildcard_directions() {
    // Step 1: agent 0 sends `hello` east and the number 7 in slot 02 to all. Step 2: agent 1
    // (east of 0) has the text from the west: `recv` and `any` (both priority 2) fire;
    // agent 2 (north of 0) has only the number, from the south: `num` fires.
    let mut e = engine(
        "send\n1\nSSEND0\nMEhello #*02 + 0007 0000 S00000\nrecv\n2\nMWhel** =#W02 0007\nSGOTIT\nany\n2\nM*hello\nC01 + 0001 0000\nnum\n1\n=#*02 0007 !MWh****\nSNUM00\n",
        "0,0 SSEND0\n1,0\n0,1\n",
    );
    e.step();
    assert_eq!(e.stats.sent, 5);
    assert_eq!(e.stats.delivered, 3);
    e.step();
    assert_eq!(state(&e, 1), "GOTIT");
    assert_eq!(ctr(&e, 1, 1), 1);
    assert_eq!(state(&e, 2), "NUM00");
    assert_eq!(ctr(&e, 2, 1), 0);
}

#[test]
fn no_message_matches_no_pattern_and_unwritten_slots_read_zero() {
    let mut e = engine("r\n1\n!M*a**** =#N01 0000 =#*08 0000\nSOK000\n", "0,0\n");
    e.step();
    assert_eq!(state(&e, 0), "OK000");
}

#[test]
fn offsets_with_counters_and_remote_terms() {
    // C00=2, C01=0: E by counters tests (2,0), empty; T tests agent 1 at (1,0) with a
    // wildcard; V reads agent 1's C03 = 5 < 6; W with #* (all zero) fails as 5 <= 0 is false.
    let mut e = engine(
        "r\n1\nEC00,C01 T1,0,AB*** V1,0,C03 0006 !W1,0,C03 #*01\nSOK000\n",
        "0,0 C00 2\n1,0 SABCDE C03 5\n",
    );
    e.step();
    assert_eq!(state(&e, 0), "OK000");
    assert_eq!(state(&e, 1), "ABCDE");
}

#[test]
fn priority_terms() {
    // Agent 1 (middle) has rule `hi` (3) only if its west neighbour's priority is smaller:
    // agent 0 runs `lo` (1) -> fixed at 1 < 3: holds. Agent 2 has no valid rule: priority 0.
    // `eq` on agent 0 needs the east neighbour <= 1: agent 1 ends at 3: fails, so agent 0
    // runs `lo`.
    let mut e = engine(
        "hi\n3\nSMID00 P*<** Q1,0\nSHI000\nlo\n1\nSLEFT0\nSLO000\neq\n2\nSLEFT0 P**=*\nSEQ000\n",
        "0,0 SLEFT0\n1,0 SMID00\n2,0 SNONE0\n",
    );
    let r = e.step();
    assert!(r.records.is_empty(), "{:?}", r.records);
    assert_eq!(state(&e, 0), "LO000");
    assert_eq!(state(&e, 1), "HI000");
}

#[test]
fn kleene_negated_priority_term_is_valid() {
    // `!P*<**`: in the first pass unknown, so valid. The west neighbour (agent 0) runs a rule
    // of priority 5 > 2, so `P*<**` is false and `!P*<**` true: agent 1 fires.
    let mut e = engine(
        "r\n2\nSB**** !P*<**\nSDONE0\nw\n5\nSA****\nSA2222\n",
        "0,0 SA0000\n1,0 SB0000\n",
    );
    e.step();
    assert_eq!(state(&e, 1), "DONE0");
}

#[test]
fn less_or_equal_needs_an_agent() {
    let mut e = engine("r\n1\nQ1,0\nSYES00\n", "0,0\n");
    let r = e.step();
    assert!(r.quiescent);
    assert_eq!(state(&e, 0), "00000");
}

#[test]
fn circular_priorities_are_removed_with_a_warning() {
    // Two agents each want the other's priority strictly smaller, at the same priority: a
    // circle. Both rules are removed; each falls to its lower rule `idle`.
    let mut e = engine(
        "top\n5\nL1,0\nSTOP00\ntop2\n5\nL-1,0\nSTOP00\nidle\n1\nS*****\nSIDLE0\n",
        "0,0\n1,0\n",
    );
    let r = e.step();
    assert_eq!(kinds(&r), vec!["circular-priority"]);
    assert_eq!(r.records[0].agents.len(), 2);
    assert_eq!(state(&e, 0), "IDLE0");
    assert_eq!(state(&e, 1), "IDLE0");
}

#[test]
fn chain_of_priorities_resolves_from_the_end() {
    // A line of three at one priority, each needing its east neighbour strictly smaller.
    // Agent 2 has an empty east (priority 0): fires. Agent 1 sees agent 2 fixed at 3: fails,
    // drops to 0. Agent 0 then sees agent 1 at 0: fires.
    let mut e = engine("r\n3\nP**<*\nSFIRED\n", "0,0\n1,0\n2,0\n");
    e.step();
    assert_eq!(
        (state(&e, 0), state(&e, 1), state(&e, 2)),
        ("FIRED".into(), "00000".into(), "FIRED".into())
    );
}

#[test]
fn rules_of_one_priority_execute_together_in_file_order() {
    let mut e = engine("a\n2\nS*****\nC00 + C00 0001\nb\n2\nS*****\nC00 * C00 0010\nc\n1\nS*****\nC00 + 0100 0000\n", "0,0 C00 1\n");
    e.step();
    assert_eq!(
        ctr(&e, 0, 0),
        20,
        "(1 + 1) * 10; `c` has lower priority and does not run"
    );
}

// ---- Section 4: postconditions ------------------------------------------------------------

#[test]
fn calculations_saturate_truncate_and_divide_by_zero() {
    let mut e = engine(
        "r\n1\nS*****\nC00 * C00 C00 C01 / -0007 0002 C02 M -0007 0002 C03 / C03 0000 C04 A C04 0003 C05 I C05 -0002\n",
        "0,0 C00 300 C03 9\n",
    );
    let r = e.step();
    assert_eq!(ctr(&e, 0, 0), 32767);
    assert_eq!(ctr(&e, 0, 1), -3);
    assert_eq!(ctr(&e, 0, 2), -1);
    assert_eq!(ctr(&e, 0, 3), 9, "division by zero leaves the target");
    assert_eq!(ctr(&e, 0, 4), 3);
    assert_eq!(ctr(&e, 0, 5), -2);
    assert_eq!(kinds(&r), vec!["saturation", "division-by-zero"]);
}

#[test]
fn external_counters_read_the_start_of_the_phase() {
    // Both agents add the other's C00 (read before either writes): 1+2 and 2+1, not 1+3.
    let mut e = engine(
        "r\n1\nS*****\nC00 + C00 1,0,C00\nl\n1\nSL****\nC00 + C00 C01,C02,C00\n",
        "0,0 C00 1\n1,0 SL0000 C00 2 C01 -1 C02 0\n",
    );
    let r = e.step();
    assert_eq!(ctr(&e, 0, 0), 3);
    // Agent 1 runs both rules: `r` reads (2,0), where no agent stands (an error, skipped);
    // `l` reads (C01,C02) = (-1,0), agent 0's C00 at the start of the phase: 2 + 1.
    assert_eq!(ctr(&e, 1, 0), 3);
    assert_eq!(kinds(&r), vec!["no-external-agent"]);
}

#[test]
fn missing_external_agent_is_an_error_and_skips() {
    let mut e = engine("r\n1\nS*****\nC00 + 0005 1,0,C00\n", "0,0 C00 1\n");
    let r = e.step();
    assert_eq!(kinds(&r), vec!["no-external-agent"]);
    assert_eq!(ctr(&e, 0, 0), 1);
}

#[test]
fn later_writes_to_a_slot_win_and_star_sends_everywhere() {
    // Agent 0 writes #E01 = 1, then #*01 = 2 (overwrites E), then #N01 = 3.
    let mut e = engine(
        "s\n1\nSS****\n#E01 + 0001 0000 #*01 + 0002 0000 #N01 + 0003 0000\nr\n1\nS0****\nC00 + #W01 #S01\n",
        "0,0 SS0000\n1,0\n0,1\n",
    );
    e.step();
    e.step();
    assert_eq!(ctr(&e, 1, 0), 2, "east neighbour got 2 from the west");
    assert_eq!(ctr(&e, 2, 0), 3, "north neighbour got 3 from the south");
    assert_eq!(e.stats.sent, 8, "two steps of four directions");
}

#[test]
fn move_offsets_read_counters_and_zero_is_no_move() {
    let mut e = engine("r\n1\nS0****\nPC00,C01 S1****\n", "0,0 C00 2 C01 -1\n5,5\n");
    e.step();
    assert_eq!(xy(&e, 0), (2, -1));
    assert_eq!(xy(&e, 1), (5, 5), "C00 = C01 = 0: P0,0 is no move");
    assert_eq!(e.stats.moves, 1);
}

// ---- Section 5: the step -------------------------------------------------------------------

#[test]
fn quiescence_ends_after_the_first_step_without_a_rule() {
    // Agent falls from y=2 to y=0 (two steps), the third step selects nothing.
    let mut e = engine(
        "fall\n1\nN***0 >C00 0000\nP0,-1 C00 - C00 0001\n",
        "U0,0,0,5\n0,2 C00 2\n",
    );
    assert!(!e.step().quiescent);
    assert!(!e.step().quiescent);
    assert!(e.step().quiescent);
    assert_eq!(e.stats.steps, 3);
    assert_eq!(xy(&e, 0), (0, 0));
}

#[test]
fn different_moves_of_one_agent_block_its_group() {
    let mut e = engine("a\n1\nS*****\nP1,0\nb\n1\nS*****\nP0,1\n", "0,0\n");
    let r = e.step();
    assert_eq!(kinds(&r), vec!["move-conflict"]);
    assert_eq!(xy(&e, 0), (0, 0));
}

#[test]
fn only_plus_carries_and_movers_without_a_move_letter_move_alone() {
    // Agent 0 moves north with `A**+*` (east letter +): carries agent 1 (east, bonded).
    // Agent 2 is bonded to agent 0's west with `*` on both ends: left behind, bond broken.
    let mut e = engine(
        "m\n1\nSM****\nP0,1 A**+*\n",
        "0,0 SM0000 A0110\n1,0 A0100\n-1,0 A0010\n",
    );
    e.step();
    assert_eq!(xy(&e, 0), (0, 1));
    assert_eq!(xy(&e, 1), (1, 1), "carried");
    assert_eq!(xy(&e, 2), (-1, 0), "left behind");
    assert_eq!(e.lat.attach[0], 0b0100, "still bonded east, west bond gone");
    assert_eq!(e.lat.attach[1], 0b0010);
    assert_eq!(e.lat.attach[2], 0);
}

#[test]
fn a_mover_without_an_attachment_action_moves_alone() {
    let mut e = engine("m\n1\nSM****\nP0,1\n", "0,0 SM0000 A0010\n1,0 A0100\n");
    e.step();
    assert_eq!(xy(&e, 0), (0, 1));
    assert_eq!(xy(&e, 1), (1, 0));
    assert_eq!((e.lat.attach[0], e.lat.attach[1]), (0, 0));
}

#[test]
fn bonds_of_agents_that_stay_survive() {
    // Nobody acts on the bond: both ends `*`, still adjacent: it re-forms.
    let mut e = engine("s\n1\nS*****\nSX****\n", "0,0 A0010\n1,0 A0100\n");
    e.step();
    assert_eq!((e.lat.attach[0], e.lat.attach[1]), (0b0100, 0b0010));
}

#[test]
fn attach_one_zero_and_refusal() {
    // Agent 0 says 1 towards east (agent 1) and north (agent 2); agent 2 says 0 towards
    // south: east bond forms, north refused with a warning. Agent 3 (west) was attached and
    // agent 0 says 0 west: detached.
    let mut e = engine(
        "a\n1\nSA****\nA101*\nz\n1\nSZ****\nA***0\n",
        "0,0 SA0000 A0100\n1,0\n0,1 SZ0000\n-1,0 A0010\n",
    );
    let r = e.step();
    assert_eq!(kinds(&r), vec!["attach-refused"]);
    assert_eq!(e.lat.attach[0], 0b0100, "east only");
    assert_eq!(e.lat.attach[1], 0b0010);
    assert_eq!(e.lat.attach[2], 0);
    assert_eq!(e.lat.attach[3], 0);
}

#[test]
fn blocked_targets_and_collisions_cancel_moves() {
    // Agent 0 at the east edge moves east: blocked. Agents 1 and 2 both move into (5,5):
    // collision, both cancelled, one record naming both. Agent 3 moves into the cell of a
    // staying agent 4: cancelled, one record naming both.
    let mut e = engine(
        "e\n1\nSE****\nP1,0\nn\n1\nSN****\nP0,1\ns\n1\nSS****\nP0,-1\nw\n1\nSW****\nP-1,0\n",
        "U0,9,0,9\n9,0 SE0000\n5,4 SN0000\n5,6 SS0000\n2,2 SW0000\n1,2\n",
    );
    let r = e.step();
    assert_eq!(
        kinds(&r),
        vec!["move-blocked", "move-collision", "move-collision"]
    );
    let agents = |i: usize| {
        let mut a: Vec<u32> = r.records[i].agents.iter().map(|a| a.0).collect();
        a.sort();
        a
    };
    assert_eq!((agents(1), agents(2)), (vec![3, 4], vec![1, 2]));
    assert!(
        r.records[2].message
            == "agents 1, 2 would meet on the cell (5,5); the moves of agents 1, 2 are cancelled",
        "{}",
        r.records[2].message
    );
    assert_eq!(xy(&e, 0), (9, 0));
    assert_eq!(xy(&e, 1), (5, 4));
    assert_eq!(xy(&e, 2), (5, 6));
    assert_eq!(xy(&e, 3), (2, 2));
}

#[test]
fn records_name_the_rules_executed_when_a_stayer_changes_state() {
    // Agent 0 (`go`) moves into the cell of agent 1, which stays and only changes its state
    // (`turn`, B to C): the collision names both rules, `go` (0) and `turn` (1), not the
    // rule of agent 1's new state (`back`, 2), with skipping or not, on one thread or two
    // (enough agents for the pool: a column of such pairs). Agent 0 takes its new state.
    let rules =
        "go\n1\nSA****\nP1,0 SB****\n\nturn\n1\nSB****\nSC****\n\nback\n1\nSC****\nSA****\n";
    // (An agent in state C, so that C's rules are known when agent 1 takes its state.)
    let mut agents: String = (0..1500)
        .map(|y| format!("0,{y} SA0000\n1,{y} SB0000\n"))
        .collect();
    agents += "9,-9 SC0000\n";
    for (at, mut e) in engines(rules, &agents, &[1, 2]) {
        let r = e.step();
        assert_eq!(r.records.len(), 1500, "{at}");
        for rec in &r.records {
            assert_eq!(rec.kind.name(), "move-collision");
            assert_eq!(rec.rules, vec![0, 1], "{at}: {}", rec.message);
        }
        assert_eq!(
            (state(&e, 0), state(&e, 1)),
            ("B0000".into(), "C0000".into())
        );
    }
}

#[test]
fn cancelled_moves_cascade() {
    // Agent 0 moves east into the cell agent 1 leaves; agent 1 moves east into a staying
    // agent 2: agent 1 is cancelled, so agent 0 now collides with agent 1 and is cancelled too.
    let mut e = engine("m\n1\nSM****\nP1,0\n", "0,0 SM0000\n1,0 SM0000\n2,0\n");
    let r = e.step();
    assert_eq!(kinds(&r), vec!["move-collision", "move-collision"]);
    assert_eq!((xy(&e, 0), xy(&e, 1)), ((0, 0), (1, 0)));
}

#[test]
fn exchanging_cells_by_moving_is_no_collision() {
    let mut e = engine(
        "e\n1\nSE****\nP1,0\nw\n1\nSW****\nP-1,0\n",
        "0,0 SE0000\n1,0 SW0000\n",
    );
    let r = e.step();
    assert!(r.records.is_empty());
    assert_eq!((xy(&e, 0), xy(&e, 1)), ((1, 0), (0, 0)));
}

#[test]
fn a_group_with_different_offsets_does_not_move() {
    let mut e = engine(
        "e\n1\nSE****\nP1,0 A**+*\nn\n1\nSN****\nP0,1 A*+**\n",
        "0,0 SE0000 A0010\n1,0 SN0000 A0100\n",
    );
    let r = e.step();
    assert_eq!(kinds(&r), vec!["group-conflict"]);
    assert_eq!((xy(&e, 0), xy(&e, 1)), ((0, 0), (1, 0)));
}

#[test]
fn swaps() {
    // 0 and 1 ask to swap with each other: one swap. 2 swaps north into 3 (3 does not ask).
    // 4 asks towards an empty cell. Bonds of swapped agents to others are dropped (5-1).
    let mut e = engine(
        "e\n1\nSE****\nXE\nw\n1\nSW****\nXW\nn\n1\nSN****\nXN\nx\n1\nSX****\nXS\n",
        "0,0 SE0000\n1,0 SW0000 A1000\n0,5 SN0000\n0,6\n9,9 SX0000\n1,1 A0001\n",
    );
    let r = e.step();
    assert_eq!(kinds(&r), vec!["swap-target"]);
    assert_eq!((xy(&e, 0), xy(&e, 1)), ((1, 0), (0, 0)));
    assert_eq!((xy(&e, 2), xy(&e, 3)), ((0, 6), (0, 5)));
    assert_eq!(e.stats.swaps, 2);
    assert_eq!((e.lat.attach[1], e.lat.attach[5]), (0, 0));
}

#[test]
fn swap_chains_are_all_cancelled_and_the_bond_between_stays() {
    // a-b, b-c, c-d: all three share agents: cancelled. Separately, bonded e and f swap and
    // stay bonded (the bond turns around).
    let mut e = engine(
        "x\n1\nSX****\nXE\nb\n1\nSB****\nXE A+***\n",
        "0,0 SX0000\n1,0 SX0000\n2,0 SX0000\n3,0\n0,5 SB0000 A0010\n1,5 A0100\n",
    );
    let r = e.step();
    assert_eq!(kinds(&r), vec!["swap-shared"; 3]);
    assert_eq!((xy(&e, 0), xy(&e, 1), xy(&e, 2)), ((0, 0), (1, 0), (2, 0)));
    assert_eq!((xy(&e, 4), xy(&e, 5)), ((1, 5), (0, 5)));
    assert_eq!((e.lat.attach[4], e.lat.attach[5]), (0b0010, 0b0100));
}

#[test]
fn messages_follow_the_agents_after_the_moves() {
    // Agent 0 moves east and sends north; it now stands at (1,0), so agent 1 at (1,1) gets
    // it (from the south) and agent 2 at (0,1) does not. A message east is dropped.
    let mut e = engine(
        "m\n1\nSM****\nP1,0 #N01 + 0042 0000 #E01 + 0001 0000\nr\n1\nS0**** >#S01 0000\nC00 + #S01 0000\n",
        "0,0 SM0000\n1,1\n0,1\n",
    );
    e.step();
    assert_eq!(e.stats.delivered, 1);
    assert_eq!(e.stats.dropped, 1);
    e.step();
    assert_eq!(ctr(&e, 1, 0), 42);
    assert_eq!(ctr(&e, 2, 0), 0);
}

#[test]
fn messages_first_delivers_before_moving() {
    let mut e = engine_with(
        "m\n1\nSM****\nP1,0 #N01 + 0042 0000\nr\n1\nS0**** >#S01 0000\nC00 + #S01 0000\n",
        "0,0 SM0000\n1,1\n0,1\n",
        Options {
            order: Order::MessagesFirst,
            ..Options::default()
        },
    );
    e.step();
    e.step();
    assert_eq!(
        ctr(&e, 2, 0),
        42,
        "delivered north of (0,0), before the move"
    );
    assert_eq!(ctr(&e, 1, 0), 0);
}

#[test]
fn static_first_detaches_before_the_movers_move() {
    // Agent 1 (static rule) detaches from agent 0 with A*0**; agent 0 moves north with `+`
    // towards east. Without --static-first the detach wins anyway (0 beats +) in one pass;
    // with it, the static pass runs first and the mover's pass sees no bond. Both: 1 stays.
    for static_first in [false, true] {
        let mut e = engine_with(
            "mv\n1\nSM****\nP0,1 A**+*\nst\n1\nSS****\nA*0**\n",
            "0,0 SM0000 A0010\n1,0 SS0000 A0100\n",
            Options {
                static_first,
                ..Options::default()
            },
        );
        e.step();
        assert_eq!((xy(&e, 0), xy(&e, 1)), ((0, 1), (1, 0)));
    }
    // What --static-first changes: a static agent saying 1 towards a cell a mover arrives
    // in. In one pass the mover arrives before bonds form: bonded. Static first: the static
    // pass finds the cell empty, and in the movers' pass the static agent says nothing.
    let rules = "mv\n1\nSM****\nP1,0\nst\n1\nSS****\nA*1**\n";
    let agents = "0,1 SM0000\n2,1 SS0000\n";
    let mut plain = engine_with(rules, agents, Options::default());
    plain.step();
    assert_eq!(xy(&plain, 0), (1, 1));
    assert_eq!((plain.lat.attach[0], plain.lat.attach[1]), (0b0100, 0b0010));
    let mut sf = engine_with(
        rules,
        agents,
        Options {
            static_first: true,
            ..Options::default()
        },
    );
    sf.step();
    assert_eq!(xy(&sf, 0), (1, 1));
    assert_eq!((sf.lat.attach[0], sf.lat.attach[1]), (0, 0));
}

#[test]
fn state_conflicts_leave_the_character() {
    let mut e = engine(
        "a\n1\nS*****\nSA*C**\nb\n1\nS*****\nSB*C**\n",
        "0,0 S00000\n",
    );
    let r = e.step();
    assert_eq!(kinds(&r), vec!["state-conflict"]);
    assert_eq!(state(&e, 0), "00C00");
}

// ---- 3D ------------------------------------------------------------------------------------

#[test]
fn three_d_moves_messages_and_neighbours() {
    // Agent 0 has an agent above (A direction): N****1*. It moves below (P0,0,-1) and sends
    // up with #A01; agent 1 above reads from below (#B01) in step 2 - but agent 0 moved away,
    // so the message goes to whatever is above (0,0,0) now: agent 1 at (0,0,1).
    let mut e = engine(
        "m\n1\nSM**** N****1*\nP0,0,-1 #A01 + 0007 0000\nr\n1\nS0**** >#B01 0000\nC00 + #B01 0000\n",
        "0,0,0 SM0000\n0,0,1\n",
    );
    e.step();
    assert_eq!(pos(&e, 0), [0, 0, -1]);
    assert_eq!(e.stats.dropped, 1, "(0,0,0) above (0,0,-1) is empty now");
    let mut e = engine(
        "m\n1\nSM**** N****1*\n#A01 + 0007 0000\nr\n1\nS0**** >#B01 0000\nC00 + #B01 0000\n",
        "0,0,0 SM0000\n0,0,1\n",
    );
    e.step();
    e.step();
    assert_eq!(ctr(&e, 1, 0), 7);
}

#[test]
fn three_d_rigid_group_moves_up() {
    let mut e = engine(
        "m\n1\nSM****\nP0,0,1 A****+*\n",
        "0,0,0 SM0000 A000010\n0,0,1 A000001\n",
    );
    e.step();
    assert_eq!(pos(&e, 0), [0, 0, 1]);
    assert_eq!(pos(&e, 1), [0, 0, 2]);
    assert_eq!((e.lat.attach[0], e.lat.attach[1]), (0b010000, 0b100000));
}

#[test]
fn different_attachment_letters_count_as_star() {
    // Two rules of agent 0 disagree about east (0 and +): an error, east counts as `*`, so
    // the bond to agent 1 (not moving) is removed and re-formed. North: both say 1, so agent
    // 0 attaches to agent 2.
    let mut e = engine(
        "a\n1\nSA****\nA1*0*\nb\n1\nSA****\nA1*+*\n",
        "0,0 SA0000 A0010\n1,0 A0100\n0,1\n",
    );
    let r = e.step();
    assert_eq!(kinds(&r), vec!["attach-conflict"]);
    assert_eq!(e.lat.attach[0], 0b0101, "north and east");
    assert_eq!(e.lat.attach[2], 0b1000);
}

#[test]
fn a_later_text_to_the_same_direction_overwrites() {
    // `a` sends `first` east, `b` (same priority, later in the file) sends `later` to all.
    let mut e = engine(
        "a\n1\nSS****\nMEfirst\nb\n1\nSS****\nM*later\nr\n1\nS0**** MWlater\nSGOT00\n",
        "0,0 SS0000\n1,0\n",
    );
    e.step();
    e.step();
    assert_eq!(state(&e, 1), "GOT00");
    assert_eq!(
        e.stats.sent, 8,
        "each step: four directions, east written twice but sent once"
    );
}

// ---- SEMANTICS 5.2: conflicts, under every option ---------------------------------------

/// The four combinations of `--order` and `--static-first`.
fn every_option() -> Vec<Options> {
    let mut v = Vec::new();
    for order in [Order::ActionsFirst, Order::MessagesFirst] {
        for static_first in [false, true] {
            v.push(Options {
                order,
                static_first,
                ..Options::default()
            });
        }
    }
    v
}

fn sorted_kinds(r: &StepReport) -> Vec<&'static str> {
    let mut k = kinds(r);
    k.sort();
    k
}

#[test]
fn a_swap_towards_an_agent_asked_for_different_swaps_is_cancelled() {
    // Issue 15's case: agent 1 (CCCCC) is asked by `an` and `aw` to swap north and west: a
    // swap-conflict, and it takes part in no swap; agent 0's `be` towards it (east) is
    // cancelled with a swap-target record. Nothing moves.
    for opts in every_option() {
        let mut e = engine_with(
            "an\n1\nSCCCCC\nXN\n\naw\n1\nSCCCCC\nXW\n\nbe\n1\nSBBBBB\nXE\n",
            "0,0 SBBBBB\n1,0 SCCCCC\n1,1 SDDDDD\n",
            opts,
        );
        let r = e.step();
        assert_eq!(
            sorted_kinds(&r),
            vec!["swap-conflict", "swap-target"],
            "{opts:?}"
        );
        assert_eq!((xy(&e, 0), xy(&e, 1), xy(&e, 2)), ((0, 0), (1, 0), (1, 1)));
        assert_eq!(e.stats.swaps, 0);
    }
}

#[test]
fn a_conflicted_agents_own_requests_block_nobody() {
    // Agent 1 asks for two swaps (east and west); its requests are dropped before pairing,
    // so agents 2 and 3, who ask to swap with each other, are judged without them and
    // swap, although one of 1's dropped requests pointed at 2.
    for opts in every_option() {
        let mut e = engine_with(
            "ae\n1\nSCCCCC\nXE\naw\n1\nSCCCCC\nXW\nb\n1\nSBBBBB\nXE\nd\n1\nSDDDDD\nXW\n",
            "0,0\n1,0 SCCCCC\n2,0 SBBBBB\n3,0 SDDDDD\n",
            opts,
        );
        let r = e.step();
        assert_eq!(sorted_kinds(&r), vec!["swap-conflict"], "{opts:?}");
        assert_eq!((xy(&e, 2), xy(&e, 3)), ((3, 0), (2, 0)), "{opts:?}");
        assert_eq!(xy(&e, 1), (1, 0));
        assert_eq!(e.stats.swaps, 1);
    }
}

#[test]
fn a_cancelled_request_towards_a_conflicted_agent_still_counts() {
    // Agent 2 asks for two swaps: no swap. Agent 1 asks to swap east, towards 2: cancelled
    // (swap-target), but it still counts as 1's request, so agent 0's request towards 1
    // shares agent 1 with it: swap-shared, cancelled too.
    for opts in every_option() {
        let mut e = engine_with(
            "a\n1\nSAAAAA\nXE\nb\n1\nSBBBBB\nXE\ncn\n1\nSCCCCC\nXN\ncs\n1\nSCCCCC\nXS\n",
            "0,0 SAAAAA\n1,0 SBBBBB\n2,0 SCCCCC\n2,1\n2,-1\n",
            opts,
        );
        let r = e.step();
        assert_eq!(
            sorted_kinds(&r),
            vec!["swap-conflict", "swap-shared", "swap-target"],
            "{opts:?}"
        );
        assert_eq!(e.stats.swaps, 0);
        assert_eq!((xy(&e, 0), xy(&e, 1), xy(&e, 2)), ((0, 0), (1, 0), (2, 0)));
    }
}

#[test]
fn static_first_judges_state_conflicts_over_all_rules() {
    // Issue 15's case: `st` (no move) sets AAAAA and `mv` moves east and sets BBBBB. Five
    // state-conflict records and the state stays XXXXX, with and without --static-first;
    // the move happens either way.
    for opts in every_option() {
        let mut e = engine_with(
            "st\n1\nSXXXXX\nSAAAAA\nmv\n1\nSXXXXX\nP1,0 SBBBBB\n",
            "0,0 SXXXXX\n",
            opts,
        );
        let r = e.step();
        assert_eq!(sorted_kinds(&r), vec!["state-conflict"; 5], "{opts:?}");
        assert_eq!(state(&e, 0), "XXXXX", "{opts:?}");
        assert_eq!(xy(&e, 0), (1, 0));
    }
}

#[test]
fn static_first_judges_attachment_conflicts_over_all_rules() {
    // `st` says 0 towards east, `mv` moves north with `+` towards east: different letters
    // for east, an attach-conflict, east counts as `*` in both passes, so agent 1 is not
    // carried (the bond is not rigid) and is not detached for good either: the bond is
    // removed and does not form again (1 is no longer adjacent). With or without the flag.
    for opts in every_option() {
        let mut e = engine_with(
            "st\n1\nSM****\nA**0*\nmv\n1\nSM****\nP0,1 A**+*\n",
            "0,0 SM0000 A0010\n1,0 A0100\n",
            opts,
        );
        let r = e.step();
        assert_eq!(sorted_kinds(&r), vec!["attach-conflict"], "{opts:?}");
        assert_eq!((xy(&e, 0), xy(&e, 1)), ((0, 1), (1, 0)), "{opts:?}");
        assert_eq!((e.lat.attach[0], e.lat.attach[1]), (0, 0), "{opts:?}");
    }
}

#[test]
fn static_first_keeps_agreeing_effects_of_both_passes() {
    // No conflict: `st` sets the first character, `mv` the second and moves; both take
    // effect with the flag (the static one first), and no record is made.
    for opts in every_option() {
        let mut e = engine_with(
            "st\n1\nSXXXXX\nSA****\nmv\n1\nSXXXXX\nP1,0 S*B***\n",
            "0,0 SXXXXX\n",
            opts,
        );
        let r = e.step();
        assert!(r.records.is_empty(), "{opts:?}: {:?}", kinds(&r));
        assert_eq!(state(&e, 0), "ABXXX");
        assert_eq!(xy(&e, 0), (1, 0));
    }
}

#[test]
fn different_moves_block_the_group_under_every_option() {
    // Agent 0's rules ask for two moves: a move-conflict, and its rigid group (with agent 1,
    // bonded by `+`) does not move.
    for opts in every_option() {
        let mut e = engine_with(
            "a\n1\nSM****\nP1,0 A+***\nb\n1\nSM****\nP0,-1\n",
            "0,0 SM0000 A1000\n0,1 A0001\n",
            opts,
        );
        let r = e.step();
        assert_eq!(sorted_kinds(&r), vec!["move-conflict"], "{opts:?}");
        assert_eq!((xy(&e, 0), xy(&e, 1)), ((0, 0), (0, 1)));
    }
}

// ---- --static-first and bonds between a static agent and a mover (docs/running.md) -----

fn with_static_first(static_first: bool) -> Options {
    Options {
        static_first,
        ..Options::default()
    }
}

#[test]
fn static_plus_carries_a_mover_without_a_letter_only_in_one_pass() {
    // Agent 1 (static, `A++++`) is bonded east of agent 0 (mover, no `A` action).
    // One pass: the bond's ends are `*` (0) and `+` (1): rigid, so 0 carries 1 north.
    // --static-first: in the static pass the bond is kept (nothing moves); in the movers'
    // pass 1's rule does not act, both ends are `*`: the bond is removed, 0 moves alone,
    // and it does not form again (0 is no longer beside 1).
    let rules = "mv\n1\nSM****\nP0,1\nst\n1\nSS****\nA++++\n";
    let agents = "0,0 SM0000 A0010\n1,0 SS0000 A0100\n";
    let mut one = engine_with(rules, agents, with_static_first(false));
    one.step();
    assert_eq!((xy(&one, 0), xy(&one, 1)), ((0, 1), (1, 1)));
    assert_eq!((one.lat.attach[0], one.lat.attach[1]), (0b0100, 0b0010));
    let mut two = engine_with(rules, agents, with_static_first(true));
    two.step();
    assert_eq!((xy(&two, 0), xy(&two, 1)), ((0, 1), (1, 0)));
    assert_eq!((two.lat.attach[0], two.lat.attach[1]), (0, 0));
}

#[test]
fn a_movers_own_plus_carries_a_static_agent_in_both() {
    // The mover says `+` towards the static agent: rigid in the movers' pass too, so the
    // static agent is carried with and without --static-first.
    for sf in [false, true] {
        let mut e = engine_with(
            "mv\n1\nSM****\nP0,1 A**+*\nst\n1\nSS****\nSST000\n",
            "0,0 SM0000 A0010\n1,0 SS0000 A0100\n",
            with_static_first(sf),
        );
        e.step();
        assert_eq!(
            (xy(&e, 0), xy(&e, 1)),
            ((0, 1), (1, 1)),
            "static-first {sf}"
        );
        assert_eq!(state(&e, 1), "ST000");
        assert_eq!((e.lat.attach[0], e.lat.attach[1]), (0b0100, 0b0010));
    }
}

#[test]
fn a_bond_of_letters_star_survives_when_the_agents_stay_beside() {
    // --static-first, the movers' pass: two bonded movers without `A` actions (both ends
    // `*`) both move north by their own rules: the bond is removed, and it forms again
    // because they are still beside each other in that direction.
    let mut e = engine_with(
        "mv\n1\nSM****\nP0,1\n",
        "0,0 SM0000 A0010\n1,0 SM0000 A0100\n",
        with_static_first(true),
    );
    e.step();
    assert_eq!((xy(&e, 0), xy(&e, 1)), ((0, 1), (1, 1)));
    assert_eq!((e.lat.attach[0], e.lat.attach[1]), (0b0100, 0b0010));
}

// ---- Records name the rules their agents executed ------------------------------------------

/// A state conflict names the two rules that set the state; a move collision the rules of
/// both movers; a mover meeting an agent at rest (which executed nothing) only the mover's
/// rule.
#[test]
fn records_name_the_rules_their_agents_executed() {
    let rules = "\
a\n1\nSAAAA0\nSB****\n\nb\n1\nSAAAA0\nSC****\n\n\
east\n1\nSEAST0\nP1,0\n\nwest\n1\nSWEST0\nP-1,0\n";
    let agents = "0,0 SAAAA0\n10,0 SEAST0\n12,0 SWEST0\n20,0 SEAST0\n21,0 SREST0\n";
    let mut e = engine(rules, agents);
    let rep = e.step();
    let named: Vec<(&str, Vec<&str>)> = (rep.records.iter())
        .map(|r| {
            let names = r
                .rules
                .iter()
                .map(|&i| e.prog.rules[i as usize].name.as_str())
                .collect();
            (r.kind.name(), names)
        })
        .collect();
    assert!(
        named.contains(&("state-conflict", vec!["a", "b"])),
        "{named:?}"
    );
    assert!(
        named.contains(&("move-collision", vec!["east", "west"])),
        "{named:?}"
    );
    assert!(
        named.contains(&("move-collision", vec!["east"])),
        "{named:?}"
    );
}

/// `Options::records_per_step` keeps a step's first records of each kind, in order, and
/// changes nothing else: the lattice, and the statistics (which count every record), are
/// those of a run keeping all, on one thread and on two (queues into walls: cascades of
/// collisions; divisions by zero).
#[test]
fn a_cap_on_records_keeps_the_first_of_each_kind() {
    let rules = "m\n1\nSM****\nP1,0\n\nd\n1\nSD****\nC00 / C00 0000\n";
    let mut agents: String = (0..50)
        .flat_map(|y| (0..60).map(move |x| format!("{x},{y} SM0000\n")))
        .collect();
    agents.extend((0..50).map(|y| format!("60,{y}\n")));
    agents.extend((0..300).map(|x| format!("{x},-5 SD0000\n")));
    for threads in [1, 2] {
        let run = |cap| {
            let opts = Options {
                threads,
                records_per_step: cap,
                ..Options::default()
            };
            let mut e = engine_with(rules, &agents, opts);
            let reports: Vec<StepReport> = (0..3).map(|_| e.step()).collect();
            (e, reports)
        };
        let (all, full) = run(None);
        let (capped, kept) = run(Some(2));
        assert_eq!(all.stats, capped.stats, "{threads} threads");
        assert_eq!(all.lat.pos, capped.lat.pos);
        assert_eq!(all.stats.records.values().sum::<u64>(), 3 * (60 * 50 + 300));
        for (f, k) in full.iter().zip(&kept) {
            let mut first: Vec<&latticesim_runtime::Record> = Vec::new();
            for r in &f.records {
                if first.iter().filter(|x| x.kind == r.kind).count() < 2 {
                    first.push(r);
                }
            }
            let kept: Vec<_> = k.records.iter().collect();
            assert_eq!(kept, first, "{threads} threads");
            assert_eq!(
                kinds(k),
                [
                    "move-collision",
                    "move-collision",
                    "division-by-zero",
                    "division-by-zero"
                ]
            );
        }
    }
}

/// States first met after the first 1,024 agents (whose lists are made one by one), in
/// blocks far apart and on several threads: every agent evaluates its own state's rules,
/// those before and after it in a state listed at once (the dispatch's second pass visits
/// only the blocks the first left unlisted; the selection evaluates the long runs it found
/// without reading their lists again, and gives those decided by their list alone their
/// entries at once: a state no rule tests, a state whose rule only sets the state). A few
/// agents at rest fire in the middle of their runs: the first selection writes only the
/// entries of agents that execute a rule, and counts those.
#[test]
fn states_first_met_late_get_their_rules_in_every_block() {
    let rules = "rest\n1\nSR**** >C00 0000\nSQ****\n\na\n1\nSA****\nSX****\n\n\
        b\n1\nSB****\nSY****\n\nc\n1\nSC****\nSZ****\n";
    let late = |x: i32| match x {
        1024 | 1500 | 1501 | 20_000 | 39_999 => 'A',
        2047 | 2048 | 5000 | 20_001 | 30_000 => 'B',
        8000..10_000 => 'W',
        12_000..14_500 => 'C',
        _ if x % 4099 == 7 => 'Q',
        _ => 'R',
    };
    let agents: String = (0..40_000)
        .map(|x| match late(x) {
            'Q' => format!("{x},0 SR0000 C00 1\n"),
            c => format!("{x},0 S{c}0000\n"),
        })
        .collect();
    let fired = (0..40_000).filter(|&x| late(x) == 'Q').count() as u64;
    for (at, mut e) in engines(rules, &agents, &[1, 2, 3, 8]) {
        let r = e.step();
        assert_eq!(e.stats.firings, vec![fired, 5, 5, 2500], "{at}");
        assert_eq!(r.executing, fired + 2510, "{at}");
        for a in 0..e.lat.len() {
            let want = match late(xy(&e, a).0) {
                'A' => "X0000",
                'B' => "Y0000",
                'Q' => "Q0000",
                'W' => "W0000",
                'C' => "Z0000",
                _ => "R0000",
            };
            assert_eq!(state(&e, a), want, "{at}, {:?}", xy(&e, a));
        }
    }
}
