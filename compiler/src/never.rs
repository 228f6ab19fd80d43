//! W503: an `S` or `T` pattern of a precondition (outside any `!`) that no state can match:
//! no agent starts in a state it matches and no `S` action can produce one. The rule can
//! never fire, and a typo (`SINTI0` for `SINIT0`) looks like this; the nearest state that
//! does occur is suggested, as a fix.
//!
//! An `S` action with `*` keeps those characters of the state before it, so it is taken to
//! produce any character there: the warning is only given when no state can match.

use latticesim_grammar::ast::{RulesFile, Term};
use latticesim_grammar::{Code, Diagnostic, FileId, Fix, Label, Spanned};

/// A state, or a state pattern: `None` for `*`.
type Pat = [Option<u8>; 5];

pub(crate) fn pat(text: &str) -> Option<Pat> {
    let b: [u8; 5] = text.as_bytes().try_into().ok()?;
    Some(b.map(|c| (c != b'*').then_some(c)))
}

fn compatible(a: &Pat, b: &Pat) -> bool {
    a.iter()
        .zip(b)
        .all(|(x, y)| x.is_none() || y.is_none() || x == y)
}

/// A tested pattern: where, its text, whether a `T` term's.
type Tested = (latticesim_grammar::Span, String, bool);

/// What the warnings about states read of a rules file, owned: per rule its name and the
/// `S` and `T` patterns its precondition tests (outside any `!`), the patterns its `S`
/// actions set, how often each state is written, and the states set one letter from a
/// tested one (W507). Made with the check, so that the fast reader of agents files, which
/// learns the start states only once the rules are checked, does not parse the rules
/// again (half the time of a language server's check of 5,005 rules was parsing them).
#[derive(Debug, Clone, Default)]
pub struct StateFacts {
    /// Per rule: its name, and its tested patterns.
    tests: Vec<(String, Vec<Tested>)>,
    /// The patterns of `S` actions.
    actions: Vec<Pat>,
    /// How often each state is written (tests and actions).
    pub(crate) spelled: std::collections::HashMap<String, usize>,
    /// States set one letter from a tested one: where, as written, the tested state, and
    /// whether an action sets the tested state.
    misspelt: Vec<(latticesim_grammar::Span, String, [u8; 5], bool)>,
}

impl StateFacts {
    pub(crate) fn of(rules: &RulesFile<'_>) -> StateFacts {
        let tests = (rules.rules.iter())
            .map(|r| {
                let mut pats = Vec::new();
                tested(r.pre.node, &mut pats);
                let pats = (pats.into_iter())
                    .map(|(s, remote)| (s.span, s.node.to_string(), remote))
                    .collect();
                (r.name.node.to_string(), pats)
            })
            .collect();
        let actions = (rules.rules.iter())
            .flat_map(|r| r.post.node)
            .filter_map(|t| match t.node {
                Term::State(s) => pat(s.node),
                _ => None,
            })
            .collect();
        let spelled = (spelled(rules).into_iter())
            .map(|(k, v)| (k.to_string(), v))
            .collect();
        let misspelt = (crate::slips::misspelt_states(rules).into_iter())
            .map(|m| {
                (
                    m.set.span,
                    m.set.node.to_string(),
                    m.tested,
                    m.tested_is_set,
                )
            })
            .collect();
        StateFacts {
            tests,
            actions,
            spelled,
            misspelt,
        }
    }

    /// The states set one letter from a tested one (see [`crate::slips::misspelt_states`]).
    pub(crate) fn misspelt(&self) -> Vec<crate::slips::Misspelt<'_>> {
        (self.misspelt.iter())
            .map(|(span, set, tested, is_set)| crate::slips::Misspelt {
                set: Spanned::new(set.as_str(), *span),
                tested: *tested,
                tested_is_set: *is_set,
            })
            .collect()
    }
}

/// The states that occur: start states and `S` actions (with their `*`s).
fn occurring(facts: &StateFacts, start: &[[u8; 5]]) -> Vec<Pat> {
    let mut out: Vec<Pat> = Vec::new();
    let mut seen = std::collections::HashSet::new();
    let mut add = |p: Pat| {
        if seen.insert(p) {
            out.push(p);
        }
    };
    for s in start {
        add(s.map(Some));
    }
    facts.actions.iter().copied().for_each(add);
    out
}

/// The `S` and `T` state patterns of a precondition outside any `!` (true for `T`).
fn tested<'a>(terms: &[Spanned<Term<'a>>], out: &mut Vec<(Spanned<&'a str>, bool)>) {
    for t in terms {
        match t.node {
            Term::State(s) => out.push((s, false)),
            Term::RemoteState { state, .. } => out.push((state, true)),
            Term::Group(ts) => tested(ts, out),
            _ => {}
        }
    }
}

