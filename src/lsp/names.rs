//! The names of a rules file and an agents file, with where each is written: states (in `S`
//! and `T` terms and agents' `S` fields), counters (`Cnn` wherever a rule reads or writes one,
//! agents' `Cnn` fields) and rule names. Go to definition, find references and rename work
//! on these lists (`super::navigate`).

use bumpalo::Bump;
use latticesim_grammar::ast::{Comp, Operand, RulesFile, Term, Value};
use latticesim_grammar::{FileId, Span, Spanned};

/// What kind of name.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum What {
    /// A state or state pattern (five characters, `*` for any).
    State,
    /// A counter; the text is its digits.
    Counter,
    /// A rule's name.
    Rule,
}

/// What the place does with the name.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Role {
    /// A precondition tests it (a state) or reads it (a counter).
    Read,
    /// A postcondition sets it (a state) or a calculation writes it (a counter).
    Written,
    /// An agent starts with it (the agents file).
    Start,
    /// The rule's name line.
    Named,
}

impl Role {
    /// Where the name gets its value: a postcondition, an agent's start, a rule's name.
    pub fn defines(self) -> bool {
        self != Role::Read
    }
}

/// One place where a name is written.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Occurrence<'t> {
    /// The kind of name.
    pub what: What,
    /// As written: the state pattern, the counter's digits, the rule's name.
    pub text: &'t str,
    /// Where `text` stands (without the `S` or `C` before it).
    pub span: Span,
    /// What the place does with it.
    pub role: Role,
    /// The file: 0 rules, 1 agents.
    pub file: FileId,
}

impl Occurrence<'_> {
    /// True when the cursor at byte `at` is on this name or on the letter before it.
    pub fn under(&self, at: usize) -> bool {
        let lead = usize::from(self.what != What::Rule);
        (self.span.start as usize).saturating_sub(lead) <= at && at <= self.span.end as usize
    }

    /// True for a state pattern with a `*`.
    pub fn is_pattern(&self) -> bool {
        self.what == What::State && self.text.contains('*')
    }

    /// True when this place names `name` (of the same kind): the same state, a pattern that
    /// matches it (with at least one character given) or the same pattern; the same counter
    /// number; the same rule name.
    pub fn names(&self, what: What, name: &str) -> bool {
        if self.what != what {
            return false;
        }
        match what {
            What::Rule => self.text == name,
            What::Counter => counter_number(self.text) == counter_number(name),
            What::State => {
                if self.text == name {
                    return true;
                }
                let (pattern, state) = if self.is_pattern() {
                    (self.text, name)
                } else {
                    (name, self.text)
                };
                !state.contains('*') && meaningful(pattern) && matches(pattern, state)
            }
        }
    }
}

/// A counter's number from its digits (`03` and `3` are one counter).
pub fn counter_number(digits: &str) -> Option<u32> {
    digits.parse().ok()
}

/// A pattern that says something: not all `*`.
fn meaningful(pattern: &str) -> bool {
    pattern.chars().any(|c| c != '*')
}

/// True when `pattern` (with `*` for any character) matches `state`.
fn matches(pattern: &str, state: &str) -> bool {
    pattern.chars().count() == state.chars().count()
        && pattern
            .chars()
            .zip(state.chars())
            .all(|(p, s)| p == '*' || p == s)
}

impl<'t> Occurrence<'t> {
    /// The place `span` of `text`, if it holds something.
    fn at(text: &'t str, what: What, span: Span, role: Role, file: FileId) -> Option<Self> {
        let t = text.get(span.start as usize..span.end as usize)?;
        (!t.is_empty()).then_some(Occurrence {
            what,
            text: t,
            span,
            role,
            file,
        })
    }
}

/// Every name of a rules file, in file order.
pub fn in_rules(text: &str) -> Vec<Occurrence<'_>> {
    let arena = Bump::new();
    let (f, _) = latticesim_grammar::parse_rules(text, FileId(0), &arena, None);
    of_rules(&f, text)
}

/// Every name of the parsed rules file `f` of `text`, in file order.
pub fn of_rules<'t>(f: &RulesFile<'_>, text: &'t str) -> Vec<Occurrence<'t>> {
    let mut out = Vec::new();
    let mut push = |what: What, span: Span, role: Role| {
        out.extend(Occurrence::at(text, what, span, role, FileId(0)));
    };
    for r in &f.rules {
        push(What::Rule, r.name.span, Role::Named);
        for t in r.pre.node {
            term(t, Role::Read, &mut push);
        }
        for t in r.post.node {
            term(t, Role::Written, &mut push);
        }
    }
    out
}

/// Every name of an agents file: each agent's state and counters.
pub fn in_agents(text: &str) -> Vec<Occurrence<'_>> {
    let (f, _) = latticesim_grammar::parse_agents(text, FileId(1));
    let mut out = Vec::new();
    for a in &f.agents {
        let fields = a.state.iter().map(|s| (What::State, s.span));
        let counters = a.counters.iter().map(|(c, _)| (What::Counter, c.span));
        for (what, span) in fields.chain(counters) {
            out.extend(Occurrence::at(text, what, span, Role::Start, FileId(1)));
        }
    }
    out
}

