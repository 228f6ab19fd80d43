//! The language server as an editor meets it (issue 33): `latticesim lsp` as a process,
//! spoken to over its standard input and output, on a generated file of 5,005 rules beside
//! an agents file of 1,000 lines and of 10^6 lines (both open in the editor). Each request's
//! round trip, from writing it to reading its answer's last byte (the editor's parse of the
//! answer is the editor's), the median and the slowest of 15 after two to warm up, and the
//! median of 5 made each just after an edit of the rules (once its diagnostics came: what
//! the server keeps per version of a document is then made again); for an edit, until the
//! rules file's diagnostics arrive. The baseline, measured in the same run: a request the
//! server refuses at once (an unknown method), the cost of the transport alone.
//!
//! `cargo bench -p latticesim-benches --bench lsp`; `LSP_QUICK=1`: the 1,000-line agents
//! file only. Target: every request within 50 ms on 5,005 rules.

use latticesim_benches::generate_rules;
use latticesim_benches::process::{latticesim, root};
use serde_json::{json, Value};
use std::io::{BufRead, BufReader, Read, Write};
use std::path::Path;
use std::process::{Child, ChildStdin, ChildStdout, Command, Stdio};
use std::time::{Duration, Instant};

struct Server {
    child: Child,
    stdin: ChildStdin,
    stdout: BufReader<ChildStdout>,
    id: i64,
    /// When the last message read was read whole, and its size.
    read_at: Instant,
    read_len: usize,
}

impl Server {
    fn start() -> Server {
        let mut child = Command::new(latticesim())
            .arg("lsp")
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::inherit())
            .spawn()
            .expect("latticesim lsp starts");
        let stdin = child.stdin.take().unwrap();
        let stdout = BufReader::new(child.stdout.take().unwrap());
        Server {
            child,
            stdin,
            stdout,
            id: 0,
            read_at: Instant::now(),
            read_len: 0,
        }
    }

    fn send(&mut self, v: &Value) {
        let body = v.to_string();
        write!(self.stdin, "Content-Length: {}\r\n\r\n{body}", body.len()).unwrap();
        self.stdin.flush().unwrap();
    }

    fn read(&mut self) -> Value {
        let mut len = 0;
        loop {
            let mut line = String::new();
            assert!(
                self.stdout.read_line(&mut line).unwrap() > 0,
                "the server ended"
            );
            let line = line.trim_end();
            if line.is_empty() {
                break;
            }
            if let Some(v) = line.strip_prefix("Content-Length: ") {
                len = v.parse().unwrap();
            }
        }
        let mut body = vec![0; len];
        self.stdout.read_exact(&mut body).unwrap();
        (self.read_at, self.read_len) = (Instant::now(), len);
        serde_json::from_slice(&body).unwrap()
    }

    fn notify(&mut self, method: &str, params: Value) {
        self.send(&json!({"jsonrpc": "2.0", "method": method, "params": params}));
    }

    /// A request's answer (errors included), the notifications before it dropped.
    fn request(&mut self, method: &str, params: Value) -> Value {
        self.id += 1;
        let id = self.id;
        self.send(&json!({"jsonrpc": "2.0", "id": id, "method": method, "params": params}));
        loop {
            let m = self.read();
            if m["id"] == json!(id) {
                return m;
            }
        }
    }

    /// Waits for the diagnostics of `uri`.
    fn diagnostics(&mut self, uri: &str) -> usize {
        loop {
            let m = self.read();
            if m["method"] == "textDocument/publishDiagnostics" && m["params"]["uri"] == uri {
                return m["params"]["diagnostics"].as_array().map_or(0, |d| d.len());
            }
        }
    }
}

/// The (line, UTF-16 column) of the first `needle` in `text`, plus `skip` characters.
fn position(text: &str, needle: &str, skip: usize) -> Value {
    let at = text.find(needle).expect("the needle is in the text") + skip;
    let line = text[..at].matches('\n').count();
    let col = at - text[..at].rfind('\n').map_or(0, |i| i + 1);
    json!({"line": line, "character": col})
}

/// The median and slowest of `reps` runs of `f` (which says how long it took), after two
/// to warm up.
fn timed(reps: usize, mut f: impl FnMut() -> Duration) -> (Duration, Duration) {
    for _ in 0..2 {
        f();
    }
    let mut v: Vec<Duration> = (0..reps).map(|_| f()).collect();
    v.sort();
    (v[reps / 2], v[reps - 1])
}

impl Server {
    /// How long a request took until its answer was read whole.
    fn round_trip(&mut self, method: &str, params: Value) -> Duration {
        let t = Instant::now();
        self.request(method, params);
        self.read_at - t
    }

    /// An edit of the rules' first line (a letter put in, then taken out), until the rules
    /// file's diagnostics arrive.
    fn edit(&mut self, rules: &str, version: &mut i32) -> Duration {
        *version += 1;
        let text = if *version % 2 == 0 { "x" } else { "" };
        let len = if *version % 2 == 0 { 0 } else { 1 };
        let t = Instant::now();
        self.notify(
            "textDocument/didChange",
            json!({"textDocument": {"uri": rules, "version": *version},
                   "contentChanges": [{"range": {"start": {"line": 0, "character": 0}, "end": {"line": 0, "character": len}}, "text": text}]}),
        );
        self.diagnostics(rules);
        self.read_at - t
    }
}

fn ms(d: Duration) -> String {
    format!("{:.1} ms", d.as_secs_f64() * 1e3)
}

