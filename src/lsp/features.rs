//! What the language server answers: diagnostics, hover, completion, formatting, quick
//! fixes. Each works from the checker's and the parser's results for the document and the
//! file it pairs with.

use super::text::LineIndex;
use super::{Kind, Server};
use bumpalo::Bump;
use latticesim_compiler::Checked;
use latticesim_grammar::ast::{Rule, Term};
use latticesim_grammar::{FileId, Label, Severity, Span, Spanned};
use lsp_server::{Message, Notification};
use lsp_types::{
    CodeAction, CodeActionKind, CodeActionOrCommand, CodeActionParams, CompletionItem,
    CompletionItemKind, CompletionParams, CompletionResponse, Diagnostic,
    DiagnosticRelatedInformation, DiagnosticSeverity, DocumentFormattingParams, Hover,
    HoverContents, HoverParams, Location, MarkupContent, MarkupKind, NumberOrString,
    PublishDiagnosticsParams, Range, TextEdit, Uri, WorkspaceEdit,
};
use std::collections::HashMap;
use std::rc::Rc;
use std::str::FromStr;

/// A document checked with its partner: the URIs of the rules (file 0) and agents (file 1)
/// files and the checker's findings.
pub(super) struct Pair {
    uris: [Option<String>; 2],
    /// The two files' texts as checked (empty for a missing one).
    texts: [Rc<String>; 2],
    checked: Checked,
    /// Each file's line starts, found once (a range per diagnostic indexed the whole file
    /// each time).
    starts: [std::cell::OnceCell<Vec<usize>>; 2],
    /// The states used in the two files, found when first asked for (completion).
    states: std::cell::OnceCell<Vec<String>>,
}

/// A file as checked: its URI, how many times it opened, changed or closed (`Server::changes`),
/// and when it is not open its size and time of change on disk.
pub(super) type FileKey = (String, u64, Option<(u64, Option<std::time::SystemTime>)>);

/// What the pair last checked was made from (see [`FileKey`]).
pub(super) type PairKey = [Option<FileKey>; 2];

/// The pair last checked, with what it was made from.
pub(super) type Kept = Option<(PairKey, Rc<Pair>)>;

impl Pair {
    fn uri(&self, f: FileId) -> Option<&str> {
        self.uris.get(f.0 as usize).and_then(|u| u.as_deref())
    }

    fn file_of(&self, uri: &str) -> Option<FileId> {
        (0..2)
            .find(|&i| self.uris[i].as_deref() == Some(uri))
            .map(|i| FileId(i as u32))
    }

    fn range(&self, l: &Label) -> Range {
        // The text the spans point into: the checker's, or, for a large agents file read
        // by the streaming reader (held in part by the verdict), the document's.
        let sources = &self.checked.sources;
        let text = match sources.is_whole(l.file) {
            true => sources.text(l.file),
            false => &self.texts[l.file.0 as usize],
        };
        let starts = self.starts[l.file.0 as usize].get_or_init(|| super::text::line_starts(text));
        LineIndex::with_starts(text, starts).range(l.span.start as usize, l.span.end as usize)
    }
}

fn name_of(uri: &str) -> String {
    uri.rsplit('/').next().unwrap_or(uri).to_string()
}

fn to_uri(s: &str) -> Option<Uri> {
    Uri::from_str(s).ok()
}

/// The notification that clears a document's diagnostics.
pub(super) fn clear(uri: &str) -> Option<Message> {
    let params = PublishDiagnosticsParams {
        uri: to_uri(uri)?,
        diagnostics: Vec::new(),
        version: None,
    };
    Some(Message::Notification(Notification::new(
        "textDocument/publishDiagnostics".into(),
        params,
    )))
}

impl Server {
    /// The document `uri` checked with its partner: kept from the last request while
    /// neither file changed (each request checked the pair again: 100 ms for 5,005 rules,
    /// a second beside 10^6 agents).
    fn pair(&self, uri: &str) -> Option<Rc<Pair>> {
        let uris = self.pair_uris(uri)?;
        let key = self.pair_key(&uris);
        if let Some((k, p)) = &*self.pair_cache.borrow() {
            if *k == key {
                return Some(Rc::clone(p));
            }
        }
        let pair = Rc::new(self.check(uris)?);
        *self.pair_cache.borrow_mut() = Some((key, Rc::clone(&pair)));
        Some(pair)
    }

