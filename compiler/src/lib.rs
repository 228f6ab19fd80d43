//! The front end's second half: checking parsed files and rendering diagnostics.
//!
//! [`check`] is the whole pipeline from the bytes of rules.txt (and optionally agents.txt)
//! to [`CheckedRules`] and a [`Config`]: decode, parse, find the dimension, check every
//! rule and agent, sort the diagnostics. It does no I/O; the CLI reads the files and prints.
//! [`fast_agents`] reads clean agents files straight into columns, for large runs.
#![warn(missing_docs)]

mod check_agents;
mod check_rules;
pub mod checked;
mod contradict;
mod idle;
mod never;
mod slips;
pub use idle::{idle_states, state_field, Idle, StartState, FIXABLE};
pub use never::StateFacts;
pub mod describe;
pub mod diagnostics;
pub mod dim;
pub mod explain;
pub mod fast_agents;
pub mod lints;
mod lower;

pub use check_agents::{
    attach_span, bond_dropped, bond_made, check_agents, position_span, shared_cell,
};
pub use check_rules::{check_rules, VALUE_MAX};
pub use checked::{CheckedRules, Columns, Config, Dim};
pub use diagnostics::Sources;
pub use latticesim_grammar::format::format_rules;
pub use lower::{compile, lower};

use bumpalo::Bump;
use dim::DimSource;
use latticesim_grammar::ast::{RulesFile, Term};
use latticesim_grammar::{decode, parse_agents, parse_rules, Code, Diagnostic, FileId, Spanned};

/// A named input file.
pub struct Input<'a> {
    /// The name shown in messages.
    pub name: &'a str,
    /// Its bytes.
    pub bytes: &'a [u8],
}

/// What [`check`] found.
pub struct Checked {
    /// The files read, for rendering.
    pub sources: Sources,
    /// The lint levels in force: the rules file's directives, then the caller's.
    pub lints: lints::Lints,
    /// Every diagnostic, in file order.
    pub diags: Vec<Diagnostic>,
    /// The dimension in force and why.
    pub dim: DimSource,
    /// The checked rules, when there was no error.
    pub rules: Option<CheckedRules>,
    /// The checked agents, when an agents file was given and there was no error.
    pub config: Option<Config>,
    /// How many rules the file has (also when there were errors).
    pub rule_count: usize,
    /// How many agent lines the file has.
    pub agent_count: usize,
    /// Diagnostics found but not kept in `diags` (see [`SHOWN_PER_LINE`]), per file.
    pub not_shown: Vec<NotShown>,
    /// What the warnings about states read of the rules, when they checked clean (for
    /// [`states_warnings_of`]).
    pub state_facts: Option<StateFacts>,
}

/// At most this many diagnostics of one line are kept for showing; the rest are counted.
pub const SHOWN_PER_LINE: usize = 10;
/// At most this many diagnostics of one file are kept for showing, unless said otherwise
/// (`--max-diagnostics`, [`lints::Lints::set_shown`]); the rest are counted per code.
pub const SHOWN_PER_FILE: usize = 200;

/// The diagnostics of one file that were found but are not shown.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct NotShown {
    /// The file.
    pub file: FileId,
    /// Errors not shown.
    pub errors: usize,
    /// Warnings not shown.
    pub warnings: usize,
    /// Per code, how many of them are not shown, in order of their first.
    pub codes: Vec<(Code, usize)>,
    /// How many of a file were shown at most.
    pub per_file: usize,
}

impl Checked {
    /// Number of errors, shown or not.
    pub fn errors(&self) -> usize {
        self.diags.iter().filter(|d| d.is_error()).count()
            + self.not_shown.iter().map(|n| n.errors).sum::<usize>()
    }

    /// Number of warnings, shown or not.
    pub fn warnings(&self) -> usize {
        self.diags.iter().filter(|d| !d.is_error()).count()
            + self.not_shown.iter().map(|n| n.warnings).sum::<usize>()
    }

