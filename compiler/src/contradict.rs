//! Warning W502: a precondition whose own terms contradict each other, so the rule can never
//! fire. Only what is certain is reported: terms joined by AND (at the top or in a group that
//! is not negated) that demand opposite things of the same cell, attachment, state or message,
//! and comparisons of two literals that are false.

use crate::checked::{CmpOp, Cond, Coord, Dim, Dir, Offset, TextPat, Val};
use latticesim_grammar::ast::Term;
use latticesim_grammar::{Code, Diagnostic, FileId, Label, Spanned};

/// Collects the AND-joined conditions with the term that wrote each.
pub(crate) fn flatten<'c, 't, 'a>(
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

pub(crate) fn lit(o: &Offset) -> Option<[i32; 3]> {
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
pub(crate) fn cells(c: &Cond) -> impl Iterator<Item = ([i32; 3], bool)> {
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

pub(crate) fn fmt_offset(o: [i32; 3], dim3: bool) -> String {
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

/// What a comparison of a counter or a numeric message slot with a literal allows of that
/// value: its key and the range it must lie in (both ends included).
pub(crate) fn range(c: &Cond) -> Option<(Val, i64, i64)> {
    let Cond::Compare(op, a, b) = c else {
        return None;
    };
    // `<a b` is a < b; with the literal first, the value's side is mirrored.
    let (v, n, op) = match (a, b) {
        (Val::Lit(_), Val::Lit(_)) => return None,
        (v, Val::Lit(n)) => (*v, *n as i64, *op),
        (Val::Lit(n), v) => {
            let op = match op {
                CmpOp::Lt => CmpOp::Gt,
                CmpOp::Gt => CmpOp::Lt,
                CmpOp::Eq => CmpOp::Eq,
            };
            (*v, *n as i64, op)
        }
        _ => return None,
    };
    // `#*` speaks of whichever message: two comparisons of it need not see one value.
    if matches!(v, Val::Msg { dir: None, .. }) {
        return None;
    }
    Some(match op {
        CmpOp::Lt => (v, i64::MIN, n - 1),
        CmpOp::Gt => (v, n + 1, i64::MAX),
        CmpOp::Eq => (v, n, n),
    })
}

/// Why two comparisons of one value with literals cannot both hold, if they cannot.
fn ranges_clash(a: &Cond, b: &Cond) -> Option<String> {
    let ((va, la, ha), (vb, lb, hb)) = (range(a)?, range(b)?);
    if va != vb || (la.max(lb) <= ha.min(hb)) {
        return None;
    }
    let name = |v: Val| match v {
        Val::Counter(c) => format!("counter C{c:02}"),
        Val::Msg { dir: Some(d), slot } => {
            format!("message slot {:02} from {}", slot + 1, d.letter())
        }
        _ => "the value".into(),
    };
    // One comparison's range in words.
    let words = |l: i64, h: i64| match (l, h) {
        (i64::MIN, h) => format!("below {}", h + 1),
        (l, i64::MAX) => format!("above {}", l - 1),
        (l, _) => format!("equal to {l}"),
    };
    Some(format!(
        "{} cannot be {} and {} at once",
        name(va),
        words(lb, hb),
        words(la, ha)
    ))
}

fn always_false(c: &Cond) -> bool {
    match c {
        Cond::Compare(op, Val::Lit(a), Val::Lit(b)) => !op.holds(*a, *b),
        _ => false,
    }
}

/// What a condition pins down, one fact at a time: a key (what it speaks of) and the value
/// it demands there. Two conditions conflict exactly when they pin one key to different
/// values, so the check is linear in the number of terms (see [`Earliest`]).
#[derive(Clone, Copy, PartialEq, Eq, Hash)]
pub(crate) enum Key {
    /// A cell at a literal offset: filled (1) or empty (0).
    Cell([i32; 3]),
    /// An own attachment: attached (1) or not (0).
    Attach(u8),
    /// A character of the own state.
    State(u8),
    /// A character of the message from a direction.
    Message(u8, u8),
    /// A character of the state of the agent at a literal offset.
    Remote([i32; 3], u8),
}

fn text_keys(pat: &TextPat, key: impl Fn(u8) -> Key) -> impl Iterator<Item = (Key, u8)> {
    let pat = *pat;
    (0..5u8).filter_map(move |k| pat[k as usize].map(|c| (key(k), c)))
}

/// Every (key, value) a condition pins down; [`conflict`] says why two of them clash.
pub(crate) fn keys(c: &Cond) -> Vec<(Key, u8)> {
    let mut out: Vec<(Key, u8)> = cells(c).map(|(o, f)| (Key::Cell(o), f as u8)).collect();
    match c {
        Cond::Attached(p) => out.extend(
            Dir::ALL
                .iter()
                .filter(|d| p.mask & (1 << d.index()) != 0)
                .map(|d| (Key::Attach(d.index() as u8), (p.want >> d.index()) & 1)),
        ),
        Cond::State(p) => out.extend(text_keys(p, Key::State)),
        Cond::Message { dir: Some(d), pat } => {
            let d = d.index() as u8;
            out.extend(text_keys(pat, |k| Key::Message(d, k)));
        }
        Cond::RemoteState(o, p) => {
            if let Some(o) = lit(o) {
                out.extend(text_keys(p, |k| Key::Remote(o, k)));
            }
        }
        _ => {}
    }
    out
}

/// Per key, the first fact that pinned it (and its value) and the first fact that pinned it
/// to another value: enough to find the earliest fact that disagrees with any value.
#[derive(Default)]
struct Earliest {
    seen: std::collections::HashMap<Key, (usize, u8, Option<usize>)>,
}

impl Earliest {
    /// The earliest fact that pins `key` to a value other than `v`.
    fn against(&self, key: Key, v: u8) -> Option<usize> {
        let &(first, value, other) = self.seen.get(&key)?;
        if value != v {
            Some(first)
        } else {
            other
        }
    }

    fn add(&mut self, key: Key, v: u8, fact: usize) {
        let e = self.seen.entry(key).or_insert((fact, v, None));
        if e.1 != v && e.2.is_none() {
            e.2 = Some(fact);
        }
    }
}

/// W502 for the precondition `terms` of the rules file `file` (in `dim`, its text `src`
/// quoted as written), whose checked
/// conditions are `conds`: each term that is always false, or that contradicts an earlier
/// term (the earliest one), pushed onto `diags`.
pub(crate) fn check(
    terms: &[Spanned<Term<'_>>],
    conds: &[Cond],
    (file, dim, src): (FileId, Dim, &str),
    diags: &mut Vec<Diagnostic>,
) {
    if terms.len() < 2
        && !conds
            .iter()
            .any(|c| always_false(c) || matches!(c, Cond::And(_)))
    {
        return;
    }
    let mut facts = Vec::new();
    flatten(terms, conds, &mut facts);
    let dim3 = dim == Dim::Three;
    let mut earliest = Earliest::default();
    for (j, &(cj, tj)) in facts.iter().enumerate() {
        let (sj, tj) = (tj.span, crate::written(src, tj.span));
        let pinned = keys(cj);
        let against = pinned
            .iter()
            .filter_map(|&(k, v)| earliest.against(k, v))
            .min();
        for &(k, v) in &pinned {
            earliest.add(k, v, j);
        }
        if always_false(cj) {
            let d = Diagnostic::new(
                Code::W502,
                format!(
                    "`{tj}` compares two numbers and is always false, so this rule never fires"
                ),
                Label::new(file, sj, "always false"),
            )
            .with_help("compare a counter or a message with the number instead");
            diags.push(d);
            continue;
        }
        // Comparisons of one value with literals: the earliest whose range misses this
        // one's (ranges on a line: when all cannot hold, two cannot).
        let clash = (facts[..j].iter().enumerate())
            .find_map(|(i, &(ci, _))| ranges_clash(cj, ci).map(|why| (i, why)));
        if let Some((i, why)) = clash {
            let (si, ti) = (facts[i].1.span, crate::written(src, facts[i].1.span));
            let d = Diagnostic::new(
                Code::W502,
                format!("`{tj}` contradicts `{ti}`: {why}, so this rule never fires"),
                Label::new(file, sj, "contradicts an earlier term"),
            )
            .with_secondary(Label::new(file, si, "the earlier term"))
            .with_help("check the two numbers and which way each comparison points: `<C00 0005` holds when C00 is below 5");
            diags.push(d);
            continue;
        }
        let Some(i) = against else { continue };
        let (ci, ti) = facts[i];
        let (si, ti) = (&ti.span, crate::written(src, ti.span));
        if let Some(why) = conflict(ci, cj, dim3) {
            let d = Diagnostic::new(
                Code::W502,
                format!("`{tj}` contradicts `{ti}`: {why}, so this rule never fires"),
                Label::new(file, sj, "contradicts an earlier term"),
            )
            .with_secondary(Label::new(file, *si, "the earlier term"))
            .with_help("remove one of the two terms, or negate one with `!` if that was meant");
            diags.push(d);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_earliest_disagreeing_fact_is_found() {
        let mut e = Earliest::default();
        let k = Key::State(0);
        e.add(k, b'A', 0);
        e.add(k, b'A', 1);
        assert_eq!(e.against(k, b'A'), None);
        assert_eq!(e.against(k, b'B'), Some(0));
        e.add(k, b'B', 2);
        e.add(k, b'C', 3);
        assert_eq!(e.against(k, b'A'), Some(2));
        assert_eq!(e.against(k, b'C'), Some(0));
        assert_eq!(e.against(Key::State(1), b'A'), None);
    }
}
