//! Go to definition, find references and rename, across a rules file and the agents file it
//! pairs with ([`Server::partner`]), on the names of [`super::names`]:
//!
//! - a state: its definitions are the postconditions that set it (a pattern with `*` that
//!   could leave it counts) and the agents that start in it; its references are every test,
//!   setting and agent of it, and the patterns that match it;
//! - a counter: defined by the calculations that write it and the agents that start with a
//!   value in it; referenced wherever a rule reads or writes it;
//! - a rule name: the rule (and any other rule of that name).
//!
//! Rename edits the exact places in both files. It refuses, with the place, a new name that
//! is not a name of that kind, one already used (the two would merge), and a rename that
//! would change what a pattern matches (`REST*` matches `REST0` but not `WALK0`).

use super::names::{self, Occurrence, What};
use super::text::LineIndex;
use super::Server;
use latticesim_grammar::FileId;
use lsp_types::{
    GotoDefinitionParams, GotoDefinitionResponse, Location, PrepareRenameResponse, ReferenceParams,
    RenameParams, TextDocumentPositionParams, TextEdit, Uri, WorkspaceEdit,
};
use std::collections::HashMap;
use std::str::FromStr;

/// At most this many places in the agents file are listed by definition and references
/// (each agent may start in the state: 10^6 locations take the editor seconds to receive
/// and are no use in a list); the rules file's places are all listed, and rename edits all.
pub const AGENT_PLACES: usize = 10_000;

/// The places to list: every one in the rules file, the first [`AGENT_PLACES`] in the
/// agents file.
fn listed<'t>(places: impl Iterator<Item = Occurrence<'t>>) -> Vec<Occurrence<'t>> {
    let mut agents = 0;
    places
        .filter(|o| {
            agents += usize::from(o.file == FileId(1));
            o.file == FileId(0) || agents <= AGENT_PLACES
        })
        .collect()
}

/// The open document and its partner: their URIs and texts (rules first). Kept between
/// requests while neither changes (`Server::nav_cache`), with what is slow to find again
/// in a large agents file: its line starts and its names.
pub(super) struct Files {
    uris: [Option<String>; 2],
    texts: [std::rc::Rc<String>; 2],
    /// Each text's line starts, found once for all the locations given.
    starts: [std::cell::OnceCell<std::rc::Rc<Vec<usize>>>; 2],
    /// The rules file's and the agents file's names: (what, where, role).
    names: [std::cell::OnceCell<std::rc::Rc<Vec<Name>>>; 2],
}

/// A name kept without its text: what, where, and the role of its place.
type Name = (What, latticesim_grammar::Span, names::Role);

/// The files last navigated, with what they were made from (as the pair checked).
pub(super) type KeptFiles = Option<(super::features::PairKey, std::rc::Rc<Files>)>;

impl Files {
    /// Every name of the two files, rules first, in file order: made as they are gone
    /// through (the names of 10^6 agents are millions of places; a list of them made at
    /// each request cost more than the search).
    fn occurrences(&self) -> impl Iterator<Item = Occurrence<'_>> {
        let kept = |i: usize| -> &[Name] {
            let text = &self.texts[i];
            self.names[i].get_or_init(|| {
                let found = match i {
                    0 => names::in_rules(text),
                    _ if self.uris[1].is_some() => names::in_agents(text),
                    _ => Vec::new(),
                };
                std::rc::Rc::new(
                    found
                        .into_iter()
                        .map(|o| (o.what, o.span, o.role))
                        .collect(),
                )
            })
        };
        (0..2).flat_map(move |i| {
            let text = &self.texts[i][..];
            kept(i).iter().map(move |&(what, span, role)| Occurrence {
                what,
                text: &text[span.start as usize..span.end as usize],
                span,
                role,
                file: FileId(i as u32),
            })
        })
    }

    /// The line index of file `i`, its line starts found once.
    fn index(&self, i: usize) -> LineIndex<'_> {
        let text = &self.texts[i];
        let starts = self.starts[i].get_or_init(|| super::text::line_starts(text).into());
        LineIndex::with_starts(text, starts)
    }

    fn location(&self, o: &Occurrence<'_>) -> Option<Location> {
        let i = o.file.0 as usize;
        let uri = Uri::from_str(self.uris[i].as_deref()?).ok()?;
        let ix = self.index(i);
        Some(Location {
            uri,
            range: ix.range(o.span.start as usize, o.span.end as usize),
        })
    }

    fn file_of(&self, uri: &str) -> Option<FileId> {
        (0..2)
            .find(|&i| self.uris[i].as_deref() == Some(uri))
            .map(|i| FileId(i as u32))
    }
}

/// Where the cursor is: the files, which of them, and the byte offset.
struct Target {
    files: std::rc::Rc<Files>,
    file: FileId,
    at: usize,
}