/// A pattern that matches nothing, and the nearest state that occurs (if one is clearly
/// nearest, at most two edits away).
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct Never<'a> {
    pub pattern: Spanned<&'a str>,
    pub is_remote: bool,
    pub rule: &'a str,
    pub nearest: Option<[u8; 5]>,
}

/// Every precondition pattern of the rules that no occurring state matches.
pub(crate) fn never<'a>(facts: &'a StateFacts, start: &[[u8; 5]]) -> Vec<Never<'a>> {
    let occ = occurring(facts, start);
    let full: Vec<[u8; 5]> = occ
        .iter()
        .filter_map(|p| {
            let s: Option<Vec<u8>> = p.iter().copied().collect();
            s.and_then(|s| s.try_into().ok())
        })
        .collect();
    let mut out = Vec::new();
    // A pattern without `*` matches a state that occurs in full when it is that state,
    // else a pattern with `*` that occurs (`S` actions that keep characters).
    let whole: std::collections::HashSet<[u8; 5]> = full.iter().copied().collect();
    let mut index = Index::of(&full);
    let by_place = Places::of(&occ);
    for (rule, pats) in &facts.tests {
        for (span, text, is_remote) in pats {
            let (s, is_remote) = (Spanned::new(text.as_str(), *span), *is_remote);
            let Some(p) = pat(s.node) else { continue };
            let matched = match exact(&p) {
                Some(e) => whole.contains(&e) || by_place.any_compatible(&p, &occ),
                None => by_place.any_compatible(&p, &occ),
            };
            if matched {
                continue;
            }
            out.push(Never {
                pattern: s,
                is_remote,
                rule: rule.as_str(),
                nearest: nearest(&p, index.near(&p, &full)),
            });
        }
    }
    out
}

/// The occurring patterns by what they hold at each place: a pattern with `*` is looked
/// for only among those that agree with it at its most selective fixed place (a scan of
/// every occurring state for each of 600 patterns that match nothing was a quarter of the
/// check of 5,005 generated rules).
struct Places {
    /// Per place and character, the patterns with that character there.
    at: Vec<Vec<u32>>,
    /// Per place, the patterns with `*` there.
    star: [Vec<u32>; 5],
}

impl Places {
    fn of(occ: &[Pat]) -> Places {
        let mut at = vec![Vec::new(); 5 * 256];
        let mut star: [Vec<u32>; 5] = Default::default();
        for (k, o) in occ.iter().enumerate() {
            for (i, c) in o.iter().enumerate() {
                match c {
                    Some(c) => at[i * 256 + *c as usize].push(k as u32),
                    None => star[i].push(k as u32),
                }
            }
        }
        Places { at, star }
    }

    /// Whether some pattern of `occ` is compatible with `p`.
    fn any_compatible(&self, p: &Pat, occ: &[Pat]) -> bool {
        let best = (p.iter().enumerate())
            .filter_map(|(i, c)| c.map(|c| (i, c)))
            .min_by_key(|&(i, c)| self.at[i * 256 + c as usize].len() + self.star[i].len());
        match best {
            None => !occ.is_empty(),
            Some((i, c)) => (self.at[i * 256 + c as usize].iter())
                .chain(&self.star[i])
                .any(|&k| compatible(p, &occ[k as usize])),
        }
    }
}

/// A pattern without `*` as the state it is.
fn exact(p: &Pat) -> Option<[u8; 5]> {
    let mut e = [0; 5];
    for (c, x) in e.iter_mut().zip(p) {
        *c = (*x)?;
    }
    Some(e)
}

/// The states that can be at most two edits from a pattern without `*`: a state two
/// edits away agrees with it at two places or more (a change and a swap of neighbours
/// leave two, two changes three), unless the edits are two swaps of neighbours, which
/// leave one; so the states are found by the pairs of places they agree at, and the three
/// double swaps are looked up whole. Also, per state, the last search that measured it (so
/// that each is measured once). Made at the first search.
/// (A search of every state for each of 600 patterns, and then of every state with one
/// character in place, was most of the check of 5,005 generated rules.)
struct Index {
    pairs: rustc_hash::FxHashMap<u32, Vec<u32>>,
    whole: rustc_hash::FxHashMap<[u8; 5], u32>,
    seen: Vec<u32>,
    search: u32,
}

