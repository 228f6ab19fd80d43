//! W603: agents that start in a state which no rule accepts (every rule's precondition
//! has an `S` term, outside any `!`, that the state fails), no rule reads in a neighbour
//! (no `T` pattern matches it) and no rule sets (no `S` action can produce it). Such agents never execute a rule, and a typo in an agents file (`SINTI0` for
//! `SINIT0`) or a sweep without `--state` looks like this; the nearest state the rules
//! name in full is suggested.

use crate::checked::{Action, CheckedRules, Cond};
use latticesim_grammar::ast::AgentsFile;
use latticesim_grammar::{Code, Diagnostic, Edit, FileId, Fix, Label, Span};
use latticesim_vm::model::TextPat;

fn matches(p: &TextPat, s: &[u8; 5]) -> bool {
    p.iter().zip(s).all(|(p, c)| p.is_none_or(|p| p == *c))
}

/// The `S` patterns of a precondition that every state it accepts must match (those
/// outside any `!`), and every `T` pattern in it.
fn patterns_of(c: &Cond, filters: &mut Vec<TextPat>, remote: &mut Vec<TextPat>, negated: bool) {
    match c {
        Cond::And(cs) => cs
            .iter()
            .for_each(|c| patterns_of(c, filters, remote, negated)),
        Cond::Not(c) => patterns_of(c, filters, remote, !negated),
        Cond::State(p) if !negated => filters.push(*p),
        Cond::RemoteState(_, p) => remote.push(*p),
        _ => {}
    }
}

/// The patterns that keep a state busy: per rule, the `S` filters of its precondition
/// (a state passes a rule when it matches all of them); the `T` patterns; the `S`
/// actions.
struct Patterns {
    filters: Vec<Vec<TextPat>>,
    remote: Vec<TextPat>,
    set: Vec<TextPat>,
}

fn patterns(rules: &CheckedRules) -> Patterns {
    let mut p = Patterns {
        filters: Vec::new(),
        remote: Vec::new(),
        set: Vec::new(),
    };
    for r in &rules.rules {
        let mut f = Vec::new();
        patterns_of(&r.pre, &mut f, &mut p.remote, false);
        p.filters.push(f);
        p.set.extend(r.post.iter().filter_map(|a| match a {
            Action::State(p) => Some(*p),
            _ => None,
        }));
    }
    p
}

impl Patterns {
    fn busy(&self, s: &[u8; 5]) -> bool {
        self.filters.iter().any(|f| f.iter().all(|p| matches(p, s)))
            || self.remote.iter().chain(&self.set).any(|p| matches(p, s))
    }

    /// The states the rules name in full.
    fn full(&self) -> Vec<[u8; 5]> {
        (self
            .filters
            .iter()
            .flatten()
            .chain(&self.remote)
            .chain(&self.set))
        .filter_map(|p| {
            let s: Option<Vec<u8>> = p.iter().copied().collect();
            s.and_then(|s| s.try_into().ok())
        })
        .collect()
    }
}

/// An idle start state, and the state to suggest instead.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Idle {
    /// The state.
    pub state: [u8; 5],
    /// The nearest state the rules name in full (tested or set), when it differs in at most
    /// two characters and no other is as near.
    pub suggestion: Option<[u8; 5]>,
}

/// Of the start states `states`, those that no rule accepts, reads in a neighbour or
/// sets, in the order given.
pub fn idle_states(rules: &CheckedRules, states: &[[u8; 5]]) -> Vec<Idle> {
    let p = patterns(rules);
    let full = p.full();
    states
        .iter()
        .filter(|s| !p.busy(s))
        .map(|s| {
            // The same nearness as W503's (a swap of two neighbours counts one; between
            // two whole states it is the same both ways).
            Idle {
                state: *s,
                suggestion: crate::never::nearest(&s.map(Some), &full),
            }
        })
        .collect()
}

/// A W603 and the idle state it is about.
pub(crate) struct IdleDiagnostic {
    pub diag: Diagnostic,
    pub idle_state: [u8; 5],
    /// The state fields of every agent that starts in it, when a fix can edit them all (at
    /// most [`FIXABLE`] agents, each with an `S` field).
    pub fields: Option<Vec<Span>>,
}

/// A fix of the agents file `file`: the state fields `fields` made `state`, which `why`
/// (e.g. "a state the rules test or set").
pub(crate) fn restate(file: FileId, fields: &[Span], state: &str, why: &str) -> Fix {
    let them = if fields.len() == 1 {
        "this agent"
    } else {
        "these agents"
    };
    Fix {
        message: format!("start {them} in `S{state}`, {why}"),
        edits: (fields.iter())
            .map(|&span| Edit {
                file,
                span,
                replacement: format!("S{state}"),
            })
            .collect(),
    }
}

/// A distinct start state of an agents file: its first agent (0-based, in file order),
/// that agent's state field (from its `S`; its position when it has none), and how many
/// agents start in it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct StartState {
    /// The state.
    pub state: [u8; 5],
    /// Its first agent.
    pub first: usize,
    /// That agent's state field.
    pub span: Span,
    /// How many agents start in it.
    pub count: usize,
    /// The agents after the first that start in it, with their state fields, up to
    /// [`FIXABLE`] agents in all: when `count` is at most that, a fix can edit every one.
    pub rest: Vec<(usize, Span)>,
}

/// The most agents in one mistyped start state that a fix edits line by line (a file of
/// more was generated, and is better generated again).
pub const FIXABLE: usize = 16;

