//! Lowering a checked program to bytecode (`latticesim_vm::Program`).

use crate::checked::{self as p, Action, CheckedRules, Cond, Dim};
use latticesim_vm::model::{AttachLetter, Coord, Offset, TextPat};
use latticesim_vm::op::{Target, Val, ANY_DIR};
use latticesim_vm::{Op, RuleInfo};
use std::collections::HashMap;
use std::hash::Hash;

struct Table<T: Hash + Eq + Clone> {
    items: Vec<T>,
    index: HashMap<T, u16>,
    /// A constant past the 65,536 an instruction can name was asked for.
    full: bool,
}

impl<T: Hash + Eq + Clone> Default for Table<T> {
    fn default() -> Self {
        Table {
            items: Vec::new(),
            index: HashMap::new(),
            full: false,
        }
    }
}

impl<T: Hash + Eq + Clone> Table<T> {
    /// The index of `t`, added if new (0, and the table marked full, when there is no room).
    fn intern(&mut self, t: T) -> u16 {
        if let Some(&i) = self.index.get(&t) {
            return i;
        }
        let Ok(i) = u16::try_from(self.items.len()) else {
            self.full = true;
            return 0;
        };
        self.items.push(t.clone());
        self.index.insert(t, i);
        i
    }
}

/// What does not fit in the bytecode's 16-bit fields.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TooLarge {
    /// A precondition longer than its jumps can span.
    Precondition,
    /// More distinct constants of one kind than instructions can name.
    Constants(&'static str),
}

#[derive(Default)]
struct Lowering {
    /// The first thing that did not fit, in the rule being lowered (then the code is wrong).
    too_large: Option<TooLarge>,
    code: Vec<Op>,
    offsets: Table<Offset>,
    pats: Table<TextPat>,
    texts: Table<[u8; 5]>,
    letters: Table<[AttachLetter; 6]>,
    externals: Table<(Coord, Coord, u8)>,
    /// Literals outside the 16-bit range.
    wide: Table<i32>,
}

fn dir_code(d: Option<p::Dir>) -> u8 {
    d.map_or(ANY_DIR, |d| d.index() as u8)
}

impl Lowering {
    fn val(&mut self, v: p::Val) -> Val {
        match v {
            p::Val::Lit(x) => match i16::try_from(x) {
                Ok(x) => Val::Lit(x),
                Err(_) => Val::Wide(self.wide.intern(x)),
            },
            p::Val::Counter(c) => Val::Counter(c),
            p::Val::Msg { dir, slot } => Val::Msg {
                dir: dir_code(dir),
                slot,
            },
        }
    }

    fn cond(&mut self, c: &Cond, start: usize, reads_prio: &mut bool) {
        match c {
            Cond::And(cs) if cs.is_empty() => self.code.push(Op::True {}),
            Cond::And(cs) => {
                let mut jumps = Vec::new();
                self.cond(&cs[0], start, reads_prio);
                for c in &cs[1..] {
                    jumps.push(self.code.len());
                    self.code.push(Op::Jf { to: 0 });
                    self.cond(c, start, reads_prio);
                    self.code.push(Op::And {});
                }
                let end = u16::try_from(self.code.len() - start).unwrap_or_else(|_| {
                    self.too_large.get_or_insert(TooLarge::Precondition);
                    u16::MAX
                });
                for j in jumps {
                    self.code[j] = Op::Jf { to: end };
                }
            }
            Cond::Not(c) => {
                self.cond(c, start, reads_prio);
                self.code.push(Op::Not {});
            }
            Cond::Neighbors(b) => self.code.push(Op::Nbr {
                mask: b.mask,
                want: b.want,
            }),
            Cond::Attached(b) => self.code.push(Op::Att {
                mask: b.mask,
                want: b.want,
            }),
            Cond::Priorities { strict, leq } => {
                *reads_prio = true;
                self.code.push(Op::Prio {
                    strict: *strict,
                    leq: *leq,
                })
            }
            Cond::State(pat) => {
                let pat = self.pats.intern(*pat);
                self.code.push(Op::State { pat })
            }
            Cond::Message { dir, pat } => {
                let pat = self.pats.intern(*pat);
                self.code.push(Op::Msg {
                    dir: dir_code(*dir),
                    pat,
                })
            }
            Cond::Empty(o) => {
                let off = self.offsets.intern(*o);
                self.code.push(Op::Empty { off })
            }
            Cond::Filled(o) => {
                let off = self.offsets.intern(*o);
                self.code.push(Op::Filled { off })
            }
            Cond::Less(o) => {
                *reads_prio = true;
                let off = self.offsets.intern(*o);
                self.code.push(Op::Less { off })
            }
            Cond::LessEq(o) => {
                *reads_prio = true;
                let off = self.offsets.intern(*o);
                self.code.push(Op::LessEq { off })
            }
            Cond::RemoteState(o, pat) => {
                let off = self.offsets.intern(*o);
                let pat = self.pats.intern(*pat);
                self.code.push(Op::RState { off, pat })
            }
            Cond::Compare(op, a, b) => {
                let (a, b) = (self.val(*a), self.val(*b));
                self.code.push(Op::Cmp { op: *op, a, b })
            }
            Cond::RemoteCompare {
                strict,
                offset,
                counter,
                rhs,
            } => {
                let off = self.offsets.intern(*offset);
                let b = self.val(*rhs);
                self.code.push(Op::RCmp {
                    strict: *strict as u8,
                    off,
                    counter: *counter,
                    b,
                })
            }
        }
    }

