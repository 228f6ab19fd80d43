//! `latticesim lsp`: a language server over standard input and output for rules and agents
//! files (docs/editors.md).
//!
//! - Diagnostics as you type: the checker of `latticesim check`, on the document and the file
//!   it pairs with (a rules file with its agents file, see [`Server::partner`]), with the
//!   secondary labels as related information (into the other file too).
//! - Hover: what a term or action under the cursor tests or does; a rule's name and
//!   priority; an agent's fields.
//! - Completion: the terms a precondition or postcondition line may hold, and the states
//!   used in the files after `S` or a `T` offset.
//! - Formatting: `latticesim fmt`'s layout.
//! - Code actions: the diagnostics' fixes as quick fixes.
//! - Navigation across the pair of files: go to definition, find references and rename of
//!   states, counters and rule names (`navigate`).
//! - The document's shape: rules as symbols, semantic tokens, folding ranges (`outline`).
//!
//! [`Server::handle`] takes a message and gives the messages to send, so tests drive it
//! without a process; [`run`] connects it to standard input and output.

mod features;
mod frame;
mod names;
mod navigate;
mod outline;
pub mod text;

use lsp_server::{Message, Notification, Request, RequestId, Response};
use lsp_types::{
    CodeActionProviderCapability, CompletionOptions, DidChangeTextDocumentParams,
    DidCloseTextDocumentParams, DidOpenTextDocumentParams, FoldingRangeProviderCapability,
    HoverProviderCapability, OneOf, PositionEncodingKind, RenameOptions, SemanticTokensFullOptions,
    SemanticTokensOptions, ServerCapabilities, TextDocumentSyncCapability, TextDocumentSyncKind,
};
use std::collections::HashMap;
use std::path::PathBuf;
use std::process::ExitCode;

/// Which language a document is in.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// A rules file.
    Rules,
    /// An agents file.
    Agents,
}

/// An open document.
pub struct Doc {
    /// The text as the editor has it (shared with what is kept of the checks: a 10^6-line
    /// agents file is not copied at each).
    pub text: std::rc::Rc<String>,
    /// The editor's version.
    pub version: i32,
    /// Rules or agents.
    pub kind: Kind,
}

/// The server's state: the open documents, and what is kept between requests of the files
/// (the last pair checked, forgotten when a document opens, changes or closes; the rest
/// kept per file while it is the same, see `Server::changes`).
#[derive(Default)]
pub struct Server {
    docs: HashMap<String, Doc>,
    pair_cache: std::cell::RefCell<features::Kept>,
    /// The files last navigated (see `navigate.rs`), with what each file was
    /// (`features::FileKey`): what was found in a file that has not changed is kept.
    nav_cache: std::cell::RefCell<navigate::KeptFiles>,
    /// The reading of the agents file last checked with rules (`agents_file::KeptReading`),
    /// kept while its text is the same (an edit of the rules beside a 10^6-line agents file
    /// read the whole file again).
    reading: std::cell::RefCell<(Option<features::FileKey>, crate::agents_file::KeptReading)>,
    /// Per document hovered, its outline (see `features.rs`) and the file it was made of (a
    /// hover in the rules between two in a 10^6-line agents file found the agents again).
    hover_cache:
        std::cell::RefCell<HashMap<String, (features::FileKey, std::rc::Rc<features::Outline>)>>,
    /// Per document, how many times it opened, changed or closed: what is kept of a file is
    /// kept with its count (a document's version need not change with its text: an editor
    /// may reopen it, or send a change without a new version), so that an edit of one file
    /// leaves what is kept of the other.
    changes: HashMap<String, u64>,
}