/// The distinct start states of the agents file `f`, in order of first appearance
/// (`00000` for an agent without `S`; a state of other than five characters is an error
/// said elsewhere, and left out).
pub(crate) fn start_states(f: &AgentsFile<'_>) -> Vec<StartState> {
    let mut seen: Vec<StartState> = Vec::new();
    for (i, a) in f.agents.iter().enumerate() {
        let state: [u8; 5] = match a.state {
            Some(s) => match s.node.as_bytes().try_into() {
                Ok(b) => b,
                Err(_) => continue,
            },
            None => *b"00000",
        };
        match seen.iter_mut().find(|e| e.state == state) {
            Some(e) => {
                e.count += 1;
                if e.count <= FIXABLE {
                    e.rest.push((i, state_field(a)));
                }
            }
            None => seen.push(StartState {
                state,
                first: i,
                span: state_field(a),
                count: 1,
                rest: Vec::new(),
            }),
        }
    }
    seen
}

/// Where an agent's state is said: its `S` field, or its position when it has none.
pub fn state_field(a: &latticesim_grammar::ast::AgentLine<'_>) -> Span {
    match a.state {
        Some(s) => Span {
            start: s.span.start - 1,
            end: s.span.end,
        },
        None => a.pos[0].span.to(a.pos[a.pos.len() - 1].span),
    }
}

/// W603 for every idle start state of `seen` (the start states of the agents file
/// `file`), on its first agent's state field.
pub(crate) fn diagnostics(
    rules: &CheckedRules,
    seen: &[StartState],
    file: FileId,
) -> Vec<IdleDiagnostic> {
    let states: Vec<[u8; 5]> = seen.iter().map(|e| e.state).collect();
    idle_states(rules, &states)
        .into_iter()
        .map(|idle| {
            let StartState {
                state: st,
                first,
                span,
                count,
                ref rest,
            } = *seen.iter().find(|e| e.state == idle.state).expect("seen");
            let fields = (count <= FIXABLE && st != *b"00000").then(|| {
                std::iter::once(span)
                    .chain(rest.iter().map(|r| r.1))
                    .collect::<Vec<_>>()
            });
            let name = String::from_utf8_lossy(&st).into_owned();
            let who = if count == 1 {
                "1 agent starts".to_string()
            } else {
                format!("{count} agents start")
            };
            // Ten times as many agents as start in the near state are another kind of agent
            // (a block of walls beside its walkers), not a slip in a few lines: no
            // suggestion then.
            let meant = idle.suggestion.filter(|t| {
                seen.iter()
                    .find(|e| e.state == *t)
                    .is_none_or(|e| count < 10 * e.count)
            });
            let help = match meant {
                Some(t) => format!(
                    "did you mean `S{}`? the rules test or set that state",
                    String::from_utf8_lossy(&t)
                ),
                None => "start these agents in a state the rules test (`S`, `T`), or write a rule for this one".into(),
            };
            let mut diag = Diagnostic::new(
                Code::W603,
                format!("{who} in state `{name}`, which no rule tests (`S`, `T`) or sets: they never execute a rule"),
                Label::new(file, span, format!("agent {first} starts in `{name}`")),
            )
            .with_help(help);
            if let (Some(t), Some(f)) = (meant, &fields) {
                diag = diag.with_fix(restate(
                    file,
                    f,
                    &String::from_utf8_lossy(&t),
                    "a state the rules test or set",
                ));
            }
            IdleDiagnostic {
                diag,
                idle_state: st,
                fields,
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{check, Input};

    fn rules(text: &str) -> CheckedRules {
        let c = check(
            Input {
                name: "rules.txt",
                bytes: text.as_bytes(),
            },
            None,
            Some(latticesim_vm::model::Dim::Two),
        );
        c.rules.expect("rules without errors")
    }

    /// Tested by `S` or `T` (negated too), set by `S`, or neither; suggestions by the
    /// characters that differ.
    #[test]
    fn states_no_rule_tests_or_sets() {
        let r = rules("go\n1\nSINIT0 !T1,0,WALL*\nSDONE0\n");
        let states = [
            *b"INIT0", *b"WALL1", *b"DONE0", *b"INTI0", *b"XXXXX", *b"ONIT0",
        ];
        let idle = idle_states(&r, &states);
        assert_eq!(
            idle,
            [
                Idle {
                    state: *b"INTI0",
                    suggestion: Some(*b"INIT0")
                },
                Idle {
                    state: *b"XXXXX",
                    suggestion: None
                },
                Idle {
                    state: *b"ONIT0",
                    suggestion: Some(*b"INIT0")
                },
            ]
        );
        // A rule without an `S` term (or with one only under `!`) accepts every state.
        let r = rules("fall\n1\nN***0\nP0,-1\n\nnot\n2\n!SA**** N1***\nSB****\n");
        assert!(idle_states(&r, &[*b"00000", *b"AAAAA"]).is_empty());
        let r = rules("two\n1\n(SA**** S*B***)\nSC****\n");
        let idle = idle_states(&r, &[*b"ABxxx", *b"AAxxx"]);
        assert_eq!(idle.len(), 1, "both filters in a group must hold: {idle:?}");
        assert_eq!(idle[0].state, *b"AAxxx");
        // A rule that keeps every character can set any state.
        let r = rules("keep\n1\nSA****\nS*****\n");
        assert!(idle_states(&r, &[*b"ZZZZZ"]).is_empty());
        // Two states as near: no suggestion.
        let r = rules("a\n1\nSAAAA0\nSAAAA1\n");
        assert_eq!(idle_states(&r, &[*b"AAAA2"])[0].suggestion, None);
    }
}
