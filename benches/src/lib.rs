//! Inputs for the benchmarks: deterministic generators of large rules files.
#![warn(missing_docs)]

pub mod native;
pub mod plot;
pub mod process;

/// A small deterministic generator (PCG-style LCG), so inputs are the same on every machine.
pub struct Lcg(u64);

impl Lcg {
    /// Seeded.
    pub fn new(seed: u64) -> Lcg {
        Lcg(seed)
    }

    /// Next value below `n`.
    pub fn below(&mut self, n: u64) -> u64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (self.0 >> 33) % n
    }
}

/// A valid 2D rules file of `n` rules mixing every kind of term and action, as a rule
/// author would write them (about 90 bytes a rule).
pub fn generate_rules(n: usize, seed: u64) -> String {
    let mut g = Lcg::new(seed);
    let mut out = String::with_capacity(n * 100);
    let pick = |g: &mut Lcg, s: &str| {
        let cs: Vec<char> = s.chars().collect();
        cs[g.below(cs.len() as u64) as usize]
    };
    for i in 0..n {
        out += &format!("rule{i}\n{}\n", 1 + g.below(100));
        let pre_terms = 1 + g.below(4);
        for t in 0..pre_terms {
            if t > 0 {
                out.push(' ');
            }
            match g.below(9) {
                0 => {
                    out += &format!(
                        "N{}{}{}{}",
                        pick(&mut g, "01*"),
                        pick(&mut g, "01*"),
                        pick(&mut g, "01*"),
                        pick(&mut g, "01*")
                    )
                }
                1 => out += &format!("S{:05}", g.below(100000)),
                2 => out += &format!("E{},{}", g.below(5) as i64 - 2, g.below(5) as i64 - 2),
                3 => out += &format!("P{}{}**", pick(&mut g, "<=*"), pick(&mut g, "<=*")),
                4 => out += &format!(">C{:02} {:04}", g.below(25), g.below(1000)),
                5 => out += &format!("T1,0,L{:04}", g.below(10000)),
                6 => out += &format!("!(A{}*** MN*a***)", pick(&mut g, "01")),
                7 => out += &format!("=#*0{} C{:02}", 1 + g.below(8), g.below(25)),
                _ => out += &format!("V-1,0,C{:02} {:04}", g.below(25), g.below(500)),
            }
        }
        out.push('\n');
        let post_terms = 1 + g.below(3);
        let mut used = [false; 4];
        for t in 0..post_terms {
            if t > 0 {
                out.push(' ');
            }
            let k = g.below(6) as usize;
            match k {
                0..=3 if !used[k] => {
                    used[k] = true;
                    match k {
                        0 => out += &format!("S{:05}", g.below(100000)),
                        1 => {
                            out += &format!(
                                "A{}{}{}*",
                                pick(&mut g, "01*+"),
                                pick(&mut g, "01*+"),
                                pick(&mut g, "01*+")
                            )
                        }
                        2 if !used[3] => {
                            out += &format!("P{},{}", g.below(3) as i64 - 1, g.below(3) as i64 - 1)
                        }
                        _ => out += &format!("ME{:05}", g.below(100000)),
                    }
                }
                4 => {
                    out += &format!(
                        "C{:02} + C{:02} {:04}",
                        g.below(25),
                        g.below(25),
                        g.below(100)
                    )
                }
                _ => {
                    out += &format!(
                        "#*0{} A C{:02} 1,0,C{:02}",
                        1 + g.below(8),
                        g.below(25),
                        g.below(25)
                    )
                }
            }
        }
        out += "\n\n";
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn generated_rules_check_without_errors() {
        let text = generate_rules(2000, 7);
        let c = latticesim_compiler::check(
            latticesim_compiler::Input {
                name: "gen.txt",
                bytes: text.as_bytes(),
            },
            None,
            None,
        );
        assert_eq!(c.errors(), 0, "{:?}", c.diags.first());
        assert_eq!(c.rule_count, 2000);
    }
}

/// The benchmark workloads of `../shared/bench/WORKLOADS.md`: their rules and agents files.
pub mod workloads {
    use std::fmt::Write;

    /// B1 maxflood: the rules.
    pub const B1_RULES: &str = "flood\n1\nS*****\nC00 A C00 #N01 C00 A C00 #W01 C00 A C00 #E01 C00 A C00 #S01 #*01 + C00 0000\n";

    /// B2 gravity: the rules.
    pub const B2_RULES: &str = "fall\n1\nN***0 >C00 0000\nP0,-1 C00 - C00 0001\n";

    /// P (priority chains, not in WORKLOADS.md): on an L x L square every agent executes
    /// `even` unless its east neighbour does, else `odd`, so each row is a chain of
    /// priority dependencies L agents long, resolved from its east end.
    pub const P_RULES: &str = "even\n2\nP**<*\nC00 + C00 0001\n\nodd\n1\nS*****\nC01 + C01 0001\n";

    /// P agents: an L x L square.
    pub fn p_agents(l: u64) -> String {
        let mut s = String::with_capacity((l * l * 10) as usize);
        for x in 0..l {
            for y in 0..l {
                let _ = writeln!(s, "{x},{y}");
            }
        }
        s
    }

    /// P's checksum after S steps, computed directly: (sum of C00, sum of C01). In each
    /// row the easternmost agent executes `even`, the next `odd`, and so on.
    pub fn p_expected(l: u64, steps: u64) -> (u64, u64) {
        (steps * l * l.div_ceil(2), steps * l * (l / 2))
    }

    /// The B1 lattice built directly, without an agents file (for sizes whose agents file
    /// would take longer to read than to run).
    pub fn b1_lattice(l: u64) -> latticesim_runtime::Lattice {
        use latticesim_vm::model::Dim;
        let n = (l * l) as usize;
        let mut b = latticesim_runtime::LatticeBuilder::new(Dim::Two, None, n);
        for x in 0..l {
            for y in 0..l {
                let c00 = (((x * l + y) * 7919) % 32749 + 1) as i32;
                b.push([x as i32, y as i32, 0], *b"00000", 0, &[(0, c00)]);
            }
        }
        b.finish()
    }

    /// B1 agents: every cell of an L x L square, C00 = ((x*L + y) * 7919) % 32749 + 1.
    pub fn b1_agents(l: u64) -> String {
        let mut s = String::with_capacity((l * l * 20) as usize);
        for x in 0..l {
            for y in 0..l {
                let _ = writeln!(s, "{x},{y} C00 {}", ((x * l + y) * 7919) % 32749 + 1);
            }
        }
        s
    }

    /// The positions of B2: cells of a W x H box drawn with the workload's generator.
    pub fn b2_cells(w: u64, h: u64) -> Vec<(u64, u64)> {
        let mut s: u64 = 12345;
        let mut out = Vec::new();
        for x in 0..w {
            for y in 0..h {
                s = s
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                let r = (s >> 11) as f64 / (1u64 << 53) as f64;
                if r < 0.3 {
                    out.push((x, y));
                }
            }
        }
        out
    }

    /// B2 agents: C00 = y.
    pub fn b2_agents(w: u64, h: u64) -> String {
        let mut s = String::new();
        for (x, y) in b2_cells(w, h) {
            let _ = writeln!(s, "{x},{y} C00 {y}");
        }
        s
    }

    /// B3 rules: k rules cycling states R0000 .. R(k-1).
    pub fn b3_rules(k: u64) -> String {
        let mut s = String::new();
        for i in 0..k {
            let _ = writeln!(s, "r{i}\n1\nSR{i:04}\nSR{:04}\n", (i + 1) % k);
        }
        s
    }

    /// B3 agents: an L x L square, state R + ((x+y) % k).
    pub fn b3_agents(l: u64, k: u64) -> String {
        let mut s = String::new();
        for x in 0..l {
            for y in 0..l {
                let _ = writeln!(s, "{x},{y} SR{:04}", (x + y) % k);
            }
        }
        s
    }
}

pub use latticesim_runtime::Engine;

/// Compiles a workload for the engine: rules and agents text to a ready engine.
pub fn engine(rules: &str, agents: &str) -> latticesim_runtime::Engine {
    let c = latticesim_compiler::check(
        latticesim_compiler::Input {
            name: "rules",
            bytes: rules.as_bytes(),
        },
        Some(latticesim_compiler::Input {
            name: "agents",
            bytes: agents.as_bytes(),
        }),
        None,
    );
    assert_eq!(c.errors(), 0, "{:?}", c.diags.first());
    let prog =
        latticesim_compiler::compile(c.rules.as_ref().expect("no errors")).expect("verified");
    latticesim_runtime::Engine::new(
        prog,
        latticesim_runtime::Lattice::new(c.config.as_ref().expect("no errors")),
        latticesim_runtime::Options::default(),
    )
}

/// The `i`-th command-line argument as a number, or `default` (for the profiling
/// examples).
pub fn arg(i: usize, default: u64) -> u64 {
    std::env::args()
        .nth(i)
        .and_then(|s| s.parse().ok())
        .unwrap_or(default)
}

/// The compiled program of a rules file that must check without errors.
pub fn program(rules: &str) -> latticesim_vm::Verified {
    let c = latticesim_compiler::check(
        latticesim_compiler::Input {
            name: "rules",
            bytes: rules.as_bytes(),
        },
        None,
        None,
    );
    assert_eq!(c.errors(), 0, "{:?}", c.diags.first());
    latticesim_compiler::compile(c.rules.as_ref().expect("no errors")).expect("verified")
}

/// The sum of a counter over all agents.
pub fn sum_counter(e: &latticesim_runtime::Engine, c: u8) -> u64 {
    (0..e.lat.len() as u32)
        .map(|a| e.lat.counter(a, c) as u64)
        .sum()
}

/// A new engine with `base`'s program and initial lattice, and these options.
pub fn fresh(
    base: &latticesim_runtime::Engine,
    opts: latticesim_runtime::Options,
) -> latticesim_runtime::Engine {
    latticesim_runtime::Engine::new(base.prog.clone(), base.lat.clone(), opts)
}

/// The sum of C00 over all agents.
pub fn sum_c00(e: &latticesim_runtime::Engine) -> u64 {
    sum_counter(e, 0)
}

/// B2's checksum: the sum of x * 100003 + y over the agents.
pub fn b2_checksum(e: &latticesim_runtime::Engine) -> u64 {
    e.lat
        .pos
        .iter()
        .map(|p| p[0] as u64 * 100003 + p[1] as u64)
        .sum()
}

/// B3's checksum: the sum of the state numbers.
pub fn b3_checksum(e: &latticesim_runtime::Engine) -> u64 {
    e.lat
        .state
        .iter()
        .map(|s| {
            std::str::from_utf8(&s[1..])
                .ok()
                .and_then(|t| t.parse::<u64>().ok())
                .unwrap_or(0)
        })
        .sum()
}