    /// What a pair of files is made from (see [`FileKey`]).
    pub(super) fn pair_key(&self, uris: &[Option<String>; 2]) -> PairKey {
        uris.clone().map(|u| u.map(|u| self.file_key(u)))
    }

    /// What file `uri` is now (see [`FileKey`]).
    pub(super) fn file_key(&self, uri: String) -> FileKey {
        let disk = (!self.docs.contains_key(&uri))
            .then(|| super::path_of(&uri)?.metadata().ok())
            .flatten()
            .map(|m| (m.len(), m.modified().ok()));
        let changes = self.changes.get(&uri).copied().unwrap_or(0);
        (uri, changes, disk)
    }

    /// Checks the files of `uris` (rules, agents) as a pair.
    fn check(&self, uris: [Option<String>; 2]) -> Option<Pair> {
        let rules = uris[0]
            .as_deref()
            .and_then(|u| self.text_of(u))
            .unwrap_or_default();
        let agents = uris[1].as_deref().and_then(|u| self.text_of(u));
        let rules_name = uris[0].as_deref().map_or("(no rules file)".into(), name_of);
        let agents_name = uris[1].as_deref().map(name_of).unwrap_or_default();
        // An agents file is read as the commands read it (the streaming reader, which
        // gives the checker's diagnostics in the time and memory of reading the file: a
        // 10^6-line agents file beside the rules no longer takes the checker a second).
        // Its reading is kept while its text is the same, for the next edit of the rules.
        let checked = match agents.as_deref() {
            Some(a) => {
                let source = crate::agents_file::Source::Bytes(a.as_bytes());
                let rules = (rules_name.as_str(), rules.as_bytes());
                let levels = Default::default();
                let file = uris[1].clone().map(|u| self.file_key(u));
                let mut reading = self.reading.borrow_mut();
                if reading.0 != file {
                    *reading = (file, Default::default());
                }
                let kept = Some(&mut reading.1);
                // A large file is read on every core, as `check` reads it.
                let how = (crate::run::io_threads(None), &levels);
                (crate::agents_file::load_keeping(rules, &agents_name, source, how, kept).ok()?)
                    .checked
            }
            None => crate::check_pair(
                (&rules_name, rules.as_bytes()),
                None,
                None,
                &Default::default(),
            ),
        };
        Some(Pair {
            uris,
            texts: [rules, agents.unwrap_or_default()],
            checked,
            starts: Default::default(),
            states: Default::default(),
        })
    }

    fn lsp_diagnostic(pair: &Pair, d: &latticesim_grammar::Diagnostic) -> Diagnostic {
        let related: Vec<DiagnosticRelatedInformation> = d
            .secondary
            .iter()
            .filter_map(|l| {
                Some(DiagnosticRelatedInformation {
                    location: Location {
                        uri: to_uri(pair.uri(l.file)?)?,
                        range: pair.range(l),
                    },
                    message: l.message.to_string(),
                })
            })
            .collect();
        let mut message = d.message.to_string();
        if !d.primary.message.is_empty() {
            message += &format!(" ({})", d.primary.message);
        }
        if let Some(h) = &d.help {
            message += &format!("\nhelp: {h}");
        }
        for f in &d.fixes {
            message += &format!("\nfix: {}", f.message);
        }
        Diagnostic {
            range: pair.range(&d.primary),
            severity: Some(match d.severity() {
                Severity::Error => DiagnosticSeverity::ERROR,
                Severity::Warning => DiagnosticSeverity::WARNING,
            }),
            code: Some(NumberOrString::String(d.code.as_str().into())),
            source: Some("latticesim".into()),
            message,
            related_information: (!related.is_empty()).then_some(related),
            ..Diagnostic::default()
        }
    }

