//! Going back in a run (`History`): every step reached backwards equals the same step of a
//! fresh run (configuration with inboxes, statistics, the step's report), and the
//! keyframes stay within their bound.

mod common;

use common::{compile, picture};
use latticesim_runtime::{Engine, History, Jump, Options};

fn cases() -> Vec<(String, String)> {
    let mut flood_agents = String::new();
    for x in 0..12 {
        for y in 0..9 {
            flood_agents += &format!("{x},{y} C00 {}\n", (x * 7 + y * 13) % 50);
        }
    }
    let mut fall_agents = String::new();
    for x in 0..10 {
        for y in 0..14 {
            if (x * 31 + y * 17) % 10 < 4 {
                fall_agents += &format!("{x},{y} C00 {y}\n");
            }
        }
    }
    vec![
        // Every value comes from the south neighbour's message: the inboxes matter at
        // every step, also right after a keyframe.
        (
            "shift\n1\nS*****\nC00 + #S01 0001 #*01 + C00 0000\n".into(),
            flood_agents.clone(),
        ),
        (
            "flood\n1\nS*****\nC00 A C00 #N01 C00 A C00 #W01 C00 A C00 #E01 C00 A C00 #S01 #*01 + C00 0000\n".into(),
            flood_agents,
        ),
        (
            "fall\n1\nN***0 >C00 0000\nP0,-1 C00 - C00 0001\n\nturn\n1\nN***1 S0****\nS1****\n".into(),
            fall_agents,
        ),
    ]
}

/// Budgets for the steps kept backwards: none (every step back is made again from a
/// keyframe), a few steps' worth (both ways, by where the step is), all of them.
const BUDGETS: [usize; 3] = [0, 6_000, usize::MAX];

#[test]
fn going_back_gives_exactly_the_earlier_step() {
    for (rules, agents) in cases() {
        let (prog, lat) = compile(&rules, &agents);
        // The fresh run: the picture, statistics and report of every step.
        let mut fresh = Engine::new(prog.clone(), lat.clone(), Options::default());
        let mut seen = vec![(picture(&fresh), fresh.stats.clone(), None)];
        for _ in 0..40 {
            let rep = fresh.step();
            seen.push((picture(&fresh), fresh.stats.clone(), Some(rep)));
        }
        for budget in BUDGETS {
            let mut h = History::new(prog.clone(), lat.clone(), Options::default(), 4, 4);
            h.set_delta_budget(budget);
            h.goto(40);
            let (mut rewound, mut replayed) = (0, 0);
            // Keyframes end up at 0, 16 and 32: targets on them, between them, both ways.
            for target in [37u64, 40, 32, 16, 12, 0, 1, 16, 15, 33, 2, 40, 8, 39, 38, 3] {
                h.goto(target);
                match h.jump() {
                    Jump::Rewound { from, deltas } => {
                        assert_eq!(from - deltas, target);
                        rewound += (deltas > 0) as usize;
                    }
                    Jump::Replayed { .. } => replayed += 1,
                    Jump::Stepped(_) => {}
                }
                let (pic, stats, rep) = &seen[target as usize];
                assert_eq!(h.steps(), target);
                assert_eq!(&picture(h.engine()), pic, "step {target}, budget {budget}");
                assert_eq!(&h.engine().stats, stats, "statistics at step {target}");
                assert_eq!(h.last_report(), rep.as_ref(), "report of step {target}");
            }
            // Which way each step was reached: the deltas when kept, else the keyframes.
            match budget {
                0 => assert_eq!(rewound, 0, "no deltas kept"),
                usize::MAX => assert_eq!(replayed, 0, "every step reached was kept"),
                _ => assert!(
                    rewound > 0 && replayed > 0,
                    "{rewound} {replayed} ({rules})"
                ),
            }
            h.back(3);
            assert_eq!(h.steps(), 0);
            h.goto(5);
            h.back(3);
            assert_eq!(h.steps(), 2);
            assert_eq!(picture(h.engine()), seen[2].0);
            h.back(100);
            assert_eq!(h.steps(), 0);
            // On past the furthest step reached, after going back: the deltas found then
            // take the run back as well.
            h.goto(30);
            h.goto(44);
            h.goto(41);
            let mut more = Engine::new(prog.clone(), lat.clone(), Options::default());
            for _ in 0..41 {
                more.step();
            }
            assert_eq!(picture(h.engine()), picture(&more), "budget {budget}");
            assert_eq!(h.engine().stats, more.stats);
        }
    }
}

/// The steps kept backwards stay within their budget, the oldest dropped first; the
/// history says what it holds.
#[test]
fn deltas_stay_within_their_budget() {
    let (rules, agents) = cases().swap_remove(2);
    let (prog, lat) = compile(&rules, &agents);
    let mut h = History::new(prog, lat, Options::default(), 8, 8);
    h.set_delta_budget(20_000);
    for _ in 0..300 {
        h.step();
        let k = h.kept();
        assert!(k.delta_bytes <= 20_000, "{k:?}");
    }
    let k = h.kept();
    assert!(k.deltas_from > 1 && k.deltas_from <= 300, "{k:?}");
    h.goto(299);
    assert!(
        matches!(
            h.jump(),
            Jump::Rewound {
                from: 300,
                deltas: 1
            }
        ),
        "{:?}",
        h.jump()
    );
    h.goto(k.deltas_from - 1);
    assert!(matches!(h.jump(), Jump::Replayed { .. }), "{:?}", h.jump());
}

#[test]
fn keyframes_stay_bounded() {
    let (rules, agents) = cases().swap_remove(0);
    let (prog, lat) = compile(&rules, &agents);
    let mut h = History::new(prog, lat, Options::default(), 2, 5);
    for _ in 0..500 {
        h.step();
        assert!(h.keyframes().0 <= 5, "{:?}", h.keyframes());
    }
    // The interval grew instead: 500 steps in at most 5 keyframes.
    assert!(h.keyframes().1 >= 128, "{:?}", h.keyframes());
}

/// The run's log holds every record of the steps reached, once, in step order: going back
/// and forth adds nothing, and it equals the records of a straight run.
#[test]
fn the_log_holds_each_step_once() {
    let rules = "a\n1\nSAAAA0\nSB****\n\nb\n1\nSAAAA0\nSC****\n";
    let agents = "0,0 SAAAA0\n5,0 SAAAA0\n10,0 SAAAA0\n";
    let (prog, lat) = compile(rules, agents);
    let mut straight = Engine::new(prog.clone(), lat.clone(), Options::default());
    let mut want = Vec::new();
    for _ in 0..12 {
        want.extend(straight.step().records);
    }
    let mut h = History::new(prog, lat, Options::default(), 4, 8);
    h.goto(7);
    h.goto(2);
    h.goto(12);
    h.back(5);
    h.goto(9);
    let (log, more, reached) = h.log();
    assert_eq!((more, reached), (0, 12));
    assert_eq!(log, &want[..]);
    assert_eq!(log.len(), 36, "three state conflicts a step");
    assert!(log.windows(2).all(|w| w[0].step <= w[1].step));
}
