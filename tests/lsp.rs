//! `latticesim lsp` driven as an editor drives it: a process speaking JSON-RPC over its
//! standard input and output (initialize, didOpen, didChange, hover, completion,
//! formatting, codeAction, definition, references, prepareRename, rename, documentSymbol,
//! semanticTokens/full, foldingRange, shutdown, exit), with the answers checked; a rules file
//! and an agents file of two dimensions opened as a pair.

use serde_json::{json, Value};
use std::io::{BufRead, BufReader, Read, Write};
use std::process::{Child, ChildStdin, Command, Stdio};
use std::sync::mpsc::{channel, Receiver};
use std::time::Duration;

struct Client {
    child: Child,
    stdin: ChildStdin,
    incoming: Receiver<Value>,
    next_id: i64,
}

impl Client {
    fn start() -> Client {
        let mut child = Command::new(env!("CARGO_BIN_EXE_latticesim"))
            .arg("lsp")
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::null())
            .spawn()
            .expect("latticesim lsp starts");
        let stdin = child.stdin.take().unwrap();
        let mut out = BufReader::new(child.stdout.take().unwrap());
        let (tx, incoming) = channel();
        std::thread::spawn(move || loop {
            let mut len = None;
            loop {
                let mut line = String::new();
                if out.read_line(&mut line).unwrap_or(0) == 0 {
                    return;
                }
                let line = line.trim_end();
                if line.is_empty() {
                    break;
                }
                if let Some(v) = line.strip_prefix("Content-Length: ") {
                    len = v.parse::<usize>().ok();
                }
            }
            let mut body = vec![0; len.expect("a Content-Length header")];
            out.read_exact(&mut body).unwrap();
            if tx.send(serde_json::from_slice(&body).unwrap()).is_err() {
                return;
            }
        });
        Client {
            child,
            stdin,
            incoming,
            next_id: 1,
        }
    }

    fn send(&mut self, v: Value) {
        let body = v.to_string();
        write!(self.stdin, "Content-Length: {}\r\n\r\n{body}", body.len()).unwrap();
        self.stdin.flush().unwrap();
    }

    fn notify(&mut self, method: &str, params: Value) {
        self.send(json!({"jsonrpc": "2.0", "method": method, "params": params}));
    }

    fn next(&mut self) -> Value {
        self.incoming
            .recv_timeout(Duration::from_secs(30))
            .expect("the server answers within 30 s")
    }

    /// Sends a request and waits for its response (notifications in between are dropped).
    fn answer(&mut self, method: &str, params: Value) -> Value {
        let id = self.next_id;
        self.next_id += 1;
        self.send(json!({"jsonrpc": "2.0", "id": id, "method": method, "params": params}));
        loop {
            let m = self.next();
            if m["id"] == json!(id) {
                return m;
            }
        }
    }

    /// A request's result; it must not fail.
    fn request(&mut self, method: &str, params: Value) -> Value {
        let m = self.answer(method, params);
        assert!(m.get("error").is_none(), "{method}: {m}");
        m["result"].clone()
    }

    /// A request that must fail; its error.
    fn request_error(&mut self, method: &str, params: Value) -> Value {
        let m = self.answer(method, params);
        assert!(m.get("error").is_some(), "{method} should fail: {m}");
        m["error"].clone()
    }

    /// Waits for the diagnostics published for `uri`.
    fn diagnostics(&mut self, uri: &str) -> Vec<Value> {
        loop {
            let m = self.next();
            if m["method"] == "textDocument/publishDiagnostics" && m["params"]["uri"] == uri {
                return m["params"]["diagnostics"].as_array().unwrap().clone();
            }
        }
    }
}

fn pos(line: u32, character: u32) -> Value {
    json!({"line": line, "character": character})
}