    /// Checks a document with its partner and publishes the diagnostics of both (the
    /// partner's when it is open).
    pub(super) fn publish(&self, uri: &str) -> Vec<Message> {
        let Some(pair) = self.pair(uri) else {
            return Vec::new();
        };
        let mut out = Vec::new();
        for f in [FileId(0), FileId(1)] {
            let Some(u) = pair.uri(f) else { continue };
            if u != uri && !self.docs.contains_key(u) {
                continue;
            }
            let Some(lsp_uri) = to_uri(u) else { continue };
            let diagnostics = pair
                .checked
                .diags
                .iter()
                .filter(|d| d.primary.file == f)
                .map(|d| Self::lsp_diagnostic(&pair, d))
                .collect();
            let params = PublishDiagnosticsParams {
                uri: lsp_uri,
                diagnostics,
                version: self.docs.get(u).map(|d| d.version),
            };
            out.push(Message::Notification(Notification::new(
                "textDocument/publishDiagnostics".into(),
                params,
            )));
        }
        out
    }

    pub(super) fn hover(&self, p: HoverParams) -> Option<Hover> {
        let uri = p.text_document_position_params.text_document.uri.as_str();
        let doc = self.docs.get(uri)?;
        // The document's line starts, agents and rules, found once per change of it (a
        // 10^6-line agents file was parsed whole at each hover).
        let key = self.file_key(uri.to_string());
        let known = self.hover_cache.borrow().get(uri).cloned();
        let kept = match known {
            Some((k, kept)) if k == key => kept,
            _ => {
                let k = Rc::new(Outline::of(&doc.text, doc.kind));
                let kept = (key, Rc::clone(&k));
                self.hover_cache.borrow_mut().insert(uri.to_string(), kept);
                k
            }
        };
        let ix = LineIndex::with_starts(&doc.text, &kept.starts);
        let at = ix.offset(p.text_document_position_params.position);
        let (text, span) = match doc.kind {
            Kind::Rules => rules_hover(&doc.text, at, &kept.rules)?,
            Kind::Agents => agents_hover(&doc.text, at, &kept.agents)?,
        };
        Some(Hover {
            contents: HoverContents::Markup(MarkupContent {
                kind: MarkupKind::Markdown,
                value: text,
            }),
            range: Some(ix.range(span.start as usize, span.end as usize)),
        })
    }

    pub(super) fn completion(&self, p: CompletionParams) -> Option<CompletionResponse> {
        let uri = p.text_document_position.text_document.uri.as_str();
        let doc = self.docs.get(uri)?;
        let ix = LineIndex::new(&doc.text);
        let at = ix.offset(p.text_document_position.position);
        let line_start = doc.text[..at].rfind('\n').map_or(0, |i| i + 1);
        let word_start = doc.text[line_start..at]
            .rfind([' ', '\t', '(', '!'])
            .map_or(line_start, |i| line_start + i + 1);
        let word = &doc.text[word_start..at];
        let pair = self.pair(uri);
        let three = pair
            .as_ref()
            .is_some_and(|p| p.checked.dim.dim == latticesim_vm::model::Dim::Three);
        let states = || -> Vec<String> {
            let Some(p) = &pair else {
                return Vec::new();
            };
            (p.states.get_or_init(|| {
                let mut v: Vec<String> = Vec::new();
                for f in (0..2).filter(|&f| p.uris[f].is_some()) {
                    states_in(&p.texts[f], &mut v);
                }
                v.sort();
                v.dedup();
                v
            }))
            .clone()
        };
        let items: Vec<CompletionItem> = if word.starts_with('S') || is_t_state(word) {
            let prefix = if word.starts_with('S') {
                "S".to_string()
            } else {
                word[..word.rfind(',').map_or(0, |i| i + 1)].to_string()
            };
            states()
                .into_iter()
                .map(|s| CompletionItem {
                    label: format!("{prefix}{s}"),
                    kind: Some(CompletionItemKind::VALUE),
                    detail: Some(format!("the state {s}, used in these files")),
                    ..CompletionItem::default()
                })
                .collect()
        } else if doc.kind == Kind::Rules {
            let line_no = doc.text[..line_start].matches('\n').count() as u32 + 1;
            let role = line_role(&doc.text, line_no);
            terms(role, three)
                .into_iter()
                .map(|(label, insert, detail)| CompletionItem {
                    label: label.into(),
                    kind: Some(CompletionItemKind::KEYWORD),
                    detail: Some(detail.into()),
                    insert_text: Some(insert),
                    ..CompletionItem::default()
                })
                .collect()
        } else {
            Vec::new()
        };
        Some(CompletionResponse::Array(items))
    }