/// The capabilities the server announces.
pub fn capabilities() -> ServerCapabilities {
    ServerCapabilities {
        position_encoding: Some(PositionEncodingKind::UTF16),
        text_document_sync: Some(TextDocumentSyncCapability::Kind(
            TextDocumentSyncKind::INCREMENTAL,
        )),
        hover_provider: Some(HoverProviderCapability::Simple(true)),
        completion_provider: Some(CompletionOptions {
            trigger_characters: Some(vec![" ".into(), ",".into(), "S".into()]),
            ..CompletionOptions::default()
        }),
        document_formatting_provider: Some(OneOf::Left(true)),
        code_action_provider: Some(CodeActionProviderCapability::Simple(true)),
        definition_provider: Some(OneOf::Left(true)),
        references_provider: Some(OneOf::Left(true)),
        rename_provider: Some(OneOf::Right(RenameOptions {
            prepare_provider: Some(true),
            work_done_progress_options: Default::default(),
        })),
        document_symbol_provider: Some(OneOf::Left(true)),
        semantic_tokens_provider: Some(
            SemanticTokensOptions {
                legend: outline::legend(),
                full: Some(SemanticTokensFullOptions::Bool(true)),
                ..SemanticTokensOptions::default()
            }
            .into(),
        ),
        folding_range_provider: Some(FoldingRangeProviderCapability::Simple(true)),
        ..ServerCapabilities::default()
    }
}

/// The file path of a `file:` URI.
pub fn path_of(uri: &str) -> Option<PathBuf> {
    url::Url::parse(uri).ok()?.to_file_path().ok()
}

/// The kind of a document from its language id or, failing that, its file name.
fn kind_of(language: &str, uri: &str) -> Kind {
    match language {
        "latticesim-agents" => Kind::Agents,
        "latticesim-rules" => Kind::Rules,
        _ => {
            let name = uri.rsplit('/').next().unwrap_or("");
            if name.starts_with("agents") {
                Kind::Agents
            } else {
                Kind::Rules
            }
        }
    }
}

/// The answer to a request the server understood but will not carry out, with why.
fn refused(id: RequestId, why: String) -> Response {
    Response::new_err(id, lsp_server::ErrorCode::RequestFailed as i32, why)
}

/// An answer's JSON text, written from its data (not through a `serde_json::Value`).
fn json_text(v: &impl serde::Serialize) -> String {
    serde_json::to_string(v).expect("answers are plain data")
}

fn params<P: serde::de::DeserializeOwned>(v: serde_json::Value) -> Option<P> {
    serde_json::from_value(v).ok()
}

impl Server {
    /// A server with no document open.
    pub fn new() -> Server {
        Server::default()
    }

    /// The text of an open document.
    pub fn open_text(&self, uri: &str) -> Option<&str> {
        self.docs.get(uri).map(|d| d.text.as_str())
    }

    /// The text of a document: the editor's when it is open, else the file's on disk.
    fn text_of(&self, uri: &str) -> Option<std::rc::Rc<String>> {
        if let Some(d) = self.docs.get(uri) {
            return Some(std::rc::Rc::clone(&d.text));
        }
        let bytes = std::fs::read(path_of(uri)?).ok()?;
        // (Valid UTF-8, as files are, is taken as it is: not copied.)
        let text = String::from_utf8(bytes)
            .unwrap_or_else(|e| String::from_utf8_lossy(e.as_bytes()).into_owned());
        Some(text.into())
    }

    /// The file a document is checked with: for `rules-X.txt` the `agents-X.txt` beside it
    /// (open or on disk), else an open agents file in the same folder, else `agents.txt`;
    /// for `agents-X.txt` the `rules-X.txt` beside it, else `rules.txt`.
    pub fn partner(&self, uri: &str, kind: Kind) -> Option<String> {
        let (dir, name) = uri.rsplit_once('/')?;
        let (own, other) = match kind {
            Kind::Rules => ("rules", "agents"),
            Kind::Agents => ("agents", "rules"),
        };
        let suffix = name.strip_prefix(own).unwrap_or(".txt");
        let exists =
            |u: &String| self.docs.contains_key(u) || path_of(u).is_some_and(|p| p.is_file());
        let same = format!("{dir}/{other}{suffix}");
        if exists(&same) {
            return Some(same);
        }
        if kind == Kind::Rules {
            let mut open: Vec<&String> = self
                .docs
                .iter()
                .filter(|(u, d)| {
                    d.kind == Kind::Agents && u.rsplit_once('/').is_some_and(|(d, _)| d == dir)
                })
                .map(|(u, _)| u)
                .collect();
            open.sort();
            if let Some(u) = open.first() {
                return Some((*u).clone());
            }
        }
        let plain = format!("{dir}/{other}.txt");
        exists(&plain).then_some(plain)
    }