    /// The diagnostics as terminal text (ANSI colours when `color`), with a line for each
    /// file some of whose diagnostics are not shown.
    pub fn render(&self, color: bool) -> String {
        let mut text = diagnostics::render_text(&self.diags, &self.sources, color);
        for n in &self.not_shown {
            text += &diagnostics::not_shown_line(n, &self.sources);
            text.push('\n');
        }
        text
    }
}

/// E321 for a rule whose bytecode would not fit.
fn too_large(
    r: &latticesim_grammar::ast::Rule<'_>,
    file: FileId,
    why: lower::TooLarge,
) -> Diagnostic {
    use latticesim_grammar::{Code, Label};
    match why {
        lower::TooLarge::Precondition => Diagnostic::new(
            Code::E321,
            format!(
                "the precondition of `{}` is too long: it compiles to more than 65,535 instructions",
                r.name.node
            ),
            Label::new(file, r.name.span, "this rule's precondition is too long"),
        )
        .with_help("split the rule into several rules, or drop repeated terms"),
        lower::TooLarge::Constants(what) => Diagnostic::new(
            Code::E321,
            format!(
                "with `{}` the rules use more than 65,536 distinct {what}",
                r.name.node
            ),
            Label::new(file, r.name.span, "the limit is passed here"),
        )
        .with_help(format!("use fewer distinct {what} in one rules file")),
    }
}

/// A piece of a file's text as written (numbers are quoted so, not as the value they were
/// read as, which saturates).
pub(crate) fn written(src: &str, span: latticesim_grammar::Span) -> &str {
    src.get(span.start as usize..span.end as usize)
        .unwrap_or("?")
}

/// Keeps at most [`SHOWN_PER_LINE`] diagnostics of a line and `per_file` of a file (in
/// file order, so the first ones), counting the others per file and code.
fn cap(diags: &mut Vec<Diagnostic>, sources: &Sources, per_file: usize) -> Vec<NotShown> {
    let mut not_shown: Vec<NotShown> = Vec::new();
    let line_of = |d: &Diagnostic| sources.line_index(d.primary.file, d.primary.span.start);
    cap_by(diags, per_file, line_of, |d| {
        let f = d.primary.file;
        if not_shown.last().is_none_or(|n| n.file != f) {
            not_shown.push(NotShown {
                file: f,
                errors: 0,
                warnings: 0,
                codes: Vec::new(),
                per_file,
            });
        }
        not_shown.last_mut().expect("just pushed").count(d);
    });
    not_shown
}

/// Keeps at most [`SHOWN_PER_LINE`] diagnostics of a line (`line_of` tells them apart)
/// and `per_file` of a file, of diagnostics sorted ([`diagnostics::sort`]); `hidden` sees
/// the others, in order, as they are taken out.
fn cap_by(
    diags: &mut Vec<Diagnostic>,
    per_file: usize,
    line_of: impl Fn(&Diagnostic) -> usize,
    mut hidden: impl FnMut(&Diagnostic),
) {
    let (mut file, mut line, mut in_file, mut in_line) = (None, None, 0, 0);
    diags.retain(|d| {
        let f = d.primary.file;
        let l = line_of(d);
        if file != Some(f) {
            (file, line, in_file, in_line) = (Some(f), None, 0, 0);
        }
        if line != Some(l) {
            (line, in_line) = (Some(l), 0);
        }
        in_file += 1;
        in_line += 1;
        let keep = in_file <= per_file && in_line <= SHOWN_PER_LINE;
        if !keep {
            hidden(d);
            // Only what is shown counts towards the file's limit.
            in_file -= 1;
        }
        keep
    });
}

impl NotShown {
    /// Counts one more diagnostic not shown.
    fn count(&mut self, d: &Diagnostic) {
        if d.is_error() {
            self.errors += 1;
        } else {
            self.warnings += 1;
        }
        match self.codes.iter_mut().find(|c| c.0 == d.code) {
            Some(c) => c.1 += 1,
            None => self.codes.push((d.code, 1)),
        }
    }
}

