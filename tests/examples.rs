//! The example algorithms, run to quiescence on generated shapes (random connected ones
//! among them, 10 to 1,000 agents in 2D, up to 300 in 3D), each outcome checked against an
//! independent computation done here: breadth-first search over the positions, counting,
//! geometry.

// The checks index agents, positions and counters in parallel.
#![allow(clippy::needless_range_loop)]

use latticesim_compiler::{check, compile, Input};
use latticesim_runtime::shapes::{agents_text, GenOptions, Shape};
use latticesim_runtime::{Engine, Lattice, Options};
use std::collections::{HashMap, VecDeque};

fn engine(rules_file: &str, agents: &str) -> Engine {
    let path = format!("{}/examples/{rules_file}", env!("CARGO_MANIFEST_DIR"));
    let rules = std::fs::read(&path).unwrap();
    let c = check(
        Input {
            name: &path,
            bytes: &rules,
        },
        Some(Input {
            name: "agents.txt",
            bytes: agents.as_bytes(),
        }),
        None,
    );
    assert!(c.diags.is_empty(), "{path}: {:?}", c.diags);
    Engine::new(
        compile(c.rules.as_ref().unwrap()).unwrap(),
        Lattice::new(c.config.as_ref().unwrap()),
        Options::default(),
    )
}

/// Runs to quiescence; checks `each_step` after every step; returns the steps.
fn run(e: &mut Engine, limit: u64, mut each_step: impl FnMut(&Engine)) -> u64 {
    loop {
        let r = e.step();
        assert!(r.records.is_empty(), "records: {:?}", r.records);
        each_step(e);
        if r.quiescent {
            return e.stats.steps;
        }
        assert!(e.stats.steps < limit, "no quiescence after {limit} steps");
    }
}

fn dirs(three_d: bool) -> Vec<[i32; 3]> {
    let mut v = vec![[0, 1, 0], [-1, 0, 0], [1, 0, 0], [0, -1, 0]];
    if three_d {
        v.extend([[0, 0, 1], [0, 0, -1]]);
    }
    v
}

/// Which agent stands on each cell.
fn cell_map(pos: &[[i32; 3]]) -> HashMap<[i32; 3], usize> {
    pos.iter().enumerate().map(|(i, p)| (*p, i)).collect()
}

/// The agent next to agent `a` in the direction with letter `d`, if any.
fn toward(pos: &[[i32; 3]], at: &HashMap<[i32; 3], usize>, a: usize, d: char) -> Option<usize> {
    let o = latticesim_vm::model::Dir::from_char(d)?.offset();
    let p = pos[a];
    at.get(&[p[0] + o[0], p[1] + o[1], p[2] + o[2]]).copied()
}

/// Breadth-first distances from agent `from` over the positions (`u32::MAX`: unreachable).
fn reach(pos: &[[i32; 3]], from: usize, three_d: bool) -> Vec<u32> {
    let at = cell_map(pos);
    let mut dist = vec![u32::MAX; pos.len()];
    dist[from] = 0;
    let mut q = VecDeque::from([from]);
    while let Some(a) = q.pop_front() {
        for o in dirs(three_d) {
            let p = pos[a];
            if let Some(&b) = at.get(&[p[0] + o[0], p[1] + o[1], p[2] + o[2]]) {
                if dist[b] == u32::MAX {
                    dist[b] = dist[a] + 1;
                    q.push_back(b);
                }
            }
        }
    }
    dist
}

/// Breadth-first distances from agent `from` over a connected shape.
fn bfs(pos: &[[i32; 3]], from: usize, three_d: bool) -> Vec<u32> {
    let dist = reach(pos, from, three_d);
    assert!(
        dist.iter().all(|&d| d != u32::MAX),
        "the shape is connected"
    );
    dist
}

