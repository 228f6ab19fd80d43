//! Finding the dimension: from `--dim`, the agents file, or the rules' own terms, in that
//! order of precedence, remembering where it came from so that a term of the other dimension
//! can point at the reason.

use crate::checked::Dim;
use latticesim_grammar::ast::{AgentsFile, Operand, RulesFile, Term, Value};
use latticesim_grammar::{Code, Diagnostic, FileId, Label, Span, Spanned};

/// The dimension in force and why.
#[derive(Debug, Clone)]
pub struct DimSource {
    /// The dimension.
    pub dim: Dim,
    /// Why, as a phrase: "the agents file's universe line has 4 bounds".
    pub why: String,
    /// Where that is written, if in a file.
    pub label: Option<Label>,
    /// For the rules' own terms: how many of their deciding terms agree (else 0).
    pub agreeing: usize,
}

impl DimSource {
    /// The secondary label pointing at the reason, if there is one.
    pub fn secondary(&self) -> Option<Label> {
        self.label.clone()
    }

    /// Adds the reason to a diagnostic: a secondary label if it is in a file, else a note in
    /// the message is left to the caller.
    pub fn attach(&self, d: Diagnostic) -> Diagnostic {
        match self.secondary() {
            Some(l) => d.with_secondary(l),
            None => d,
        }
    }
}

/// The dimension an agents file declares: its universe line, else its first position.
pub fn from_agents(f: &AgentsFile<'_>, file: FileId) -> Option<DimSource> {
    if let Some(u) = &f.universe {
        let dim = Dim::from_coords(u.bounds.len() / 2)?;
        return Some(DimSource {
            dim,
            why: format!(
                "the agents file's universe line has {} bounds",
                u.bounds.len()
            ),
            label: Some(Label::new(
                file,
                u.span,
                format!("{} because of this universe line", dim.name()),
            )),
            agreeing: 0,
        });
    }
    let a = f.agents.first()?;
    let dim = Dim::from_coords(a.pos.len())?;
    let span = a.pos[0].span.to(a.pos[a.pos.len() - 1].span);
    Some(DimSource {
        dim,
        why: format!(
            "the agents file's first position has {} coordinates",
            a.pos.len()
        ),
        label: Some(Label::new(
            file,
            span,
            format!("{} because of this position", dim.name()),
        )),
        agreeing: 0,
    })
}

/// The dimension given with `--dim`.
pub fn from_flag(dim: Dim) -> DimSource {
    DimSource {
        dim,
        why: format!("--dim {} was given", dim.coords()),
        label: None,
        agreeing: 0,
    }
}

/// The default when nothing decides: 2D.
pub fn default_2d() -> DimSource {
    DimSource {
        dim: Dim::Two,
        why: "no term decides the dimension, so 2D is assumed".into(),
        label: None,
        agreeing: 0,
    }
}

/// `--dim` against the agents file: the flag wins, a disagreement is E301.
pub fn reconcile(
    flag: Option<Dim>,
    agents: Option<DimSource>,
    diags: &mut Vec<Diagnostic>,
) -> Option<DimSource> {
    match (flag, agents) {
        (Some(f), Some(a)) if a.dim != f => {
            if let Some(l) = &a.label {
                diags.push(
                    Diagnostic::new(
                        Code::E301,
                        format!(
                            "--dim {} was given, but the agents file is {}",
                            f.coords(),
                            a.dim.name()
                        ),
                        Label::new(
                            l.file,
                            l.span,
                            format!("this makes the agents file {}", a.dim.name()),
                        ),
                    )
                    .with_help(format!(
                        "drop --dim (the agents file decides), or pass --dim {}",
                        a.dim.coords()
                    )),
                );
            }
            // The rules are read in the agents' dimension: the help above says the agents
            // file decides, and a wrong --dim then costs one error, not one per term.
            Some(a)
        }
        (Some(f), _) => Some(from_flag(f)),
        (None, a) => a,
    }
}

/// The E301 of an agents file whose dimension the rules' own terms contradict (the caller
/// asks for at least two such terms: a single term of the other dimension is that term's
/// error, with its fix): on the agents file, the rules' deciding term beside it. Each file
/// is then read in its own dimension, so that a wrong pairing costs this one error, not
/// one per term.
pub fn mismatch(agents: &DimSource, rules: &DimSource) -> Option<Diagnostic> {
    let l = agents.label.as_ref()?;
    let mut d = Diagnostic::new(
        Code::E301,
        format!(
            "the agents file is {}, but the rules are {}",
            agents.dim.name(),
            rules.dim.name()
        ),
        Label::new(
            l.file,
            l.span,
            format!("this makes the agents file {}", agents.dim.name()),
        ),
    )
    .with_help(format!(
        "pair these rules with a {} agents file, or write them for {} ({})",
        rules.dim.name(),
        agents.dim.name(),
        match agents.dim {
            Dim::Three => "patterns of 6 characters, offsets of 3 coordinates",
            Dim::Two => "patterns of 4 characters, offsets of 2 coordinates",
        }
    ));
    if let Some(r) = rules.secondary() {
        d = d.with_secondary(r);
    }
    Some(d)
}

