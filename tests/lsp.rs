//! `latticesim lsp` driven as an editor drives it: a process speaking JSON-RPC over its
//! standard input and output (initialize, didOpen, didChange, hover, completion,
//! formatting, codeAction, shutdown, exit), with the answers checked.

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
    fn request(&mut self, method: &str, params: Value) -> Value {
        let id = self.next_id;
        self.next_id += 1;
        self.send(json!({"jsonrpc": "2.0", "id": id, "method": method, "params": params}));
        loop {
            let m = self.next();
            if m["id"] == json!(id) {
                assert!(m.get("error").is_none(), "{method}: {m}");
                return m["result"].clone();
            }
        }
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
    }

    fn op() -> impl Strategy<Value = Op> {
        prop_oneof![
            4 => (0u32..8, 0u32..20, 0u32..8, 0u32..20, piece()).prop_map(|(a, b, c, d, t)| Op::Edit(a, b, c, d, t)),
            1 => (0u32..8, 0u32..20).prop_map(|(l, c)| Op::Hover(l, c)),
            1 => (0u32..8, 0u32..20).prop_map(|(l, c)| Op::Complete(l, c)),
            1 => Just(Op::Format),
            1 => (0u32..8, 0u32..20).prop_map(|(l, c)| Op::Actions(l, c)),
        ]
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
                };
                for m in out {
                    if let Message::Response(r) = m {
                        prop_assert!(r.error.is_none(), "{:?}", r.error);
                    }
                }
                prop_assert_eq!(s.open_text(URI), Some(model.as_str()));
            }
        }
    }
}
