//! The evaluator for one agent: preconditions in three-valued (Kleene) logic, and the
//! calculations and sends of a postcondition, over an environment the runtime provides.

use crate::model::{CalcOp, Coord, Dir, Offset, TextPat, Width};
use crate::op::{Op, Target, Val, ANY_DIR};
use crate::program::MAX_STACK;
use crate::Program;

/// A truth value in Kleene logic: false, true, unknown.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Tri {
    /// False.
    F,
    /// True.
    T,
    /// Unknown (depends on priorities not yet resolved).
    U,
}

impl Tri {
    /// From a definite boolean.
    pub fn of(b: bool) -> Tri {
        if b {
            Tri::T
        } else {
            Tri::F
        }
    }

    /// Kleene conjunction.
    pub fn and(self, o: Tri) -> Tri {
        match (self, o) {
            (Tri::F, _) | (_, Tri::F) => Tri::F,
            (Tri::T, Tri::T) => Tri::T,
            _ => Tri::U,
        }
    }
}

impl std::ops::Not for Tri {
    type Output = Tri;

    /// Kleene negation.
    fn not(self) -> Tri {
        match self {
            Tri::F => Tri::T,
            Tri::T => Tri::F,
            Tri::U => Tri::U,
        }
    }
}

/// What is at a cell.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Cell {
    /// Outside the universe (or the coordinate range): no agent, not free.
    Blocked,
    /// Free.
    Empty,
    /// The agent with this id.
    Agent(u32),
}

/// What a precondition reads, for the agent being evaluated, at the start of the step.
pub trait Env {
    /// An own counter.
    fn counter(&self, i: u8) -> i32;
    /// The own state.
    fn state(&self) -> [u8; 5];
    /// The own attachment bits.
    fn attach(&self) -> u8;
    /// The cell at an offset from the agent.
    fn cell(&self, off: [i32; 3]) -> Cell;
    /// Another agent's state.
    fn agent_state(&self, id: u32) -> [u8; 5];
    /// Another agent's counter.
    fn agent_counter(&self, id: u32, i: u8) -> i32;
    /// The numeric message received from direction `dir` in slot `slot` (0 if none).
    fn inbox_num(&self, dir: u8, slot: u8) -> i32;
    /// The text received from direction `dir`, if any.
    fn inbox_text(&self, dir: u8) -> Option<[u8; 5]>;
    /// Whether priorities are being compared; when false, every `P`, `L` and `Q` term is
    /// unknown (the first pass of selection).
    fn priorities_known(&self) -> bool;
    /// Whether the agent `other` (`None`: an empty or blocked cell, priority 0) has a
    /// priority smaller than (`strict`) or smaller than or equal to `p`.
    fn prio(&self, other: Option<u32>, p: u16, strict: bool) -> Tri;
    /// Number of directions (4 or 6).
    fn dirs(&self) -> u8;
    /// The cell next to the agent in direction index `d` (an implementation may answer
    /// from a table).
    fn neighbour_cell(&self, d: u8) -> Cell {
        self.cell(Dir::ALL[d as usize].offset())
    }
}

/// Whether a text matches a pattern.
pub fn matches(pat: &TextPat, text: &[u8; 5]) -> bool {
    pat.iter().zip(text).all(|(p, c)| p.is_none_or(|p| p == *c))
}

/// Resolves an offset with the agent's counters.
pub fn resolve<E: Env + ?Sized>(o: &Offset, env: &E) -> [i32; 3] {
    let c = |c: &Coord| match *c {
        Coord::Lit(v) => v,
        Coord::Counter(i) => env.counter(i),
    };
    [c(&o[0]), c(&o[1]), c(&o[2])]
}

fn value<E: Env + ?Sized>(prog: &Program, v: Val, dir_override: u8, env: &E) -> i32 {
    match v {
        Val::Lit(x) => x as i32,
        Val::Wide(i) => prog.wide[i as usize],
        Val::Counter(c) => env.counter(c),
        Val::Msg { dir, slot } => {
            let d = if dir == ANY_DIR { dir_override } else { dir };
            env.inbox_num(d, slot)
        }
        // Verified away: external counters are only read by calculations.
        Val::Ext(_) => 0,
    }
}