fn session(dir: &Path, agents_lines: usize) {
    let rules_text = generate_rules(5005, 1);
    let state = {
        let at = rules_text.find("\nS").expect("a state test") + 2;
        rules_text[at..at + 5].to_string()
    };
    let rules_path = dir.join("rules.txt");
    let agents_path = dir.join("agents.txt");
    std::fs::write(&rules_path, &rules_text).unwrap();
    let mut agents_text = String::with_capacity(agents_lines * 24);
    for i in 0..agents_lines {
        agents_text += &format!("{},{} S{state} C01 3\n", i % 1000, i / 1000);
    }
    std::fs::write(&agents_path, &agents_text).unwrap();
    let rules = format!("file://{}", rules_path.display());
    let agents = format!("file://{}", agents_path.display());

    let mut s = Server::start();
    s.request(
        "initialize",
        json!({"processId": null, "rootUri": null, "capabilities": {}}),
    );
    s.notify("initialized", json!({}));
    let t = Instant::now();
    s.notify(
        "textDocument/didOpen",
        json!({"textDocument": {"uri": rules, "languageId": "latticesim-rules", "version": 1, "text": rules_text}}),
    );
    let shown = s.diagnostics(&rules);
    let open_rules = t.elapsed();
    let t = Instant::now();
    s.notify(
        "textDocument/didOpen",
        json!({"textDocument": {"uri": agents, "languageId": "latticesim-agents", "version": 1, "text": agents_text}}),
    );
    s.diagnostics(&agents);
    let open_agents = t.elapsed();
    println!(
        "\n5,005 rules ({} KB, {shown} diagnostics) beside {agents_lines} agents ({} KB), both open",
        rules_text.len() / 1000,
        agents_text.len() / 1000
    );
    println!("| request | median | slowest | just after an edit | answer |");
    println!("|---|---:|---:|---:|---:|");
    println!(
        "| open the rules file (until its diagnostics) | {} | | | |",
        ms(open_rules)
    );
    println!(
        "| open the agents file (until its diagnostics) | {} | | | |",
        ms(open_agents)
    );

    let doc = json!({"uri": rules});
    let state_at = position(&rules_text, &format!("\nS{state}"), 2);
    let counter_at = position(&rules_text, ">C", 2);
    let name_at = position(&rules_text, "rule7\n", 1);
    let at = |p: &Value| json!({"textDocument": doc, "position": p});
    let reps = 15;
    let mut version = 1;
    // (what, median and slowest, just after an edit, the answer's size)
    type Row = (String, (Duration, Duration), Option<Duration>, usize);
    let mut rows: Vec<Row> = Vec::new();
    let d = timed(reps, || s.round_trip("latticesim/nothing", json!({})));
    rows.push((
        "baseline: an unknown method (refused at once)".into(),
        d,
        None,
        s.read_len,
    ));
    let d = timed(reps, || s.edit(&rules, &mut version));
    rows.push((
        "an edit, until the rules file's diagnostics".into(),
        d,
        None,
        s.read_len,
    ));
    let requests: Vec<(&str, &str, Value)> = vec![
        ("hover", "textDocument/hover", at(&state_at)),
        (
            "completion",
            "textDocument/completion",
            at(&json!({"line": 2, "character": 0})),
        ),
        (
            "go to definition (a state)",
            "textDocument/definition",
            at(&state_at),
        ),
        (
            "find references (a state, both files)",
            "textDocument/references",
            json!({"textDocument": doc, "position": state_at, "context": {"includeDeclaration": true}}),
        ),
        (
            "find references (a counter, both files)",
            "textDocument/references",
            json!({"textDocument": doc, "position": counter_at, "context": {"includeDeclaration": true}}),
        ),
        ("prepare rename", "textDocument/prepareRename", at(&name_at)),
        (
            "rename (a counter, both files)",
            "textDocument/rename",
            json!({"textDocument": doc, "position": counter_at, "newName": "C24"}),
        ),
        (
            "document symbols",
            "textDocument/documentSymbol",
            json!({"textDocument": doc}),
        ),
        (
            "semantic tokens",
            "textDocument/semanticTokens/full",
            json!({"textDocument": doc}),
        ),
        (
            "folding ranges",
            "textDocument/foldingRange",
            json!({"textDocument": doc}),
        ),
        (
            "code actions",
            "textDocument/codeAction",
            json!({"textDocument": doc, "range": {"start": state_at, "end": state_at}, "context": {"diagnostics": []}}),
        ),
        (
            "formatting",
            "textDocument/formatting",
            json!({"textDocument": doc, "options": {"tabSize": 4, "insertSpaces": true}}),
        ),
        (
            "hover in the agents file",
            "textDocument/hover",
            json!({"textDocument": {"uri": agents}, "position": {"line": 0, "character": 6}}),
        ),
    ];
    for (what, method, params) in requests {
        let answer = s.request(method, params.clone());
        assert!(
            answer.get("error").is_none() || what.starts_with("rename"),
            "{what}: {answer}"
        );
        let d = timed(reps, || s.round_trip(method, params.clone()));
        let size = s.read_len;
        let mut after: Vec<Duration> = (0..5)
            .map(|_| {
                s.edit(&rules, &mut version);
                s.round_trip(method, params.clone())
            })
            .collect();
        after.sort();
        rows.push((what.into(), d, Some(after[2]), size));
    }
    for (what, (median, slowest), after, size) in rows {
        let after = after.map_or(String::new(), ms);
        println!(
            "| {what} | {} | {} | {after} | {:.1} KB |",
            ms(median),
            ms(slowest),
            size as f64 / 1e3
        );
    }
    s.request("shutdown", Value::Null);
    s.notify("exit", Value::Null);
    s.child.wait().unwrap();
}

fn main() {
    if std::env::args().any(|a| a == "--list") {
        return;
    }
    let dir = root().join("target/lsp");
    std::fs::create_dir_all(&dir).unwrap();
    session(&dir, 1000);
    if std::env::var_os("LSP_QUICK").is_none() {
        session(&dir, 1_000_000);
    }
}