impl Target {
    /// The name under the cursor among the files' names.
    fn name<'t>(&self, mut all: impl Iterator<Item = Occurrence<'t>>) -> Option<Occurrence<'t>> {
        all.find(|o| o.file == self.file && o.under(self.at))
    }

    /// Where a place is, as `file:line`.
    fn line_of(&self, o: &Occurrence<'_>) -> String {
        let i = o.file.0 as usize;
        let line = self.files.texts[i][..o.span.start as usize]
            .matches('\n')
            .count()
            + 1;
        let file = self.files.uris[i]
            .as_deref()
            .map_or("", |u| u.rsplit('/').next().unwrap_or(u));
        format!("{file}:{line}")
    }
}

/// The name under the cursor when it can be renamed, or why not.
fn renamable<'t>(
    t: &Target,
    all: impl Iterator<Item = Occurrence<'t>>,
) -> Result<Occurrence<'t>, String> {
    let o = t
        .name(all)
        .ok_or("nothing to rename here: put the cursor on a state, a counter or a rule's name")?;
    if o.is_pattern() {
        return Err(format!(
            "`{}` is a pattern; rename one of the states it matches",
            o.text
        ));
    }
    Ok(o)
}

impl Server {
    /// The document `uri` and its partner, kept from the last request while neither
    /// changed (a 10^6-line agents file was read and its names found at every request).
    fn files(&self, uri: &str) -> Option<std::rc::Rc<Files>> {
        let uris = self.pair_uris(uri)?;
        let key = self.pair_key(&uris);
        let before = self.nav_cache.borrow_mut().take();
        if let Some((k, _)) = &before {
            if *k == key {
                *self.nav_cache.borrow_mut() = before.clone();
                return before.map(|(_, f)| f);
            }
        }
        let texts = [0, 1].map(|i| {
            uris[i]
                .as_deref()
                .and_then(|u| self.text_of(u))
                .unwrap_or_default()
        });
        let files = Files {
            uris,
            texts,
            starts: Default::default(),
            names: Default::default(),
        };
        // What was found in a file that has not changed is kept (the names of a 10^6-line
        // agents file, at each edit of the rules).
        if let Some((old_key, old)) = before {
            for i in (0..2).filter(|&i| old_key[i] == key[i]) {
                if let Some(n) = old.names[i].get() {
                    let _ = files.names[i].set(std::rc::Rc::clone(n));
                }
                if let Some(s) = old.starts[i].get() {
                    let _ = files.starts[i].set(std::rc::Rc::clone(s));
                }
            }
        }
        let files = std::rc::Rc::new(files);
        *self.nav_cache.borrow_mut() = Some((key, std::rc::Rc::clone(&files)));
        Some(files)
    }

    fn target(&self, p: &TextDocumentPositionParams) -> Option<Target> {
        let uri = p.text_document.uri.as_str();
        let files = self.files(uri)?;
        let file = files.file_of(uri)?;
        let at = files.index(file.0 as usize).offset(p.position);
        Some(Target { files, file, at })
    }

    pub(super) fn definition(&self, p: GotoDefinitionParams) -> Option<GotoDefinitionResponse> {
        let t = self.target(&p.text_document_position_params)?;
        let n = t.name(t.files.occurrences())?;
        let places =
            (t.files.occurrences()).filter(|o| o.role.defines() && o.names(n.what, n.text));
        let found = listed(places)
            .iter()
            .filter_map(|o| t.files.location(o))
            .collect();
        Some(GotoDefinitionResponse::Array(found))
    }

    pub(super) fn references(&self, p: ReferenceParams) -> Option<Vec<Location>> {
        let t = self.target(&p.text_document_position)?;
        let n = t.name(t.files.occurrences())?;
        let with_definitions = p.context.include_declaration;
        let places = (t.files.occurrences())
            .filter(|o| o.names(n.what, n.text) && (with_definitions || !o.role.defines()));
        Some(
            listed(places)
                .iter()
                .filter_map(|o| t.files.location(o))
                .collect(),
        )
    }

    pub(super) fn prepare_rename(
        &self,
        p: TextDocumentPositionParams,
    ) -> Result<Option<PrepareRenameResponse>, String> {
        let Some(t) = self.target(&p) else {
            return Ok(None);
        };
        let o = renamable(&t, t.files.occurrences())?;
        let ix = LineIndex::new(&t.files.texts[t.file.0 as usize]);
        // A counter is renamed with its `C`.
        let start = o.span.start as usize - usize::from(o.what == What::Counter);
        Ok(Some(PrepareRenameResponse::RangeWithPlaceholder {
            range: ix.range(start, o.span.end as usize),
            placeholder: shown(o.what, o.text),
        }))
    }

