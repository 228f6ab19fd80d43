//! Warnings about rules that check clean but hold a slip their author would want to be told
//! of (only what is certain is said):
//!
//! - W504: a move onto a cell the precondition requires to hold an agent (blocked unless
//!   that agent moves away in the same step);
//! - W505: two rules of one priority and one precondition that set a character of the
//!   state, or the move, differently: whenever one fires both do, and the step records a
//!   conflict;
//! - W506: a rule that can never fire because a rule of higher priority holds wherever it
//!   holds (decided where the higher rule has no priority terms, whose truth depends on the
//!   neighbours' rules);
//! - W507: a state set one letter away from a state the rules test, which no rule tests (a
//!   typo that leaves the agent idle: `SSTPO0` for `SSTOP0`).
//!
//! A state tested that no agent starts in and no rule sets is W503 (`never.rs`), which
//! steps back where W507 says the same slip from the other end.

use crate::checked::{Action, Cond, Dim, Rule};
use crate::contradict::{cells, flatten, fmt_offset, keys, lit, range, Key};
use crate::never::pat;
use latticesim_grammar::ast::{RulesFile, Term};
use latticesim_grammar::{Code, Diagnostic, FileId, Fix, Label, Span, Spanned};
use rustc_hash::{FxHashMap as HashMap, FxHashSet as HashSet};
use std::hash::{BuildHasher, Hash};

/// How many rules of higher priority a rule is compared with for W506, at most, and how
/// many earlier rules of its group for W505 (a file of many alike rules stays linear).
const CANDIDATES: usize = 64;

/// W504 to W507 for the rules file `f` whose rules all checked (`rules`, in the same
/// order; nothing is said otherwise), in `dim`, its text `src`.
pub(crate) fn check(
    f: &RulesFile<'_>,
    rules: &[Rule],
    (file, dim, src): (FileId, Dim, &str),
    diags: &mut Vec<Diagnostic>,
) {
    if rules.len() != f.rules.len() {
        return;
    }
    // Each rule's facts are made when needed; only those of the rules that may outrank
    // others are kept (a file of 100,000 rules stays within its memory).
    let facts = |i: usize| Facts::of(f.rules[i].pre.node, &rules[i]);
    let mut contradictory = vec![false; rules.len()];
    let mut outranking: HashMap<usize, Facts> = HashMap::default();
    for (i, (a, r)) in f.rules.iter().zip(rules).enumerate() {
        let fi = facts(i);
        if let Some(d) = move_onto_agent(a.post.node, r, &fi, (file, dim)) {
            diags.push(d);
        }
        contradictory[i] = fi.contradictory;
        if !fi.contradictory && !fi.priority_terms {
            outranking.insert(i, fi);
        }
    }
    conflicts(f, rules, &contradictory, (file, src), diags);
    outranked(f, rules, (&outranking, facts), file, diags);
    // A tested state no rule sets may be where agents start: judged with them (or
    // without an agents file) in `lib.rs`.
    let set = misspelt_states(f).into_iter().filter(|m| m.tested_is_set);
    diags.extend(set.map(|m| m.diagnostic(file)));
}

