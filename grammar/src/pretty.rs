//! Printing syntax trees back as text in the paper's notation.
//!
//! The output parses to an equal tree (spans aside): numbers in comparisons and
//! calculations are written with four digits as the paper does (`0010`, `-0005`), offsets
//! plainly (`E-1,0`), and everything else as it was written.

use crate::ast::{AgentsFile, CalcOp, CmpOp, Comp, Offset, Operand, Rule, RulesFile, Term, Value};
use std::fmt::{self, Display, Formatter, Write};

fn comps(f: &mut Formatter<'_>, o: &Offset<'_>) -> fmt::Result {
    for (i, c) in o.node.iter().enumerate() {
        if i > 0 {
            f.write_char(',')?;
        }
        match c.node {
            Comp::Int(n) => write!(f, "{n}")?,
            Comp::Counter(d) => write!(f, "C{d}")?,
        }
    }
    Ok(())
}

impl Display for Value<'_> {
    fn fmt(&self, f: &mut Formatter<'_>) -> fmt::Result {
        match *self {
            Value::Int(n) if n < 0 => write!(f, "-{:04}", n.unsigned_abs()),
            Value::Int(n) => write!(f, "{n:04}"),
            Value::Counter(d) => write!(f, "C{d}"),
            Value::Msg(m) => write!(f, "#{m}"),
        }
    }
}

struct OperandFmt<'o, 'a>(&'o Operand<'a>);

impl Display for OperandFmt<'_, '_> {
    fn fmt(&self, f: &mut Formatter<'_>) -> fmt::Result {
        match self.0 {
            Operand::Value(v) => v.node.fmt(f),
            Operand::External(o) => comps(f, o),
        }
    }
}

impl Display for CmpOp {
    fn fmt(&self, f: &mut Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            CmpOp::Lt => "<",
            CmpOp::Gt => ">",
            CmpOp::Eq => "=",
        })
    }
}

impl Display for CalcOp {
    fn fmt(&self, f: &mut Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            CalcOp::Add => "+",
            CalcOp::Sub => "-",
            CalcOp::Mul => "*",
            CalcOp::Div => "/",
            CalcOp::Mod => "M",
            CalcOp::Max => "A",
            CalcOp::Min => "I",
        })
    }
}

impl Display for Term<'_> {
    fn fmt(&self, f: &mut Formatter<'_>) -> fmt::Result {
        match self {
            Term::Neighbors(p) => write!(f, "N{}", p.node),
            Term::Attach(p) => write!(f, "A{}", p.node),
            Term::Priorities(p) => write!(f, "P{}", p.node),
            Term::State(p) => write!(f, "S{}", p.node),
            Term::Message { dir, text } => write!(f, "M{}{}", dir.node, text.node),
            Term::Empty(o) => f.write_char('E').and_then(|_| comps(f, o)),
            Term::Filled(o) => f.write_char('F').and_then(|_| comps(f, o)),
            Term::Less(o) => f.write_char('L').and_then(|_| comps(f, o)),
            Term::LessEq(o) => f.write_char('Q').and_then(|_| comps(f, o)),
            Term::Move(o) => f.write_char('P').and_then(|_| comps(f, o)),
            Term::RemoteState { offset, state } => {
                f.write_char('T')?;
                comps(f, offset)?;
                write!(f, ",{}", state.node)
            }
            Term::Compare(c) => write!(f, "{}{} {}", c.op.node, c.lhs.node, c.rhs.node),
            Term::RemoteCompare(r) => {
                f.write_char(if r.strict { 'V' } else { 'W' })?;
                comps(f, &r.comps)?;
                write!(f, " {}", r.rhs.node)
            }
            Term::Swap(d) => write!(f, "X{}", d.node),
            Term::Calc(c) => write!(
                f,
                "{} {} {} {}",
                c.target.node,
                c.op.node,
                OperandFmt(&c.lhs),
                OperandFmt(&c.rhs)
            ),
            Term::Not(t) => write!(f, "!{}", t.node),
            Term::Group(ts) => {
                f.write_char('(')?;
                line(f, ts)?;
                f.write_char(')')
            }
            Term::Error => f.write_str("<error>"),
        }
    }
}

fn line(f: &mut Formatter<'_>, terms: &[crate::span::Spanned<Term<'_>>]) -> fmt::Result {
    for (i, t) in terms.iter().enumerate() {
        if i > 0 {
            f.write_char(' ')?;
        }
        t.node.fmt(f)?;
    }
    Ok(())
}

impl Display for Rule<'_> {
    fn fmt(&self, f: &mut Formatter<'_>) -> fmt::Result {
        writeln!(f, "{}", self.name.node)?;
        match self.priority.node {
            Some(p) => writeln!(f, "{p}")?,
            None => writeln!(f, "<error>")?,
        }
        line(f, self.pre.node)?;
        f.write_char('\n')?;
        line(f, self.post.node)?;
        f.write_char('\n')
    }
}

impl Display for RulesFile<'_> {
    fn fmt(&self, f: &mut Formatter<'_>) -> fmt::Result {
        for (i, r) in self.rules.iter().enumerate() {
            if i > 0 {
                f.write_char('\n')?;
            }
            r.fmt(f)?;
        }
        Ok(())
    }
}

impl Display for AgentsFile<'_> {
    fn fmt(&self, f: &mut Formatter<'_>) -> fmt::Result {
        let list = |f: &mut Formatter<'_>, xs: &[crate::span::Spanned<i64>]| {
            for (i, x) in xs.iter().enumerate() {
                if i > 0 {
                    f.write_char(',')?;
                }
                write!(f, "{}", x.node)?;
            }
            Ok(())
        };
        if let Some(u) = &self.universe {
            f.write_char('U')?;
            list(f, &u.bounds)?;
            f.write_char('\n')?;
        }
        for a in &self.agents {
            list(f, &a.pos)?;
            if let Some(s) = a.state {
                write!(f, " S{}", s.node)?;
            }
            if let Some(s) = a.attach {
                write!(f, " A{}", s.node)?;
            }
            for (c, v) in &a.counters {
                write!(f, " C{} {}", c.node, v.node)?;
            }
            f.write_char('\n')?;
        }
        Ok(())
    }
}