fn is_any(v: Val) -> bool {
    matches!(v, Val::Msg { dir: ANY_DIR, .. })
}

/// Evaluates the precondition of rule `rule` for the agent `env` describes: a stack
/// machine over the rule's terms ([`term`]), negations, conjunctions and jumps past what
/// cannot change a false result.
pub fn eval_pre<E: Env + ?Sized>(prog: &Program, rule: usize, env: &E) -> Tri {
    let r = &prog.rules[rule];
    let code = &prog.code[r.pre.start as usize..r.pre.end as usize];
    let mut stack = [Tri::T; MAX_STACK];
    let mut sp = 0usize;
    let mut pc = 0usize;
    let known = env.priorities_known();
    while pc < code.len() {
        match code[pc] {
            Op::Not {} => stack[sp - 1] = !stack[sp - 1],
            Op::And {} => {
                sp -= 1;
                stack[sp - 1] = stack[sp - 1].and(stack[sp]);
            }
            Op::Jf { to } => {
                if stack[sp - 1] == Tri::F {
                    pc = to as usize;
                    continue;
                }
            }
            op => {
                stack[sp] = term(prog, (op, r.priority, known), env);
                sp += 1;
            }
        }
        pc += 1;
    }
    stack[0]
}

/// The value of one term `op` of a precondition of priority `p` (`known`: whether the
/// neighbours' priorities are known yet; `P`, `L` and `Q` are unknown until they are).
#[inline(always)]
fn term<E: Env + ?Sized>(prog: &Program, (op, p, known): (Op, u16, bool), env: &E) -> Tri {
    match op {
        Op::True {} => Tri::T,
        Op::Nbr { mask, want } => {
            let mut ok = true;
            for d in 0..env.dirs() {
                if mask & (1 << d) == 0 {
                    continue;
                }
                let want_filled = want & (1 << d) != 0;
                ok &= match env.neighbour_cell(d) {
                    Cell::Blocked => false,
                    Cell::Empty => !want_filled,
                    Cell::Agent(_) => want_filled,
                };
            }
            Tri::of(ok)
        }
        Op::Att { mask, want } => Tri::of(env.attach() & mask == want & mask),
        Op::Prio { strict, leq } => {
            if !known {
                Tri::U
            } else {
                let mut acc = Tri::T;
                for d in 0..env.dirs() {
                    let bit = 1 << d;
                    if (strict | leq) & bit == 0 {
                        continue;
                    }
                    let other = match env.neighbour_cell(d) {
                        Cell::Agent(id) => Some(id),
                        _ => None,
                    };
                    acc = acc.and(env.prio(other, p, strict & bit != 0));
                }
                acc
            }
        }
        Op::State { pat } => Tri::of(matches(&prog.pats[pat as usize], &env.state())),
        Op::Msg { dir, pat } => {
            let p = &prog.pats[pat as usize];
            let hit = |d: u8| env.inbox_text(d).is_some_and(|t| matches(p, &t));
            Tri::of(if dir == ANY_DIR {
                (0..env.dirs()).any(hit)
            } else {
                hit(dir)
            })
        }
        Op::Empty { off } => {
            Tri::of(env.cell(resolve(&prog.offsets[off as usize], env)) == Cell::Empty)
        }
        Op::Filled { off } => Tri::of(matches!(
            env.cell(resolve(&prog.offsets[off as usize], env)),
            Cell::Agent(_)
        )),
        Op::Less { off } | Op::LessEq { off } => {
            if !known {
                Tri::U
            } else {
                match env.cell(resolve(&prog.offsets[off as usize], env)) {
                    Cell::Agent(id) => env.prio(Some(id), p, matches!(op, Op::Less { .. })),
                    _ => Tri::F,
                }
            }
        }
        Op::RState { off, pat } => {
            Tri::of(match env.cell(resolve(&prog.offsets[off as usize], env)) {
                Cell::Agent(id) => matches(&prog.pats[pat as usize], &env.agent_state(id)),
                _ => false,
            })
        }
        Op::Cmp { op, a, b } => {
            let holds = |d: u8| op.holds(value(prog, a, d, env), value(prog, b, d, env));
            Tri::of(if is_any(a) || is_any(b) {
                (0..env.dirs()).any(holds)
            } else {
                holds(0)
            })
        }
        Op::RCmp {
            strict,
            off,
            counter,
            b,
        } => Tri::of(match env.cell(resolve(&prog.offsets[off as usize], env)) {
            Cell::Agent(id) => {
                let c = env.agent_counter(id, counter);
                let holds = |d: u8| {
                    let rhs = value(prog, b, d, env);
                    if strict != 0 {
                        c < rhs
                    } else {
                        c <= rhs
                    }
                };
                if is_any(b) {
                    (0..env.dirs()).any(holds)
                } else {
                    holds(0)
                }
            }
            _ => false,
        }),
        // Verified away: postcondition instructions never stand in a precondition.
        _ => Tri::U,
    }
}

