//! Warning W502: a precondition whose own terms contradict each other, so the rule can never
//! fire. Only what is certain is reported: terms joined by AND (at the top or in a group that
//! is not negated) that demand opposite things of the same cell, attachment, state or message,
//! and comparisons of two literals that are false.

use crate::check_rules::Checker;
use crate::program::{Cond, Coord, Dir, Offset, TextPat, Val};
use latticesim_grammar::ast::Term;
use latticesim_grammar::{Code, Diagnostic, Label, Spanned};

/// Collects the AND-joined conditions with the term that wrote each.
fn flatten<'c, 't, 'a>(
    terms: &'t [Spanned<Term<'a>>],
    conds: &'c [Cond],
    out: &mut Vec<(&'c Cond, &'t Spanned<Term<'a>>)>,
) {
    for (t, c) in terms.iter().zip(conds) {
        match (&t.node, c) {
            (Term::Group(ts), Cond::And(cs)) => flatten(ts, cs, out),
            _ => out.push((c, t)),
        }
    }
}

fn lit(o: &Offset) -> Option<[i32; 3]> {
    let mut out = [0; 3];
    for (v, c) in out.iter_mut().zip(o) {
        match c {
            Coord::Lit(n) => *v = *n,
            Coord::Counter(_) => return None,
        }
    }
    Some(out)
}

/// What a condition says about whether cells are filled: (offset, filled?), at most six.
fn cells(c: &Cond) -> impl Iterator<Item = ([i32; 3], bool)> {
    let (mask, want, single) = match c {
        Cond::Neighbors(p) => (p.mask, p.want, None),
        Cond::Attached(p) => (p.mask & p.want, p.want, None),
        Cond::Empty(o) => (0, 0, lit(o).map(|o| (o, false))),
        Cond::Filled(o) | Cond::Less(o) | Cond::LessEq(o) | Cond::RemoteState(o, _) => {
            (0, 0, lit(o).map(|o| (o, true)))
        }
        Cond::RemoteCompare { offset, .. } => (0, 0, lit(offset).map(|o| (o, true))),
        _ => (0, 0, None),
    };
    Dir::ALL
        .iter()
        .filter(move |d| mask & (1 << d.index()) != 0)
        .map(move |d| (d.offset(), want & (1 << d.index()) != 0))
        .chain(single)
}

fn disjoint(a: &TextPat, b: &TextPat) -> bool {
    a.iter()
        .zip(b)
        .any(|(x, y)| matches!((x, y), (Some(x), Some(y)) if x != y))
}

fn fmt_offset(o: [i32; 3], dim3: bool) -> String {
    let xy = if dim3 {
        format!("{},{},{}", o[0], o[1], o[2])
    } else {
        format!("{},{}", o[0], o[1])
    };
    match Dir::from_offset(o) {
        Some(d) => format!(
            "{xy} ({})",
            ["north", "west", "east", "south", "above", "below"][d.index()]
        ),
        None => xy,
    }
}

/// Why `a` and `b` cannot both hold, if they cannot.
fn conflict(a: &Cond, b: &Cond, dim3: bool) -> Option<String> {
    match (a, b) {
        (Cond::Attached(p), Cond::Attached(q)) => {
            let clash = p.mask & q.mask & (p.want ^ q.want);
            let d = Dir::ALL.iter().find(|d| clash & (1 << d.index()) != 0)?;
            return Some(format!(
                "the agent cannot be both attached and not attached towards {}",
                d.letter()
            ));
        }
        (Cond::State(p), Cond::State(q)) if disjoint(p, q) => {
            return Some("no state matches both patterns".into());
        }
        (
            Cond::Message {
                dir: Some(d),
                pat: p,
            },
            Cond::Message {
                dir: Some(e),
                pat: q,
            },
        ) if d == e && disjoint(p, q) => {
            return Some(format!(
                "no message from {} matches both patterns",
                d.letter()
            ));
        }
        (Cond::RemoteState(o, p), Cond::RemoteState(q_o, q))
            if lit(o).is_some() && lit(o) == lit(q_o) && disjoint(p, q) =>
        {
            return Some(format!(
                "the agent at {} cannot be in both states",
                fmt_offset(lit(o)?, dim3)
            ));
        }
        _ => {}
    }
    for (ca, fa) in cells(a) {
        for (cb, fb) in cells(b) {
            if ca == cb && fa != fb {
                return Some(format!(
                    "the cell at {} cannot be both empty and hold an agent",
                    fmt_offset(ca, dim3)
                ));
            }
        }
    }
    None
}

fn always_false(c: &Cond) -> bool {
    match c {
        Cond::Compare(op, Val::Lit(a), Val::Lit(b)) => !op.holds(*a as i32, *b as i32),
        _ => false,
    }
}

/// Reports W502 for the precondition `terms`, whose checked conditions are `conds`.
pub(crate) fn check(terms: &[Spanned<Term<'_>>], conds: &[Cond], ck: &mut Checker<'_>) {
    if terms.len() < 2
        && !conds
            .iter()
            .any(|c| always_false(c) || matches!(c, Cond::And(_)))
    {
        return;
    }
    let mut facts = Vec::new();
    flatten(terms, conds, &mut facts);
    let dim3 = ck.dim.dim == crate::program::Dim::Three;
    'next: for j in 0..facts.len() {
        let (cj, tj) = facts[j];
        let (sj, tj) = (tj.span, &tj.node);
        if always_false(cj) {
            let d = Diagnostic::new(
                Code::W502,
                format!(
                    "`{tj}` compares two numbers and is always false, so this rule never fires"
                ),
                Label::new(ck.file, sj, "always false"),
            )
            .with_help("compare a counter or a message with the number instead");
            ck.push(d);
            continue;
        }
        for &(ci, ti) in &facts[..j] {
            let (si, ti) = (&ti.span, &ti.node);
            if let Some(why) = conflict(ci, cj, dim3) {
                let d = Diagnostic::new(
                    Code::W502,
                    format!("`{tj}` contradicts `{ti}`: {why}, so this rule never fires"),
                    Label::new(ck.file, sj, "contradicts an earlier term"),
                )
                .with_secondary(Label::new(ck.file, *si, "the earlier term"))
                .with_help("remove one of the two terms, or negate one with `!` if that was meant");
                ck.push(d);
                continue 'next;
            }
        }
    }
}