#[test]
fn an_editor_session() {
    let dir = std::env::temp_dir().join(format!("latticesim-lsp-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let dir = dir.canonicalize().unwrap();
    // The agents file is on disk only: the server reads it beside the rules file.
    std::fs::write(dir.join("agents.txt"), "0,0 SINIT0\n1,0 SINIT0\n").unwrap();
    let rules_uri = url_of(&dir.join("rules.txt"));
    let agents_uri = url_of(&dir.join("agents.txt"));

    let mut c = Client::start();
    let init = c.request(
        "initialize",
        json!({"processId": null, "rootUri": null, "capabilities": {}}),
    );
    let caps = &init["capabilities"];
    assert_eq!(caps["hoverProvider"], json!(true));
    assert_eq!(caps["documentFormattingProvider"], json!(true));
    assert_eq!(caps["textDocumentSync"], json!(2), "incremental sync");
    c.notify("initialized", json!({}));

    // 1. A slip as typed: the letter O in a pattern, and a state that no agent has.
    let text = "start\n1\nSINTI0   N1*O*\nSLEAD0\n";
    c.notify(
        "textDocument/didOpen",
        json!({"textDocument": {"uri": rules_uri, "languageId": "latticesim-rules", "version": 1, "text": text}}),
    );
    let d = c.diagnostics(&rules_uri);
    assert_eq!(d.len(), 1, "{d:?}");
    assert_eq!(d[0]["code"], "E304");
    assert_eq!(d[0]["range"]["start"], pos(2, 12));
    assert_eq!(d[0]["range"]["end"], pos(2, 13));
    assert!(d[0]["message"]
        .as_str()
        .unwrap()
        .contains("fix: write the digit `0`"));

    // 2. The quick fix for it.
    let actions = c.request(
        "textDocument/codeAction",
        json!({"textDocument": {"uri": rules_uri}, "range": {"start": pos(2, 12), "end": pos(2, 12)},
               "context": {"diagnostics": d}}),
    );
    let a = &actions.as_array().unwrap()[0];
    assert_eq!(a["kind"], "quickfix");
    let edits = &a["edit"]["changes"][&rules_uri];
    assert_eq!(edits[0]["newText"], "0");
    assert_eq!(edits[0]["range"]["start"], pos(2, 12));

    // 3. An incremental change applies it: what is left is the state no agent starts in,
    // with the agents file as related information and the nearest state as a fix.
    c.notify(
        "textDocument/didChange",
        json!({"textDocument": {"uri": rules_uri, "version": 2},
               "contentChanges": [{"range": {"start": pos(2, 12), "end": pos(2, 13)}, "text": "0"}]}),
    );
    let d = c.diagnostics(&rules_uri);
    assert_eq!(d.len(), 1, "{d:?}");
    assert_eq!(d[0]["code"], "W503");
    assert_eq!(d[0]["severity"], 2);
    let related = &d[0]["relatedInformation"][0];
    assert_eq!(related["location"]["uri"], agents_uri);
    assert_eq!(related["location"]["range"]["start"], pos(0, 4));
    let actions = c.request(
        "textDocument/codeAction",
        json!({"textDocument": {"uri": rules_uri}, "range": {"start": pos(2, 1), "end": pos(2, 3)},
               "context": {"diagnostics": d}}),
    );
    assert_eq!(
        actions[0]["edit"]["changes"][&rules_uri][0]["newText"],
        "INIT0"
    );
    c.notify(
        "textDocument/didChange",
        json!({"textDocument": {"uri": rules_uri, "version": 3},
               "contentChanges": [{"range": {"start": pos(2, 1), "end": pos(2, 6)}, "text": "INIT0"}]}),
    );
    assert_eq!(c.diagnostics(&rules_uri), Vec::<Value>::new());

    // 4. Hover on the pattern and on the state action.
    let h = c.request(
        "textDocument/hover",
        json!({"textDocument": {"uri": rules_uri}, "position": pos(2, 11)}),
    );
    let value = h["contents"]["value"].as_str().unwrap();
    assert!(
        value.contains("Neighbour cells") && value.contains("north filled"),
        "{value}"
    );
    assert_eq!(h["range"]["start"], pos(2, 9));
    let h = c.request(
        "textDocument/hover",
        json!({"textDocument": {"uri": rules_uri}, "position": pos(3, 2)}),
    );
    assert!(h["contents"]["value"]
        .as_str()
        .unwrap()
        .contains("Set the state"));

    // 5. Completion: states of both files after `S`, actions on a postcondition line.
    c.notify(
        "textDocument/didChange",
        json!({"textDocument": {"uri": rules_uri, "version": 4},
               "contentChanges": [{"range": {"start": pos(2, 14), "end": pos(2, 14)}, "text": " SI"},
                                  {"range": {"start": pos(3, 6), "end": pos(3, 6)}, "text": " "}]}),
    );
    let labels = |r: &Value| -> Vec<String> {
        r.as_array()
            .unwrap()
            .iter()
            .map(|i| i["label"].as_str().unwrap().to_string())
            .collect()
    };
    let r = c.request(
        "textDocument/completion",
        json!({"textDocument": {"uri": rules_uri}, "position": pos(2, 17)}),
    );
    let l = labels(&r);
    assert!(
        l.contains(&"SINIT0".to_string()) && l.contains(&"SLEAD0".to_string()),
        "{l:?}"
    );
    // The pair checked is kept between requests, but not past a change of the agents file
    // on disk (its size or time of change).
    std::fs::write(
        dir.join("agents.txt"),
        "0,0 SINIT0\n1,0 SINIT0\n2,0 SWAIT0\n",
    )
    .unwrap();
    let r = c.request(
        "textDocument/completion",
        json!({"textDocument": {"uri": rules_uri}, "position": pos(2, 17)}),
    );
    assert!(
        labels(&r).contains(&"SWAIT0".to_string()),
        "{:?}",
        labels(&r)
    );
    let r = c.request(
        "textDocument/completion",
        json!({"textDocument": {"uri": rules_uri}, "position": pos(3, 7)}),
    );
    let l = labels(&r);
    assert!(
        l.contains(&"X".to_string()) && !l.contains(&"N".to_string()),
        "{l:?}"
    );

    // 6. Formatting gives the canonical layout.
    let f = c.request(
        "textDocument/formatting",
        json!({"textDocument": {"uri": rules_uri}, "options": {"tabSize": 4, "insertSpaces": true}}),
    );
    assert_eq!(f[0]["newText"], "start\n1\nSINIT0 N1*0* SI\nSLEAD0\n");

    // 7. Shutdown and exit end the process cleanly.
    assert_eq!(c.request("shutdown", Value::Null), Value::Null);
    c.notify("exit", Value::Null);
    let status = c.child.wait().unwrap();
    assert!(status.success(), "{status:?}");
    std::fs::remove_dir_all(&dir).ok();
}

/// The places of a list of locations: (file name, line, first character, last character).
fn places(v: &Value) -> Vec<(String, u64, u64, u64)> {
    let mut out: Vec<_> = v
        .as_array()
        .unwrap_or_else(|| panic!("locations: {v}"))
        .iter()
        .map(|l| {
            let name = l["uri"].as_str().unwrap().rsplit('/').next().unwrap();
            let r = &l["range"];
            (
                name.to_string(),
                r["start"]["line"].as_u64().unwrap(),
                r["start"]["character"].as_u64().unwrap(),
                r["end"]["character"].as_u64().unwrap(),
            )
        })
        .collect();
    out.sort();
    out
}

fn place(name: &str, line: u64, start: u64, end: u64) -> (String, u64, u64, u64) {
    (name.to_string(), line, start, end)
}

const WALK_RULES: &str = "// Walkers go east while C01 > 0,
// until a resting agent is ahead.
walk
1
SWALK0 >C01 0000 !T1,0,REST*
P1,0 C01 - C01 0001

stop
2
SWALK0 =C01 0000
SDONE0
";

const WALK_AGENTS: &str = "0,0 SWALK0 C01 3\n0,2 SWALK0 C01 1\n5,0 SREST0\n";

#[test]
fn navigating_a_pair_of_files() {
    let dir = std::env::temp_dir().join(format!("latticesim-lsp-nav-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let dir = dir.canonicalize().unwrap();
    std::fs::write(dir.join("rules.txt"), WALK_RULES).unwrap();
    std::fs::write(dir.join("agents.txt"), WALK_AGENTS).unwrap();
    let rules = url_of(&dir.join("rules.txt"));
    let agents = url_of(&dir.join("agents.txt"));
    let mut c = Client::start();
    let init = c.request(
        "initialize",
        json!({"processId": null, "rootUri": null, "capabilities": {}}),
    );
    let caps = &init["capabilities"];
    for cap in [
        "definitionProvider",
        "referencesProvider",
        "documentSymbolProvider",
        "foldingRangeProvider",
    ] {
        assert_eq!(caps[cap], json!(true), "{cap}");
    }
    assert_eq!(caps["renameProvider"]["prepareProvider"], json!(true));
    let legend = caps["semanticTokensProvider"]["legend"]["tokenTypes"].clone();
    assert!(legend.as_array().unwrap().len() >= 8, "{legend}");
    c.notify("initialized", json!({}));
    c.notify(
        "textDocument/didOpen",
        json!({"textDocument": {"uri": rules, "languageId": "latticesim-rules", "version": 1, "text": WALK_RULES}}),
    );
    assert_eq!(c.diagnostics(&rules), Vec::<Value>::new());
    let at = |uri: &str, line: u32, ch: u32| json!({"textDocument": {"uri": uri}, "position": pos(line, ch)});

    // Go to definition: a state to where agents start in it and the rules that set it.
    let d = c.request("textDocument/definition", at(&rules, 4, 1));
    assert_eq!(
        places(&d),
        vec![place("agents.txt", 0, 5, 10), place("agents.txt", 1, 5, 10)]
    );
    let d = c.request("textDocument/definition", at(&rules, 10, 3));
    assert_eq!(places(&d), vec![place("rules.txt", 10, 1, 6)]);
    // A pattern in a T term: the agents it matches.
    let d = c.request("textDocument/definition", at(&rules, 4, 24));
    assert_eq!(places(&d), vec![place("agents.txt", 2, 5, 10)]);
    // A counter: the calculation that writes it and the agents' start values.
    let d = c.request("textDocument/definition", at(&rules, 4, 9));
    assert_eq!(
        places(&d),
        vec![
            place("agents.txt", 0, 12, 14),
            place("agents.txt", 1, 12, 14),
            place("rules.txt", 5, 6, 8)
        ]
    );

    // Find references: every place of the counter in both files, and of a state from the
    // agents file (the pattern that matches it too).
    let r = c.request(
        "textDocument/references",
        json!({"textDocument": {"uri": rules}, "position": pos(4, 8), "context": {"includeDeclaration": true}}),
    );
    assert_eq!(places(&r).len(), 6, "{r}");
    let r = c.request(
        "textDocument/references",
        json!({"textDocument": {"uri": rules}, "position": pos(4, 8), "context": {"includeDeclaration": false}}),
    );
    assert_eq!(
        places(&r),
        vec![
            place("rules.txt", 4, 9, 11),
            place("rules.txt", 5, 12, 14),
            place("rules.txt", 9, 9, 11)
        ]
    );
    c.notify(
        "textDocument/didOpen",
        json!({"textDocument": {"uri": agents, "languageId": "latticesim-agents", "version": 1, "text": WALK_AGENTS}}),
    );
    let r = c.request(
        "textDocument/references",
        json!({"textDocument": {"uri": agents}, "position": pos(2, 6), "context": {"includeDeclaration": true}}),
    );
    assert_eq!(
        places(&r),
        vec![place("agents.txt", 2, 5, 10), place("rules.txt", 4, 23, 28)]
    );

    // Rename a state across both files; refused where a pattern would change its meaning
    // or the new name is taken.
    let p = c.request("textDocument/prepareRename", at(&rules, 4, 2));
    assert_eq!(p["placeholder"], "WALK0");
    let e = c.request_error("textDocument/prepareRename", at(&rules, 4, 24));
    assert!(e["message"].as_str().unwrap().contains("pattern"), "{e}");
    let rename = |uri: &str, line, ch, name: &str| json!({"textDocument": {"uri": uri}, "position": pos(line, ch), "newName": name});
    let params = rename(&rules, 4, 2, "STEP0");
    let w = c.request("textDocument/rename", params);
    let edits = |w: &Value, uri: &str| -> Vec<(u64, u64, String)> {
        let mut v: Vec<_> = w["changes"][uri]
            .as_array()
            .unwrap()
            .iter()
            .map(|e| {
                (
                    e["range"]["start"]["line"].as_u64().unwrap(),
                    e["range"]["start"]["character"].as_u64().unwrap(),
                    e["newText"].as_str().unwrap().to_string(),
                )
            })
            .collect();
        v.sort();
        v
    };
    let step = |l| (l, 1, "STEP0".to_string());
    assert_eq!(edits(&w, &rules), vec![step(4), step(9)]);
    let step = |l| (l, 5, "STEP0".to_string());
    assert_eq!(edits(&w, &agents), vec![step(0), step(1)]);
    let params = rename(&agents, 2, 6, "WALL0");
    let e = c.request_error("textDocument/rename", params);
    let m = e["message"].as_str().unwrap();
    assert!(
        m.contains("`REST*` (rules.txt:5) matches `REST0` but would not match `WALL0`"),
        "{m}"
    );
    let params = rename(&rules, 4, 2, "DONE0");
    let e = c.request_error("textDocument/rename", params);
    assert!(
        e["message"]
            .as_str()
            .unwrap()
            .contains("already used (rules.txt:11)"),
        "{e}"
    );
    let params = rename(&rules, 4, 2, "DONE");
    let e = c.request_error("textDocument/rename", params);
    assert!(
        e["message"].as_str().unwrap().contains("not a state"),
        "{e}"
    );
    // A counter: both files, its digits.
    let params = rename(&rules, 5, 7, "C07");
    let w = c.request("textDocument/rename", params);
    assert_eq!(edits(&w, &rules).len(), 4);
    assert_eq!(
        edits(&w, &agents),
        vec![(0, 12, "07".to_string()), (1, 12, "07".to_string())]
    );
    let params = rename(&rules, 5, 7, "C25");
    let e = c.request_error("textDocument/rename", params);
    assert!(e["message"].as_str().unwrap().contains("C00 to C24"), "{e}");

    // The outline, semantic tokens and folding.
    let s = c.request(
        "textDocument/documentSymbol",
        json!({"textDocument": {"uri": rules}}),
    );
    let names: Vec<(&str, &str)> = s
        .as_array()
        .unwrap()
        .iter()
        .map(|s| (s["name"].as_str().unwrap(), s["detail"].as_str().unwrap()))
        .collect();
    assert_eq!(names, vec![("walk", "priority 1"), ("stop", "priority 2")]);
    assert_eq!(s[0]["range"]["start"], pos(2, 0));
    assert_eq!(s[0]["range"]["end"], pos(5, 19));
    let t = c.request(
        "textDocument/semanticTokens/full",
        json!({"textDocument": {"uri": rules}}),
    );
    let data = t["data"].as_array().unwrap();
    assert_eq!(data.len() % 5, 0);
    // The first two tokens: the comment lines; the third the first rule's name.
    let ty = |i: usize| legend[data[i * 5 + 3].as_u64().unwrap() as usize].clone();
    assert_eq!(ty(0), "comment");
    assert_eq!(ty(2), "function");
    assert_eq!(data[2 * 5].as_u64(), Some(1), "the name is a line below");
    let f = c.request(
        "textDocument/foldingRange",
        json!({"textDocument": {"uri": rules}}),
    );
    let folds: Vec<(u64, u64)> = f
        .as_array()
        .unwrap()
        .iter()
        .map(|f| {
            (
                f["startLine"].as_u64().unwrap(),
                f["endLine"].as_u64().unwrap(),
            )
        })
        .collect();
    assert_eq!(folds, vec![(0, 1), (2, 5), (7, 10)]);

    assert_eq!(c.request("shutdown", Value::Null), Value::Null);
    c.notify("exit", Value::Null);
    assert!(c.child.wait().unwrap().success());
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_3d_agents_file_beside_2d_rules_is_one_error() {
    let dir = std::env::temp_dir().join(format!("latticesim-lsp-dim-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let dir = dir.canonicalize().unwrap();
    let rules_text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/examples/gravity/rules.txt"
    ))
    .unwrap();
    let agents_text: String = (0..200)
        .map(|i| format!("{i},0,0 C00 1 SFALL0\n"))
        .collect::<String>()
        + "0,1,0 C99 1\n";
    std::fs::write(dir.join("rules.txt"), &rules_text).unwrap();
    std::fs::write(dir.join("agents.txt"), &agents_text).unwrap();
    let rules = url_of(&dir.join("rules.txt"));
    let agents = url_of(&dir.join("agents.txt"));
    let mut c = Client::start();
    c.request(
        "initialize",
        json!({"processId": null, "rootUri": null, "capabilities": {}}),
    );
    c.notify("initialized", json!({}));
    c.notify(
        "textDocument/didOpen",
        json!({"textDocument": {"uri": rules, "languageId": "latticesim-rules", "version": 1, "text": rules_text}}),
    );
    c.notify(
        "textDocument/didOpen",
        json!({"textDocument": {"uri": agents, "languageId": "latticesim-agents", "version": 1, "text": agents_text}}),
    );
    // The second open publishes both files, the agents file first or second.
    let mut got = std::collections::HashMap::new();
    while got.len() < 2 || !got.contains_key(&agents) {
        let m = c.next();
        if m["method"] == "textDocument/publishDiagnostics" {
            let uri = m["params"]["uri"].as_str().unwrap().to_string();
            got.insert(uri, m["params"]["diagnostics"].as_array().unwrap().clone());
        }
    }
    let codes = |v: &Vec<Value>| -> Vec<String> {
        v.iter()
            .map(|d| d["code"].as_str().unwrap().to_string())
            .collect()
    };
    assert_eq!(codes(&got[&rules]), Vec::<String>::new());
    assert_eq!(codes(&got[&agents]), vec!["E301", "E404"]);
    // Hover numbers the agents as the checker does (the last line, with an error, is
    // still an agent that parses), and follows an edit.
    let hover = |c: &mut Client, line: u32| {
        let h = c.request(
            "textDocument/hover",
            json!({"textDocument": {"uri": agents}, "position": pos(line, 2)}),
        );
        h["contents"]["value"].as_str().unwrap_or("").to_string()
    };
    assert!(
        hover(&mut c, 7).starts_with("**Agent 7** at (7, 0, 0)"),
        "{}",
        hover(&mut c, 7)
    );
    assert!(hover(&mut c, 200).starts_with("**Agent 200** at (0, 1, 0)"));
    c.notify(
        "textDocument/didChange",
        json!({"textDocument": {"uri": agents, "version": 2}, "contentChanges": [
            {"range": {"start": pos(0, 0), "end": pos(0, 0)}, "text": "U0,300,0,2,0,2\n// a comment\n"}
        ]}),
    );
    let h = hover(&mut c, 0);
    assert!(h.starts_with("**Universe**: x from 0 to 300"), "{h}");
    assert!(hover(&mut c, 9).starts_with("**Agent 7** at (7, 0, 0)"));
    assert_eq!(hover(&mut c, 1), "");
    std::fs::remove_dir_all(&dir).ok();
}

fn url_of(p: &std::path::Path) -> String {
    format!("file://{}", p.display())
}

mod fuzz {
    //! The server in-process under random incremental edits (positions past line ends and
    //! inside surrogate pairs included) and requests at random places: no panic, every
    //! answer well formed, and the document always equal to a plain model of the edits.

    use latticesim::lsp::Server;
    use lsp_server::{Message, Notification, Request, RequestId};
    use proptest::prelude::*;
    use serde_json::json;

    const URI: &str = "file:///nowhere/rules.txt";

    /// The byte offset of (line, UTF-16 column), taken to the line's or text's end: written
    /// apart from the server's own.
    fn model_offset(text: &str, line: u32, col: u32) -> usize {
        let mut start = 0;
        for _ in 0..line {
            match text[start..].find('\n') {
                Some(i) => start += i + 1,
                None => return text.len(),
            }
        }
        let end = text[start..].find('\n').map_or(text.len(), |i| start + i);
        let mut units = 0;
        for (i, c) in text[start..end].char_indices() {
            if units >= col {
                return start + i;
            }
            units += c.len_utf16() as u32;
        }
        end
    }

    fn piece() -> impl Strategy<Value = String> {
        prop_oneof![
            Just("N1*0* ".to_string()),
            Just("\n".to_string()),
            Just("SINIT0".to_string()),
            Just("C00 = 1 ".to_string()),
            Just("é😀".to_string()),
            Just("(!".to_string()),
            Just("r\n1\n".to_string()),
            "[ -~]{0,6}",
        ]
    }

    #[derive(Debug, Clone)]
    enum Op {
        Edit(u32, u32, u32, u32, String),
        Hover(u32, u32),
        Complete(u32, u32),
        Format,
        Actions(u32, u32),
        Navigate(u32, u32, u8),
        Rename(u32, u32, String),
        Shape(u8),
    }

    fn op() -> impl Strategy<Value = Op> {
        prop_oneof![
            4 => (0u32..8, 0u32..20, 0u32..8, 0u32..20, piece()).prop_map(|(a, b, c, d, t)| Op::Edit(a, b, c, d, t)),
            1 => (0u32..8, 0u32..20).prop_map(|(l, c)| Op::Hover(l, c)),
            1 => (0u32..8, 0u32..20).prop_map(|(l, c)| Op::Complete(l, c)),
            1 => Just(Op::Format),
            1 => (0u32..8, 0u32..20).prop_map(|(l, c)| Op::Actions(l, c)),
            1 => (0u32..8, 0u32..20, 0u8..3).prop_map(|(l, c, k)| Op::Navigate(l, c, k)),
            1 => (0u32..8, 0u32..20, prop_oneof![Just("DONE0".to_string()), Just("C03".to_string()), "[ -~]{0,6}"]).prop_map(|(l, c, n)| Op::Rename(l, c, n)),
            1 => (0u8..3).prop_map(Op::Shape),
        ]
    }

    /// Semantic tokens decoded against the text: in order, each within its line.
    fn tokens_fit(text: &str, result: &serde_json::Value) -> Result<(), TestCaseError> {
        let data: Vec<u64> = result["data"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_u64().unwrap())
            .collect();
        prop_assert_eq!(data.len() % 5, 0);
        let lines: Vec<usize> = text.split('\n').map(|l| l.encode_utf16().count()).collect();
        let (mut line, mut col) = (0usize, 0usize);
        for t in data.chunks(5) {
            if t[0] > 0 {
                line += t[0] as usize;
                col = 0;
            }
            col += t[1] as usize;
            prop_assert!(
                line < lines.len(),
                "token on line {} of {}",
                line,
                lines.len()
            );
            prop_assert!(
                col + t[2] as usize <= lines[line],
                "token past its line's end: {:?} in {:?}",
                t,
                text
            );
            prop_assert!(t[2] > 0 && t[3] < 8, "{:?}", t);
        }
        Ok(())
    }

    fn request(id: i32, method: &str, params: serde_json::Value) -> Message {
        Message::Request(Request::new(RequestId::from(id), method.into(), params))
    }

    proptest! {
        #![proptest_config(ProptestConfig {
            cases: std::env::var("PROPTEST_CASES").ok().and_then(|s| s.parse().ok()).unwrap_or(128),
            failure_persistence: None,
            ..ProptestConfig::default()
        })]

        #[test]
        fn random_edits_and_requests(start in "[ -~\n]{0,40}", ops in proptest::collection::vec(op(), 1..30)) {
            let mut s = Server::new();
            let mut model = start.clone();
            s.handle(Message::Notification(Notification::new(
                "textDocument/didOpen".into(),
                json!({"textDocument": {"uri": URI, "languageId": "latticesim-rules", "version": 1, "text": start}}),
            )));
            for (k, op) in ops.into_iter().enumerate() {
                let pos = |l: u32, c: u32| json!({"line": l, "character": c});
                let out = match op {
                    Op::Edit(a, b, c, d, t) => {
                        let (x, y) = (model_offset(&model, a, b), model_offset(&model, c, d));
                        model.replace_range(x.min(y)..x.max(y), &t);
                        s.handle(Message::Notification(Notification::new(
                            "textDocument/didChange".into(),
                            json!({"textDocument": {"uri": URI, "version": k + 2},
                                   "contentChanges": [{"range": {"start": pos(a, b), "end": pos(c, d)}, "text": t}]}),
                        )))
                    }
                    Op::Hover(l, c) => s.handle(request(1, "textDocument/hover", json!({"textDocument": {"uri": URI}, "position": pos(l, c)}))),
                    Op::Complete(l, c) => s.handle(request(2, "textDocument/completion", json!({"textDocument": {"uri": URI}, "position": pos(l, c)}))),
                    Op::Format => s.handle(request(3, "textDocument/formatting", json!({"textDocument": {"uri": URI}, "options": {"tabSize": 4, "insertSpaces": true}}))),
                    Op::Actions(l, c) => s.handle(request(4, "textDocument/codeAction", json!({"textDocument": {"uri": URI}, "range": {"start": pos(l, c), "end": pos(l, c)}, "context": {"diagnostics": []}}))),
                    Op::Navigate(l, c, k) => {
                        let method = ["textDocument/definition", "textDocument/references", "textDocument/prepareRename"][k as usize];
                        s.handle(request(5, method, json!({"textDocument": {"uri": URI}, "position": pos(l, c), "context": {"includeDeclaration": true}})))
                    }
                    Op::Rename(l, c, n) => s.handle(request(6, "textDocument/rename", json!({"textDocument": {"uri": URI}, "position": pos(l, c), "newName": n}))),
                    Op::Shape(k) => {
                        let method = ["textDocument/documentSymbol", "textDocument/semanticTokens/full", "textDocument/foldingRange"][k as usize];
                        s.handle(request(7 + k as i32, method, json!({"textDocument": {"uri": URI}})))
                    }
                };
                for m in out {
                    if let Message::Response(r) = m {
                        // A rename may be refused (a pattern, a name taken, nothing there).
                        let refusal = matches!(r.id.to_string().as_str(), "5" | "6")
                            && r.error.as_ref().is_some_and(|e| e.code == lsp_server::ErrorCode::RequestFailed as i32);
                        prop_assert!(r.error.is_none() || refusal, "{:?}", r.error);
                        if r.id == RequestId::from(8) {
                            tokens_fit(&model, r.result.as_ref().unwrap())?;
                        }
                    }
                }
                prop_assert_eq!(s.open_text(URI), Some(model.as_str()));
            }
        }
    }
}
