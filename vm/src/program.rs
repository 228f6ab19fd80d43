//! A compiled rules file and its one-time verification.

use crate::model::{AttachLetter, Coord, Dim, Dir, Offset, TextPat, Width};
use crate::op::{Op, Target, Val, ANY_DIR};
use std::fmt::{self, Write};
use std::ops::Range;

/// One rule's code and what the runtime needs to know about it without running it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RuleInfo {
    /// Its name.
    pub name: String,
    /// 1..=32767.
    pub priority: u16,
    /// Its precondition: a range of [`Program::code`].
    pub pre: Range<u32>,
    /// Its postcondition: a range of [`Program::code`].
    pub post: Range<u32>,
    /// The precondition has a `P`, `L` or `Q` term.
    pub reads_priorities: bool,
    /// A state pattern the precondition requires at its top level (an index into
    /// [`Program::pats`]): agents in other states need not evaluate the rule.
    pub state_filter: Option<u16>,
    /// The move offset (index into [`Program::offsets`]), if it has a `P` action.
    pub moves: Option<u16>,
    /// The swap direction, if it has an `X` action.
    pub swaps: Option<Dir>,
    /// The attachment letters (index into [`Program::letters`]), if it has an `A` action.
    pub attaches: Option<u16>,
    /// The new state pattern (index into [`Program::pats`]), if it has an `S` action.
    pub sets_state: Option<u16>,
    /// It has calculations or sends.
    pub computes: bool,
}

/// A compiled rules file: code and the constant tables it indexes.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Program {
    /// The dimension.
    pub dim: Dim,
    /// The rules, in file order.
    pub rules: Vec<RuleInfo>,
    /// All instructions; each rule owns two ranges.
    pub code: Vec<Op>,
    /// Offsets.
    pub offsets: Vec<Offset>,
    /// State and message patterns (`None` = `*`).
    pub pats: Vec<TextPat>,
    /// Sent texts.
    pub texts: Vec<[u8; 5]>,
    /// Attachment letters per direction (unused directions `Keep`).
    pub letters: Vec<[AttachLetter; 6]>,
    /// External counters: x, y, counter.
    pub externals: Vec<(Coord, Coord, u8)>,
    /// The width of counters and numeric messages: its literals are in its range, its
    /// calculations saturate to it, and a runtime stores its columns in it.
    pub width: Width,
    /// Literals outside the 16-bit range ([`Val::Wide`]), only with [`Width::W32`].
    pub wide: Vec<i32>,
}

/// The counters, message slots and texts a program reads or writes anywhere (so that a
/// runtime can store only those).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Uses {
    /// Bit i: counter i.
    pub counters: u64,
    /// Bit s: numeric slot s (0-based).
    pub slots: u8,
    /// Text messages are sent or read.
    pub texts: bool,
}

/// Why a program is rejected.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct VerifyError {
    /// The rule.
    pub rule: usize,
    /// What is wrong.
    pub what: String,
}

impl fmt::Display for VerifyError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "rule {}: {}", self.rule, self.what)
    }
}

/// The deepest evaluation stack a precondition may need.
pub const MAX_STACK: usize = 64;

/// A program that passed [`Program::verify`]: the only kind the engine runs. Made by
/// [`Program::verified`] (and, from checked rules, by the compiler's `compile`); it reads
/// as the [`Program`] it holds.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Verified(Program);

impl std::ops::Deref for Verified {
    type Target = Program;

    fn deref(&self) -> &Program {
        &self.0
    }
}

impl Program {
    /// The program, verified ([`Program::verify`]).
    pub fn verified(self) -> Result<Verified, VerifyError> {
        self.verify()?;
        Ok(Verified(self))
    }
}

impl Program {
    /// What the program reads and writes: counters, numeric slots, texts.
    pub fn uses(&self) -> Uses {
        let mut u = Uses::default();
        let val = |u: &mut Uses, v: Val| match v {
            Val::Counter(c) => u.counters |= 1 << c,
            Val::Msg { slot, .. } => u.slots |= 1 << slot,
            Val::Lit(_) | Val::Ext(_) | Val::Wide(_) => {}
        };
        for op in &self.code {
            match *op {
                Op::Cmp { a, b, .. } => {
                    val(&mut u, a);
                    val(&mut u, b);
                }
                Op::RCmp { counter, b, .. } => {
                    u.counters |= 1 << counter;
                    val(&mut u, b);
                }
                Op::Calc { target, a, b, .. } => {
                    match target {
                        Target::Counter(c) => u.counters |= 1 << c,
                        Target::Msg { slot, .. } => u.slots |= 1 << slot,
                    }
                    val(&mut u, a);
                    val(&mut u, b);
                }
                Op::Msg { .. } | Op::Send { .. } => u.texts = true,
                _ => {}
            }
        }
        let coord = |u: &mut Uses, c: Coord| {
            if let Coord::Counter(i) = c {
                u.counters |= 1 << i;
            }
        };
        for o in &self.offsets {
            for &c in o {
                coord(&mut u, c);
            }
        }
        for &(x, y, c) in &self.externals {
            coord(&mut u, x);
            coord(&mut u, y);
            u.counters |= 1 << c;
        }
        u
    }