    /// The URIs of a document and its partner, rules file first (see [`Server::partner`]).
    fn pair_uris(&self, uri: &str) -> Option<[Option<String>; 2]> {
        let kind = self.docs.get(uri)?.kind;
        let partner = self.partner(uri, kind);
        Some(match kind {
            Kind::Rules => [Some(uri.to_string()), partner],
            Kind::Agents => [partner, Some(uri.to_string())],
        })
    }

    /// Handles one message from the client; gives the messages to send back.
    pub fn handle(&mut self, msg: Message) -> Vec<Message> {
        match msg {
            Message::Request(r) => vec![self.request(r)],
            Message::Notification(n) => self.notification(n),
            Message::Response(_) => Vec::new(),
        }
    }

    fn request(&mut self, r: Request) -> Message {
        let id: RequestId = r.id.clone();
        // Large answers, written as JSON text straight from their data.
        let raw = match r.method.as_str() {
            "textDocument/documentSymbol" => {
                Some(params(r.params.clone()).map(|p| self.document_symbols_json(p)))
            }
            "textDocument/semanticTokens/full" => {
                Some(params(r.params.clone()).map(|p| self.semantic_tokens_json(p)))
            }
            // (Up to 10,000 places in a large agents file.)
            "textDocument/definition" => {
                Some(params(r.params.clone()).map(|p| json_text(&self.definition(p))))
            }
            "textDocument/references" => {
                Some(params(r.params.clone()).map(|p| json_text(&self.references(p))))
            }
            _ => None,
        };
        match raw {
            Some(Some(json)) => return frame::raw(&id, &json),
            Some(None) => {
                return Message::Response(Response::new_err(
                    id,
                    lsp_server::ErrorCode::InvalidParams as i32,
                    "the parameters could not be read".into(),
                ))
            }
            None => {}
        }
        Message::Response(self.response(r))
    }

    fn response(&mut self, r: Request) -> Response {
        let id: RequestId = r.id.clone();
        let result = match r.method.as_str() {
            "textDocument/hover" => params(r.params).map(|p| serde_json::to_value(self.hover(p))),
            "textDocument/completion" => {
                params(r.params).map(|p| serde_json::to_value(self.completion(p)))
            }
            "textDocument/formatting" => {
                params(r.params).map(|p| serde_json::to_value(self.formatting(p)))
            }
            "textDocument/codeAction" => {
                params(r.params).map(|p| serde_json::to_value(self.code_actions(p)))
            }
            "textDocument/foldingRange" => {
                params(r.params).map(|p| serde_json::to_value(self.folding_ranges(p)))
            }
            "textDocument/prepareRename" => {
                match params(r.params).map(|p| self.prepare_rename(p)) {
                    Some(Err(why)) => return refused(id, why),
                    other => other.map(|a| serde_json::to_value(a.ok().flatten())),
                }
            }
            "textDocument/rename" => match params(r.params).map(|p| self.rename(p)) {
                Some(Err(why)) => return refused(id, why),
                other => other.map(|a| serde_json::to_value(a.ok().flatten())),
            },
            "shutdown" => Some(Ok(serde_json::Value::Null)),
            _ => {
                return Response::new_err(
                    id,
                    lsp_server::ErrorCode::MethodNotFound as i32,
                    format!("latticesim lsp does not handle `{}`", r.method),
                )
            }
        };
        match result {
            Some(Ok(v)) => Response::new_ok(id, v),
            _ => Response::new_err(
                id,
                lsp_server::ErrorCode::InvalidParams as i32,
                "the parameters could not be read".into(),
            ),
        }
    }