fn shapes(three_d: bool) -> Vec<(String, Shape, u64)> {
    let mut v = vec![("line".to_string(), Shape::Line { n: 25 }, 0)];
    // EXAMPLE_SEEDS=K adds K more random connected shapes of 10 to 1,000 agents (300 in 3D)
    // for the longer run documented in docs/testing.md.
    let extra: u64 = std::env::var("EXAMPLE_SEEDS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(0);
    let top = if three_d { 300 } else { 1000 };
    for seed in 100..100 + extra {
        let n = 10 + (seed * 7919 % (top - 9)) as u32;
        v.push((format!("extra-{n}-{seed}"), Shape::Connected { n }, seed));
    }
    if three_d {
        v.push(("box".into(), Shape::Block { w: 4, h: 3, d: 5 }, 0));
        for (n, seed) in [(10, 1), (60, 2), (150, 3), (300, 4)] {
            v.push((format!("polycube-{n}-{seed}"), Shape::Connected { n }, seed));
        }
    } else {
        v.push(("rect".into(), Shape::Block { w: 7, h: 5, d: 1 }, 0));
        for (n, seed) in [(10, 1), (10, 2), (50, 3), (100, 4), (300, 5), (1000, 6)] {
            v.push((
                format!("polyomino-{n}-{seed}"),
                Shape::Connected { n },
                seed,
            ));
        }
    }
    v
}

fn gen(
    shape: &Shape,
    three_d: bool,
    seed: u64,
    state: &str,
    first: Option<&str>,
    ids: bool,
) -> String {
    let o = GenOptions {
        three_d,
        state: Some(state.into()),
        first_state: first.map(String::from),
        ids: ids.then_some(0),
        seed,
        ..Default::default()
    };
    agents_text(shape, &o).unwrap()
}

fn state(e: &Engine, a: usize) -> String {
    String::from_utf8_lossy(&e.lat.state[a]).into_owned()
}

fn ctr(e: &Engine, a: usize, i: usize) -> i32 {
    e.lat.counter(a as u32, i as u8)
}

#[test]
fn leader_election() {
    for three_d in [false, true] {
        let file = if three_d {
            "leader-election/rules-3d.txt"
        } else {
            "leader-election/rules.txt"
        };
        for (name, shape, seed) in shapes(three_d) {
            let mut e = engine(file, &gen(&shape, three_d, seed, "INIT0", None, true));
            let n = e.lat.len();
            // At every step the agent with the largest id is a leader, never a follower.
            let steps = run(&mut e, 10_000, |e| {
                let top = (0..n).max_by_key(|&a| ctr(e, a, 0)).unwrap();
                assert_eq!(
                    state(e, top),
                    "LEAD0",
                    "{name}: the largest id always leads"
                );
            });
            let top = (0..n).max_by_key(|&a| ctr(&e, a, 0)).unwrap();
            assert_eq!(ctr(&e, top, 0) as usize, n, "{name}: ids are 1..n");
            let leaders: Vec<usize> = (0..n).filter(|&a| state(&e, a) == "LEAD0").collect();
            assert_eq!(
                leaders,
                vec![top],
                "{name}: exactly one leader, the largest id"
            );
            assert!(
                (0..n).all(|a| ctr(&e, a, 1) as usize == n),
                "{name}: everyone knows the largest id"
            );
            let ecc = *bfs(&e.lat.pos, top, three_d).iter().max().unwrap() as u64;
            assert_eq!(
                steps,
                ecc + 2,
                "{name}: steps = eccentricity of the leader + 2"
            );
        }
    }
}

fn tree_check(
    e: &Engine,
    three_d: bool,
    name: &str,
    root_state: &str,
    parent_of: impl Fn(&str) -> Option<char>,
) {
    let n = e.lat.len();
    let dist = bfs(&e.lat.pos, 0, three_d);
    assert_eq!(state(e, 0), root_state, "{name}");
    let at = cell_map(&e.lat.pos);
    for a in 1..n {
        let s = state(e, a);
        let parent = parent_of(&s)
            .and_then(|d| toward(&e.lat.pos, &at, a, d))
            .unwrap_or_else(|| panic!("{name}: agent {a} in state {s} has no parent"));
        assert_eq!(
            dist[parent] + 1,
            dist[a],
            "{name}: the parent of {a} is one step closer to the root"
        );
    }
}

#[test]
fn spanning_tree() {
    for three_d in [false, true] {
        let file = if three_d {
            "spanning-tree/rules-3d.txt"
        } else {
            "spanning-tree/rules.txt"
        };
        for (name, shape, seed) in shapes(three_d) {
            let mut e = engine(
                file,
                &gen(&shape, three_d, seed, "WAIT0", Some("ROOT0"), false),
            );
            let dist = bfs(&e.lat.pos, 0, three_d);
            // At every step, the agents in the tree so far form a tree: each one's parent is
            // in it and one breadth-first step closer to the root.
            let steps = run(&mut e, 10_000, |e| {
                let at = cell_map(&e.lat.pos);
                for a in 1..e.lat.len() {
                    let s = state(e, a);
                    if let Some(d) = s.strip_prefix("TREE").and_then(|d| d.chars().next()) {
                        let parent = toward(&e.lat.pos, &at, a, d).expect("a parent");
                        let joined = parent == 0 || state(e, parent).starts_with("TREE");
                        assert!(joined, "{name}: the parent of {a} is not in the tree");
                        assert_eq!(dist[parent] + 1, dist[a], "{name}");
                    }
                }
            });
            tree_check(&e, three_d, &name, "TROOT", |s| {
                s.strip_prefix("TREE").and_then(|d| d.chars().next())
            });
            let ecc = *bfs(&e.lat.pos, 0, three_d).iter().max().unwrap() as u64;
            assert_eq!(steps, ecc + 2, "{name}");
        }
    }
}

#[test]
fn counting() {
    for three_d in [false, true] {
        let file = if three_d {
            "counting/rules-3d.txt"
        } else {
            "counting/rules.txt"
        };
        for (name, shape, seed) in shapes(three_d) {
            let mut e = engine(
                file,
                &gen(&shape, three_d, seed, "WAIT0", Some("ROOT0"), false),
            );
            let n = e.lat.len();
            let steps = run(&mut e, 10_000, |_| {});
            assert_eq!(ctr(&e, 0, 13) as usize, n, "{name}: the root holds n");
            tree_check(&e, three_d, &name, "dCNTR", |s| {
                s.strip_prefix("dCNT").and_then(|d| d.chars().next())
            });
            let ecc = *bfs(&e.lat.pos, 0, three_d).iter().max().unwrap() as u64;
            assert!(
                steps <= 3 * ecc + 6,
                "{name}: {steps} steps, eccentricity {ecc}"
            );
        }
    }
}

#[test]
fn bounding_box() {
    for three_d in [false, true] {
        // Where each file keeps (max x, min x, max y, min y[, max z, min z]), the sizes, and
        // the own coordinates.
        let (file, extremes, sizes): (&str, &[usize], &[usize]) = if three_d {
            (
                "bounding-box/rules-3d.txt",
                &[11, 12, 13, 14, 15, 16],
                &[17, 18, 19],
            )
        } else {
            ("bounding-box/rules.txt", &[15, 16, 17, 18], &[21, 22])
        };
        let axes = if three_d { 3 } else { 2 };
        for (name, shape, seed) in shapes(three_d) {
            let mut e = engine(
                file,
                &gen(&shape, three_d, seed, "WAIT0", Some("ROOT0"), false),
            );
            let n = e.lat.len();
            let steps = run(&mut e, 10_000, |_| {});
            let r = e.lat.pos[0];
            let rel: Vec<[i32; 3]> = e
                .lat
                .pos
                .iter()
                .map(|p| [p[0] - r[0], p[1] - r[1], p[2] - r[2]])
                .collect();
            let mut want = Vec::new();
            for k in 0..axes {
                want.push(rel.iter().map(|p| p[k]).max().unwrap());
                want.push(rel.iter().map(|p| p[k]).min().unwrap());
            }
            for a in 0..n {
                let got: Vec<i32> = extremes.iter().map(|&c| ctr(&e, a, c)).collect();
                assert_eq!(got, want, "{name}: agent {a}");
                for k in 0..axes {
                    assert_eq!(
                        ctr(&e, a, sizes[k]),
                        want[2 * k] - want[2 * k + 1] + 1,
                        "{name}"
                    );
                    assert_eq!(ctr(&e, a, 2 + k), rel[a][k], "{name}: own coordinates");
                }
            }
            let ecc = *bfs(&e.lat.pos, 0, three_d).iter().max().unwrap() as u64;
            let bound = if three_d { 6 * ecc + 8 } else { 3 * ecc + 4 };
            assert!(steps <= bound, "{name}: {steps} steps, eccentricity {ecc}");
        }
    }
}

/// Follows parent directions (state character `k`) from `from` until `stop`; returns the
/// agents visited.
fn follow(e: &Engine, from: usize, k: usize, stop: impl Fn(usize) -> bool) -> Vec<usize> {
    let at = cell_map(&e.lat.pos);
    let mut path = vec![from];
    let mut a = from;
    while !stop(a) {
        a = toward(&e.lat.pos, &at, a, e.lat.state[a][k] as char)
            .unwrap_or_else(|| panic!("agent {a} has no parent"));
        path.push(a);
        assert!(path.len() <= e.lat.len(), "a cycle");
    }
    path
}

fn path_finding_case(name: &str, agents: &str, source: usize) {
    let mut e = engine("path-finding/rules.txt", agents);
    let n = e.lat.len();
    run(&mut e, 10_000, |_| {});
    let target = (0..n).find(|&a| e.lat.state[a][0] == b'T').unwrap();
    let dist = bfs(&e.lat.pos, target, false);
    for (a, d) in dist.iter().enumerate() {
        assert_eq!(ctr(&e, a, 1) as u32, *d, "{name}: distance of agent {a}");
    }
    let path = follow(&e, source, 2, |a| a == target);
    assert_eq!(
        path.len() as u32,
        dist[source] + 1,
        "{name}: a shortest path"
    );
    for &a in &path {
        assert_eq!(
            e.lat.state[a][1], b'2',
            "{name}: agent {a} on the path is marked"
        );
    }
    let marked = (0..n).filter(|&a| e.lat.state[a][1] == b'2').count();
    assert_eq!(marked, path.len(), "{name}: nothing else is marked");
}

#[test]
fn path_finding() {
    for (name, shape, seed) in shapes(false) {
        let text = gen(&shape, false, seed, "F0-00", Some("T0-00"), false);
        let pos: Vec<[i32; 3]> = text
            .lines()
            .map(|l| {
                let v: Vec<i32> = l
                    .split(' ')
                    .next()
                    .unwrap()
                    .split(',')
                    .map(|x| x.parse().unwrap())
                    .collect();
                [v[0], v[1], 0]
            })
            .collect();
        // The source: the agent farthest from the target.
        let d = bfs(&pos, 0, false);
        let source = (0..pos.len()).max_by_key(|&a| (d[a], a)).unwrap();
        let text: String = text
            .lines()
            .enumerate()
            .map(|(i, l)| if i == source { l.replace("SF0-00", "SS0-00") } else { l.to_string() } + "\n")
            .collect();
        path_finding_case(&name, &text, source);
    }
    // Around an obstacle: a 15 x 9 block with a wall at x = 7 open only at the top.
    let mut text = String::new();
    for x in 0..15 {
        for y in 0..9 {
            if x == 7 && y < 8 {
                continue;
            }
            let st = match (x, y) {
                (0, 0) => "SS0-00",
                (14, 0) => "ST0-00",
                _ => "SF0-00",
            };
            text += &format!("{x},{y} {st}\n");
        }
    }
    path_finding_case("wall", &text, 0);
}

#[test]
fn gravity_3d() {
    for seed in 0..4u64 {
        let shape = Shape::Cloud {
            n: 120,
            w: 5,
            h: 4,
            d: 12,
        };
        let mut text = String::from("U0,4,0,3,0,11\n");
        text += &gen(&shape, true, seed, "00000", None, false);
        let mut e = engine("gravity-3d/rules.txt", &text);
        let before = e.lat.pos.clone();
        run(&mut e, 1_000, |_| {});
        let mut cols: HashMap<(i32, i32), Vec<i32>> = HashMap::new();
        for p in &before {
            cols.entry((p[0], p[1])).or_default().push(p[2]);
        }
        let mut expect_moves = 0;
        for hs in cols.values_mut() {
            hs.sort();
            expect_moves += hs
                .iter()
                .enumerate()
                .map(|(i, h)| (h - i as i32) as u64)
                .sum::<u64>();
        }
        let mut after: HashMap<(i32, i32), Vec<i32>> = HashMap::new();
        for p in &e.lat.pos {
            after.entry((p[0], p[1])).or_default().push(p[2]);
        }
        for (col, hs) in &cols {
            let mut got = after[col].clone();
            got.sort();
            assert_eq!(
                got,
                (0..hs.len() as i32).collect::<Vec<_>>(),
                "seed {seed}: column {col:?} is a stack from the floor"
            );
        }
        assert_eq!(
            e.stats.moves, expect_moves,
            "seed {seed}: every agent moved exactly its drop"
        );
    }
}

#[test]
fn bouncing_dots_never_collide() {
    for seed in 0..4u64 {
        let shape = Shape::Cloud {
            n: 40,
            w: 16,
            h: 10,
            d: 1,
        };
        let mut text = String::from("U0,15,0,9\n");
        for (i, l) in gen(&shape, false, seed, "NE000", None, false)
            .lines()
            .enumerate()
        {
            text += &l.replace(
                "NE000",
                ["NE000", "NW000", "SE000", "SW000"][(i * 7 + seed as usize) % 4],
            );
            text.push('\n');
        }
        let mut e = engine("bouncing/rules.txt", &text);
        for _ in 0..300 {
            let r = e.step();
            assert!(r.records.is_empty(), "seed {seed}: {:?}", r.records);
            assert!(!r.quiescent);
        }
        assert!(
            e.stats.moves > 1000,
            "seed {seed}: the dots keep flying ({} moves)",
            e.stats.moves
        );
        assert!(e
            .lat
            .pos
            .iter()
            .all(|p| (0..16).contains(&p[0]) && (0..10).contains(&p[1])));
    }
}

fn connected_now(pos: &[[i32; 3]]) -> bool {
    reach(pos, 0, false).iter().all(|&d| d != u32::MAX)
}

/// What a reconfiguration example is run on and checked for, besides connectivity at every
/// step and the final line.
#[derive(Clone, Copy)]
struct Reconf {
    /// Fill the generated shapes' holes.
    fill_holes: bool,
    /// At most one agent moves per step, to a touching cell.
    one_mover: bool,
    /// The line ends as one chain of attached agents.
    bonded_line: bool,
}

fn reconfiguration_case(file: &str, name: &str, shape: &Shape, seed: u64, r: Reconf) {
    let Reconf {
        fill_holes,
        one_mover,
        bonded_line,
    } = r;
    let o = GenOptions {
        state: Some("WAIT0".into()),
        first_state: Some("ROOT0".into()),
        first_east: true,
        fill_holes,
        seed,
        ..Default::default()
    };
    let text = agents_text(shape, &o).unwrap();
    let mut e = engine(file, &text);
    let n = e.lat.len();
    let root = (0..n).find(|&a| state(&e, a) == "ROOT0").unwrap();
    let start = e.lat.pos[root];
    let mut before = e.lat.pos.clone();
    run(&mut e, 500_000, |e| {
        assert!(connected_now(&e.lat.pos), "{name}: disconnected");
        if one_mover {
            let moved = before
                .iter()
                .zip(&e.lat.pos)
                .filter(|(a, b)| a != b)
                .count();
            assert!(moved <= 1, "{name}: {moved} agents moved in one step");
            for (a, b) in before.iter().zip(&e.lat.pos) {
                let d = (a[0] - b[0]).abs().max((a[1] - b[1]).abs());
                assert!(
                    d <= 1,
                    "{name}: a move to a cell that does not touch the old one"
                );
            }
        }
        before.clone_from(&e.lat.pos);
    });
    let mut got: Vec<[i32; 3]> = e.lat.pos.clone();
    got.sort();
    let want: Vec<[i32; 3]> = (0..n as i32).map(|i| [start[0] + i, start[1], 0]).collect();
    assert_eq!(got, want, "{name}: a line east of the root's cell");
    if bonded_line {
        // The line is a chain of attached agents: W and E bonds, none at the two ends.
        for a in 0..n {
            let x = e.lat.pos[a][0] - start[0];
            let want =
                (if x > 0 { 0b0010 } else { 0 }) | (if x < n as i32 - 1 { 0b0100 } else { 0 });
            assert_eq!(
                e.lat.attach[a], want,
                "{name}: bonds of the agent at x + {x}"
            );
        }
    }
}

fn reconfiguration_cases() -> Vec<(String, Shape, u64)> {
    let extra: u64 = std::env::var("EXAMPLE_SEEDS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(0);
    let mut cases: Vec<(String, Shape, u64)> = vec![
        ("line".into(), Shape::Line { n: 8 }, 0),
        ("rect".into(), Shape::Block { w: 5, h: 4, d: 1 }, 0),
    ];
    for (n, seed) in [(10, 1), (10, 2), (25, 3), (40, 4), (60, 5)] {
        cases.push((
            format!("polyomino-{n}-{seed}"),
            Shape::Connected { n },
            seed,
        ));
    }
    for seed in 100..100 + extra / 10 {
        let n = 10 + (seed * 7919 % 141) as u32;
        cases.push((format!("extra-{n}-{seed}"), Shape::Connected { n }, seed));
    }
    cases
}

#[test]
fn reconfiguration_into_a_line() {
    for (name, shape, seed) in reconfiguration_cases() {
        let r = Reconf {
            fill_holes: false,
            one_mover: false,
            bonded_line: true,
        };
        reconfiguration_case("reconfigure-line/rules.txt", &name, &shape, seed, r);
    }
}

#[test]
fn reconfiguration_by_walking_along_the_surface() {
    // Without holes (the shapes' holes are filled): a walker on a hole's rim could not leave.
    for (name, shape, seed) in reconfiguration_cases() {
        let r = Reconf {
            fill_holes: true,
            one_mover: true,
            bonded_line: false,
        };
        reconfiguration_case("reconfigure-walk/rules.txt", &name, &shape, seed, r);
    }
}

/// Odd-even transposition sort on reversed lines and random permutations: the line ends
/// sorted (smallest in the west), with one swap per inversion of the input (counted here,
/// pair by pair) in n + 1 steps, and every agent's parity counter is its x's parity.
#[test]
fn odd_even_sort() {
    let mut seed = 12345u64;
    let mut random = move |k: usize| {
        seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (seed >> 33) as usize % k
    };
    for n in [1usize, 2, 3, 8, 17, 40, 101] {
        let reversed: Vec<usize> = (1..=n).rev().collect();
        let mut shuffled: Vec<usize> = (1..=n).collect();
        for i in (1..n).rev() {
            shuffled.swap(i, random(i + 1));
        }
        for values in [reversed, shuffled] {
            let agents: String = (values.iter().enumerate())
                .map(|(x, v)| format!("{x},0 S0SORT C00 {v} C01 {} C03 {n}\n", x % 2))
                .collect();
            let mut e = engine("odd-even-sort/rules.txt", &agents);
            let steps = run(&mut e, 10_000, |_| {});
            let inversions = (0..n)
                .flat_map(|i| (i + 1..n).map(move |j| (i, j)))
                .filter(|&(i, j)| values[i] > values[j])
                .count() as u64;
            let mut by_x: Vec<(i32, i32, i32)> = (0..n)
                .map(|a| (e.lat.pos[a][0], ctr(&e, a, 0), ctr(&e, a, 1)))
                .collect();
            by_x.sort();
            let sorted: Vec<i32> = by_x.iter().map(|t| t.1).collect();
            assert_eq!(
                sorted,
                (1..=n as i32).collect::<Vec<_>>(),
                "{values:?}: sorted"
            );
            assert!(by_x.iter().all(|t| t.2 == t.0 % 2), "{values:?}: parities");
            assert_eq!(
                e.stats.swaps, inversions,
                "{values:?}: one swap per inversion"
            );
            assert_eq!(steps, n as u64 + 1, "{values:?}: n + 1 steps");
        }
    }
}