    pub(super) fn rename(&self, p: RenameParams) -> Result<Option<WorkspaceEdit>, String> {
        let Some(t) = self.target(&p.text_document_position) else {
            return Ok(None);
        };
        let all = || t.files.occurrences();
        let o = renamable(&t, all())?;
        let (what, old) = (o.what, o.text);
        let new = new_name(what, &p.new_name, &t.files)?;
        if let Some(clash) = all().find(|o| !o.is_pattern() && o.names(what, &new)) {
            return Err(format!(
                "`{}` is already used ({}): renaming would merge the two",
                shown(what, &new),
                t.line_of(&clash)
            ));
        }
        if let Some(p) = all().find(|o| o.is_pattern() && o.names(what, old) != o.names(what, &new))
        {
            let (does, not) = if p.names(what, old) {
                ("matches", "would not match")
            } else {
                ("does not match", "would match")
            };
            return Err(format!(
                "the pattern `{}` ({}) {does} `{old}` but {not} `{new}`: change it first",
                p.text,
                t.line_of(&p)
            ));
        }
        #[allow(clippy::mutable_key_type)] // lsp-types' map type for workspace edits
        let mut changes: HashMap<Uri, Vec<TextEdit>> = HashMap::new();
        for o in all().filter(|o| !o.is_pattern() && o.names(what, old)) {
            let Some(loc) = t.files.location(&o) else {
                continue;
            };
            changes.entry(loc.uri).or_default().push(TextEdit {
                range: loc.range,
                new_text: new.clone(),
            });
        }
        Ok(Some(WorkspaceEdit {
            changes: Some(changes),
            ..WorkspaceEdit::default()
        }))
    }
}

/// A name as the user writes it.
fn shown(what: What, name: &str) -> String {
    match what {
        What::Counter => format!("C{name}"),
        _ => name.to_string(),
    }
}

/// The new name as it is written in the files (a counter's two digits), or why it cannot be.
fn new_name(what: What, typed: &str, files: &Files) -> Result<String, String> {
    let typed = typed.trim();
    match what {
        What::State => {
            let typed = typed
                .strip_prefix('S')
                .filter(|s| s.len() == 5)
                .unwrap_or(typed);
            if typed.chars().count() == 5
                && typed.chars().all(|c| c.is_ascii_alphanumeric() || c == '_')
            {
                Ok(typed.to_string())
            } else {
                Err(format!(
                    "`{typed}` is not a state: five letters, digits or `_` (e.g. `DONE0`)"
                ))
            }
        }
        What::Counter => {
            let digits = typed.strip_prefix(['C', 'c']).unwrap_or(typed);
            let most = if three_d(files) { 44 } else { 24 };
            match digits.parse::<u32>() {
                Ok(n) if digits.chars().all(|c| c.is_ascii_digit()) && n <= most => {
                    Ok(format!("{n:02}"))
                }
                _ => Err(format!(
                    "`{typed}` is not a counter: C00 to C{most} in these files"
                )),
            }
        }
        What::Rule => {
            if typed.is_empty() || typed.contains("//") || typed.contains(['\n', '\r']) {
                Err("a rule's name is one line of text, without `//`".into())
            } else {
                Ok(typed.to_string())
            }
        }
    }
}

/// True when the files are 3D: as the agents file's head says (its universe line or first
/// position), else as the rules' own terms say (the checker's judgement of both).
fn three_d(files: &Files) -> bool {
    use latticesim_compiler::{dim, fast_agents, Dim};
    if let Some(head) = fast_agents::read_head(files.texts[1].as_bytes()) {
        return head.dim == Dim::Three;
    }
    let arena = bumpalo::Bump::new();
    let (rules, _) = latticesim_grammar::parse_rules(&files.texts[0], FileId(0), &arena, None);
    dim::from_rules(&rules, FileId(0), &files.texts[0]).is_some_and(|d| d.dim == Dim::Three)
}

#[cfg(test)]
mod tests {
    use super::*;
    use latticesim_grammar::Span;

    #[test]
    fn agents_places_are_listed_up_to_the_limit_and_rules_places_all() {
        let o = |file| Occurrence {
            what: What::State,
            text: "WALK0",
            span: Span::new(0, 5),
            role: names::Role::Start,
            file: FileId(file),
        };
        let v: Vec<Occurrence<'_>> = (0..AGENT_PLACES + 5)
            .map(|_| o(1))
            .chain((0..7).map(|_| o(0)))
            .collect();
        let l = listed(v.iter().copied());
        assert_eq!(l.len(), AGENT_PLACES + 7);
        assert_eq!(l.iter().filter(|o| o.file == FileId(0)).count(), 7);
    }
}