    /// Checks once, before running, what the evaluator then trusts: every index in range,
    /// counters, slots and directions valid for the dimension, jumps forward inside their
    /// rule, the precondition stack balanced and within [`MAX_STACK`], and each instruction
    /// on its side (precondition or postcondition).
    pub fn verify(&self) -> Result<(), VerifyError> {
        for (ri, r) in self.rules.iter().enumerate() {
            let err = |what: String| VerifyError { rule: ri, what };
            if r.pre.start > r.pre.end
                || r.pre.end as usize > self.code.len()
                || r.post.end as usize > self.code.len()
            {
                return Err(err("code range outside the program".into()));
            }
            if r.priority == 0 || r.priority > 32767 {
                return Err(err(format!("priority {}", r.priority)));
            }
            if r.state_filter
                .is_some_and(|p| p as usize >= self.pats.len())
            {
                return Err(err("state filter outside the pattern table".into()));
            }
            let pre = &self.code[r.pre.start as usize..r.pre.end as usize];
            let mut depth: i32 = 0;
            let mut max = 0;
            for (i, op) in pre.iter().enumerate() {
                if !op.is_pre() {
                    return Err(err(format!("{op} in a precondition")));
                }
                self.check_operands(op).map_err(err)?;
                depth += match op {
                    Op::Not {} => 0,
                    Op::And {} => -1,
                    Op::Jf { to } => {
                        if (*to as usize) <= i || *to as usize > pre.len() {
                            return Err(err(format!("jump from {i} to {to}")));
                        }
                        0
                    }
                    _ => 1,
                };
                if depth < 1 && !matches!(op, Op::Jf { .. }) {
                    return Err(err(format!("stack underflow at {i}")));
                }
                max = max.max(depth);
            }
            if depth != 1 || max as usize > MAX_STACK {
                return Err(err(format!(
                    "precondition leaves {depth} values (deepest {max})"
                )));
            }
            for op in &self.code[r.post.start as usize..r.post.end as usize] {
                if op.is_pre() {
                    return Err(err(format!("{op} in a postcondition")));
                }
                self.check_operands(op).map_err(err)?;
            }
        }
        Ok(())
    }

    fn check_operands(&self, op: &Op) -> Result<(), String> {
        let d = self.dim;
        let dirs_mask = ((1u16 << d.dirs()) - 1) as u8;
        let idx = |i: u16, n: usize, what: &str| {
            if (i as usize) < n {
                Ok(())
            } else {
                Err(format!("{what} index {i} of {n}"))
            }
        };
        let dir = |x: u8, any: bool| {
            if (x as usize) < d.dirs() || (any && x == ANY_DIR) {
                Ok(())
            } else {
                Err(format!("direction {x}"))
            }
        };
        let counter = |c: u8| {
            if (c as usize) < d.counters() {
                Ok(())
            } else {
                Err(format!("counter {c}"))
            }
        };
        let coords = |o: &Offset| {
            o.iter().try_for_each(|c| {
                if let Coord::Counter(i) = c {
                    counter(*i)
                } else {
                    Ok(())
                }
            })
        };
        let val = |v: &Val, ext: bool| match *v {
            Val::Lit(x) if x == i16::MIN => Err("literal -32768".to_string()),
            Val::Lit(_) => Ok(()),
            Val::Wide(i) => idx(i, self.wide.len(), "wide literal").and_then(|_| {
                let x = self.wide[i as usize];
                if self.width.holds(x as i64) {
                    Ok(())
                } else {
                    Err(format!("literal {x} in {}-bit counters", self.width.bits()))
                }
            }),
            Val::Counter(c) => counter(c),
            Val::Msg { dir: x, slot } => dir(x, true).and_then(|_| {
                if (slot as usize) < d.slots() {
                    Ok(())
                } else {
                    Err(format!("slot {slot}"))
                }
            }),
            Val::Ext(i) if ext && d == Dim::Two => idx(i, self.externals.len(), "external"),
            Val::Ext(_) => Err("external counter outside a 2D calculation".into()),
        };
        match op {
            Op::Nbr { mask, .. } | Op::Att { mask, .. } if mask & !dirs_mask != 0 => {
                Err(format!("mask {mask:#b}"))
            }
            Op::Prio { strict, leq } if (strict | leq) & !dirs_mask != 0 || strict & leq != 0 => {
                Err("priority pattern".into())
            }
            Op::State { pat } | Op::SetState { pat } => idx(*pat, self.pats.len(), "pattern"),
            Op::Msg { dir: x, pat } => dir(*x, true).and(idx(*pat, self.pats.len(), "pattern")),
            Op::Empty { off }
            | Op::Filled { off }
            | Op::Less { off }
            | Op::LessEq { off }
            | Op::Move { off } => idx(*off, self.offsets.len(), "offset")
                .and_then(|_| coords(&self.offsets[*off as usize])),
            Op::RState { off, pat } => idx(*off, self.offsets.len(), "offset")
                .and(idx(*pat, self.pats.len(), "pattern"))
                .and_then(|_| coords(&self.offsets[*off as usize])),
            Op::Cmp { a, b, .. } => val(a, false).and(val(b, false)),
            Op::RCmp {
                off, counter: c, b, ..
            } => idx(*off, self.offsets.len(), "offset")
                .and(counter(*c))
                .and(val(b, false)),
            Op::Attach { letters } => idx(*letters, self.letters.len(), "letters"),
            Op::Swap { dir: x } => dir(*x, false),
            Op::Send { dir: x, text } => dir(*x, true).and(idx(*text, self.texts.len(), "text")),
            Op::Calc { target, a, b, .. } => {
                let t = match *target {
                    Target::Counter(c) => counter(c),
                    Target::Msg { dir: x, slot } => dir(x, true).and_then(|_| {
                        if (slot as usize) < d.slots() {
                            Ok(())
                        } else {
                            Err(format!("slot {slot}"))
                        }
                    }),
                };
                t.and(val(a, true)).and(val(b, true))
            }
            _ => Ok(()),
        }
    }

