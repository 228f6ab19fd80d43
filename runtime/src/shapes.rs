//! Generators of agents files: lines, rectangles and boxes, random connected polyominoes and
//! polycubes, random sparse clouds. Seeded and deterministic on every machine.

use latticesim_vm::model::Dir;
use std::collections::HashSet;
use std::fmt::Write;

/// A small deterministic generator (SplitMix64).
#[derive(Debug, Clone)]
pub struct Rng(u64);

impl Rng {
    /// Seeded.
    pub fn new(seed: u64) -> Rng {
        Rng(seed)
    }

    /// Next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e3779b97f4a7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58476d1ce4e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d049bb133111eb);
        z ^ (z >> 31)
    }

    /// Uniform below `n` (n > 0).
    pub fn below(&mut self, n: u64) -> u64 {
        self.next_u64() % n
    }
}

/// A shape to generate.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Shape {
    /// `n` agents in a row along x.
    Line {
        /// Agents.
        n: u32,
    },
    /// A full `w` x `h` (x `d` in 3D) block.
    Block {
        /// Width (x).
        w: u32,
        /// Height (y).
        h: u32,
        /// Depth (z), 1 in 2D.
        d: u32,
    },
    /// A random connected set of `n` cells grown from the origin.
    Connected {
        /// Agents.
        n: u32,
    },
    /// `n` cells drawn uniformly from a `w` x `h` (x `d`) box.
    Cloud {
        /// Agents.
        n: u32,
        /// Width.
        w: u32,
        /// Height.
        h: u32,
        /// Depth, 1 in 2D.
        d: u32,
    },
}

/// What to write for each agent besides its position.
#[derive(Debug, Clone, Default)]
pub struct GenOptions {
    /// 2 or 3 coordinates.
    pub three_d: bool,
    /// The state of every agent (default `00000`).
    pub state: Option<String>,
    /// The state of agent 0 (e.g. a root), if different.
    pub first_state: Option<String>,
    /// Give `first_state` to the easternmost agent (largest x, then largest y) instead of
    /// agent 0: a root whose row is free to the east.
    pub first_east: bool,
    /// A counter to hold unique ids 1..n, in a seeded random order.
    pub ids: Option<u8>,
    /// Write a universe line (the bounding box of the agents).
    pub universe: bool,
    /// Fill the holes of a 2D shape (add every empty cell that is enclosed), so that it is
    /// simply connected.
    pub fill_holes: bool,
    /// The seed.
    pub seed: u64,
}

/// The cells of a shape, in generation order; the first is the origin where that applies.
pub fn cells(shape: &Shape, three_d: bool, seed: u64) -> Result<Vec<[i32; 3]>, String> {
    let mut rng = Rng::new(seed);
    let dirs: Vec<[i32; 3]> = Dir::ALL[..if three_d { 6 } else { 4 }]
        .iter()
        .map(|d| d.offset())
        .collect();
    Ok(match *shape {
        Shape::Line { n } => (0..n as i32).map(|x| [x, 0, 0]).collect(),
        Shape::Block { w, h, d } => {
            let d = if three_d { d } else { 1 };
            let mut v = Vec::with_capacity((w * h * d) as usize);
            for x in 0..w as i32 {
                for y in 0..h as i32 {
                    for z in 0..d as i32 {
                        v.push([x, y, z]);
                    }
                }
            }
            v
        }
        Shape::Connected { n: 0 } => Vec::new(),
        Shape::Connected { n } => {
            let mut v = vec![[0, 0, 0]];
            let mut seen: HashSet<[i32; 3]> = v.iter().copied().collect();
            while v.len() < n as usize {
                let from = v[rng.below(v.len() as u64) as usize];
                let o = dirs[rng.below(dirs.len() as u64) as usize];
                let c = [from[0] + o[0], from[1] + o[1], from[2] + o[2]];
                if seen.insert(c) {
                    v.push(c);
                }
            }
            v
        }
        Shape::Cloud { n, w, h, d } => {
            let d = if three_d { d } else { 1 };
            let room = w as u64 * h as u64 * d as u64;
            if n as u64 > room {
                return Err(format!("{n} agents do not fit in {room} cells"));
            }
            let mut v = Vec::with_capacity(n as usize);
            let mut seen = HashSet::new();
            while v.len() < n as usize {
                let c = [
                    rng.below(w as u64) as i32,
                    rng.below(h as u64) as i32,
                    rng.below(d as u64) as i32,
                ];
                if seen.insert(c) {
                    v.push(c);
                }
            }
            v
        }
    })
}

/// Adds every empty cell of the bounding box that the outside cannot reach (2D).
pub fn fill_holes(cs: &mut Vec<[i32; 3]>) {
    if cs.is_empty() {
        return;
    }
    let set: HashSet<[i32; 3]> = cs.iter().copied().collect();
    let (x0, x1) = (
        cs.iter().map(|c| c[0]).min().unwrap() - 1,
        cs.iter().map(|c| c[0]).max().unwrap() + 1,
    );
    let (y0, y1) = (
        cs.iter().map(|c| c[1]).min().unwrap() - 1,
        cs.iter().map(|c| c[1]).max().unwrap() + 1,
    );
    let mut outside = HashSet::new();
    let mut stack = vec![[x0, y0, 0]];
    outside.insert([x0, y0, 0]);
    while let Some(c) = stack.pop() {
        for o in [[0, 1], [-1, 0], [1, 0], [0, -1]] {
            let d = [c[0] + o[0], c[1] + o[1], 0];
            if d[0] >= x0
                && d[0] <= x1
                && d[1] >= y0
                && d[1] <= y1
                && !set.contains(&d)
                && outside.insert(d)
            {
                stack.push(d);
            }
        }
    }
    for x in x0..=x1 {
        for y in y0..=y1 {
            let c = [x, y, 0];
            if !set.contains(&c) && !outside.contains(&c) {
                cs.push(c);
            }
        }
    }
}