/// What a precondition's AND-joined terms (outside any `!`) demand (kept small: a file of
/// 100,000 rules holds one per rule).
struct Facts<'c> {
    /// The conditions, with the spans of the terms that wrote them and where the facts
    /// each pins down end in `keys`.
    conds: Box<[(&'c Cond, Span, u32)]>,
    /// Every fact they pin down, condition by condition.
    keys: Box<[(Key, u8)]>,
    /// Two of them pin one fact to different values (W502 says so; the rule never fires).
    contradictory: bool,
    /// A priority term anywhere (its truth depends on the neighbours' rules).
    priority_terms: bool,
    /// A bit per thing its conditions speak of (each pinned fact, each value compared, each
    /// other kind of condition): a rule holds wherever another does only if the other's
    /// bits hold all of its own (a quick test before [`Facts::hold_where`]).
    sig: u64,
}

/// The bit of [`Facts::sig`] for a thing conditions speak of.
fn bit(x: impl Hash) -> u64 {
    1 << (rustc_hash::FxBuildHasher.hash_one(x) % 64)
}

/// The bits of [`Facts::sig`] a condition has beside those of the facts it pins: those
/// that whatever implies it ([`implied`]) has too. A comparison: the value compared; a
/// message pattern: its direction; a condition only an equal one implies: its kind.
fn sig_of(c: &Cond) -> u64 {
    if let Some((v, _, _)) = range(c) {
        return bit(v);
    }
    match c {
        Cond::Neighbors(_) | Cond::Attached(_) | Cond::State(_) => 0,
        Cond::Empty(o) | Cond::Filled(o) | Cond::RemoteState(o, _) if lit(o).is_some() => 0,
        Cond::Message { dir: Some(d), .. } => bit(("message", d.index())),
        _ => bit(std::mem::discriminant(c)),
    }
}

impl<'c> Facts<'c> {
    fn of(terms: &[Spanned<Term<'_>>], r: &'c Rule) -> Facts<'c> {
        let Cond::And(conds) = &r.pre else {
            unreachable!("a checked precondition is an `And` at the top")
        };
        let mut flat = Vec::new();
        flatten(terms, conds, &mut flat);
        let (mut keyed, mut sig) = (Vec::new(), 0);
        let conds = (flat.iter())
            .map(|&(c, t)| {
                let pinned = keys(c);
                sig |= pinned.iter().fold(sig_of(c), |s, k| s | bit(k.0));
                keyed.extend(pinned);
                (c, t.span, keyed.len() as u32)
            })
            .collect();
        let mut facts = Facts {
            conds,
            keys: keyed.into_boxed_slice(),
            contradictory: false,
            priority_terms: has_priority_terms(&r.pre),
            sig,
        };
        facts.contradictory =
            (facts.keys.iter()).any(|&(k, v)| facts.get(k).is_some_and(|w| w != v));
        facts
    }

    /// The value the conditions pin `k` to (the first, if several).
    fn get(&self, k: Key) -> Option<u8> {
        self.keys.iter().find(|e| e.0 == k).map(|e| e.1)
    }

    /// Each condition with the facts it pins down.
    fn each(&self) -> impl Iterator<Item = (&'c Cond, Span, &[(Key, u8)])> {
        let mut start = 0;
        self.conds.iter().map(move |&(c, span, end)| {
            let pinned = &self.keys[start as usize..end as usize];
            start = end;
            (c, span, pinned)
        })
    }

    /// The whole state the precondition tests, if it tests all five characters.
    fn state(&self) -> Option<[u8; 5]> {
        let mut s = [0; 5];
        for (k, c) in s.iter_mut().enumerate() {
            *c = self.get(Key::State(k as u8))?;
        }
        Some(s)
    }

    /// Whether every condition of these facts holds wherever `by`'s all hold.
    fn hold_where(&self, by: &Facts) -> bool {
        self.sig & !by.sig == 0 && self.each().all(|(c, _, k)| implied((c, k), by))
    }
}

fn has_priority_terms(c: &Cond) -> bool {
    match c {
        Cond::Priorities { .. } | Cond::Less(_) | Cond::LessEq(_) => true,
        Cond::And(cs) => cs.iter().any(has_priority_terms),
        Cond::Not(c) => has_priority_terms(c),
        _ => false,
    }
}

/// Whether condition `c` holds wherever the facts `by` all hold: the same condition among
/// them, a comparison whose range holds theirs, or a pattern whose every fact they pin to
/// the same value.
fn implied((c, pinned): (&Cond, &[(Key, u8)]), by: &Facts) -> bool {
    if by.conds.iter().any(|&(d, _, _)| d == c) {
        return true;
    }
    if let Some((v, lo, hi)) = range(c) {
        let within = |d: &Cond| range(d).is_some_and(|(w, l, h)| w == v && l >= lo && h <= hi);
        if by.conds.iter().any(|(d, _, _)| within(d)) {
            return true;
        }
    }
    // Conditions that are exactly the facts they pin (a message pattern also needs a
    // message from that direction, which only another test of one gives).
    let keyed = match c {
        Cond::Neighbors(_) | Cond::Attached(_) | Cond::State(_) => true,
        Cond::Empty(o) | Cond::Filled(o) | Cond::RemoteState(o, _) => lit(o).is_some(),
        Cond::Message { dir: Some(d), .. } => (by.conds.iter())
            .any(|(x, _, _)| matches!(x, Cond::Message { dir: Some(e), .. } if e == d)),
        _ => false,
    };
    keyed && pinned.iter().all(|&(k, v)| by.get(k) == Some(v))
}

/// W504 for one rule: its move (postcondition `terms`) goes to a literal offset whose cell
/// the precondition requires to hold an agent. Not said when the rule bonds, or requires a
/// bond that way (a carried group moves along).
fn move_onto_agent(
    terms: &[Spanned<Term<'_>>],
    r: &Rule,
    facts: &Facts,
    (file, dim): (FileId, Dim),
) -> Option<Diagnostic> {
    let (k, o) = (r.post.iter().enumerate()).find_map(|(k, a)| match a {
        Action::Move(o) => lit(o).map(|o| (k, o)),
        _ => None,
    })?;
    let bonds = r.post.iter().any(|a| matches!(a, Action::Attach(_)))
        || crate::checked::Dir::from_offset(o)
            .is_some_and(|d| facts.get(Key::Attach(d.index() as u8)) == Some(1));
    if bonds || facts.get(Key::Cell(o)) != Some(1) || facts.contradictory {
        return None;
    }
    let &(_, by, _) = (facts.conds.iter()).find(|(c, _, _)| cells(c).any(|(p, f)| p == o && f))?;
    let place = fmt_offset(o, dim == Dim::Three);
    Some(
        Diagnostic::new(
            Code::W504,
            format!(
                "this move goes to {place}, where the precondition requires an agent: it is \
                 blocked unless that agent moves away in the same step"
            ),
            Label::new(file, terms[k].span, "moves onto an agent"),
        )
        .with_secondary(Label::new(file, by, "requires an agent there"))
        .with_help(
            "to move into a free cell, require it empty (`E` or a `0` in the `N` pattern); \
             if the agent there always moves on in the same step, allow W504",
        ),
    )
}

/// W505: rules of one priority whose preconditions are the same terms (in any order), of
/// which a later one sets a character of the state, or the move, differently from an
/// earlier one.
fn conflicts(
    f: &RulesFile<'_>,
    rules: &[Rule],
    contradictory: &[bool],
    (file, src): (FileId, &str),
    diags: &mut Vec<Diagnostic>,
) {
    // A rule's group: its priority and its precondition's terms as written, in sorted
    // order; hashed (rules whose hashes agree are compared in full).
    let terms = |i: usize| {
        let mut t: Vec<&str> = (f.rules[i].pre.node.iter())
            .map(|t| crate::written(src, t.span))
            .collect();
        t.sort_unstable();
        (rules[i].priority, t)
    };
    let mut groups: HashMap<u64, Vec<usize>> = HashMap::default();
    for i in (0..rules.len()).filter(|&i| !contradictory[i]) {
        let key = rustc_hash::FxBuildHasher.hash_one(terms(i));
        groups.entry(key).or_default().push(i);
    }
    let mut said = Vec::new();
    for group in groups.values().filter(|g| g.len() > 1) {
        for (n, &j) in group.iter().enumerate().skip(1) {
            let clash = (group[n.saturating_sub(CANDIDATES)..n].iter())
                .filter(|&&i| terms(i) == terms(j))
                .find_map(|&i| differ(&rules[i], &rules[j]).map(|(ki, kj, why)| (i, ki, kj, why)));
            let Some((i, ki, kj, why)) = clash else {
                continue;
            };
            let (ti, tj) = (&f.rules[i].post.node[ki], &f.rules[j].post.node[kj]);
            said.push((
                j,
                Diagnostic::new(
                    Code::W505,
                    format!(
                        "`{}` and `{}` of the rule `{}` {why}: the two rules have the same \
                         priority and precondition, so whenever one fires both do, and the \
                         step records a conflict",
                        crate::written(src, tj.span),
                        crate::written(src, ti.span),
                        rules[i].name
                    ),
                    Label::new(file, tj.span, "always conflicts"),
                )
                .with_secondary(Label::new(file, ti.span, "with this action"))
                .with_help(
                    "make the preconditions differ where the actions should, or merge the \
                     two rules",
                ),
            ));
        }
    }
    said.sort_by_key(|s| s.0);
    diags.extend(said.into_iter().map(|s| s.1));
}

/// Where rules `a` and `b` ask for different things: the indices of the two actions, and
/// in words.
fn differ(a: &Rule, b: &Rule) -> Option<(usize, usize, String)> {
    let find = |r: &Rule, f: fn(&Action) -> bool| r.post.iter().position(f);
    let state = |x: &Action| matches!(x, Action::State(_));
    if let (Some(i), Some(j)) = (find(a, state), find(b, state)) {
        let (Action::State(p), Action::State(q)) = (&a.post[i], &b.post[j]) else {
            unreachable!("found as states")
        };
        let k = (0..5).find(|&k| matches!((p[k], q[k]), (Some(x), Some(y)) if x != y));
        if let Some(k) = k {
            let nth = ["1st", "2nd", "3rd", "4th", "5th"][k];
            return Some((i, j, format!("set the state's {nth} character differently")));
        }
    }
    let moves = |x: &Action| matches!(x, Action::Move(_));
    if let (Some(i), Some(j)) = (find(a, moves), find(b, moves)) {
        let (Action::Move(p), Action::Move(q)) = (&a.post[i], &b.post[j]) else {
            unreachable!("found as moves")
        };
        if lit(p).is_some() && lit(q).is_some() && lit(p) != lit(q) {
            return Some((i, j, "move the agent to different cells".into()));
        }
    }
    None
}

/// W506: rules that a rule of higher priority without priority terms always outranks
/// (`outranking`: the facts of the rules that may, by index; `facts` makes any rule's).
fn outranked<'c>(
    f: &RulesFile<'_>,
    rules: &'c [Rule],
    (outranking, facts): (&HashMap<usize, Facts<'c>>, impl Fn(usize) -> Facts<'c>),
    file: FileId,
    diags: &mut Vec<Diagnostic>,
) {
    // The rules that may outrank others, by the whole state they test (such a rule holds
    // only where that state is), and those that test no whole state; highest priority
    // first, so that a rule's candidates are where each list starts.
    // Each candidate with its priority and the bits of its facts, for a quick first test.
    type Candidate = (u16, u64, usize);
    let mut by_state: HashMap<[u8; 5], Vec<Candidate>> = HashMap::default();
    let mut open = Vec::new();
    for (&h, fh) in outranking {
        let c = (rules[h].priority, fh.sig, h);
        match fh.state() {
            Some(s) => by_state.entry(s).or_default().push(c),
            None => open.push(c),
        }
    }
    let by_priority = |v: &mut Vec<Candidate>| v.sort_by_key(|c| (std::cmp::Reverse(c.0), c.2));
    by_state.values_mut().for_each(by_priority);
    by_priority(&mut open);
    for (i, r) in rules.iter().enumerate() {
        let made;
        let fi = match outranking.get(&i) {
            Some(fi) => fi,
            None => {
                made = facts(i);
                &made
            }
        };
        if fi.contradictory {
            continue;
        }
        let above = |c: &&Candidate| c.0 > r.priority;
        let same = fi
            .state()
            .and_then(|s| by_state.get(&s))
            .into_iter()
            .flatten();
        let mut candidates =
            (same.take_while(above).chain(open.iter().take_while(above))).take(CANDIDATES);
        let Some(&(_, _, h)) =
            candidates.find(|c| c.1 & !fi.sig == 0 && outranking[&c.2].hold_where(fi))
        else {
            continue;
        };
        // Fixed texts (the rules are named by the labels): a generated file may have tens
        // of thousands of these.
        diags.push(
            Diagnostic::new(
                Code::W506,
                "this rule can never fire: a rule of higher priority holds wherever it does, \
                 and outranks it",
                Label::new(file, f.rules[i].name.span, "never fires"),
            )
            .with_secondary(Label::new(file, f.rules[h].name.span, "outranks it"))
            .with_help(
                "give the rule a higher priority than the one that outranks it, or add a \
                 term to that one that rules out this rule's agents",
            ),
        );
    }
}

/// A state an `S` action sets, which no precondition pattern matches, one letter away from
/// a whole state a precondition tests: W507.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct Misspelt<'a> {
    /// The state as the action writes it.
    pub set: Spanned<&'a str>,
    /// The state the rules test.
    pub tested: [u8; 5],
    /// Whether an `S` action can set the tested state (else it occurs only where agents
    /// start in it).
    pub tested_is_set: bool,
}