/// The pairs of places (i < j) of a state.
const PAIRS: [(usize, usize); 10] = [
    (0, 1),
    (0, 2),
    (0, 3),
    (0, 4),
    (1, 2),
    (1, 3),
    (1, 4),
    (2, 3),
    (2, 4),
    (3, 4),
];

/// A pair of places and the characters there, as a key.
fn pair_key(k: usize, a: u8, b: u8) -> u32 {
    (k as u32) << 16 | (a as u32) << 8 | b as u32
}

impl Index {
    fn of(full: &[[u8; 5]]) -> Index {
        Index {
            pairs: Default::default(),
            whole: Default::default(),
            seen: vec![0; full.len()],
            search: 0,
        }
    }

    fn make(&mut self, full: &[[u8; 5]]) {
        if !self.whole.is_empty() || full.is_empty() {
            return;
        }
        for (n, f) in full.iter().enumerate() {
            self.whole.insert(*f, n as u32);
            for (k, &(i, j)) in PAIRS.iter().enumerate() {
                self.pairs
                    .entry(pair_key(k, f[i], f[j]))
                    .or_default()
                    .push(n as u32);
            }
        }
    }
}

/// The state among `candidates` nearest to `p`, when one is clearly nearest (no other
/// state at its distance) and at most two edits away; in one pass, each distance given up
/// past two. The answer does not depend on the candidates' order.
pub(crate) fn nearest<'s>(
    p: &Pat,
    candidates: impl IntoIterator<Item = &'s [u8; 5]>,
) -> Option<[u8; 5]> {
    let mut best: Option<(usize, [u8; 5], bool)> = None;
    for f in candidates {
        let Some(d) = distance_within(p, f, 2) else {
            continue;
        };
        best = match best {
            Some((b, s, alone)) if d == b => Some((b, s, alone && s == *f)),
            Some((b, ..)) if d > b => best,
            _ => Some((d, *f, true)),
        };
    }
    best.filter(|b| b.2).map(|b| b.1)
}

impl Index {
    /// The states of `full` that can be at most two edits from `p` (every one when `p` has
    /// a `*`), each once.
    fn near<'a>(&'a mut self, p: &Pat, full: &'a [[u8; 5]]) -> impl Iterator<Item = &'a [u8; 5]> {
        self.make(full);
        self.search += 1;
        let (search, seen) = (self.search, &mut self.seen);
        let ks: Vec<u32> = match exact(p) {
            Some(e) => {
                let swap = |mut s: [u8; 5], a: usize, b: usize| {
                    s.swap(a, a + 1);
                    s.swap(b, b + 1);
                    s
                };
                let doubles = [(0, 2), (0, 3), (1, 3)].map(|(a, b)| swap(e, a, b));
                (PAIRS.iter().enumerate())
                    .filter_map(|(k, &(i, j))| self.pairs.get(&pair_key(k, e[i], e[j])))
                    .flatten()
                    .copied()
                    .chain(doubles.iter().filter_map(|d| self.whole.get(d).copied()))
                    .collect()
            }
            None => (0..full.len() as u32).collect(),
        };
        ks.into_iter()
            .filter(move |&k| std::mem::replace(&mut seen[k as usize], search) != search)
            .map(move |k| &full[k as usize])
    }
}

/// The edits (changed characters, or two neighbours swapped) between a pattern and a
/// state, when they are at most `max`, else `None` (found without going further).
pub(crate) fn distance_within(p: &Pat, s: &[u8; 5], max: usize) -> Option<usize> {
    let same = |i: usize, c: u8| p[i].is_none_or(|x| x == c);
    let (mut i, mut d) = (0, 0);
    while i < 5 {
        if same(i, s[i]) {
            i += 1;
            continue;
        }
        d += 1;
        if d > max {
            return None;
        }
        i += if i + 1 < 5 && same(i, s[i + 1]) && same(i + 1, s[i]) {
            2
        } else {
            1
        };
    }
    Some(d)
}

/// How many times the rules write each state in full: in `S` and `T` patterns (negated
/// too) and `S` actions. Counted once for the file (a walk per pattern was quadratic: 5,005
/// generated rules took a second).
pub(crate) fn spelled<'a>(rules: &RulesFile<'a>) -> std::collections::HashMap<&'a str, usize> {
    fn walk<'a>(terms: &[Spanned<Term<'a>>], out: &mut std::collections::HashMap<&'a str, usize>) {
        for t in terms {
            match t.node {
                Term::State(s) | Term::RemoteState { state: s, .. } => {
                    *out.entry(s.node).or_default() += 1
                }
                Term::Group(ts) => walk(ts, out),
                Term::Not(t) => walk(std::slice::from_ref(t), out),
                _ => {}
            }
        }
    }
    let mut out = std::collections::HashMap::new();
    for r in &rules.rules {
        walk(r.pre.node, &mut out);
        walk(r.post.node, &mut out);
    }
    out
}