/// An agents file for a shape.
pub fn agents_text(shape: &Shape, o: &GenOptions) -> Result<String, String> {
    let mut out = Vec::new();
    write_agents(shape, o, &mut out)?.expect("writing to memory does not fail");
    Ok(String::from_utf8(out).expect("agents files are ASCII"))
}

/// Writes the agents file for a shape into `w` as it is made: `Err` for a shape or an
/// option that cannot be made, else the result of writing.
pub fn write_agents(
    shape: &Shape,
    o: &GenOptions,
    w: &mut impl std::io::Write,
) -> Result<std::io::Result<()>, String> {
    for s in [&o.state, &o.first_state].into_iter().flatten() {
        if s.chars().count() != 5 || s.chars().any(|c| c == '*' || !c.is_ascii_graphic()) {
            return Err(format!(
                "`{s}` is not a state: 5 printable characters other than `*`"
            ));
        }
    }
    let mut cs = cells(shape, o.three_d, o.seed)?;
    if o.fill_holes && !o.three_d {
        fill_holes(&mut cs);
    }
    let n = cs.len();
    let first = if o.first_east {
        (0..n)
            .max_by_key(|&i| (cs[i][0], cs[i][1], cs[i][2]))
            .unwrap_or(0)
    } else {
        0
    };
    let mut ids: Vec<u32> = (1..=n as u32).collect();
    let mut rng = Rng::new(o.seed ^ 0x5eed);
    for i in (1..n).rev() {
        ids.swap(i, rng.below(i as u64 + 1) as usize);
    }
    let mut s = String::with_capacity(1 << 16);
    if o.universe && n > 0 {
        let lo = |k: usize| cs.iter().map(|c| c[k]).min().unwrap_or(0);
        let hi = |k: usize| cs.iter().map(|c| c[k]).max().unwrap_or(0);
        let _ = write!(s, "U{},{},{},{}", lo(0), hi(0), lo(1), hi(1));
        if o.three_d {
            let _ = write!(s, ",{},{}", lo(2), hi(2));
        }
        s.push('\n');
    }
    for (i, c) in cs.iter().enumerate() {
        if o.three_d {
            let _ = write!(s, "{},{},{}", c[0], c[1], c[2]);
        } else {
            let _ = write!(s, "{},{}", c[0], c[1]);
        }
        let state = if i == first {
            o.first_state.as_ref().or(o.state.as_ref())
        } else {
            o.state.as_ref()
        };
        if let Some(st) = state {
            let _ = write!(s, " S{st}");
        }
        if let Some(k) = o.ids {
            let _ = write!(s, " C{k:02} {}", ids[i]);
        }
        s.push('\n');
        if s.len() >= 1 << 16 {
            if let Err(e) = w.write_all(s.as_bytes()) {
                return Ok(Err(e));
            }
            s.clear();
        }
    }
    Ok(w.write_all(s.as_bytes()))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn connected(cs: &[[i32; 3]]) -> bool {
        let set: HashSet<[i32; 3]> = cs.iter().copied().collect();
        let mut seen = HashSet::new();
        let mut stack = vec![cs[0]];
        seen.insert(cs[0]);
        while let Some(c) = stack.pop() {
            for o in Dir::ALL.map(Dir::offset) {
                let d = [c[0] + o[0], c[1] + o[1], c[2] + o[2]];
                if set.contains(&d) && seen.insert(d) {
                    stack.push(d);
                }
            }
        }
        seen.len() == cs.len()
    }

    #[test]
    fn connected_shapes_are_connected_and_distinct() {
        for seed in 0..20 {
            for three_d in [false, true] {
                let cs = cells(&Shape::Connected { n: 200 }, three_d, seed).unwrap();
                assert_eq!(cs.len(), 200);
                assert_eq!(cs.iter().collect::<HashSet<_>>().len(), 200);
                assert!(connected(&cs));
                assert!(three_d || cs.iter().all(|c| c[2] == 0));
            }
        }
    }

    #[test]
    fn empty_shapes_are_empty() {
        for s in [
            Shape::Line { n: 0 },
            Shape::Connected { n: 0 },
            Shape::Block { w: 0, h: 3, d: 1 },
        ] {
            assert!(cells(&s, false, 1).unwrap().is_empty());
        }
    }

    #[test]
    fn ids_are_a_permutation_and_seeds_repeat() {
        let o = GenOptions {
            ids: Some(0),
            seed: 3,
            ..Default::default()
        };
        let a = agents_text(&Shape::Line { n: 50 }, &o).unwrap();
        assert_eq!(a, agents_text(&Shape::Line { n: 50 }, &o).unwrap());
        let mut ids: Vec<u32> = a
            .lines()
            .map(|l| l.rsplit(' ').next().unwrap().parse().unwrap())
            .collect();
        ids.sort();
        assert_eq!(ids, (1..=50).collect::<Vec<_>>());
        assert!(agents_text(
            &Shape::Cloud {
                n: 10,
                w: 3,
                h: 3,
                d: 1
            },
            &o
        )
        .is_err());
    }
}