    pub(super) fn formatting(&self, p: DocumentFormattingParams) -> Option<Vec<TextEdit>> {
        let doc = self.docs.get(p.text_document.uri.as_str())?;
        if doc.kind != Kind::Rules {
            return None;
        }
        let formatted = latticesim_compiler::format_rules(&doc.text, None).ok()?;
        if formatted == *doc.text {
            return Some(Vec::new());
        }
        let ix = LineIndex::new(&doc.text);
        Some(vec![TextEdit {
            range: ix.range(0, doc.text.len()),
            new_text: formatted,
        }])
    }

    pub(super) fn code_actions(&self, p: CodeActionParams) -> Option<Vec<CodeActionOrCommand>> {
        let uri = p.text_document.uri.as_str();
        let pair = self.pair(uri)?;
        let file = pair.file_of(uri)?;
        let mut out = Vec::new();
        for d in pair.checked.diags.iter().filter(|d| d.primary.file == file) {
            let range = pair.range(&d.primary);
            if range.end < p.range.start || p.range.end < range.start {
                continue;
            }
            for (k, f) in d.fixes.iter().enumerate() {
                // lsp-types' own map type for workspace edits (its `Uri` caches its parts
                // inside, which clippy flags; it is never mutated as a key here).
                #[allow(clippy::mutable_key_type)]
                let mut changes: HashMap<Uri, Vec<TextEdit>> = HashMap::new();
                for e in &f.edits {
                    let Some(u) = pair.uri(e.file).and_then(to_uri) else {
                        continue;
                    };
                    let l = Label::new(e.file, e.span, "");
                    changes.entry(u).or_default().push(TextEdit {
                        range: pair.range(&l),
                        new_text: e.replacement.clone(),
                    });
                }
                out.push(CodeActionOrCommand::CodeAction(CodeAction {
                    title: f.message.clone(),
                    kind: Some(CodeActionKind::QUICKFIX),
                    diagnostics: Some(vec![Self::lsp_diagnostic(&pair, d)]),
                    edit: Some(WorkspaceEdit {
                        changes: Some(changes),
                        ..WorkspaceEdit::default()
                    }),
                    // The first fix is the likelier (see W503's).
                    is_preferred: Some(k == 0),
                    ..CodeAction::default()
                }));
            }
        }
        Some(out)
    }
}

/// True for the start of a `T` term up to its state (`T1,0,` or `T1,0,AB`).
fn is_t_state(word: &str) -> bool {
    word.starts_with('T') && word.matches(',').count() >= 2
}

/// The states named in a file: `S` and `T` terms of rules, `S` fields of agents, without
/// `*`s.
fn states_in(text: &str, out: &mut Vec<String>) {
    for word in text.split([' ', '\t', '\n', '\r', '(', ')', '!']) {
        let state = if let Some(s) = word.strip_prefix('S') {
            Some(s)
        } else if word.starts_with('T') {
            word.rsplit(',').next()
        } else {
            None
        };
        if let Some(s) = state {
            if s.chars().count() == 5 && !s.contains('*') && !s.contains("//") {
                out.push(s.to_string());
            }
        }
    }
}

/// Which line of a rule line `number` (1-based) is: 2 precondition, 3 postcondition, other
/// values for the rest (or when the structure is unclear).
fn line_role(text: &str, number: u32) -> u8 {
    let lines: Vec<_> = latticesim_grammar::lines::significant_lines(text).collect();
    for l in latticesim_grammar::structure::layouts(&lines) {
        if l.pre.is_some_and(|p| p.number == number) {
            return 2;
        }
        if l.post.is_some_and(|p| p.number == number) {
            return 3;
        }
        if l.name.is_some_and(|p| p.number == number)
            || l.priority.is_some_and(|p| p.number == number)
        {
            return 0;
        }
    }
    9
}