/// Where agents start in a state near a pattern that matches nothing: the same slip seen
/// from the agents file.
pub(crate) struct Idle {
    /// Their first agent's state field.
    pub label: Label,
    /// The fix that starts them in the pattern's state instead (when it is a state in full
    /// and few enough agents start there to edit each).
    pub fix: Option<Fix>,
}

/// W503 for one pattern that matches nothing. `idle`, when agents start in a state no
/// rule tests near this pattern: the same slip, shown here instead of as a W603 of its
/// own. Which file holds the slip: when the rules write the pattern's state more than
/// once, they mean it, and the fix edits the agents file; otherwise the fix edits the
/// pattern, and the agents file's fix comes second.
pub(crate) fn diagnostic(
    n: &Never<'_>,
    file: FileId,
    idle: Option<Idle>,
    spelled: &std::collections::HashMap<String, usize>,
) -> Diagnostic {
    let what = if n.is_remote {
        "no neighbour can ever be in a state it matches"
    } else {
        "no agent can ever be in a state it matches"
    };
    let mut d = Diagnostic::new(
        Code::W503,
        format!(
            "the rule `{}` can never fire: `{}` matches no state an agent starts in or a rule sets",
            n.rule, n.pattern.node
        ),
        Label::new(file, n.pattern.span, what),
    )
    .with_help(
        "a state occurs when an agent starts in it or an `S` action sets it; check the spelling",
    );
    let (label, agents_fix) = match idle {
        Some(i) => (Some(i.label), i.fix),
        None => (None, None),
    };
    if let Some(l) = label {
        d = d.with_secondary(l);
    }
    let meant = spelled.get(n.pattern.node).is_some_and(|&k| k > 1);
    if let (Some(s), false) = (n.nearest, meant) {
        let s = String::from_utf8_lossy(&s).into_owned();
        d = d.with_fix(Fix::replace(
            format!("did you mean `{s}`? it occurs"),
            file,
            n.pattern.span,
            s,
        ));
    }
    if let Some(f) = agents_fix {
        d = d.with_fix(f);
    }
    d
}

#[cfg(test)]
mod tests {
    use super::*;

    fn distance(p: &Pat, s: &[u8; 5]) -> usize {
        distance_within(p, s, usize::MAX).expect("no limit")
    }

    #[test]
    fn distances_count_swaps_once_and_stars_as_any() {
        let p = pat("INTI0").unwrap();
        assert_eq!(distance(&p, b"INIT0"), 1);
        assert_eq!(distance(&p, b"INTI0"), 0);
        assert_eq!(distance(&pat("IN**0").unwrap(), b"INXY0"), 0);
        assert_eq!(distance(&pat("ABCDE").unwrap(), b"XBCDY"), 2);
        assert!(compatible(&pat("A****").unwrap(), &pat("**B**").unwrap()));
        assert!(!compatible(&pat("A****").unwrap(), &pat("B****").unwrap()));
    }

    /// The index finds every state within two edits of a pattern, whatever its kind (a
    /// brute-force search over all states agrees), among states made of few letters.
    #[test]
    fn the_index_finds_what_a_search_of_every_state_finds() {
        let letters = b"ABC";
        let mut full = Vec::new();
        for n in 0..243u32 {
            let mut s = [0u8; 5];
            let mut m = n;
            for c in s.iter_mut() {
                *c = letters[(m % 3) as usize];
                m /= 3;
            }
            if n % 7 != 3 {
                full.push(s);
            }
        }
        let mut index = Index::of(&full);
        for p in [
            *b"BADCE", *b"ABCDE", *b"CABBA", *b"ZZZZZ", *b"ABZZC", *b"BACBA",
        ] {
            let p = p.map(Some);
            let mut want: Vec<[u8; 5]> = (full.iter())
                .filter(|f| distance_within(&p, f, 2).is_some())
                .copied()
                .collect();
            let mut got: Vec<[u8; 5]> = (index.near(&p, &full))
                .filter(|f| distance_within(&p, f, 2).is_some())
                .copied()
                .collect();
            want.sort();
            got.sort();
            assert_eq!(got, want, "{p:?}");
        }
        // Two swaps of neighbours: one place agrees.
        let f = [*b"ABCDE"];
        let mut index = Index::of(&f);
        let p = pat("BADCE").unwrap();
        assert_eq!(nearest(&p, index.near(&p, &f)), Some(*b"ABCDE"));
    }
}