/// The digits of a counter token `Cnn` as written in a rule.
fn counter_digits(span: Span) -> Span {
    Span::new(span.start as usize + 1, span.end as usize)
}

fn offset(comps: &[Spanned<Comp<'_>>], push: &mut impl FnMut(What, Span, Role)) {
    for c in comps {
        if let Comp::Counter(_) = c.node {
            push(What::Counter, counter_digits(c.span), Role::Read);
        }
    }
}

fn value(v: &Spanned<Value<'_>>, role: Role, push: &mut impl FnMut(What, Span, Role)) {
    if let Value::Counter(_) = v.node {
        push(What::Counter, counter_digits(v.span), role);
    }
}

/// The names in one term; `role` is the line's (Read in a precondition, Written in a
/// postcondition); what a postcondition's calculation reads is Read.
fn term(t: &Spanned<Term<'_>>, role: Role, push: &mut impl FnMut(What, Span, Role)) {
    match &t.node {
        Term::State(s) => push(What::State, s.span, role),
        Term::RemoteState { offset: o, state } => {
            offset(o.node, push);
            push(What::State, state.span, Role::Read);
        }
        Term::Empty(o) | Term::Filled(o) | Term::Less(o) | Term::LessEq(o) | Term::Move(o) => {
            offset(o.node, push)
        }
        Term::Compare(c) => {
            value(&c.lhs, Role::Read, push);
            value(&c.rhs, Role::Read, push);
        }
        Term::RemoteCompare(c) => {
            offset(c.comps.node, push);
            value(&c.rhs, Role::Read, push);
        }
        Term::Calc(c) => {
            value(&c.target, Role::Written, push);
            for o in [&c.lhs, &c.rhs] {
                match o {
                    Operand::Value(v) => value(v, Role::Read, push),
                    Operand::External(o) => offset(o.node, push),
                }
            }
        }
        Term::Not(inner) => term(inner, role, push),
        Term::Group(ts) => {
            for t in ts.iter() {
                term(t, role, push);
            }
        }
        Term::Neighbors(_)
        | Term::Attach(_)
        | Term::Priorities(_)
        | Term::Message { .. }
        | Term::Swap(_)
        | Term::Error => {}
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn shown<'t>(text: &'t str, v: &[Occurrence<'t>]) -> Vec<(What, &'t str, Role)> {
        v.iter()
            .map(|o| {
                assert_eq!(&text[o.span.start as usize..o.span.end as usize], o.text);
                (o.what, o.text, o.role)
            })
            .collect()
    }

    #[test]
    fn the_names_of_a_rule_and_their_roles() {
        let text = "// c\nwalk\n1\nSWALK0 >C01 0000 T1,0,REST* !(E0,C02)\n\
                    SWAL*1 C01 - C01 0001 P1,0 C03 + 1,0,C04 #*01\n";
        let v = in_rules(text);
        use Role::*;
        use What::*;
        assert_eq!(
            shown(text, &v),
            vec![
                (Rule, "walk", Named),
                (State, "WALK0", Read),
                (Counter, "01", Read),
                (State, "REST*", Read),
                (Counter, "02", Read),
                (State, "WAL*1", Written),
                (Counter, "01", Written),
                (Counter, "01", Read),
                (Counter, "03", Written),
                (Counter, "04", Read),
            ]
        );
    }

    #[test]
    fn the_names_of_agents() {
        let text = "U0,9,0,9\n0,0 SWALK0 C01 1000\n1,1\n2,2 C3 4 SREST0\n";
        let v = in_agents(text);
        use What::*;
        let got: Vec<_> = shown(text, &v)
            .into_iter()
            .map(|(w, t, _)| (w, t))
            .collect();
        assert_eq!(
            got,
            vec![
                (State, "WALK0"),
                (Counter, "01"),
                (State, "REST0"),
                (Counter, "3")
            ]
        );
    }

    #[test]
    fn patterns_name_the_states_they_match() {
        let o = |text| Occurrence {
            what: What::State,
            text,
            span: Span::new(0, 5),
            role: Role::Read,
            file: FileId(0),
        };
        assert!(o("REST*").names(What::State, "REST0"));
        assert!(o("REST0").names(What::State, "REST*"));
        assert!(o("REST*").names(What::State, "REST*"));
        assert!(!o("*****").names(What::State, "REST0"));
        assert!(!o("REST*").names(What::State, "WALK0"));
        assert!(!o("REST*").names(What::Counter, "REST0"));
        let c = Occurrence {
            what: What::Counter,
            text: "3",
            ..o("")
        };
        assert!(c.names(What::Counter, "03"));
    }
}