/// Term completions for a line role: (label, text inserted, what it is).
fn terms(role: u8, three: bool) -> Vec<(&'static str, String, &'static str)> {
    let dirs = if three { 6 } else { 4 };
    let pat = |c: char| format!("{c}{}", "*".repeat(dirs));
    let off = if three { "0,0,1" } else { "0,1" };
    let tests = vec![
        (
            "N",
            pat('N'),
            "neighbour cells: 0 empty, 1 filled, * either",
        ),
        ("E", format!("E{off}"), "the cell at the offset is empty"),
        ("F", format!("F{off}"), "the cell at the offset is filled"),
        (
            "L",
            format!("L{off}"),
            "the agent there has a smaller priority",
        ),
        (
            "Q",
            format!("Q{off}"),
            "the agent there has a smaller or equal priority",
        ),
        (
            "T",
            format!("T{off},*****"),
            "the agent there is in a matching state",
        ),
        (
            "P<",
            pat('P'),
            "neighbour priorities: < smaller, = smaller or equal, * any",
        ),
        (
            "A",
            pat('A'),
            "attachments: 0 not attached, 1 attached, * either",
        ),
        ("S", "S*****".into(), "the agent's state matches"),
        (
            "M",
            "M*hello".into(),
            "a text message came (direction or *, 5 characters)",
        ),
        ("<", "<C00 0000".into(), "a value is smaller than another"),
        (">", ">C00 0000".into(), "a value is larger than another"),
        ("=", "=C00 0000".into(), "two values are equal"),
        (
            "V",
            "V1,0,C00 0000".into(),
            "a neighbour's counter is smaller (2D)",
        ),
        (
            "W",
            "W1,0,C00 0000".into(),
            "a neighbour's counter is smaller or equal (2D)",
        ),
        ("!", "!".into(), "the next term must not hold"),
    ];
    let actions = vec![
        ("P", format!("P{off}"), "move by the offset"),
        ("X", "XN".into(), "swap places with a neighbour"),
        (
            "A",
            pat('A'),
            "set attachments: 0 detach, 1 attach, * keep, + carry",
        ),
        ("S", "S*****".into(), "set the state (* keeps a character)"),
        (
            "M",
            "MNhello".into(),
            "send a text message (direction or *, 5 characters)",
        ),
        ("C", "C00 + C00 0001".into(), "a calculation into a counter"),
        (
            "#",
            "#*01 + C00 0000".into(),
            "a calculation into a numeric message",
        ),
    ];
    match role {
        2 => tests,
        3 => actions,
        _ => tests.into_iter().chain(actions).collect(),
    }
}

/// The innermost term at `at` among `terms`, and whether `in_post`.
fn term_at<'t, 'a>(terms: &'t [Spanned<Term<'a>>], at: usize) -> Option<&'t Spanned<Term<'a>>> {
    let t = terms.iter().find(|t| {
        (t.span.start as usize) <= at && at < (t.span.end as usize).max(t.span.start as usize + 1)
    })?;
    match &t.node {
        Term::Not(inner) => term_at(std::slice::from_ref(*inner), at).or(Some(t)),
        Term::Group(ts) => term_at(ts, at).or(Some(t)),
        _ => Some(t),
    }
}

/// The hover of a rules file at `at`: found in the rule there alone (`rules`: each rule's
/// extent, from its name to its postcondition's end), parsed again on its own.
fn rules_hover(text: &str, at: usize, rules: &[(u32, u32)]) -> Option<(String, Span)> {
    let k = rules
        .partition_point(|&(s, _)| s as usize <= at)
        .checked_sub(1)?;
    let (start, end) = (rules[k].0 as usize, rules[k].1 as usize);
    let (hover, span) = rule_hover(text.get(start..end.max(at))?, at - start)?;
    let shift = |p: u32| p as usize + start;
    Some((hover, Span::new(shift(span.start), shift(span.end))))
}

/// [`rules_hover`] in a text of rules.
fn rule_hover(text: &str, at: usize) -> Option<(String, Span)> {
    let arena = Bump::new();
    let (f, _) = latticesim_grammar::parse_rules(text, FileId(0), &arena, None);
    let within = |s: Span| (s.start as usize) <= at && at <= s.end as usize;
    let r: &Rule<'_> = f.rules.iter().find(|r| {
        within(r.name.span) || within(r.priority.span) || within(r.pre.span) || within(r.post.span)
    })?;
    if within(r.name.span) {
        return Some((format!("**Rule** `{}`", r.name.node), r.name.span));
    }
    if within(r.priority.span) {
        let p = r.priority.node.map_or("?".into(), |p| p.to_string());
        return Some((
            format!("**Priority** {p} of `{}`: among the rules an agent may apply, the highest priority wins", r.name.node),
            r.priority.span,
        ));
    }
    let (terms, in_post) = if within(r.pre.span) {
        (r.pre.node, false)
    } else {
        (r.post.node, true)
    };
    let t = term_at(terms, at)?;
    Some((
        latticesim_compiler::describe::term(&t.node, in_post),
        t.span,
    ))
}