/// What a calculation can go wrong with; the runtime turns these into records.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CalcIssue {
    /// The result was outside the program's width (-32767..32767, or the 32-bit range)
    /// and was saturated.
    Saturated {
        /// The exact result.
        exact: i64,
    },
    /// Division or remainder by zero: the target is unchanged.
    DivisionByZero,
    /// No agent stands where an external counter is read: the calculation is skipped.
    NoExternalAgent {
        /// The offset read.
        off: [i32; 2],
    },
}

/// What the calculations of a postcondition read and write.
pub trait CalcEnv {
    /// An own counter (current value).
    fn counter(&self, i: u8) -> i32;
    /// Sets an own counter.
    fn set_counter(&mut self, i: u8, v: i32);
    /// The numeric message received from `dir` in `slot` this step (0 if none).
    fn inbox_num(&self, dir: u8, slot: u8) -> i32;
    /// The counter of the agent at an offset, as it was at the start of the phase.
    fn external(&self, off: [i32; 2], counter: u8) -> Option<i32>;
    /// Writes an outgoing numeric slot towards `dir` (or all, [`ANY_DIR`]).
    fn send_num(&mut self, dir: u8, slot: u8, v: i32);
    /// Writes the outgoing text towards `dir` (or all, [`ANY_DIR`]).
    fn send_text(&mut self, dir: u8, text: [u8; 5]);
    /// Reports a problem of instruction `pc` of the postcondition.
    fn issue(&mut self, pc: usize, issue: CalcIssue);
}

/// Applies an operation exactly and saturates to the width `w` (-32767..32767, or
/// -2,147,483,647..2,147,483,647): the result, and the exact one when it was saturated.
pub fn apply(op: CalcOp, a: i32, b: i32, w: Width) -> Result<(i32, Option<i64>), CalcIssue> {
    let exact: i64 = match op {
        CalcOp::Add => a as i64 + b as i64,
        CalcOp::Sub => a as i64 - b as i64,
        CalcOp::Mul => a as i64 * b as i64,
        CalcOp::Div if b == 0 => return Err(CalcIssue::DivisionByZero),
        CalcOp::Div => a as i64 / b as i64,
        CalcOp::Mod if b == 0 => return Err(CalcIssue::DivisionByZero),
        CalcOp::Mod => a as i64 % b as i64,
        CalcOp::Max => a.max(b) as i64,
        CalcOp::Min => a.min(b) as i64,
    };
    let sat = w.saturate(exact);
    Ok((sat, (sat as i64 != exact).then_some(exact)))
}