/// The diagnostics of one file found a line at a time (the streaming reader of agents
/// files), of which only those that can still be shown are held: the same ones, and the
/// same counts of the others, as the checker keeps of the whole file ([`check`]), in
/// memory that does not grow with the file.
#[derive(Debug, Clone)]
pub struct Shown {
    per_file: usize,
    /// The diagnostics that may be shown, and the starts of their lines (sorted).
    kept: Vec<Diagnostic>,
    lines: Vec<usize>,
    /// The others, counted; per code, the sort key of its first and whether it is an
    /// error.
    hidden: Option<NotShown>,
    firsts: Vec<diagnostics::Key>,
    errors: Vec<bool>,
}

impl Shown {
    /// No diagnostics yet; `per_file` of them are shown (see [`lints::Lints::shown`]).
    pub fn new(per_file: usize) -> Shown {
        Shown {
            per_file,
            kept: Vec::new(),
            lines: Vec::new(),
            hidden: None,
            firsts: Vec::new(),
            errors: Vec::new(),
        }
    }

    /// Takes in the diagnostics of `later`, which were all found after these (in file
    /// order, as the parts of a file read on several threads).
    pub fn absorb(&mut self, later: Shown) {
        for (d, line) in later.with_lines() {
            self.push(d, line);
        }
        if let Some(n) = later.hidden {
            for (k, &(code, count)) in n.codes.iter().enumerate() {
                self.hide(code, later.errors[k], later.firsts[k], count);
            }
        }
    }

    /// The diagnostics held, each with the start of its line.
    fn with_lines(&self) -> Vec<(Diagnostic, usize)> {
        let lines = &self.lines;
        (self.kept.iter())
            .map(|d| {
                let k = lines.partition_point(|&l| l <= d.primary.span.start as usize);
                (d.clone(), lines[k - 1])
            })
            .collect()
    }

    /// One more diagnostic, on the line that starts at `line` (its primary label's).
    pub fn push(&mut self, d: Diagnostic, line: usize) {
        self.kept.push(d);
        if let Err(k) = self.lines.binary_search(&line) {
            self.lines.insert(k, line);
        }
        if self.kept.len() > 2 * self.per_file + 64 {
            self.compact();
        }
    }

    /// Counts `count` diagnostics not shown, of code `code` (errors or not), the first of
    /// them at `key` in the order (not made, as they cannot be shown: the first `per_file`
    /// of the file come before them).
    pub fn hide(
        &mut self,
        code: latticesim_grammar::Code,
        error: bool,
        key: diagnostics::Key,
        count: usize,
    ) {
        let n = self.hidden.get_or_insert_with(|| NotShown {
            file: key.1,
            errors: 0,
            warnings: 0,
            codes: Vec::new(),
            per_file: 0,
        });
        if error {
            n.errors += count;
        } else {
            n.warnings += count;
        }
        match n.codes.iter().position(|c| c.0 == code) {
            Some(k) => {
                n.codes[k].1 += count;
                self.firsts[k] = self.firsts[k].min(key);
            }
            None => {
                n.codes.push((code, count));
                self.firsts.push(key);
                self.errors.push(error);
            }
        }
    }

    /// True when no diagnostic was pushed or counted yet.
    pub fn is_empty(&self) -> bool {
        self.kept.is_empty() && self.hidden.is_none()
    }

    /// The starts of the lines of the diagnostics held (ascending).
    pub fn lines(&self) -> &[usize] {
        &self.lines
    }