    fn operand(&mut self, o: &p::Operand) -> Val {
        match *o {
            p::Operand::Val(v) => self.val(v),
            p::Operand::External { x, y, counter } => {
                Val::Ext(self.externals.intern((x, y, counter)))
            }
        }
    }

    fn rule(&mut self, r: &p::Rule, dim: Dim) -> RuleInfo {
        let pre_start = self.code.len();
        let mut reads_priorities = false;
        self.cond(&r.pre, pre_start, &mut reads_priorities);
        let pre = pre_start as u32..self.code.len() as u32;
        let state_filter = top_state(&r.pre).map(|p| self.pats.intern(p));
        let mut info = RuleInfo {
            name: r.name.clone(),
            priority: r.priority,
            pre,
            post: 0..0,
            reads_priorities,
            state_filter,
            moves: None,
            swaps: None,
            attaches: None,
            sets_state: None,
            computes: false,
        };
        let post_start = self.code.len() as u32;
        for a in &r.post {
            let op = match a {
                Action::Move(o) => {
                    let off = self.offsets.intern(*o);
                    info.moves = Some(off);
                    Op::Move { off }
                }
                Action::Attach(ls) => {
                    let mut all = [AttachLetter::Keep; 6];
                    all[..dim.dirs()].copy_from_slice(&ls[..dim.dirs()]);
                    let letters = self.letters.intern(all);
                    info.attaches = Some(letters);
                    Op::Attach { letters }
                }
                Action::State(pat) => {
                    let pat = self.pats.intern(*pat);
                    info.sets_state = Some(pat);
                    Op::SetState { pat }
                }
                Action::Swap(d) => {
                    info.swaps = Some(*d);
                    Op::Swap {
                        dir: d.index() as u8,
                    }
                }
                Action::Send { dir, text } => {
                    info.computes = true;
                    let text = self.texts.intern(*text);
                    Op::Send {
                        dir: dir_code(*dir),
                        text,
                    }
                }
                Action::Calc {
                    target,
                    op,
                    lhs,
                    rhs,
                } => {
                    info.computes = true;
                    let target = match *target {
                        p::Target::Counter(c) => Target::Counter(c),
                        p::Target::Msg { dir, slot } => Target::Msg {
                            dir: dir_code(dir),
                            slot,
                        },
                    };
                    let a = self.operand(lhs);
                    let b = self.operand(rhs);
                    Op::Calc {
                        target,
                        op: *op,
                        a,
                        b,
                    }
                }
            };
            self.code.push(op);
        }
        info.post = post_start..self.code.len() as u32;
        info
    }
}

/// The first state pattern among the terms joined by AND at the top of a precondition.
fn top_state(c: &Cond) -> Option<p::TextPat> {
    match c {
        Cond::State(p) => Some(*p),
        Cond::And(cs) => cs.iter().find_map(top_state),
        _ => None,
    }
}

impl Lowering {
    /// What the rules lowered so far do not fit in, if anything.
    fn too_large(&self) -> Option<TooLarge> {
        let full = [
            (self.offsets.full, "offsets"),
            (self.pats.full, "state patterns"),
            (self.texts.full, "message texts"),
            (self.letters.full, "attachment actions"),
            (self.externals.full, "external counters"),
            (self.wide.full, "32-bit literals"),
        ];
        self.too_large
            .or_else(|| full.iter().find(|f| f.0).map(|f| TooLarge::Constants(f.1)))
    }
}

/// The first rule (its index) whose bytecode would not fit, and why: the checker reports it
/// (E321), so that [`lower`] is only given programs that fit.
pub(crate) fn too_large(p: &CheckedRules) -> Option<(usize, TooLarge)> {
    let mut l = Lowering::default();
    for (i, r) in p.rules.iter().enumerate() {
        l.rule(r, p.dim);
        if let Some(t) = l.too_large() {
            return Some((i, t));
        }
    }
    None
}

/// Lowers a checked program to bytecode. The result passes `verify`.
///
/// # Panics
/// When the program does not fit (which [`crate::check`] reports as an error first).
pub fn lower(p: &CheckedRules) -> latticesim_vm::Program {
    lower_unverified(p)
}

/// The checked rules compiled to bytecode and verified: what the engine runs. The front
/// door from checked rules to a run; an `Err` is a fault of the compiler (lowering made a
/// program the verifier refuses), never of the rules.
///
/// # Panics
/// As [`lower`].
pub fn compile(p: &CheckedRules) -> Result<latticesim_vm::Verified, latticesim_vm::VerifyError> {
    lower_unverified(p).verified()
}

fn lower_unverified(p: &CheckedRules) -> latticesim_vm::Program {
    let mut l = Lowering::default();
    let rules = p.rules.iter().map(|r| l.rule(r, p.dim)).collect();
    if let Some(t) = l.too_large() {
        panic!("lowering a program that does not fit ({t:?}); `check` reports it as E321");
    }
    let prog = latticesim_vm::Program {
        dim: p.dim,
        rules,
        code: l.code,
        offsets: l.offsets.items,
        pats: l.pats.items,
        texts: l.texts.items,
        letters: l.letters.items,
        externals: l.externals.items,
        width: p.width,
        wide: l.wide.items,
    };
    debug_assert_eq!(prog.verify(), Ok(()));
    prog
}