impl Misspelt<'_> {
    pub(crate) fn diagnostic(&self, file: FileId) -> Diagnostic {
        let tested = String::from_utf8_lossy(&self.tested).into_owned();
        Diagnostic::new(
            Code::W507,
            format!(
                "the state `{}` set here is tested by no rule; the rules test `{tested}`, one \
                 letter away",
                self.set.node
            ),
            Label::new(file, self.set.span, "no rule tests this state"),
        )
        .with_help(format!(
            "an agent in `{}` matches no rule and stays there; write `{tested}` if that was meant",
            self.set.node
        ))
        .with_fix(Fix::replace(
            format!("set `{tested}`, the state the rules test"),
            file,
            self.set.span,
            tested,
        ))
    }
}

/// Every whole state set by an `S` action that no precondition pattern matches (anywhere,
/// `!` or not) and that is one slip from one whole state a pattern tests (of several, the
/// one that also occurs): a letter typed for another letter, or two neighbouring
/// characters swapped, one of them a letter (digits changed are taken as meant: `WAIT1`
/// beside `WAIT0` is a state of its own).
pub(crate) fn misspelt_states<'a>(f: &RulesFile<'a>) -> Vec<Misspelt<'a>> {
    let mut patterns = Vec::new();
    for r in &f.rules {
        tested(r.pre.node, &mut patterns);
    }
    let tests = Patterns::of(&patterns);
    let actions: Vec<[Option<u8>; 5]> = (f.rules.iter())
        .flat_map(|r| r.post.node)
        .filter_map(|t| match t.node {
            Term::State(s) => pat(s.node),
            _ => None,
        })
        .collect();
    let sets = Patterns::of(&actions);
    let mut out = Vec::new();
    for r in &f.rules {
        for t in r.post.node {
            let Term::State(s) = t.node else { continue };
            let Some(set) = s
                .node
                .as_bytes()
                .try_into()
                .ok()
                .filter(|b: &[u8; 5]| !b.contains(&b'*'))
            else {
                continue;
            };
            if tests.any_matches(&set) {
                continue;
            }
            // One state a pattern matches; of several, the one state that also occurs.
            let near: Vec<[u8; 5]> = one_slip_from(&set).filter(|w| tests.whole(w)).collect();
            let occurring: Vec<&[u8; 5]> = near.iter().filter(|w| sets.any_matches(w)).collect();
            let one = match (near.as_slice(), occurring.as_slice()) {
                ([w], _) => Some(*w),
                (_, [w]) => Some(**w),
                _ => None,
            };
            if let Some(tested) = one {
                out.push(Misspelt {
                    set: s,
                    tested,
                    tested_is_set: sets.any_matches(&tested),
                });
            }
        }
    }
    out
}