    /// Takes out what can no longer be shown: as the checker caps the whole file, which
    /// shows a diagnostic only when fewer than `per_file` are shown before it (and fewer
    /// than [`SHOWN_PER_LINE`] on its line); diagnostics found later can only add to those.
    fn compact(&mut self) {
        diagnostics::sort(&mut self.kept);
        let lines = &self.lines;
        let line_of =
            |d: &Diagnostic| lines.partition_point(|&l| l <= d.primary.span.start as usize);
        let (hidden, firsts, errors) = (&mut self.hidden, &mut self.firsts, &mut self.errors);
        cap_by(&mut self.kept, self.per_file, line_of, |d| {
            let n = hidden.get_or_insert_with(|| NotShown {
                file: d.primary.file,
                errors: 0,
                warnings: 0,
                codes: Vec::new(),
                per_file: 0,
            });
            let known = n.codes.len();
            n.count(d);
            let key = diagnostics::key(d);
            match n.codes.iter().position(|c| c.0 == d.code) {
                Some(k) if k < known => firsts[k] = firsts[k].min(key),
                _ => {
                    firsts.push(key);
                    errors.push(d.is_error());
                }
            }
        });
        let mut still: Vec<usize> = (self.kept.iter())
            .map(|d| self.lines[line_of(d) - 1])
            .collect();
        still.sort_unstable();
        still.dedup();
        self.lines = still;
    }

    /// The diagnostics shown, in order (their lines' starts beside them), and the count of
    /// the others, as [`check`] keeps them.
    pub fn finish(mut self) -> (Vec<(Diagnostic, usize)>, Option<NotShown>) {
        self.compact();
        let shown = self.with_lines();
        let hidden = self.hidden.map(|mut n| {
            n.per_file = self.per_file;
            let mut codes: Vec<_> = n.codes.into_iter().zip(self.firsts).collect();
            codes.sort_by_key(|c| c.1);
            n.codes = codes.into_iter().map(|(c, _)| c).collect();
            n
        });
        (shown, hidden)
    }
}

fn t_arity_mismatch(f: &RulesFile<'_>, dim: Dim) -> bool {
    fn walk(t: &Spanned<Term<'_>>, dim: Dim) -> bool {
        match &t.node {
            Term::RemoteState { offset, .. } => offset.node.len() != dim.coords(),
            Term::Not(i) => walk(i, dim),
            Term::Group(ts) => ts.iter().any(|t| walk(t, dim)),
            _ => false,
        }
    }
    f.rules
        .iter()
        .any(|r| r.pre.node.iter().chain(r.post.node).any(|t| walk(t, dim)))
}

/// W503 and W603: patterns no state matches, states no rule tests. When a start state that
/// no rule tests is near a pattern that nothing matches, that is one slip: one W503, with
/// the agents' place as a secondary label. When some idle start state is near no pattern,
/// the agents started in the wrong state and the patterns that match nothing follow from
/// it: only the W603s are given.
fn states_warnings(
    facts: &StateFacts,
    rules: &CheckedRules,
    rid: FileId,
    seen: &[StartState],
    aid: FileId,
) -> Vec<Diagnostic> {
    let mut idle = idle::diagnostics(rules, seen, aid);
    let mut out = Vec::new();
    let states: Vec<[u8; 5]> = seen.iter().map(|s| s.state).collect();
    let never = never::never(facts, &states);
    let pats: Vec<_> = never
        .iter()
        .map(|n| never::pat(n.pattern.node).expect("a pattern of five characters"))
        .collect();
    let far = |d: &idle::IdleDiagnostic| {
        !pats
            .iter()
            .any(|p| never::distance_within(p, &d.idle_state, 2).is_some())
    };
    if idle.iter().any(far) {
        // Agents start in a state no rule tests, far from every pattern: the patterns that
        // match nothing are what follows (`gen` without `--state`), not slips of their own.
        out.extend(idle.into_iter().map(|d| d.diag));
        return out;
    }
    let spelled = &facts.spelled;
    // W507 where the state tested is set by no rule: where agents start in it, a W507; where
    // not, the tested pattern matches nothing (a W503) and one of the two spellings is the
    // slip: the one the rules write less often (a tie: the pattern, as W503 says).
    let mut said = Vec::new();
    for m in facts.misspelt().iter().filter(|m| !m.tested_is_set) {
        let written = |s: &[u8]| spelled.get(std::str::from_utf8(s).unwrap_or("")).copied();
        if states.contains(&m.tested)
            || written(&m.tested).unwrap_or(0) > written(m.set.node.as_bytes()).unwrap_or(0)
        {
            out.push(m.diagnostic(rid));
            said.push(m.tested);
        }
    }
    let said = |n: &never::Never| said.iter().any(|t| n.pattern.node.as_bytes() == t);
    for n in never.into_iter().filter(|n| !said(n)) {
        let p = never::pat(n.pattern.node).expect("a pattern of five characters");
        let near = idle
            .iter()
            .position(|d| never::distance_within(&p, &d.idle_state, 2).is_some());
        let seen_idle = near.map(|i| {
            let d = idle.remove(i);
            let full = !n.pattern.node.contains('*');
            never::Idle {
                fix: (d.fields.as_deref())
                    .filter(|_| full)
                    .map(|f| idle::restate(aid, f, n.pattern.node, "the state the rule tests")),
                label: latticesim_grammar::Label {
                    message: format!("{}, which no rule tests", d.diag.primary.message).into(),
                    ..d.diag.primary
                },
            }
        });
        out.push(never::diagnostic(&n, rid, seen_idle, spelled));
    }
    out.extend(idle.into_iter().map(|d| d.diag));
    out
}