/// What hover needs of a document, found once per version: its line starts and, for an
/// agents file, where each agent's line stands (the agents that parse, in order); for a
/// rules file, each rule's extent (a hover parses that rule alone: the whole file took 10
/// ms at 5,005 rules).
pub(super) struct Outline {
    starts: Vec<usize>,
    agents: Vec<(u32, u32)>,
    rules: Vec<(u32, u32)>,
}

impl Outline {
    fn of(text: &str, kind: Kind) -> Outline {
        let (mut agents, mut rules) = (Vec::new(), Vec::new());
        match kind {
            Kind::Rules => {
                let arena = Bump::new();
                let (f, _) = latticesim_grammar::parse_rules(text, FileId(0), &arena, None);
                // From the name (its first line) to the end of the last of its parts.
                rules.extend(f.rules.iter().map(|r| {
                    let parts = [r.name.span, r.priority.span, r.pre.span, r.post.span];
                    (
                        r.name.span.start,
                        parts.iter().map(|s| s.end).max().unwrap_or(0),
                    )
                }));
            }
            Kind::Agents => agents.extend(
                (latticesim_grammar::parse_agents(text, FileId(1))
                    .0
                    .agents
                    .iter())
                .map(|a| (a.span.start, a.span.end)),
            ),
        }
        Outline {
            starts: super::text::line_starts(text),
            agents,
            rules,
        }
    }
}

/// The hover of an agents file at `at`: the agent there (numbered by `agents`, the lines
/// of the agents that parse), or the universe line.
fn agents_hover(text: &str, at: usize, agents: &[(u32, u32)]) -> Option<(String, Span)> {
    let k = agents.partition_point(|&(s, _)| s as usize <= at);
    if let Some(i) = k.checked_sub(1).filter(|&i| at <= agents[i].1 as usize) {
        // The agent's line alone, parsed again.
        let (s, e) = (agents[i].0 as usize, agents[i].1 as usize);
        let (f, _) = latticesim_grammar::parse_agents(&text[s..e], FileId(1));
        let a = f.agents.first()?;
        return Some((agent_text(i, a), Span::new(s, e)));
    }
    // The universe line: the first significant line.
    let first = latticesim_grammar::lines::significant_lines(text).next()?;
    let end = first.start + first.text.len();
    let (f, _) = latticesim_grammar::parse_agents(&text[..end], FileId(1));
    if let Some(u) = f
        .universe
        .as_ref()
        .filter(|u| (u.span.start as usize) <= at && at <= u.span.end as usize)
    {
        let b: Vec<i64> = u.bounds.iter().map(|b| b.node).collect();
        let axes: Vec<String> = b
            .chunks(2)
            .zip(["x", "y", "z"])
            .map(|(c, a)| format!("{a} from {} to {}", c[0], c.get(1).copied().unwrap_or(c[0])))
            .collect();
        return Some((format!("**Universe**: {}", axes.join(", ")), u.span));
    }
    None
}

