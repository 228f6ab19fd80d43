//! The example algorithms, run to quiescence on generated shapes (random connected ones
//! among them, 10 to 1,000 agents in 2D, up to 300 in 3D), each outcome checked against an
//! independent computation done here: breadth-first search over the positions, counting,
//! geometry.

use latticesim_compiler::{check, lower, Input};
use latticesim_runtime::gen::{agents_text, GenOptions, Shape};
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
        lower(c.program.as_ref().unwrap()),
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

/// Breadth-first distances from agent `from` over the positions.
fn bfs(pos: &[[i32; 3]], from: usize, three_d: bool) -> Vec<u32> {
    let at: HashMap<[i32; 3], usize> = pos.iter().enumerate().map(|(i, p)| (*p, i)).collect();
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
    assert!(
        dist.iter().all(|&d| d != u32::MAX),
        "the shape is connected"
    );
    dist
}

fn shapes(three_d: bool) -> Vec<(String, Shape, u64)> {
    let mut v = vec![("line".to_string(), Shape::Line { n: 25 }, 0)];
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

fn ctr(e: &Engine, a: usize, i: usize) -> i16 {
    e.lat.counters[a * e.lat.nc() + i]
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
            let steps = run(&mut e, 10_000, |_| {});
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
    let at: HashMap<[i32; 3], usize> = e.lat.pos.iter().enumerate().map(|(i, p)| (*p, i)).collect();
    for a in 1..n {
        let s = state(e, a);
        let d =
            parent_of(&s).unwrap_or_else(|| panic!("{name}: agent {a} in state {s} has no parent"));
        let o = latticesim_vm::model::Dir::from_char(d).unwrap().offset();
        let p = e.lat.pos[a];
        let parent = at[&[p[0] + o[0], p[1] + o[1], p[2] + o[2]]];
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
            let steps = run(&mut e, 10_000, |_| {});
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
    for (name, shape, seed) in shapes(false) {
        let mut e = engine(
            "bounding-box/rules.txt",
            &gen(&shape, false, seed, "WAIT0", Some("ROOT0"), false),
        );
        let n = e.lat.len();
        let steps = run(&mut e, 10_000, |_| {});
        let r = e.lat.pos[0];
        let xs: Vec<i32> = e.lat.pos.iter().map(|p| p[0] - r[0]).collect();
        let ys: Vec<i32> = e.lat.pos.iter().map(|p| p[1] - r[1]).collect();
        let want = [
            *xs.iter().max().unwrap(),
            *xs.iter().min().unwrap(),
            *ys.iter().max().unwrap(),
            *ys.iter().min().unwrap(),
        ];
        for a in 0..n {
            let got = [
                ctr(&e, a, 15),
                ctr(&e, a, 16),
                ctr(&e, a, 17),
                ctr(&e, a, 18),
            ]
            .map(i32::from);
            assert_eq!(got, want, "{name}: agent {a}");
            assert_eq!(ctr(&e, a, 21) as i32, want[0] - want[1] + 1);
            assert_eq!(ctr(&e, a, 22) as i32, want[2] - want[3] + 1);
            assert_eq!(
                [ctr(&e, a, 2) as i32, ctr(&e, a, 3) as i32],
                [xs[a], ys[a]],
                "{name}: own coordinates"
            );
        }
        let ecc = *bfs(&e.lat.pos, 0, false).iter().max().unwrap() as u64;
        assert!(
            steps <= 3 * ecc + 4,
            "{name}: {steps} steps, eccentricity {ecc}"
        );
    }
}