/// W503 and W603 for rules already checked clean (`checked`, with the rules file 0), given
/// the distinct states agents of file `aid` start in: for the fast reader of agents files,
/// which checks the rules with the file's first part only, and finds the start states as
/// it reads. The same warnings as [`check`] gives on the whole file.
pub fn states_warnings_of(checked: &Checked, aid: FileId, seen: &[StartState]) -> Vec<Diagnostic> {
    let Some(rules) = checked.rules.as_ref() else {
        return Vec::new();
    };
    let facts = match &checked.state_facts {
        Some(f) => std::borrow::Cow::Borrowed(f),
        None => {
            let arena = Bump::new();
            let text = checked.sources.text(FileId(0));
            let hint = Some(checked.dim.dim.coords() as u8);
            let (ast, _) = parse_rules(text, FileId(0), &arena, hint);
            std::borrow::Cow::Owned(StateFacts::of(&ast))
        }
    };
    states_warnings(&facts, rules, FileId(0), seen, aid)
}

/// Checks a rules file and, if given, an agents file. `dim` is `--dim`.
pub fn check(rules: Input<'_>, agents: Option<Input<'_>>, dim: Option<Dim>) -> Checked {
    check_with(rules, agents, dim, &lints::Lints::new())
}

/// [`check`] with lint levels (the command line's), which come after the rules file's
/// directives (see [`lints`]).
pub fn check_with(
    rules: Input<'_>,
    agents: Option<Input<'_>>,
    dim: Option<Dim>,
    levels: &lints::Lints,
) -> Checked {
    let mut c = check_uncapped(rules, agents, dim, levels);
    cap_checked(&mut c);
    c
}

/// Sorts a verdict's diagnostics and keeps those shown ([`SHOWN_PER_LINE`] of a line, the
/// levels' number of a file), counting the others: the last step of [`check_with`], for
/// a verdict to which diagnostics were added.
pub fn cap_checked(c: &mut Checked) {
    diagnostics::sort(&mut c.diags);
    let more = cap(&mut c.diags, &c.sources, c.lints.shown());
    c.not_shown.extend(more);
}