    fn notification(&mut self, n: Notification) -> Vec<Message> {
        if n.method.starts_with("textDocument/did") {
            *self.pair_cache.get_mut() = None;
            let uri = n
                .params
                .pointer("/textDocument/uri")
                .and_then(|u| u.as_str());
            if let Some(uri) = uri {
                *self.changes.entry(uri.to_string()).or_default() += 1;
            }
        }
        match n.method.as_str() {
            "textDocument/didOpen" => {
                let Some(p) = params::<DidOpenTextDocumentParams>(n.params) else {
                    return Vec::new();
                };
                let uri = p.text_document.uri.as_str().to_string();
                let kind = kind_of(&p.text_document.language_id, &uri);
                self.docs.insert(
                    uri.clone(),
                    Doc {
                        text: p.text_document.text.into(),
                        version: p.text_document.version,
                        kind,
                    },
                );
                self.publish(&uri)
            }
            "textDocument/didChange" => {
                let Some(p) = params::<DidChangeTextDocumentParams>(n.params) else {
                    return Vec::new();
                };
                let uri = p.text_document.uri.as_str().to_string();
                let Some(d) = self.docs.get_mut(&uri) else {
                    return Vec::new();
                };
                d.version = p.text_document.version;
                text::apply_changes(std::rc::Rc::make_mut(&mut d.text), p.content_changes);
                self.publish(&uri)
            }
            "textDocument/didClose" => {
                let Some(p) = params::<DidCloseTextDocumentParams>(n.params) else {
                    return Vec::new();
                };
                let uri = p.text_document.uri.as_str().to_string();
                self.docs.remove(&uri);
                self.hover_cache.get_mut().remove(&uri);
                // Its diagnostics go with it.
                features::clear(&uri).into_iter().collect()
            }
            _ => Vec::new(),
        }
    }
}

/// Runs the server on standard input and output until the client says `exit`.
/// A session over `input`, framed as an editor sends it, without a process (for the fuzz
/// harness, `crate::fuzzing`): each frame read as [`run`] reads it and handled; what
/// happened, in words.
pub fn replay(input: &[u8]) -> Vec<String> {
    let mut r = std::io::BufReader::new(input);
    let mut server = Server::new();
    let mut seen = Vec::new();
    loop {
        match frame::read(&mut r) {
            Ok(None) => break,
            Err(e) => {
                seen.push(format!("ended: {:?}", e.kind()));
                break;
            }
            Ok(Some(frame::Frame::Refused(code, _))) => seen.push(format!("refused {code}")),
            Ok(Some(frame::Frame::Message(m))) => {
                let what = match &m {
                    Message::Request(r) => r.method.clone(),
                    Message::Notification(n) => n.method.clone(),
                    Message::Response(_) => "a response".into(),
                };
                for reply in server.handle(m) {
                    seen.push(match reply {
                        Message::Response(Response { error: Some(e), .. }) => {
                            format!("error {}", e.code)
                        }
                        Message::Notification(n) if n.method == frame::RAW => {
                            format!("answered {what}")
                        }
                        Message::Notification(n) => {
                            let codes = (n.params["diagnostics"].as_array())
                                .into_iter()
                                .flatten()
                                .filter_map(|d| d["code"].as_str())
                                .collect::<std::collections::BTreeSet<_>>();
                            format!("{what}: {} {codes:?}", n.method)
                        }
                        _ => format!("answered {what}"),
                    });
                }
            }
        }
    }
    seen
}

pub fn run() -> ExitCode {
    let (connection, reader, writer) = frame::stdio();
    let caps = serde_json::to_value(capabilities()).expect("capabilities are plain data");
    if let Err(e) = connection.initialize(caps) {
        crate::output::say!("error: the language client did not initialize: {e}");
        return ExitCode::from(2);
    }
    let mut server = Server::new();
    for msg in &connection.receiver {
        if let Message::Request(r) = &msg {
            match connection.handle_shutdown(r) {
                Ok(true) => break,
                Ok(false) => {}
                Err(_) => break,
            }
        }
        for out in server.handle(msg) {
            if connection.sender.send(out).is_err() {
                break;
            }
        }
    }
    drop(connection);
    // The writer ends when the connection is dropped; the reader at the end of the input
    // or at `exit` (not waited for after a shutdown without `exit`: the process ends).
    let mut code = ExitCode::SUCCESS;
    for t in std::iter::once(writer).chain(reader.is_finished().then_some(reader)) {
        let ended = t
            .join()
            .unwrap_or_else(|_| Err(std::io::Error::other("a thread of the connection panicked")));
        if let Err(e) = ended {
            crate::output::say!("error: the language client's connection failed: {e}");
            code = ExitCode::from(2);
        }
    }
    code
}