/// State patterns, by which characters they give: whether one matches a state is a lookup
/// per kind (at most 32), not a pass over them all.
struct Patterns {
    /// Per mask of the characters given (bit k: character k), the patterns' characters
    /// there (others zero).
    by_mask: HashMap<u8, HashSet<[u8; 5]>>,
}

impl Patterns {
    fn of(pats: &[[Option<u8>; 5]]) -> Patterns {
        let mut by_mask: HashMap<u8, HashSet<[u8; 5]>> = HashMap::default();
        for p in pats {
            let mask = (0..5)
                .filter(|&k| p[k].is_some())
                .fold(0u8, |m, k| m | 1 << k);
            by_mask
                .entry(mask)
                .or_default()
                .insert(p.map(|c| c.unwrap_or(0)));
        }
        Patterns { by_mask }
    }

    /// Whether a pattern gives all five characters of `s` (a pattern with `*` matches
    /// end states one letter from the states it means too often to be a sign of a slip).
    fn whole(&self, s: &[u8; 5]) -> bool {
        self.by_mask
            .get(&0b11111)
            .is_some_and(|set| set.contains(s))
    }

    fn any_matches(&self, s: &[u8; 5]) -> bool {
        (self.by_mask.iter()).any(|(&mask, set)| {
            let key: [u8; 5] = std::array::from_fn(|k| if mask >> k & 1 != 0 { s[k] } else { 0 });
            set.contains(&key)
        })
    }
}