/// [`check_with`] with every diagnostic kept (sorted), none counted as not shown.
pub(crate) fn check_uncapped(
    rules: Input<'_>,
    agents: Option<Input<'_>>,
    dim: Option<Dim>,
    levels: &lints::Lints,
) -> Checked {
    let mut sources = Sources::new();
    let mut diags = Vec::new();
    let (rules_text, bad) = decode(rules.bytes, FileId(0));
    diags.extend(bad);
    let rid = sources.add(rules.name, rules_text);
    let agents_id = agents.map(|a| {
        let (text, bad) = decode(a.bytes, FileId(1));
        diags.extend(bad);
        sources.add(a.name, text)
    });

    let agents_ast = agents_id.map(|id| {
        let (ast, d) = parse_agents(sources.text(id), id);
        diags.extend(d);
        ast
    });
    let agents_dim = agents_ast
        .as_ref()
        .zip(agents_id)
        .and_then(|(a, id)| dim::from_agents(a, id));
    let fixed = dim::reconcile(dim, agents_dim.clone(), &mut diags);

    // The directives come first: the width of counters bounds the values of both files.
    let (said, bad) = lints::Lints::from_rules(sources.text(rid), rid);
    diags.extend(bad);
    let levels = said.then(levels);
    let width = levels.width();

    let arena = Bump::new();
    let text = sources.text(rid);
    let hint = fixed.as_ref().map(|d| d.dim.coords() as u8);
    let (mut ast, mut parse_diags) = parse_rules(text, rid, &arena, hint);
    let dim_src = match fixed {
        // Rules whose own terms (two or more) say another dimension than the agents file's
        // are not its pair: one E301 (unless `--dim` against the agents file said it, and
        // the rules side with the flag), and each file is read in its own dimension.
        Some(d) => match (agents_dim.as_ref(), dim::from_rules(&ast, rid, text)) {
            (Some(a), Some(own)) if own.dim != a.dim && own.agreeing >= 2 => {
                if dim.is_none_or(|f| f == a.dim) {
                    diags.extend(dim::mismatch(a, &own));
                }
                let hint = Some(own.dim.coords() as u8);
                (ast, parse_diags) = parse_rules(text, rid, &arena, hint);
                own
            }
            _ => d,
        },
        None => {
            let d = dim::from_rules(&ast, rid, text).unwrap_or_else(dim::default_2d);
            if t_arity_mismatch(&ast, d.dim) {
                (ast, parse_diags) = parse_rules(text, rid, &arena, Some(d.dim.coords() as u8));
            }
            d
        }
    };
    diags.extend(parse_diags);
    let rules = check_rules(&ast, rid, text, &dim_src, width, &mut diags);
    let config = agents_ast.as_ref().zip(agents_id).map(|(a, id)| {
        let own = agents_dim.clone().unwrap_or_else(|| dim_src.clone());
        check_agents(a, id, sources.text(id), &own, width, &mut diags)
    });
    // (Not made at all when both are allowed: the fast reader of agents files judges them
    // with the whole file's start states, `states_warnings_of`.)
    let states_said = !(levels.allows(Code::W503) && levels.allows(Code::W603));
    let clean = !diags.iter().any(|d| d.is_error());
    let state_facts = (clean && agents_id.is_some()).then(|| StateFacts::of(&ast));
    if let (Some(a), Some(id), Some(_), Some(facts)) =
        (&agents_ast, agents_id, &config, &state_facts)
    {
        if states_said {
            diags.extend(states_warnings(
                facts,
                &rules,
                rid,
                &idle::start_states(a),
                id,
            ));
        }
    }
    if agents_id.is_none() && !diags.iter().any(|d| d.is_error()) {
        // Without agents, no start state is known: a state tested that no rule sets may
        // be where agents start, and a state set one letter away from it is the slip.
        let unset = slips::misspelt_states(&ast)
            .into_iter()
            .filter(|m| !m.tested_is_set);
        diags.extend(unset.map(|m| m.diagnostic(rid)));
    }
    if !diags.iter().any(|d| d.is_error()) {
        if let Some((i, why)) = lower::too_large(&rules) {
            diags.push(too_large(&ast.rules[i], rid, why));
        }
    }
    let rule_count = ast.rules.len();
    let agent_count = agents_ast.as_ref().map_or(0, |a| a.agents.len());
    drop((ast, agents_ast));
    levels.apply(&mut diags);
    diagnostics::sort(&mut diags);
    let ok = !diags.iter().any(|d| d.is_error());
    let not_shown = Vec::new();
    Checked {
        lints: levels,
        not_shown,
        sources,
        rule_count,
        agent_count,
        diags,
        dim: dim_src,
        rules: ok.then_some(rules),
        config: if ok { config } else { None },
        state_facts: state_facts.filter(|_| ok),
    }
}