/// Runs the calculations and sends of rule `rule`'s postcondition, in written order.
pub fn run_post<E: CalcEnv + ?Sized>(prog: &Program, rule: usize, env: &mut E) {
    let r = &prog.rules[rule];
    let code = &prog.code[r.post.start as usize..r.post.end as usize];
    for (pc, op) in code.iter().enumerate() {
        match *op {
            Op::Send { dir, text } => env.send_text(dir, prog.texts[text as usize]),
            Op::Calc { target, op, a, b } => {
                let read = |v: Val| -> Result<i32, CalcIssue> {
                    Ok(match v {
                        Val::Lit(x) => x as i32,
                        Val::Wide(i) => prog.wide[i as usize],
                        Val::Counter(c) => env.counter(c),
                        Val::Msg { dir, slot } => env.inbox_num(dir, slot),
                        Val::Ext(i) => {
                            let (x, y, c) = prog.externals[i as usize];
                            let co = |k: Coord| match k {
                                Coord::Lit(v) => v,
                                Coord::Counter(j) => env.counter(j),
                            };
                            let off = [co(x), co(y)];
                            env.external(off, c)
                                .ok_or(CalcIssue::NoExternalAgent { off })?
                        }
                    })
                };
                let res = read(a)
                    .and_then(|x| read(b).map(|y| (x, y)))
                    .and_then(|(x, y)| apply(op, x, y, prog.width));
                match res {
                    Ok((v, saturated)) => {
                        if let Some(exact) = saturated {
                            env.issue(pc, CalcIssue::Saturated { exact });
                        }
                        match target {
                            Target::Counter(c) => env.set_counter(c, v),
                            Target::Msg { dir, slot } => env.send_num(dir, slot, v),
                        }
                    }
                    Err(e) => env.issue(pc, e),
                }
            }
            _ => {}
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn kleene() {
        use Tri::*;
        assert_eq!(T.and(U), U);
        assert_eq!(F.and(U), F);
        assert_eq!(!U, U);
        assert_eq!(!F, T);
    }

    #[test]
    fn arithmetic_saturates_and_truncates() {
        let n = Width::W16;
        assert_eq!(apply(CalcOp::Add, 32767, 1, n), Ok((32767, Some(32768))));
        assert_eq!(apply(CalcOp::Mul, -300, 300, n), Ok((-32767, Some(-90000))));
        assert_eq!(apply(CalcOp::Div, -7, 2, n), Ok((-3, None)));
        assert_eq!(apply(CalcOp::Mod, -7, 2, n), Ok((-1, None)));
        assert_eq!(apply(CalcOp::Mod, 7, -2, n), Ok((1, None)));
        assert_eq!(apply(CalcOp::Div, 1, 0, n), Err(CalcIssue::DivisionByZero));
        assert_eq!(apply(CalcOp::Max, -1, 3, n), Ok((3, None)));
        assert_eq!(apply(CalcOp::Min, -1, 3, n), Ok((-1, None)));
    }

    /// The 32-bit extension: exact in i64, saturated at both bounds, division as in i32.
    #[test]
    fn wide_arithmetic_saturates_at_both_bounds() {
        let w = Width::W32;
        let max = 2_147_483_647;
        assert_eq!(apply(CalcOp::Add, 32767, 1, w), Ok((32768, None)));
        assert_eq!(
            apply(CalcOp::Add, max, 1, w),
            Ok((max, Some(2_147_483_648)))
        );
        assert_eq!(
            apply(CalcOp::Sub, -max, 1, w),
            Ok((-max, Some(-2_147_483_648)))
        );
        assert_eq!(
            apply(CalcOp::Mul, max, max, w),
            Ok((max, Some(max as i64 * max as i64)))
        );
        assert_eq!(
            apply(CalcOp::Mul, -max, 2, w),
            Ok((-max, Some(-2 * max as i64)))
        );
        assert_eq!(apply(CalcOp::Div, -max, -1, w), Ok((max, None)));
        assert_eq!(apply(CalcOp::Div, -7_000_001, 2, w), Ok((-3_500_000, None)));
        assert_eq!(apply(CalcOp::Mod, -max, 10, w), Ok((-7, None)));
        assert_eq!(apply(CalcOp::Mod, 5, 0, w), Err(CalcIssue::DivisionByZero));
    }
}