    /// A readable listing of every rule's code and the tables.
    pub fn disassemble(&self) -> String {
        let mut s = String::new();
        let _ = writeln!(
            s,
            "; {} program, {} rules, {} instructions",
            self.dim.name(),
            self.rules.len(),
            self.code.len()
        );
        for (i, r) in self.rules.iter().enumerate() {
            let _ = writeln!(s, "\nrule {i} `{}` priority {}", r.name, r.priority);
            let _ = writeln!(s, "  pre:");
            for (k, op) in self.code[r.pre.start as usize..r.pre.end as usize]
                .iter()
                .enumerate()
            {
                let _ = writeln!(s, "    {k:4}  {op}");
            }
            let _ = writeln!(s, "  post:");
            for (k, op) in self.code[r.post.start as usize..r.post.end as usize]
                .iter()
                .enumerate()
            {
                let _ = writeln!(s, "    {k:4}  {op}");
            }
        }
        let show_coord = |c: &Coord| match c {
            Coord::Lit(v) => v.to_string(),
            Coord::Counter(i) => format!("C{i:02}"),
        };
        let show_pat = |p: &TextPat| {
            p.iter()
                .map(|c| c.map_or('*', |b| b as char))
                .collect::<String>()
        };
        if !self.offsets.is_empty() {
            let _ = writeln!(s, "\noffsets:");
            for (i, o) in self.offsets.iter().enumerate() {
                let cs: Vec<String> = o[..self.dim.coords()].iter().map(show_coord).collect();
                let _ = writeln!(s, "  {i:4}  {}", cs.join(","));
            }
        }
        if !self.pats.is_empty() {
            let _ = writeln!(s, "\npatterns:");
            for (i, p) in self.pats.iter().enumerate() {
                let _ = writeln!(s, "  {i:4}  {}", show_pat(p));
            }
        }
        if !self.texts.is_empty() {
            let _ = writeln!(s, "\ntexts:");
            for (i, t) in self.texts.iter().enumerate() {
                let _ = writeln!(s, "  {i:4}  {}", String::from_utf8_lossy(t));
            }
        }
        if !self.letters.is_empty() {
            let _ = writeln!(s, "\nattachment letters:");
            for (i, l) in self.letters.iter().enumerate() {
                let t: String = l[..self.dim.dirs()]
                    .iter()
                    .map(|x| match x {
                        AttachLetter::Detach => '0',
                        AttachLetter::Attach => '1',
                        AttachLetter::Keep => '*',
                        AttachLetter::Rigid => '+',
                    })
                    .collect();
                let _ = writeln!(s, "  {i:4}  {t}");
            }
        }
        if !self.externals.is_empty() {
            let _ = writeln!(s, "\nexternal counters:");
            for (i, (x, y, c)) in self.externals.iter().enumerate() {
                let _ = writeln!(s, "  {i:4}  {},{},C{c:02}", show_coord(x), show_coord(y));
            }
        }
        s
    }
}