/// The hover text of agent `i`.
fn agent_text(i: usize, a: &latticesim_grammar::ast::AgentLine<'_>) -> String {
    let pos: Vec<String> = a.pos.iter().map(|p| p.node.to_string()).collect();
    let mut s = format!("**Agent {i}** at ({})", pos.join(", "));
    s += &format!(", state `{}`", a.state.map_or("00000", |s| s.node));
    if let Some(at) = a.attach {
        s += &format!(", attachments `{}` (N, W, E, S[, A, B])", at.node);
    }
    for (c, v) in &a.counters {
        s += &format!(", C{} = {}", c.node, v.node);
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The diagnostics of an agents file follow its every change, and the rules' edits
    /// between (what is kept of the agents file is kept only while it is the same).
    #[test]
    fn kept_readings_follow_the_agents_file() {
        use lsp_server::{Message, Notification};
        use serde_json::json;
        let (rules, agents) = ("file:///k/rules.txt", "file:///k/agents.txt");
        let mut s = Server::new();
        let note =
            |m: &str, p: serde_json::Value| Message::Notification(Notification::new(m.into(), p));
        let codes = |out: Vec<Message>, uri: &str| -> Vec<String> {
            let mut v = Vec::new();
            for m in out {
                if let Message::Notification(n) = m {
                    if n.params["uri"] == uri {
                        for d in n.params["diagnostics"].as_array().unwrap() {
                            v.push(d["code"].as_str().unwrap_or("").to_string());
                        }
                    }
                }
            }
            v
        };
        let fall = "fall\n1\nSFALL0 N***0 >C00 0000\nP0,-1 C00 - C00 0001\n";
        let open = |uri: &str, lang: &str, text: &str| {
            note(
                "textDocument/didOpen",
                json!({"textDocument": {"uri": uri, "languageId": lang, "version": 1, "text": text}}),
            )
        };
        s.handle(open(rules, "latticesim-rules", fall));
        let out = s.handle(open(agents, "latticesim-agents", "0,0 SFALL0 C00 3\n"));
        assert_eq!(codes(out, agents), Vec::<String>::new());
        let change = |uri: &str, v: i32, text: &str| {
            note(
                "textDocument/didChange",
                json!({"textDocument": {"uri": uri, "version": v}, "contentChanges": [{"text": text}]}),
            )
        };
        // The same version, another text: an idle state.
        let out = s.handle(change(agents, 1, "0,0 SFALL0 C00 3\n0,1 SIDLE0\n"));
        assert_eq!(codes(out, agents), vec!["W603"]);
        // The rules change (the reading is used again), then test the state.
        let out = s.handle(change(
            rules,
            2,
            &format!("{fall}\nidle\n1\nSIDLE0\nSFALL0\n"),
        ));
        assert_eq!(codes(out, agents), Vec::<String>::new());
        let out = s.handle(change(rules, 3, fall));
        assert_eq!(codes(out, agents), vec!["W603"]);
        // Each document keeps its hover outline beside the other's (the agents file's was
        // made again at each hover after one in the rules), until it closes.
        for uri in [rules, agents, rules] {
            let at = json!({"textDocument": {"uri": uri}, "position": {"line": 0, "character": 1}});
            let hover = lsp_server::Request::new(1.into(), "textDocument/hover".into(), at);
            s.handle(Message::Request(hover));
        }
        assert_eq!(s.hover_cache.borrow().len(), 2);
        // Closed and opened again with the same version and another text.
        s.handle(note(
            "textDocument/didClose",
            json!({"textDocument": {"uri": agents}}),
        ));
        assert_eq!(s.hover_cache.borrow().len(), 1);
        let out = s.handle(open(agents, "latticesim-agents", "0,0 SFALL0 C00 3\n"));
        assert_eq!(codes(out, agents), Vec::<String>::new());
    }

    /// A hover found in the rule at the cursor alone, parsed on its own, says what the
    /// whole file parsed says, at every place of every example's rules (and of a file with
    /// comments, blank lines and a rule without its priority).
    #[test]
    fn a_hover_in_one_rule_is_the_hover_in_the_whole_file() {
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
        let mut texts = vec![
            "// head\n\nfirst\n1\nSAAAA0 N***0\nSBBBB0\n\n// between\nsecond\nS*0\nSCCC0\n\nthird\n2\n>C00 0001 !E0,1\nP0,1 C00 - C00 0001\n".to_string(),
        ];
        for e in std::fs::read_dir(root.join("examples")).unwrap() {
            if let Ok(t) = std::fs::read_to_string(e.unwrap().path().join("rules.txt")) {
                texts.push(t);
            }
        }
        assert!(texts.len() > 10, "the examples' rules");
        for text in &texts {
            let rules = Outline::of(text, Kind::Rules).rules;
            let mut shown = 0;
            for at in (0..=text.len()).filter(|&at| text.is_char_boundary(at)) {
                let one = rules_hover(text, at, &rules);
                assert_eq!(one, rule_hover(text, at), "at {at} of\n{text}");
                shown += usize::from(one.is_some());
            }
            assert!(shown > 0, "hovers in\n{text}");
        }
    }
}