/// Every state one slip from `s` ([`one_slip`]).
fn one_slip_from(s: &[u8; 5]) -> impl Iterator<Item = [u8; 5]> + '_ {
    let letters = (0..5)
        .filter(|&k| s[k].is_ascii_alphabetic())
        .flat_map(move |k| {
            (b'A'..=b'Z')
                .chain(b'a'..=b'z')
                .filter(move |&c| c != s[k])
                .map(move |c| {
                    let mut t = *s;
                    t[k] = c;
                    t
                })
        });
    let swaps = (0..4)
        .filter(|&k| s[k] != s[k + 1] && s[k..k + 2].iter().any(u8::is_ascii_alphabetic))
        .map(|k| {
            let mut t = *s;
            t.swap(k, k + 1);
            t
        });
    letters.chain(swaps)
}

/// The precondition state patterns (`S` and `T`), anywhere in the terms.
fn tested(terms: &[Spanned<Term<'_>>], out: &mut Vec<[Option<u8>; 5]>) {
    for t in terms {
        match t.node {
            Term::State(s) | Term::RemoteState { state: s, .. } => out.extend(pat(s.node)),
            Term::Group(ts) => tested(ts, out),
            Term::Not(t) => tested(std::slice::from_ref(t), out),
            _ => {}
        }
    }
}

/// Whether `a` is `b` with one letter typed for another, or two neighbouring characters
/// swapped, one of them a letter.
#[cfg(test)]
fn one_slip(a: &[u8; 5], b: &[u8; 5]) -> bool {
    one_slip_from(a).any(|t| t == *b)
}

#[cfg(test)]
mod tests {
    use super::one_slip;

    #[test]
    fn one_slip_is_a_letter_or_a_swap() {
        assert!(one_slip(b"STPO0", b"STOP0"));
        assert!(one_slip(b"STAP0", b"STOP0"));
        assert!(!one_slip(b"WAIT1", b"WAIT0"), "a digit changed is meant");
        assert!(!one_slip(b"STOP0", b"STOP0"));
        assert!(!one_slip(b"SPOT0", b"STOP0"), "not neighbours");
        assert!(!one_slip(b"XTPO0", b"STOP0"), "two slips");
        assert!(!one_slip(b"A1200", b"A2100"), "digits swapped are meant");
        assert!(one_slip(b"AB1C0", b"A1BC0"));
    }
}