fn evidence<'a>(t: &Spanned<Term<'a>>, src: &str) -> Option<(Dim, Span, String)> {
    let written = crate::written(src, t.span);
    let by_len = |p: &Spanned<&str>, letter: char| {
        let n = p.node.chars().count();
        let dim = match n {
            4 => Dim::Two,
            6 => Dim::Three,
            _ => return None,
        };
        Some((
            dim,
            t.span,
            format!("`{letter}{}` has {n} characters", p.node),
        ))
    };
    let by_arity = |o: &Spanned<&[Spanned<latticesim_grammar::ast::Comp<'a>>]>| {
        let dim = Dim::from_coords(o.node.len())?;
        Some((
            dim,
            t.span,
            format!("`{}` has {} coordinates", t.node, o.node.len()),
        ))
    };
    let by_value = |v: &Spanned<Value<'_>>| match v.node {
        Value::Msg(m) if m.starts_with(['A', 'B']) => {
            Some((Dim::Three, v.span, format!("`#{m}` names a 3D direction")))
        }
        _ => None,
    };
    match &t.node {
        Term::Neighbors(p) => by_len(p, 'N'),
        Term::Attach(p) => by_len(p, 'A'),
        Term::Priorities(p) => by_len(p, 'P'),
        Term::Empty(o) | Term::Filled(o) | Term::Less(o) | Term::LessEq(o) | Term::Move(o) => {
            by_arity(o)
        }
        // How a `T` term splits depends on the dimension, so it is no evidence of it.
        Term::Message { dir, .. } if matches!(dir.node, 'A' | 'B') => Some((
            Dim::Three,
            t.span,
            format!("`{written}` names a 3D direction"),
        )),
        Term::Swap(d) if matches!(d.node, "A" | "B") => Some((
            Dim::Three,
            t.span,
            format!("`{written}` names a 3D direction"),
        )),
        Term::RemoteCompare(_) => {
            Some((Dim::Two, t.span, format!("`{written}` exists only in 2D")))
        }
        Term::Calc(c) => {
            let (target, lhs, rhs) = (&c.target, &c.lhs, &c.rhs);
            if matches!(lhs, Operand::External(_)) || matches!(rhs, Operand::External(_)) {
                return Some((
                    Dim::Two,
                    t.span,
                    "an external counter exists only in 2D".into(),
                ));
            }
            let vals = [Some(target), value_of(lhs), value_of(rhs)];
            vals.into_iter().flatten().find_map(by_value)
        }
        Term::Compare(c) => by_value(&c.lhs).or_else(|| by_value(&c.rhs)),
        Term::Not(inner) => evidence(inner, src),
        Term::Group(ts) => ts.iter().find_map(|t| evidence(t, src)),
        _ => None,
    }
}

fn value_of<'o, 'a>(o: &'o Operand<'a>) -> Option<&'o Spanned<Value<'a>>> {
    match o {
        Operand::Value(v) => Some(v),
        Operand::External(_) => None,
    }
}

fn collect<'a>(t: &Spanned<Term<'a>>, src: &str, out: &mut Vec<(Dim, Span, String)>) {
    match &t.node {
        Term::Not(inner) => collect(inner, src, out),
        Term::Group(ts) => ts.iter().for_each(|t| collect(t, src, out)),
        _ => out.extend(evidence(t, src)),
    }
}

/// The dimension the rules' own terms show: the one most deciding terms agree on (the
/// first deciding term breaks a tie), so that a single odd term is the one reported. `src`
/// is the file's text, to quote terms as written.
pub fn from_rules(f: &RulesFile<'_>, file: FileId, src: &str) -> Option<DimSource> {
    let mut all = Vec::new();
    for r in &f.rules {
        for t in r.pre.node.iter().chain(r.post.node.iter()) {
            collect(t, src, &mut all);
        }
    }
    let first = all.first()?.0;
    let threes = all.iter().filter(|e| e.0 == Dim::Three).count();
    let twos = all.len() - threes;
    let dim = match twos.cmp(&threes) {
        std::cmp::Ordering::Greater => Dim::Two,
        std::cmp::Ordering::Less => Dim::Three,
        std::cmp::Ordering::Equal => first,
    };
    let (_, span, why) = all.iter().find(|e| e.0 == dim)?.clone();
    let agree = if dim == Dim::Two { twos } else { threes };
    Some(DimSource {
        dim,
        why: format!(
            "{agree} of the {} terms of the rules file that decide the dimension are {}; the first: {why}",
            all.len(),
            dim.name()
        ),
        label: Some(Label::new(file, span, format!("{} because of this term", dim.name()))),
        agreeing: agree,
    })
}
