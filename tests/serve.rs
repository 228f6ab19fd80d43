//! `latticesim serve` over real HTTP: the API against `latticesim run`, and bad requests
//! (malformed bodies, huge bodies, unknown routes, paths outside the working folder), after
//! each of which the server must still answer. The browser side is tested by e2e/viewer.mjs.

use serde_json::{json, Value};
use std::io::{BufRead, BufReader, Read, Write};
use std::net::TcpStream;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};

const ROOT: &str = env!("CARGO_MANIFEST_DIR");

/// A running server in its own working folder; killed when dropped.
struct Server {
    child: Child,
    addr: String,
    token: String,
    dir: PathBuf,
}

impl Drop for Server {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
        let _ = std::fs::remove_dir_all(&self.dir);
    }
}

/// Starts a server in a fresh working folder holding copies of the example's two files.
fn start(name: &str, rules: &str, agents: &str) -> Server {
    let dir = std::env::temp_dir().join(format!("latticesim-serve-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    for f in [rules, agents] {
        let to = dir.join(Path::new(f).file_name().unwrap());
        std::fs::copy(Path::new(ROOT).join(f), to).unwrap();
    }
    let names = [rules, agents].map(|f| Path::new(f).file_name().unwrap().to_owned());
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_latticesim"));
    cmd.current_dir(&dir)
        .args(["serve".as_ref(), names[0].as_os_str(), names[1].as_os_str()])
        .args(["--port", "0"])
        .stderr(Stdio::null());
    let (child, line) = launch(cmd);
    let (addr, token) = url_parts(&line);
    Server {
        child,
        addr,
        token,
        dir,
    }
}

/// Starts `cmd` with its standard output piped: the process and the first line it printed.
fn launch(mut cmd: Command) -> (Child, String) {
    let mut child = cmd.stdout(Stdio::piped()).spawn().unwrap();
    let mut line = String::new();
    BufReader::new(child.stdout.take().unwrap())
        .read_line(&mut line)
        .unwrap();
    (child, line)
}

/// The address and the token of the URL in the line the server printed.
fn url_parts(line: &str) -> (String, String) {
    let url = line
        .split("http://")
        .nth(1)
        .and_then(|s| s.split_whitespace().next())
        .unwrap_or_else(|| panic!("no URL in {line:?}"));
    let (addr, rest) = url.split_once('/').unwrap();
    // Without a token in the URL, the gate's test fails (it asks for the cookie).
    let token = rest.strip_prefix("?token=").unwrap_or("");
    (addr.to_string(), token.to_string())
}

impl Server {
    /// Sends raw bytes; the status and the body of the answer.
    fn raw(&self, request: &[u8]) -> (u16, String) {
        let (status, body) = self.raw_bytes(request);
        (status, String::from_utf8_lossy(&body).into_owned())
    }

    /// Sends raw bytes; the status and the body's bytes.
    fn raw_bytes(&self, request: &[u8]) -> (u16, Vec<u8>) {
        let mut s = TcpStream::connect(&self.addr).unwrap();
        // The server may answer and close before it has read everything (huge bodies).
        let _ = s.write_all(request);
        let mut out = Vec::new();
        let _ = s.read_to_end(&mut out);
        let head_end = out.windows(4).position(|w| w == b"\r\n\r\n");
        let head = String::from_utf8_lossy(&out[..head_end.unwrap_or(out.len())]).into_owned();
        let status = head
            .split(' ')
            .nth(1)
            .and_then(|c| c.parse().ok())
            .unwrap_or_else(|| panic!("no status in {head:?}"));
        let body = head_end.map_or(Vec::new(), |e| out[e + 4..].to_vec());
        (status, body)
    }

    fn request(&self, method: &str, path: &str, body: &[u8]) -> (u16, String) {
        let token = format!("X-Latticesim-Token: {}\r\n", self.token);
        self.request_with(method, path, &token, body)
    }

    /// A request with these header lines (each ending in CRLF) besides Host.
    fn request_with(&self, method: &str, path: &str, headers: &str, body: &[u8]) -> (u16, String) {
        let mut req = format!(
            "{method} {path} HTTP/1.1\r\nHost: {}\r\n{headers}Connection: close\r\nContent-Length: {}\r\n\r\n",
            self.addr,
            body.len()
        )
        .into_bytes();
        req.extend_from_slice(body);
        self.raw(&req)
    }

    fn json(&self, method: &str, path: &str, body: &[u8]) -> (u16, Value) {
        let (status, text) = self.request(method, path, body);
        let v = serde_json::from_str(&text).unwrap_or_else(|e| panic!("{path}: {e}: {text}"));
        (status, v)
    }

    fn get(&self, path: &str) -> (u16, Value) {
        self.json("GET", path, b"")
    }

    /// GET with the token and these header lines (each ending in CRLF): the status, the
    /// head and the body as sent (not decompressed).
    fn get_with_head(&self, path: &str, headers: &str) -> (u16, String, Vec<u8>) {
        let req = format!(
            "GET {path} HTTP/1.1\r\nHost: {}\r\nX-Latticesim-Token: {}\r\n{headers}Connection: close\r\n\r\n",
            self.addr, self.token
        );
        let mut s = TcpStream::connect(&self.addr).unwrap();
        s.write_all(req.as_bytes()).unwrap();
        let mut out = Vec::new();
        s.read_to_end(&mut out).unwrap();
        let end = out.windows(4).position(|w| w == b"\r\n\r\n").unwrap();
        let head = String::from_utf8_lossy(&out[..end]).into_owned();
        let status = head.split(' ').nth(1).unwrap().parse().unwrap();
        (status, head, out[end + 4..].to_vec())
    }

    fn get_bytes(&self, path: &str, headers: &str) -> (u16, Vec<u8>) {
        let (status, _, body) = self.get_with_head(path, headers);
        (status, body)
    }

    fn post(&self, path: &str, v: Value) -> (u16, Value) {
        self.json("POST", path, v.to_string().as_bytes())
    }

    /// The server still answers.
    fn alive(&self) {
        assert_eq!(self.get("/api/session").0, 200);
    }
}

/// (position, state) of every agent after `steps` steps, from `latticesim run`.
fn run_agents(rules: &str, agents: &str, steps: u64) -> Vec<(Vec<i64>, String)> {
    let out = Command::new(env!("CARGO_BIN_EXE_latticesim"))
        .current_dir(ROOT)
        .args([
            "run",
            rules,
            agents,
            "--quiet",
            "--max-steps",
            &steps.to_string(),
        ])
        .output()
        .unwrap();
    assert!(out.status.success());
    String::from_utf8(out.stdout)
        .unwrap()
        .lines()
        .filter(|l| !l.starts_with('U'))
        .map(|l| {
            let mut w = l.split_whitespace();
            let pos = w
                .next()
                .unwrap()
                .split(',')
                .map(|v| v.parse().unwrap())
                .collect();
            // The default state is left out of the text.
            let state = (w.next().and_then(|s| s.strip_prefix('S')))
                .unwrap_or("00000")
                .to_string();
            (pos, state)
        })
        .collect()
}

/// (position, state) of every agent in a frame.
fn frame_agents(f: &Value) -> Vec<(Vec<i64>, String)> {
    let dim = f["dim"].as_u64().unwrap() as usize;
    let pos: Vec<i64> = f["pos"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_i64().unwrap())
        .collect();
    let names: Vec<&str> = f["states"]
        .as_array()
        .unwrap()
        .iter()
        .map(|s| s["name"].as_str().unwrap())
        .collect();
    f["state"]
        .as_array()
        .unwrap()
        .iter()
        .enumerate()
        .map(|(i, s)| {
            (
                pos[i * dim..(i + 1) * dim].to_vec(),
                names[s.as_u64().unwrap() as usize].to_string(),
            )
        })
        .collect()
}

#[test]
fn frames_forwards_and_back_match_run() {
    // A 2D run with moves and bonds (the tour) and a 3D one with moves (gravity).
    for (name, rules, agents, steps) in [
        (
            "tour",
            "examples/tour/rules.txt",
            "examples/tour/agents.txt",
            [2, 1, 2, 0, 1],
        ),
        (
            "gravity3d",
            "examples/gravity-3d/rules.txt",
            "examples/gravity-3d/agents.txt",
            [5, 2, 7, 0, 3],
        ),
    ] {
        let srv = start(name, rules, agents);
        for s in steps {
            let (status, f) = srv.get(&format!("/api/frame?step={s}"));
            assert_eq!(status, 200, "{f}");
            assert_eq!(f["step"], s, "{name}");
            assert!(f["note"].is_null(), "{f}");
            assert_eq!(
                frame_agents(&f),
                run_agents(rules, agents, s),
                "{name} at step {s}"
            );
            let (status, a) = srv.get("/api/agent?id=0");
            assert_eq!(status, 200);
            assert_eq!(
                a["state"],
                run_agents(rules, agents, s)[0].1,
                "{name} at step {s}"
            );
        }
    } // The tour is quiescent at step 2 (no agent has a rule): asking for more stops there.
    let srv = start(
        "tour-end",
        "examples/tour/rules.txt",
        "examples/tour/agents.txt",
    );
    let (_, f) = srv.get("/api/frame?step=50");
    assert_eq!((&f["step"], &f["quiescent"]), (&json!(2), &json!(true)));
    assert!(
        f["note"]
            .as_str()
            .unwrap()
            .starts_with("quiescent at step 2"),
        "{f}"
    );
    assert!(f["attach"].is_array(), "the tour's agents are attached");
}

impl Server {
    /// A JSON request of tab `tab`.
    fn tab_json(&self, tab: &str, method: &str, path: &str, body: &[u8]) -> (u16, Value) {
        let headers = format!(
            "X-Latticesim-Token: {}\r\nX-Latticesim-Tab: {tab}\r\n",
            self.token
        );
        let (status, text) = self.request_with(method, path, &headers, body);
        (status, serde_json::from_str(&text).unwrap_or(Value::Null))
    }
}

#[test]
fn each_tab_has_its_own_run() {
    let (rules, agents) = ("examples/gravity/rules.txt", "examples/gravity/agents.txt");
    let srv = start("tabs", rules, agents);
    let (s, a) = srv.post("/api/tab", json!(null));
    assert_eq!(s, 200, "{a}");
    let (s, b) = srv.post("/api/tab", json!(null));
    assert_eq!(s, 200, "{b}");
    let (a, b) = (a["tab"].as_str().unwrap(), b["tab"].as_str().unwrap());
    assert_ne!(a, b);
    // Tab a goes to step 3; tab b and the default session stay at step 0.
    let (s, f) = srv.tab_json(a, "GET", "/api/frame?step=3", b"");
    assert_eq!((s, &f["step"]), (200, &json!(3)));
    assert_eq!(frame_agents(&f), run_agents(rules, agents, 3));
    let (_, f) = srv.tab_json(b, "GET", "/api/frame", b"");
    assert_eq!(f["step"], 0, "another tab's steps do not move this one");
    assert_eq!(srv.get("/api/frame").1["step"], 0);
    // Tab b applies other files: tab a still shows gravity, at its step.
    let other = json!({
        "rules": std::fs::read_to_string("examples/tour/rules.txt").unwrap(),
        "agents": std::fs::read_to_string("examples/tour/agents.txt").unwrap(),
    });
    let (s, v) = srv.tab_json(b, "POST", "/api/apply", other.to_string().as_bytes());
    assert_eq!(s, 200, "{v}");
    let (_, f) = srv.tab_json(a, "GET", "/api/frame", b"");
    assert_eq!(f["step"], 3);
    assert_eq!(frame_agents(&f), run_agents(rules, agents, 3));
    let (_, sa) = srv.tab_json(a, "GET", "/api/session", b"");
    let (_, sb) = srv.tab_json(b, "GET", "/api/session", b"");
    assert_eq!(sa["rules"], std::fs::read_to_string(rules).unwrap());
    assert_ne!(sa["rules"], sb["rules"]);
    // An unknown tab is told at once, and what to do.
    let (s, v) = srv.tab_json("nosuchtab", "GET", "/api/frame", b"");
    assert_eq!(s, 410);
    assert!(
        v["error"].as_str().unwrap().contains("reload the page"),
        "{v}"
    );
    let (s, _) = srv.get("/api/tab");
    assert_eq!(s, 405);
    // At most 16 tabs: the least recently used are closed, and say why.
    let mut ids = Vec::new();
    for _ in 0..17 {
        let (s, v) = srv.post("/api/tab", json!(null));
        assert_eq!(s, 200);
        ids.push(v["tab"].as_str().unwrap().to_string());
    }
    let (s, v) = srv.tab_json(a, "GET", "/api/frame", b"");
    assert_eq!(s, 410, "{v}");
    assert!(v["error"].as_str().unwrap().contains("to make room"), "{v}");
    let (s, _) = srv.tab_json(ids.last().unwrap(), "GET", "/api/frame", b"");
    assert_eq!(s, 200);
    srv.alive();
}

/// A frame as the test reads it: its head, and every agent's position and state name.
type Decoded = (Value, Vec<(Vec<i64>, String)>);

/// A binary frame decoded (docs/viewer.md, src/serve/binary.rs) onto the one held.
fn decode_bin(bytes: &[u8], held: Option<&Decoded>) -> Decoded {
    assert_eq!(&bytes[..4], b"LSF2");
    let len = u32::from_le_bytes(bytes[4..8].try_into().unwrap()) as usize;
    let head: Value = serde_json::from_slice(&bytes[8..8 + len]).unwrap();
    let (n, dim) = (
        head["n"].as_u64().unwrap() as usize,
        head["dim"].as_u64().unwrap() as usize,
    );
    let delta = head["delta"].as_bool().unwrap();
    let names: Vec<String> = (head["states"].as_array().unwrap().iter())
        .map(|s| s["name"].as_str().unwrap().to_string())
        .collect();
    let mut agents = match (delta, held) {
        (true, Some(h)) => {
            assert_eq!(head["base"], h.0["step"], "a delta on the frame held");
            h.1.clone()
        }
        (true, None) => panic!("a delta without a frame held"),
        (false, _) => vec![(vec![0; dim], String::new()); n],
    };
    let align = |at: usize| at.div_ceil(4) * 4;
    let mut at = align(8 + len);
    let value = |v: &[u8]| -> i64 {
        match v.len() {
            1 => v[0] as i64,
            2 => u16::from_le_bytes(v.try_into().unwrap()) as i64,
            _ => u32::from_le_bytes(v.try_into().unwrap()) as i64,
        }
    };
    let columns = head["columns"].as_array().unwrap();
    let names_of: Vec<&str> = columns
        .iter()
        .map(|c| c["name"].as_str().unwrap())
        .collect();
    assert_eq!(&names_of[..2], ["pos", "state"]);
    for c in columns {
        let (count, size) = (
            c["count"].as_u64().unwrap() as usize,
            c["bytes"].as_u64().unwrap() as usize,
        );
        let ids: Vec<usize> = match c["set"].as_str().unwrap() {
            "all" => (0..n).collect(),
            "bits" => {
                let bits = &bytes[at..at + n.div_ceil(8)];
                at = align(at + n.div_ceil(8));
                (0..n)
                    .filter(|&i| bits[i / 8] & (1 << (i % 8)) != 0)
                    .collect()
            }
            "ids" => {
                let ids = (0..count)
                    .map(|k| value(&bytes[at + 4 * k..at + 4 * k + 4]) as usize)
                    .collect();
                at = align(at + 4 * count);
                ids
            }
            other => panic!("a set `{other}`"),
        };
        assert_eq!(ids.len(), count, "{c}");
        let width = if c["name"] == "pos" { size * dim } else { size };
        for (k, &i) in ids.iter().enumerate() {
            let v = &bytes[at + k * width..at + (k + 1) * width];
            match c["name"].as_str().unwrap() {
                "pos" if size == 1 => {
                    assert!(delta, "moves only in a delta");
                    for (p, &m) in agents[i].0.iter_mut().zip(v) {
                        *p += m as i8 as i64;
                    }
                }
                "pos" => {
                    agents[i].0 = (0..dim)
                        .map(|d| i32::from_le_bytes(v[4 * d..4 * d + 4].try_into().unwrap()) as i64)
                        .collect()
                }
                "state" => agents[i].1 = names[value(v) as usize].clone(),
                _ => {}
            }
        }
        at = align(at + count * width);
    }
    (head, agents)
}

/// Frames of these steps asked for in turn (each a delta on the one before where the
/// server finds that smaller), decoded, against `latticesim run`: how many were deltas.
fn frames_match_run(srv: &Server, rules: &str, agents: &str, steps: &[u64]) -> usize {
    let mut held: Option<Decoded> = None;
    let mut deltas = 0;
    for &step in steps {
        let since = held
            .as_ref()
            .map_or(String::new(), |h| format!("&since={}", h.0["step"]));
        let (status, body) =
            srv.get_bytes(&format!("/api/frame?format=bin&step={step}{since}"), "");
        assert_eq!(status, 200);
        let f = decode_bin(&body, held.as_ref());
        let at = f.0["step"].as_u64().unwrap();
        assert_eq!(f.1, run_agents(rules, agents, at), "{rules}, step {at}");
        deltas += f.0["delta"].as_bool().unwrap() as usize;
        held = Some(f);
    }
    deltas
}

#[test]
fn binary_frames_and_their_deltas_match_run() {
    let (rules, agents) = ("examples/gravity/rules.txt", "examples/gravity/agents.txt");
    let srv = start("binary", rules, agents);
    let deltas = frames_match_run(&srv, rules, agents, &[0, 1, 2, 3, 5, 9, 10, 4, 4, 12]);
    assert!(
        deltas > 0,
        "gravity's agents fall a cell a step: sent as moves"
    );
    // A `since` that is not the frame last sent gets a whole frame.
    let (_, body) = srv.get_bytes("/api/frame?format=bin&step=6&since=2", "");
    assert_eq!(decode_bin(&body, None).0["delta"], false);
    let (status, _) = srv.get_bytes("/api/frame?format=xml", "");
    assert_eq!(status, 400);
    // Bonds made and broken and states changing: the line reconfiguration.
    let (rules, agents) = (
        "examples/reconfigure-line/rules.txt",
        "examples/reconfigure-line/agents-30.txt",
    );
    let srv = start("binary-line", rules, agents);
    let deltas = frames_match_run(&srv, rules, agents, &[0, 1, 2, 3, 4, 8, 20, 21, 60, 2, 3]);
    assert!(deltas > 0);
    // In 3D: moves of three coordinates.
    let (rules, agents) = (
        "examples/gravity-3d/rules.txt",
        "examples/gravity-3d/agents.txt",
    );
    let srv = start("binary-3d", rules, agents);
    let deltas = frames_match_run(&srv, rules, agents, &[0, 1, 2, 3, 6, 7, 1]);
    assert!(deltas > 0);
}

#[test]
fn frames_with_more_states_than_a_byte_holds() {
    // 300 states at step 0 (indices of two bytes), all turning into a 301st at step 1.
    let dir =
        std::env::temp_dir().join(format!("latticesim-serve-{}-wide-src", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let (rules, agents) = (dir.join("rules.txt"), dir.join("agents.txt"));
    std::fs::write(&rules, "turn\n1\nSA****\nSZZZZZ\n").unwrap();
    let text: String = (0..300).map(|i| format!("{i},0 SA{i:04}\n")).collect();
    std::fs::write(&agents, text).unwrap();
    let (rules, agents) = (rules.to_str().unwrap(), agents.to_str().unwrap());
    let srv = start("wide", rules, agents);
    frames_match_run(&srv, rules, agents, &[0, 1, 2, 0, 1]);
    let (_, body) = srv.get_bytes("/api/frame?format=bin&step=1", "");
    let head = decode_bin(&body, None).0;
    let state = &head["columns"][1];
    assert_eq!(
        (&state["name"], &state["bytes"]),
        (&json!("state"), &json!(2)),
        "{head}"
    );
    assert_eq!(head["states"].as_array().unwrap().len(), 301);
}

#[test]
fn files_too_large_to_edit_stay_on_the_server() {
    let srv = start(
        "large",
        "examples/gravity/rules.txt",
        "examples/gravity/agents.txt",
    );
    // 6 MB of agents: more than the editor takes (4 MiB).
    let big: String = (0..300_000)
        .map(|i| format!("{},{} SGRAV0 C00 7\n", i % 400, i / 400))
        .collect();
    assert!(big.len() > 4 << 20);
    std::fs::write(srv.dir.join("big.txt"), &big).unwrap();
    let (s, v) = srv.post("/api/file", json!({ "path": "big.txt" }));
    assert_eq!(s, 200, "{v}");
    assert!(
        v["text"].is_null(),
        "the text of a file too large to edit is not sent"
    );
    assert_eq!(v["bytes"], big.len());
    let rules =
        std::fs::read_to_string(Path::new(ROOT).join("examples/gravity/rules.txt")).unwrap();
    // null: the file as it is on disk.
    let ask = json!({ "rules": rules, "agents": null, "agents_path": "big.txt" });
    let (s, v) = srv.post("/api/check", ask.clone());
    assert_eq!(
        (s, &v["errors"], &v["agents"]),
        (200, &json!(0), &json!(300_000)),
        "{v}"
    );
    let (s, v) = srv.post("/api/apply", ask);
    assert_eq!(s, 200, "{v}");
    let (_, v) = srv.get("/api/session");
    assert!(
        v["agents"].is_null(),
        "the text of a file too large to edit is not sent"
    );
    assert_eq!(v["agents_bytes"], big.len());
    assert_eq!(v["agents_path"], "big.txt");
    assert!(v["rules"].is_string());
    // A file that is not there.
    let (s, v) = srv.post(
        "/api/check",
        json!({ "rules": rules, "agents": null, "agents_path": "gone.txt" }),
    );
    assert_eq!(s, 404, "{v}");
}

#[test]
fn large_answers_are_compressed_for_clients_that_take_zstd() {
    let srv = start(
        "zstd",
        "examples/gravity/rules.txt",
        "examples/gravity/agents.txt",
    );
    let agents: String = (0..5000)
        .map(|i| format!("{},{} SGRAV0\n", i % 100, 10 + i / 100))
        .collect();
    let rules =
        std::fs::read_to_string(Path::new(ROOT).join("examples/gravity/rules.txt")).unwrap();
    let (s, v) = srv.post("/api/apply", json!({ "rules": rules, "agents": agents }));
    assert_eq!(s, 200, "{v}");
    let path = "/api/frame?format=bin&step=3";
    let (s, head, packed) = srv.get_with_head(path, "Accept-Encoding: gzip, deflate, br, zstd\r\n");
    assert_eq!(s, 200);
    assert!(head.contains("Content-Encoding: zstd"), "{head}");
    let (_, plain) = srv.get_bytes(path, "Accept-Encoding: gzip, zstd;q=0\r\n");
    assert!(
        packed.len() * 4 < plain.len(),
        "{} of {}",
        packed.len(),
        plain.len()
    );
    assert_eq!(zstd::decode_all(&packed[..]).unwrap(), plain);
    // Small answers go as they are.
    let (s, head, body) = srv.get_with_head("/api/agent?id=0", "Accept-Encoding: zstd\r\n");
    assert_eq!(s, 200);
    assert!(!head.contains("Content-Encoding"), "{head}");
    serde_json::from_slice::<Value>(&body).unwrap();
}

/// A frame coloured by a counter carries its values in the run's width: 4 bytes each with
/// 32-bit counters, whole past 16 bits.
#[test]
fn frames_carry_counters_of_32_bits_whole() {
    let dir = std::env::temp_dir().join(format!("latticesim-serve-{}-ids-src", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let agents = dir.join("agents.txt");
    let text: String = (0..40)
        .map(|i| format!("{i},0 SINIT0 C00 {}\n", 100_000 + i))
        .collect();
    std::fs::write(&agents, text).unwrap();
    let agents = agents.to_str().unwrap();
    let srv = start("ids", "examples/leader-election/rules.txt", agents);
    let (_, body) = srv.get_bytes("/api/frame?format=bin&step=0&counter=C00", "");
    let head = decode_bin(&body, None).0;
    assert_eq!(head["counter_bytes"], json!(4), "{head}");
    let values = &body[body.len() - 4 * 40..];
    let got: Vec<i32> = (values.chunks_exact(4))
        .map(|b| i32::from_le_bytes(b.try_into().unwrap()))
        .collect();
    assert_eq!(got, (100_000..100_040).collect::<Vec<_>>());
    let (_, a) = srv.get("/api/agent?id=39");
    assert_eq!(a["counters"][0], json!({ "name": "C00", "value": 100_039 }));
}

#[test]
fn inspector_shows_counters_messages_and_next_rules() {
    let srv = start(
        "inspect",
        "examples/leader-election/rules.txt",
        "examples/leader-election/agents-30.txt",
    );
    // Before the first step agent 0 (C00 26) is in INIT0: its next rule is `start`.
    let (_, a) = srv.get("/api/agent?id=0");
    assert_eq!(a["state"], "INIT0");
    assert_eq!(a["next"], json!({ "rules": ["start"], "priority": 2 }));
    assert_eq!(a["counters"][0], json!({ "name": "C00", "value": 26 }));
    srv.get("/api/frame?step=1");
    let (_, a) = srv.get("/api/agent?id=0");
    // After step 1 every agent told its neighbours its id: agent 0 at (0,0) hears 25 from
    // (0,1) in the north.
    assert_eq!(a["state"], "LEAD0");
    assert!(a["messages"]
        .as_array()
        .unwrap()
        .contains(&json!({ "name": "#N01", "value": 25 })));
    assert_eq!(a["next_step"], 2);
}

#[test]
fn bad_requests_get_clear_errors_and_the_server_goes_on() {
    let srv = start(
        "bad",
        "examples/leader-election/rules.txt",
        "examples/leader-election/agents-30.txt",
    );
    let err = |r: (u16, Value)| (r.0, r.1["error"].as_str().unwrap_or("").to_string());

    // Malformed bodies.
    let (s, e) = err(srv.json("POST", "/api/check", b"{\"rules\": "));
    assert_eq!(s, 400);
    assert!(e.contains("not valid JSON"), "{e}");
    srv.alive();
    let (s, e) = err(srv.json("POST", "/api/check", b"[1, 2]"));
    assert_eq!(
        (s, e.as_str()),
        (400, "the request body must be a JSON object")
    );
    let (s, e) = err(srv.post("/api/apply", json!({ "rules": 3, "agents": "" })));
    assert_eq!(s, 400);
    assert!(e.contains("string field `rules`"), "{e}");
    let (s, _) = err(srv.json("POST", "/api/check", b"\xff\xfe"));
    assert_eq!(s, 400);
    srv.alive();

    // Huge bodies are refused before they are read whole.
    let huge = vec![b'x'; 9 << 20];
    let (s, e) = err(srv.json("POST", "/api/check", &huge));
    assert_eq!(s, 413);
    assert!(e.contains("larger than"), "{e}");
    srv.alive();

    // Unknown routes, wrong methods, bad numbers, missing agents.
    let (s, e) = err(srv.get("/etc/passwd"));
    assert_eq!((s, e.as_str()), (404, "no such page or API: /etc/passwd"));
    assert_eq!(err(srv.json("DELETE", "/api/frame", b"")).0, 405);
    let (s, e) = err(srv.get("/api/file"));
    assert_eq!(
        (s, e.as_str()),
        (405, "GET is not allowed on /api/file; it takes POST")
    );
    let (s, e) = err(srv.get("/api/frame?step=-1"));
    assert_eq!(s, 400);
    assert!(e.contains("`step`"), "{e}");
    assert_eq!(err(srv.get("/api/agent")).0, 400);
    let (s, e) = err(srv.get("/api/agent?id=30"));
    assert_eq!(
        (s, e.as_str()),
        (404, "there is no agent 30: ids go from 0 to 29")
    );
    // Not HTTP at all.
    let (s, _) = srv.raw(b"NONSENSE\r\n\r\n");
    assert_eq!(s, 400);
    srv.alive();
}

#[test]
fn files_outside_the_folder_or_with_errors_are_refused_and_the_run_goes_on() {
    let srv = start(
        "files",
        "examples/leader-election/rules.txt",
        "examples/leader-election/agents-30.txt",
    );
    let err = |r: (u16, Value)| (r.0, r.1["error"].as_str().unwrap_or("").to_string());

    // Paths outside the working folder: relative, absolute, and through a symbolic link.
    for p in [
        "../outside.txt",
        "/etc/passwd",
        "/etc/new.txt",
        "sub/../../x.txt",
    ] {
        let (s, e) = err(srv.post("/api/file", json!({ "path": p })));
        assert!(s == 403 || s == 404, "{p}: {s} {e}");
        let (s, e) = err(srv.post("/api/file", json!({ "path": p, "text": "x" })));
        assert_eq!(s, 403, "{p}: {e}");
        assert!(e.contains("outside the working folder"), "{e}");
    }
    #[cfg(unix)]
    {
        std::os::unix::fs::symlink("/etc", srv.dir.join("link")).unwrap();
        let (s, _) = err(srv.post("/api/file", json!({ "path": "link/hostname" })));
        assert!(s == 403 || s == 404);
        let (s, _) = err(srv.post("/api/file", json!({ "path": "link/new.txt", "text": "x" })));
        assert_eq!(s, 403);
        assert!(!Path::new("/etc/new.txt").exists());
    }
    let (s, e) = err(srv.post("/api/file", json!({ "path": "" })));
    assert_eq!((s, e.as_str()), (400, "the path is empty"));
    // A name of 255 bytes (the system's most) is saved; its temporary file's name is cut to
    // fit (it was 500: the temporary name was too long). One past the most: 400.
    let long = format!("{}.txt", "n".repeat(251));
    let (s, e) = err(srv.post("/api/file", json!({ "path": long, "text": "x\n" })));
    assert_eq!(s, 200, "{e}");
    assert_eq!(std::fs::read_to_string(srv.dir.join(&long)).unwrap(), "x\n");
    let longer = format!("{}.txt", "n".repeat(252));
    let (s, e) = err(srv.post("/api/file", json!({ "path": longer, "text": "x\n" })));
    assert_eq!(s, 400, "{e}");
    assert!(e.contains("at most 255"), "{e}");
    srv.alive();

    // Inside the working folder, files are written and read back.
    let (s, v) = srv.post(
        "/api/file",
        json!({ "path": "copy.txt", "text": "0,0 SAAAAA\n" }),
    );
    assert_eq!((s, &v["bytes"]), (200, &json!(11)));
    assert_eq!(
        std::fs::read_to_string(srv.dir.join("copy.txt")).unwrap(),
        "0,0 SAAAAA\n"
    );
    let (s, v) = srv.post("/api/file", json!({ "path": "copy.txt" }));
    assert_eq!((s, &v["text"]), (200, &json!("0,0 SAAAAA\n")));

    // Files with errors are not run: the run goes on as it was, and restarts from step 0
    // when they are fixed.
    let rules = std::fs::read_to_string(srv.dir.join("rules.txt")).unwrap();
    let agents = std::fs::read_to_string(srv.dir.join("agents-30.txt")).unwrap();
    assert_eq!(srv.get("/api/frame?step=4").1["step"], 4);
    // The run's log: how far it reached, and a kind it does not know refused.
    let (s, v) = srv.get("/api/log?agent=0&limit=5");
    assert_eq!(
        (s, &v["reached"], v["records"].is_array()),
        (200, &json!(4), true)
    );
    assert!(v["kinds"]
        .as_array()
        .unwrap()
        .contains(&json!("state-conflict")));
    let (s, v) = srv.get("/api/log?kind=bogus");
    assert_eq!(s, 400, "{v}");
    // Breakpoints: stepping forwards pauses at the step asked for, and the note says so;
    // one written wrongly leaves them as they were.
    let (s, v) = srv.post("/api/breaks", json!({ "step": 6 }));
    assert_eq!(
        (s, &v["set"], &v["breaks"]["step"]),
        (200, &json!(true), &json!(6))
    );
    let (s, v) = srv.post("/api/breaks", json!({ "counter": "C00 > 5" }));
    assert_eq!(
        (s, &v["set"], &v["breaks"]["step"]),
        (200, &json!(false), &json!(6))
    );
    assert!(
        v["error"]
            .as_str()
            .unwrap()
            .contains("not a counter condition"),
        "{v}"
    );
    let (_, v) = srv.get("/api/frame?step=9");
    assert_eq!(v["step"], 6);
    assert_eq!(v["note"], "paused at a breakpoint: step 6");
    srv.post("/api/breaks", json!({}));
    srv.get("/api/frame?step=4");
    let (s, v) = srv.post("/api/apply", json!({ "rules": "x", "agents": agents }));
    assert_eq!((s, &v["applied"]), (200, &json!(false)));
    assert_eq!(v["check"]["errors"], 1);
    assert_eq!(srv.get("/api/frame").1["step"], 4);
    let (s, v) = srv.post("/api/apply", json!({ "rules": rules, "agents": agents }));
    assert_eq!((s, &v["frame"]["step"]), (200, &json!(0)));
    srv.alive();

    // A server started on files with errors has no run until they are applied fixed.
    let broken = start(
        "broken",
        "examples/mistakes/rules.txt",
        "examples/tour/agents.txt",
    );
    let (s, e) = err(broken.get("/api/frame?step=1"));
    assert_eq!(s, 409);
    assert!(e.starts_with("nothing is running"), "{e}");
    let (_, session) = broken.get("/api/session");
    assert_eq!(
        (&session["running"], &session["check"]["errors"]),
        (&json!(false), &json!(6))
    );
}

#[test]
fn check_marks_errors_in_the_editor_they_belong_to() {
    let srv = start(
        "check",
        "examples/leader-election/rules.txt",
        "examples/leader-election/agents-30.txt",
    );
    let (s, v) = srv.post(
        "/api/check",
        json!({
            "rules": "start\n2\nSINIT0 (\nC01 + C00 0000\n",
            "agents": "0,0 SINIT0\n0,1 SINIT0 C99 1\n",
            "rules_path": "r.txt",
            "agents_path": "a.txt",
        }),
    );
    assert_eq!(s, 200);
    let d = v["diagnostics"].as_array().unwrap();
    let at = |editor: &str| {
        d.iter()
            .filter(|x| x["editor"] == editor)
            .map(|x| (x["line"].as_u64().unwrap(), x["column"].as_u64().unwrap()))
            .collect::<Vec<_>>()
    };
    assert_eq!(at("rules"), vec![(3, 8)], "{v}");
    assert_eq!(at("agents").first().map(|p| p.0), Some(2), "{v}");
}

#[test]
fn serves_the_app_and_refuses_a_busy_port() {
    let srv = start(
        "app",
        "examples/leader-election/rules.txt",
        "examples/leader-election/agents-30.txt",
    );
    let (s, html) = srv.request("GET", "/", b"");
    assert_eq!(s, 200);
    assert!(html.contains("<script type=\"module\" src=\"/app.js\">"));
    // The script's ES modules, followed from app.js through their imports, each served
    // from the asset table; every module in web/ is reached.
    let mut all = String::new();
    let mut todo = vec!["app".to_string()];
    let mut seen = std::collections::BTreeSet::new();
    while let Some(m) = todo.pop() {
        if !seen.insert(m.clone()) {
            continue;
        }
        let (s, js) = srv.request("GET", &format!("/{m}.js"), b"");
        assert_eq!(s, 200, "/{m}.js");
        for piece in js.split("'./").skip(1) {
            if let Some(name) = piece.split_once(".js'").map(|p| p.0) {
                todo.push(name.to_string());
            }
        }
        all += &js;
    }
    let on_disk: std::collections::BTreeSet<String> = std::fs::read_dir(format!("{ROOT}/web"))
        .unwrap()
        .filter_map(|e| {
            e.unwrap()
                .file_name()
                .to_str()?
                .strip_suffix(".js")
                .map(String::from)
        })
        .collect();
    assert_eq!(seen, on_disk, "every module of web/ is imported and served");
    assert!(all.contains("/api/frame?format=bin&step="));
    let port = srv.addr.rsplit(':').next().unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_latticesim"))
        .current_dir(ROOT)
        .args(["serve", "--port", port])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("cannot listen on 127.0.0.1:"), "{err}");
}

/// The error text of a JSON error answer (which every error must be).
fn error_of(text: &str) -> String {
    let v: Value = serde_json::from_str(text).unwrap_or_else(|e| panic!("{e}: {text:?}"));
    v["error"]
        .as_str()
        .unwrap_or_else(|| panic!("no error in {text}"))
        .to_string()
}

#[test]
fn only_the_viewers_own_pages_with_the_token_get_in() {
    let srv = start(
        "gate",
        "examples/leader-election/rules.txt",
        "examples/leader-election/agents-30.txt",
    );
    let write = br#"{"path":"csrf.txt","text":"x"}"#;
    // A page of another site posting text/plain (no preflight in a browser): refused, with
    // or without the token, and nothing is written.
    let (s, e) = srv.request_with(
        "POST",
        "/api/file",
        "Origin: http://evil.example\r\nContent-Type: text/plain\r\n",
        write,
    );
    assert_eq!(s, 403, "{e}");
    assert!(error_of(&e).contains("cross-origin"), "{e}");
    let (s, _) = srv.request_with(
        "POST",
        "/api/apply",
        &format!(
            "Origin: http://evil.example\r\nX-Latticesim-Token: {}\r\n",
            srv.token
        ),
        b"{}",
    );
    assert_eq!(s, 403);
    let (s, _) = srv.request_with(
        "GET",
        "/api/session",
        &format!(
            "Sec-Fetch-Site: cross-site\r\nX-Latticesim-Token: {}\r\n",
            srv.token
        ),
        b"",
    );
    assert_eq!(s, 403);
    assert!(!srv.dir.join("csrf.txt").exists());
    // DNS rebinding: the browser sends the attacker's host name.
    let port = srv.addr.rsplit(':').next().unwrap();
    let mut req = format!(
        "GET /api/file HTTP/1.1\r\nHost: rebind.attacker.example:{port}\r\nX-Latticesim-Token: {}\r\nConnection: close\r\n\r\n",
        srv.token
    )
    .into_bytes();
    let (s, e) = srv.raw(&req);
    assert_eq!(s, 403, "{e}");
    assert!(error_of(&e).contains("DNS rebinding"), "{e}");
    let body = r#"{"path":"rules.txt"}"#;
    req = format!(
        "POST /api/file HTTP/1.1\r\nHost: rebind.attacker.example:{port}\r\nX-Latticesim-Token: {}\r\nContent-Length: {}\r\nConnection: close\r\n\r\n{body}",
        srv.token,
        body.len()
    )
    .into_bytes();
    let (s, e) = srv.raw(&req);
    assert_eq!(s, 403, "{e}");
    assert!(!e.contains("leader"), "{e}");
    // No token, a wrong one: refused; the viewer's own origin with the token: served.
    let (s, e) = srv.request_with("GET", "/api/session", "", b"");
    assert_eq!(s, 403);
    assert!(error_of(&e).contains("token"), "{e}");
    let (s, _) = srv.request_with("GET", "/", "X-Latticesim-Token: 0000\r\n", b"");
    assert_eq!(s, 403);
    let origin = format!("Origin: http://{}\r\n", srv.addr);
    let (s, _) = srv.request_with(
        "GET",
        "/api/session",
        &format!("{origin}X-Latticesim-Token: {}\r\n", srv.token),
        b"",
    );
    assert_eq!(s, 200);
    let local = format!("localhost:{port}");
    let mut req = format!(
        "GET /api/session HTTP/1.1\r\nHost: {local}\r\nAuthorization: token {}\r\nConnection: close\r\n\r\n",
        srv.token
    );
    assert_eq!(srv.raw(req.as_bytes()).0, 200);
    // The printed URL sets a cookie and takes the token out of the address bar; the cookie
    // then lets the page and its API calls in.
    req = format!(
        "GET /?token={} HTTP/1.1\r\nHost: {}\r\nConnection: close\r\n\r\n",
        srv.token, srv.addr
    );
    let mut s = TcpStream::connect(&srv.addr).unwrap();
    s.write_all(req.as_bytes()).unwrap();
    let mut head = String::new();
    s.read_to_string(&mut head).unwrap();
    assert!(head.starts_with("HTTP/1.1 303"), "{head}");
    assert!(head.contains("\r\nLocation: /\r\n"), "{head}");
    let cookie = head
        .lines()
        .find_map(|l| l.strip_prefix("Set-Cookie: "))
        .unwrap_or_else(|| panic!("no cookie in {head}"));
    assert!(
        cookie.contains("HttpOnly") && cookie.contains("SameSite=Strict"),
        "{cookie}"
    );
    let pair = cookie.split(';').next().unwrap();
    let (s, html) = srv.request_with("GET", "/", &format!("Cookie: a=b; {pair}\r\n"), b"");
    assert_eq!(s, 200);
    assert!(html.contains("<script type=\"module\" src=\"/app.js\">"));
}

#[test]
fn the_file_api_never_leaves_the_folder_nor_fails_on_odd_names() {
    let srv = start(
        "files",
        "examples/leader-election/rules.txt",
        "examples/leader-election/agents-30.txt",
    );
    let err = |r: (u16, Value)| (r.0, r.1["error"].as_str().unwrap_or("").to_string());
    // A dangling link to a file outside: refused, and the file is not created.
    let outside = srv.dir.with_extension("outside");
    let _ = std::fs::remove_dir_all(&outside);
    std::fs::create_dir_all(&outside).unwrap();
    #[cfg(unix)]
    {
        std::os::unix::fs::symlink(outside.join(".bash_profile"), srv.dir.join("notes.txt"))
            .unwrap();
        let (s, e) = err(srv.post(
            "/api/file",
            json!({ "path": "notes.txt", "text": "echo owned" }),
        ));
        assert_eq!(s, 403, "{e}");
        assert!(!outside.join(".bash_profile").exists());
        // A link inside the folder to a file inside: the file is written, the link stays.
        std::fs::write(srv.dir.join("real.txt"), "old").unwrap();
        std::os::unix::fs::symlink("real.txt", srv.dir.join("alias.txt")).unwrap();
        let (s, _) = srv.post("/api/file", json!({ "path": "alias.txt", "text": "new" }));
        assert_eq!(s, 200);
        assert_eq!(
            std::fs::read_to_string(srv.dir.join("real.txt")).unwrap(),
            "new"
        );
        assert!(std::fs::symlink_metadata(srv.dir.join("alias.txt"))
            .unwrap()
            .file_type()
            .is_symlink());
    }
    let _ = std::fs::remove_dir_all(&outside);
    // Odd names are the client's mistake (400), not the server's (500).
    for p in [
        "a".repeat(5000),
        "x/".to_string() + &"b".repeat(300),
        "a\0b".into(),
    ] {
        let (s, e) = err(srv.post("/api/file", json!({ "path": p, "text": "x" })));
        assert_eq!(s, 400, "{e}");
        let (s, e) = err(srv.post("/api/file", json!({ "path": p })));
        assert_eq!(s, 400, "{e}");
    }
    // No temporary file is left behind by a save.
    let left: Vec<_> = std::fs::read_dir(&srv.dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".tmp"))
        .collect();
    assert!(left.is_empty(), "{left:?}");
    srv.alive();
}

#[test]
fn a_slow_or_stalled_client_holds_up_no_one() {
    let srv = start(
        "slow",
        "examples/leader-election/rules.txt",
        "examples/leader-election/agents-30.txt",
    );
    let answers_meanwhile = |what: &str| {
        // Plain requests keep being answered while the bad client holds its connection.
        let mut s = TcpStream::connect(&srv.addr).unwrap();
        s.set_read_timeout(Some(std::time::Duration::from_secs(10)))
            .unwrap();
        let req = format!(
            "GET /api/session HTTP/1.1\r\nHost: {}\r\nX-Latticesim-Token: {}\r\nConnection: close\r\n\r\n",
            srv.addr, srv.token
        );
        s.write_all(req.as_bytes()).unwrap();
        let mut out = Vec::new();
        let r = s.read_to_end(&mut out);
        assert!(
            r.is_ok() && out.starts_with(b"HTTP/1.1 200"),
            "no answer while {what}: {r:?}"
        );
    };
    // A body announced as 2,000 bytes of which one arrives.
    let mut slow = TcpStream::connect(&srv.addr).unwrap();
    let head = format!(
        "POST /api/check HTTP/1.1\r\nHost: {}\r\nX-Latticesim-Token: {}\r\nContent-Length: 2000\r\n\r\n{{",
        srv.addr, srv.token
    );
    slow.write_all(head.as_bytes()).unwrap();
    answers_meanwhile("a body is slow to come");
    // A client that asks for a 9 MB answer and never reads it.
    std::fs::write(srv.dir.join("big.txt"), "x".repeat(8 << 20)).unwrap();
    let mut stalled = TcpStream::connect(&srv.addr).unwrap();
    let body = r#"{"path":"big.txt"}"#;
    let req = format!(
        "POST /api/file HTTP/1.1\r\nHost: {}\r\nX-Latticesim-Token: {}\r\nContent-Length: {}\r\n\r\n{body}",
        srv.addr,
        srv.token,
        body.len()
    );
    stalled.write_all(req.as_bytes()).unwrap();
    std::thread::sleep(std::time::Duration::from_millis(300));
    answers_meanwhile("an answer is not read");
    // A head that never ends: refused at the limit with a JSON error, not read for ever.
    let mut s = TcpStream::connect(&srv.addr).unwrap();
    let _ = s.write_all(b"GET / HTTP/1.1\r\nX-Long: ");
    let line = vec![b'a'; 1 << 20];
    let _ = s.write_all(&line);
    let mut out = Vec::new();
    let _ = s.read_to_end(&mut out);
    let text = String::from_utf8_lossy(&out);
    assert!(text.starts_with("HTTP/1.1 431"), "{text}");
    let body = text.split_once("\r\n\r\n").unwrap().1;
    assert!(error_of(body).contains("head is larger"), "{body}");
    // The transport's own errors are JSON too.
    let (s, body) = srv.raw(b"NONSENSE\r\n\r\n");
    assert_eq!(s, 400);
    assert!(error_of(&body).contains("malformed"), "{body}");
    let (s, body) = srv.raw(
        format!(
            "POST /api/check HTTP/1.1\r\nHost: {}\r\nTransfer-Encoding: chunked\r\n\r\n",
            srv.addr
        )
        .as_bytes(),
    );
    assert_eq!(s, 411);
    error_of(&body);
    drop((slow, stalled));
    srv.alive();
}

#[test]
fn connections_that_send_nothing_lock_no_one_out() {
    let srv = start(
        "halfopen",
        "examples/leader-election/rules.txt",
        "examples/leader-election/agents-30.txt",
    );
    // Far more connections than the server serves at once (64), sending nothing or half a
    // head; a client with the token is answered at once all the same (it waited 30 s for a
    // 503 before), and again after more of them.
    let mut idle: Vec<TcpStream> = Vec::new();
    for round in 0..2 {
        for i in 0..100 {
            let mut s = TcpStream::connect(&srv.addr).unwrap();
            if i % 2 == 1 {
                let _ = s.write_all(b"GET /api/session HTTP/1.1\r\nHost: ");
            }
            idle.push(s);
        }
        std::thread::sleep(std::time::Duration::from_millis(200));
        let t = std::time::Instant::now();
        let (status, body) = srv.get("/api/session");
        assert_eq!(status, 200, "round {round}: {body}");
        assert!(
            t.elapsed() < std::time::Duration::from_secs(5),
            "round {round}: answered after {:?}",
            t.elapsed()
        );
    }
    // The oldest were closed to make room: they read the end of the stream.
    let mut first = idle.remove(0);
    first
        .set_read_timeout(Some(std::time::Duration::from_secs(5)))
        .unwrap();
    assert_eq!(first.read(&mut [0u8; 16]).ok(), Some(0));
    drop(idle);
    srv.alive();
}

#[test]
fn the_ipv6_loopback_is_loopback() {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_latticesim"));
    cmd.args(["serve", "--host", "::1", "--port", "0"])
        .stderr(Stdio::piped());
    let (mut child, line) = launch(cmd);
    let _ = child.kill();
    let out = child.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    if err.contains("cannot listen") {
        // This machine has no IPv6 loopback; nothing to check.
        return;
    }
    assert!(line.contains("http://[::1]:"), "{line}");
    assert!(!err.contains("warning"), "{err}");
}

#[test]
fn deep_and_huge_checks_are_answered_and_the_server_goes_on() {
    let srv = start(
        "deep",
        "examples/leader-election/rules.txt",
        "examples/leader-election/agents-30.txt",
    );
    let rules = format!("r\n1\n{}S0****\nS1****\n", "!".repeat(20_000));
    let (s, v) = srv.post("/api/check", json!({ "rules": rules, "agents": "0,0\n" }));
    assert_eq!(s, 200, "{v}");
    assert_eq!(v["diagnostics"][0]["code"], "E206", "{v}");
    let agents = format!("0,0{}\n", " Q".repeat(100_000));
    let (s, v) = srv.post(
        "/api/check",
        json!({ "rules": "r\n1\nS*****\nS*****\n", "agents": agents }),
    );
    assert_eq!(s, 200);
    assert_eq!(v["errors"], 100_000);
    assert_eq!(v["diagnostics"].as_array().unwrap().len(), 10);
    assert_eq!(v["not_shown"][0]["errors"], 99_990);
    srv.alive();
}

/// Editing (`POST /api/edit`): each edit starts the run from the edited agents (at step 0,
/// checked), undo and redo go back and forth, what cannot be changes nothing and says why,
/// an edit after stepping on takes the step shown, and save writes the canonical text.
#[test]
fn edits_start_the_run_from_the_edited_agents() {
    let srv = start(
        "edit",
        "examples/gravity/rules.txt",
        "examples/gravity/agents.txt",
    );
    let (_, f0) = srv.get("/api/frame?step=0");
    let n = frame_agents(&f0).len();
    let edit = |v: Value| {
        let (s, r) = srv.post("/api/edit", v);
        assert_eq!(s, 200, "{r}");
        r
    };
    let r = edit(json!({ "op": "place", "pos": [-7, 40], "state": "GRAV0" }));
    assert_eq!(r["applied"], true, "{r}");
    assert_eq!(r["frame"]["step"], 0);
    let agents = frame_agents(&r["frame"]);
    assert_eq!(agents.len(), n + 1);
    assert_eq!(agents[n], (vec![-7, 40], "GRAV0".to_string()));
    assert!(
        r["agents"].as_str().unwrap().ends_with("-7,40 SGRAV0\n"),
        "{r}"
    );
    assert_eq!((&r["undo"], &r["redo"]), (&json!(1), &json!(0)));
    // A neighbour, a bond, counters; undone and done again.
    edit(json!({ "op": "place", "pos": [-6, 40], "state": "GRAV0" }));
    let r = edit(json!({ "op": "bond", "id": n, "dir": "E", "on": true }));
    assert_eq!(r["frame"]["attach"][n], 4, "{r}");
    assert_eq!(r["frame"]["attach"][n + 1], 2);
    let r = edit(json!({ "op": "set", "id": n, "counters": "C00 3" }));
    assert!(
        r["agents"]
            .as_str()
            .unwrap()
            .contains("-7,40 SGRAV0 A0010 C00 3\n"),
        "{r}"
    );
    let r = edit(json!({ "op": "undo" }));
    assert!(
        r["agents"]
            .as_str()
            .unwrap()
            .contains("-7,40 SGRAV0 A0010\n"),
        "{r}"
    );
    let r = edit(json!({ "op": "redo" }));
    assert!(r["agents"]
        .as_str()
        .unwrap()
        .contains("-7,40 SGRAV0 A0010 C00 3\n"));
    // What cannot be: nothing changes, and why.
    for (v, why) in [
        (json!({ "op": "place", "pos": [-6, 40] }), "agent"),
        (json!({ "op": "place", "pos": [1, 2, 3] }), "2D"),
        (
            json!({ "op": "bond", "id": n, "dir": "N" }),
            "no agent stands N",
        ),
        (
            json!({ "op": "set", "id": n, "counters": "C00 99999" }),
            "outside",
        ),
        (json!({ "op": "set", "id": 10_000 }), "there is no agent"),
        (json!({ "op": "fly" }), "is not an edit"),
    ] {
        let r = edit(v);
        assert_eq!(r["applied"], false, "{r}");
        assert!(r["error"].as_str().unwrap().contains(why), "{r}");
        assert_eq!(frame_agents(&r["frame"]).len(), n + 2);
    }
    // Removing an agent removes its bonds.
    let r = edit(json!({ "op": "remove", "id": n + 1 }));
    assert!(
        r["frame"]["attach"].is_null(),
        "no agent is attached any more: {r}"
    );
    // The run goes on from the edited agents; an edit then takes the step shown.
    let (_, f) = srv.get("/api/frame?step=3");
    assert_eq!(
        frame_agents(&f)[n].0,
        vec![-7, 37],
        "the placed agent fell 3 cells"
    );
    let r = edit(json!({ "op": "place", "pos": [-20, 0] }));
    assert_eq!(frame_agents(&r["frame"])[n].0, vec![-7, 37], "{r}");
    assert_eq!((&r["undo"], &r["redo"]), (&json!(1), &json!(0)));
    // Save: the canonical text, which checks.
    let r = edit(json!({ "op": "save", "path": "edited.txt" }));
    assert_eq!(r["saved"], "edited.txt");
    let saved = std::fs::read_to_string(srv.dir.join("edited.txt")).unwrap();
    let (_, s) = srv.get("/api/session");
    assert_eq!(saved, s["agents"].as_str().unwrap());
    let out = Command::new(env!("CARGO_BIN_EXE_latticesim"))
        .current_dir(&srv.dir)
        .args(["check", "rules.txt", "--agents", "edited.txt"])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}
