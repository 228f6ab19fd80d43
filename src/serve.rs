//! `latticesim serve`: the viewer and editor in the browser. An HTTP server on 127.0.0.1
//! ([`http`]: connections, limits, deadlines) serves the single-page app embedded in the
//! binary (`web/`) and a JSON API over a [`History`] of the run; the API and the security
//! model are documented in docs/viewer.md.
//!
//! Every request passes the [`Gate`] first: its `Host` must be an address this server is
//! reached at (against DNS rebinding), a cross-origin request is refused, and it must carry
//! the session's secret token (query, header or the cookie set when the printed URL was
//! opened). Requests are then handled one at a time under a lock on the [`Session`]. A
//! request that fails gets a JSON `{"error": "..."}` with a 4xx status; a panic while
//! handling one is caught, answered with 500 and ends the run (the files stay), so the
//! server keeps serving.

mod http;

use crate::output::say;
use crate::render::state_colour;
use http::{error, Response as Reply};
use latticesim_compiler::{compile, Checked};
use latticesim_runtime::{Engine, History, Lattice, Options, Order, TraceEvent};
use serde::Serialize;
use serde_json::{json, Value};
use std::collections::HashMap;
use std::io::Read;
use std::net::{IpAddr, SocketAddr, TcpListener, ToSocketAddrs};
use std::path::{Component, Path, PathBuf};
use std::process::ExitCode;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

const INDEX_HTML: &str = include_str!("../web/index.html");
const APP_JS: &str = include_str!("../web/app.js");
const APP_CSS: &str = include_str!("../web/app.css");

/// The largest request body accepted (rules and agents texts travel in bodies).
pub const MAX_BODY: usize = 8 << 20;
/// The largest file the editor loads.
const MAX_FILE: u64 = 8 << 20;
/// How long one request may step forwards before it answers with the step it reached.
const STEP_BUDGET: Duration = Duration::from_secs(5);
/// What a client may send, and how slowly (see [`http::Limits`]).
const LIMITS: http::Limits = http::Limits {
    head: 32 << 10,
    headers: 64,
    body: MAX_BODY,
    read: Duration::from_secs(30),
    write: Duration::from_secs(30),
    connections: 64,
};
/// The longest path the file API takes, in bytes, and the longest name in it.
const MAX_PATH: usize = 4096;
const MAX_NAME: usize = 255;

/// The arguments of `latticesim serve`.
#[derive(clap::Args)]
pub struct ServeArgs {
    /// The rules file to open (the editor can load others from the working folder).
    #[arg(requires = "agents")]
    rules: Option<PathBuf>,
    /// The agents file to open.
    agents: Option<PathBuf>,
    /// The port (0: any free port; the URL printed says which).
    #[arg(long, default_value_t = 8080)]
    port: u16,
    /// The address to listen on. Anyone who can reach it and knows the token can read and
    /// write files in the working folder, so only 127.0.0.1 is the default.
    #[arg(long, default_value = "127.0.0.1")]
    host: String,
    /// The secret every request must carry (default: a new random one each time, printed
    /// in the URL).
    #[arg(long)]
    token: Option<String>,
    /// Threads for the per-agent work (default: all cores).
    #[arg(long)]
    threads: Option<usize>,
    /// Keep a keyframe every K steps for stepping back (the interval doubles past 256
    /// keyframes, so memory stays bounded).
    #[arg(long, default_value_t = 64)]
    keyframe_every: u64,
}

fn reply_json<T: Serialize>(status: u16, v: &T) -> Reply {
    Reply {
        status,
        ctype: "application/json",
        headers: Vec::new(),
        body: serde_json::to_vec(v).expect("plain data"),
    }
}

fn asset(ctype: &'static str, text: &str) -> Reply {
    Reply {
        status: 200,
        ctype,
        headers: Vec::new(),
        body: text.as_bytes().to_vec(),
    }
}

/// The run shown: its history and the names of its rules.
struct Run {
    hist: History,
    /// Why the last forward stepping stopped early, if it did.
    note: Option<String>,
}

/// Everything the server holds.
struct Session {
    /// The working folder: files outside it are neither read nor written.
    root: PathBuf,
    /// Files named on the command line, which may lie outside the working folder.
    allowed: Vec<PathBuf>,
    opts: Options,
    keyframe_every: u64,
    rules_path: String,
    agents_path: String,
    rules: String,
    agents: String,
    run: Option<Run>,
}

/// A request: method, path, query parameters and body.
struct Req<'a> {
    method: &'a str,
    path: &'a str,
    query: HashMap<&'a str, &'a str>,
    body: &'a [u8],
}

impl Req<'_> {
    fn json(&self) -> Result<Value, Reply> {
        let v: Value = serde_json::from_slice(self.body)
            .map_err(|e| error(400, format!("the request body is not valid JSON: {e}")))?;
        if !v.is_object() {
            return Err(error(400, "the request body must be a JSON object"));
        }
        Ok(v)
    }

    fn number(&self, name: &str) -> Result<Option<u64>, Reply> {
        self.query
            .get(name)
            .map(|v| {
                v.parse::<u64>().map_err(|_| {
                    error(
                        400,
                        format!("`{name}` must be a non-negative integer, not `{v}`"),
                    )
                })
            })
            .transpose()
    }
}

fn text_field<'v>(v: &'v Value, name: &str) -> Result<&'v str, Reply> {
    v.get(name).and_then(Value::as_str).ok_or_else(|| {
        error(
            400,
            format!("the request body needs a string field `{name}`"),
        )
    })
}

/// Checks the editor's texts: the verdict, and the lattice when there are no errors.
fn check_texts(
    rules_name: &str,
    rules: &str,
    agents_name: &str,
    agents: &str,
) -> (Checked, Option<Lattice>) {
    let l = crate::agents_file::load(
        (rules_name, rules.as_bytes()),
        agents_name,
        crate::agents_file::Source::Bytes(agents.as_bytes()),
        crate::run::io_threads(None),
    )
    .expect("reading memory does not fail");
    (l.checked, l.lattice)
}

/// The checker's verdict: counts, dimension and every diagnostic with the editor it
/// belongs to (`rules` or `agents`).
fn check_json(c: &Checked, rules_name: &str) -> Value {
    let diags: Vec<Value> = latticesim_compiler::render::to_json(&c.diags, &c.sources)
        .into_iter()
        .map(|d| {
            let editor = if d.file == rules_name {
                "rules"
            } else {
                "agents"
            };
            let mut v = serde_json::to_value(d).expect("plain data");
            v["editor"] = json!(editor);
            v
        })
        .collect();
    json!({
        "errors": c.errors(),
        "warnings": c.warnings(),
        "dimension": c.dim.dim.name(),
        "rules": c.rule_count,
        "agents": c.agent_count,
        "diagnostics": diags,
        "not_shown": crate::not_shown_json(c),
    })
}

/// A configuration as the viewer draws it.
#[derive(Serialize)]
struct Frame {
    step: u64,
    dim: usize,
    quiescent: bool,
    /// Positions, `dim` numbers per agent.
    pos: Vec<i32>,
    /// Per agent: its index in `states`.
    state: Vec<u32>,
    states: Vec<StateInfo>,
    /// Attachment bits per agent (bit i = direction i of N, W, E, S, A, B), or none when
    /// no agent is attached.
    attach: Option<Vec<u8>>,
    universe: Option<Vec<[i32; 2]>>,
    records: Vec<Value>,
    stats: Value,
    keyframes: [u64; 2],
    note: Option<String>,
}

#[derive(Serialize)]
struct StateInfo {
    name: String,
    colour: String,
    count: u64,
}

fn hex(c: [u8; 3]) -> String {
    format!("#{:02x}{:02x}{:02x}", c[0], c[1], c[2])
}

fn state_name(s: &[u8; 5]) -> String {
    String::from_utf8_lossy(s).into_owned()
}

fn frame(run: &Run) -> Frame {
    let e = run.hist.engine();
    let lat = &e.lat;
    let coords = lat.dim.coords();
    let mut index: HashMap<[u8; 5], u32> = HashMap::new();
    let mut states: Vec<StateInfo> = Vec::new();
    // Neighbours often share a state: the last one found is tried first.
    let mut last: Option<([u8; 5], u32)> = None;
    let state = lat
        .state
        .iter()
        .map(|s| {
            let i = match last {
                Some((l, i)) if l == *s => i,
                _ => *index.entry(*s).or_insert_with(|| {
                    states.push(StateInfo {
                        name: state_name(s),
                        colour: hex(state_colour(s)),
                        count: 0,
                    });
                    states.len() as u32 - 1
                }),
            };
            last = Some((*s, i));
            states[i as usize].count += 1;
            i
        })
        .collect();
    let mut pos = Vec::with_capacity(lat.len() * coords);
    for p in &lat.pos {
        pos.extend_from_slice(&p[..coords]);
    }
    let attach = lat
        .attach
        .iter()
        .any(|&b| b != 0)
        .then(|| lat.attach.clone());
    let universe = lat
        .universe
        .map(|b| b[..coords].iter().map(|&(lo, hi)| [lo, hi]).collect());
    let records = run
        .hist
        .last_report()
        .map(|rep| {
            rep.records
                .iter()
                .map(|r| {
                    json!({
                        "kind": r.kind.name(),
                        "severity": if r.is_error() { "error" } else { "warning" },
                        "message": r.message,
                        "agents": r.agents.iter().map(|(id, _)| id).collect::<Vec<_>>(),
                    })
                })
                .collect()
        })
        .unwrap_or_default();
    let s = &e.stats;
    let stats = json!({
        "firings": s.firings.iter().sum::<u64>(),
        "moves": s.moves,
        "swaps": s.swaps,
        "sent": s.sent,
        "delivered": s.delivered,
        "dropped": s.dropped,
        "errors": s.errors(),
        "warnings": s.warnings(),
    });
    let (k, every) = run.hist.keyframes();
    Frame {
        step: run.hist.steps(),
        dim: coords,
        quiescent: s.quiescent,
        pos,
        state,
        states,
        attach,
        universe,
        records,
        stats,
        keyframes: [k as u64, every],
        note: run.note.clone(),
    }
}

/// What the inspector shows of agent `a`: its columns, its inbox, and the rules it executes
/// in the next step (found by running that step on a copy with tracing).
fn inspect(run: &Run, a: u32) -> Value {
    let e = run.hist.engine();
    let lat = &e.lat;
    let i = a as usize;
    let dirs = lat.dim.dirs();
    let letters = ['N', 'W', 'E', 'S', 'A', 'B'];
    let attached: String = (0..dirs)
        .filter(|d| lat.attach[i] & (1 << d) != 0)
        .map(|d| letters[d])
        .collect();
    let counters: Vec<Value> = lat
        .counter_numbers()
        .into_iter()
        .map(|c| json!({ "name": format!("C{c:02}"), "value": lat.counter(a, c) }))
        .collect();
    let mut messages: Vec<Value> = Vec::new();
    for (d, letter) in letters.iter().enumerate().take(dirs) {
        for s in lat.slot_numbers() {
            let v = lat.inbox(a, d as u8, s);
            if v != 0 {
                messages.push(json!({ "name": format!("#{letter}{:02}", s + 1), "value": v }));
            }
        }
        if let Some(t) = lat.inbox_text(a, d as u8) {
            messages.push(json!({ "name": format!("#{letter}"), "value": state_name(&t) }));
        }
    }
    let mut opts = e.opts;
    opts.trace = true;
    opts.threads = 1;
    let mut next = Engine::new(e.prog.clone(), lat.clone(), opts);
    let rep = next.step();
    let fires = rep.trace.iter().find_map(|ev| match ev {
        TraceEvent::Fire {
            agent,
            rules,
            priority,
        } if *agent == a => Some(json!({ "rules": rules, "priority": priority })),
        _ => None,
    });
    let p = lat.pos[i];
    json!({
        "id": a,
        "pos": &p[..lat.dim.coords()],
        "state": state_name(&lat.state[i]),
        "attached": attached,
        "counters": counters,
        "messages": messages,
        "next": fires,
        "next_step": run.hist.steps() + 1,
    })
}

impl Session {
    fn info(&self) -> Value {
        json!({
            "root": self.root.display().to_string(),
            "rules_path": self.rules_path,
            "agents_path": self.agents_path,
            "rules": self.rules,
            "agents": self.agents,
            "check": check_json(
                &check_texts(&self.rules_path, &self.rules, &self.agents_path, &self.agents).0,
                &self.rules_path,
            ),
            "running": self.run.is_some(),
        })
    }

    /// Checks the texts and, when they have no errors, starts a run of them from step 0
    /// (true); with errors the run stays as it was (false).
    fn apply(&mut self) -> (Value, bool) {
        let (c, lat) = check_texts(
            &self.rules_path,
            &self.rules,
            &self.agents_path,
            &self.agents,
        );
        let verdict = check_json(&c, &self.rules_path);
        if let (Some(p), Some(lat)) = (c.rules.as_ref(), lat) {
            if let Ok(prog) = compile(p) {
                let hist = History::new(prog, lat, self.opts, self.keyframe_every, 256);
                self.run = Some(Run { hist, note: None });
                return (verdict, true);
            }
        }
        (verdict, false)
    }

    /// A path from the browser, made absolute and checked to lie in the working folder
    /// (or to be a file named on the command line). `new` allows a file that does not
    /// exist yet (its folder must).
    fn resolve(&self, p: &str, new: bool) -> Result<PathBuf, Reply> {
        if p.trim().is_empty() {
            return Err(error(400, "the path is empty"));
        }
        if p.contains('\0') {
            return Err(error(400, "the path contains a NUL character"));
        }
        if p.len() > MAX_PATH {
            return Err(error(
                400,
                format!(
                    "the path has {} bytes; at most {MAX_PATH} are allowed",
                    p.len()
                ),
            ));
        }
        if let Some(long) = Path::new(p)
            .components()
            .find(|c| c.as_os_str().len() > MAX_NAME)
        {
            return Err(error(
                400,
                format!(
                    "a name in the path has {} bytes; at most {MAX_NAME} are allowed",
                    long.as_os_str().len()
                ),
            ));
        }
        // First by the path's text (so that `a/../../b` is refused whether `a` exists or
        // not), then by where it really leads (symbolic links).
        let mut full = PathBuf::new();
        for c in self.root.join(p).components() {
            match c {
                Component::ParentDir => {
                    full.pop();
                }
                Component::CurDir => {}
                c => full.push(c),
            }
        }
        let outside = |q: &Path| !q.starts_with(&self.root) && !self.allowed.iter().any(|a| a == q);
        let refuse = || {
            error(
                403,
                format!(
                    "`{p}` is outside the working folder {}; the server reads and writes only there",
                    self.root.display()
                ),
            )
        };
        if outside(&full) {
            return Err(refuse());
        }
        let canon = match full.canonicalize() {
            Ok(c) => c,
            Err(_) if std::fs::symlink_metadata(&full).is_ok() => {
                return Err(error(
                    403,
                    format!(
                    "`{p}` is a symbolic link that leads nowhere; the server does not follow it"
                ),
                ))
            }
            Err(_) if new => {
                let name = full
                    .file_name()
                    .filter(|n| *n != "..")
                    .ok_or_else(|| error(400, format!("`{p}` does not name a file")))?;
                let parent = full.parent().unwrap_or(Path::new("/"));
                let parent = parent.canonicalize().map_err(|e| {
                    error(404, format!("the folder of `{p}` cannot be opened: {e}"))
                })?;
                parent.join(name)
            }
            Err(e) => return Err(error(404, format!("cannot open `{p}`: {e}"))),
        };
        if outside(&canon) {
            return Err(refuse());
        }
        Ok(canon)
    }

    fn handle(&mut self, req: &Req) -> Reply {
        // Every route and its method (for the answer to another method).
        let routes: [(&str, &str); 10] = [
            ("GET", "/"),
            ("GET", "/index.html"),
            ("GET", "/app.js"),
            ("GET", "/app.css"),
            ("GET", "/api/session"),
            ("POST", "/api/check"),
            ("POST", "/api/apply"),
            ("GET", "/api/frame"),
            ("GET", "/api/agent"),
            ("POST", "/api/file"),
        ];
        let result = match (req.method, req.path) {
            ("GET", "/" | "/index.html") => Ok(asset("text/html; charset=utf-8", INDEX_HTML)),
            ("GET", "/app.js") => Ok(asset("text/javascript; charset=utf-8", APP_JS)),
            ("GET", "/app.css") => Ok(asset("text/css; charset=utf-8", APP_CSS)),
            ("GET", "/api/session") => Ok(reply_json(200, &self.info())),
            ("POST", "/api/check") => self.api_check(req),
            ("POST", "/api/apply") => self.api_apply(req),
            ("GET", "/api/frame") => self.api_frame(req),
            ("GET", "/api/agent") => self.api_agent(req),
            ("POST", "/api/file") => self.api_file(req),
            (m, p) => match routes.iter().find(|r| r.1 == p) {
                Some((takes, _)) => Err(error(
                    405,
                    format!("{m} is not allowed on {p}; it takes {takes}"),
                )),
                None => Err(error(404, format!("no such page or API: {p}"))),
            },
        };
        result.unwrap_or_else(|r| r)
    }

    fn api_check(&mut self, req: &Req) -> Result<Reply, Reply> {
        let v = req.json()?;
        let (rules, agents) = (text_field(&v, "rules")?, text_field(&v, "agents")?);
        let rules_path = v["rules_path"].as_str().unwrap_or(&self.rules_path);
        let agents_path = v["agents_path"].as_str().unwrap_or(&self.agents_path);
        let (c, _) = check_texts(rules_path, rules, agents_path, agents);
        Ok(reply_json(200, &check_json(&c, rules_path)))
    }

    fn api_apply(&mut self, req: &Req) -> Result<Reply, Reply> {
        let v = req.json()?;
        self.rules = text_field(&v, "rules")?.to_string();
        self.agents = text_field(&v, "agents")?.to_string();
        if let Some(p) = v["rules_path"].as_str() {
            self.rules_path = p.to_string();
        }
        if let Some(p) = v["agents_path"].as_str() {
            self.agents_path = p.to_string();
        }
        match self.apply() {
            (verdict, true) => {
                let run = self.run.as_ref().expect("just started");
                Ok(reply_json(
                    200,
                    &json!({ "check": verdict, "frame": frame(run) }),
                ))
            }
            (verdict, false) => Ok(reply_json(
                422,
                &json!({
                    "error": format!("the files have {} error(s); the run goes on as it was until they are fixed", verdict["errors"]),
                    "check": verdict,
                }),
            )),
        }
    }

    fn run_mut(&mut self) -> Result<&mut Run, Reply> {
        self.run.as_mut().ok_or_else(|| {
            error(
                409,
                "nothing is running: the files have errors, or none were applied",
            )
        })
    }

    fn api_frame(&mut self, req: &Req) -> Result<Reply, Reply> {
        let target = req.number("step")?;
        let run = self.run_mut()?;
        run.note = None;
        if let Some(t) = target {
            if t < run.hist.steps() {
                run.hist.goto(t);
            }
            let started = Instant::now();
            while run.hist.steps() < t {
                if run.hist.engine().stats.quiescent {
                    run.note = Some(format!(
                        "quiescent at step {}: no agent has a rule to execute",
                        run.hist.steps()
                    ));
                    break;
                }
                if started.elapsed() > STEP_BUDGET {
                    run.note = Some(format!(
                        "reached step {} of {t} in {} s; ask again to go on",
                        run.hist.steps(),
                        STEP_BUDGET.as_secs()
                    ));
                    break;
                }
                run.hist.step();
            }
        }
        Ok(reply_json(200, &frame(run)))
    }

    fn api_agent(&mut self, req: &Req) -> Result<Reply, Reply> {
        let id = req
            .number("id")?
            .ok_or_else(|| error(400, "`id` is missing"))?;
        let run = self.run_mut()?;
        let n = run.hist.engine().lat.len() as u64;
        if id >= n {
            return Err(error(
                404,
                format!(
                    "there is no agent {id}: ids go from 0 to {}",
                    n.saturating_sub(1)
                ),
            ));
        }
        Ok(reply_json(200, &inspect(run, id as u32)))
    }

    /// POST /api/file: `{"path"}` reads a file, `{"path", "text"}` writes one.
    fn api_file(&mut self, req: &Req) -> Result<Reply, Reply> {
        let v = req.json()?;
        let p = text_field(&v, "path")?;
        match v.get("text") {
            None => {
                let path = self.resolve(p, false)?;
                let meta = std::fs::metadata(&path)
                    .map_err(|e| error(404, format!("cannot open `{p}`: {e}")))?;
                if !meta.is_file() {
                    return Err(error(400, format!("`{p}` is not a file")));
                }
                if meta.len() > MAX_FILE {
                    return Err(error(
                        413,
                        format!(
                            "`{p}` has {} bytes; the editor opens files up to {MAX_FILE} bytes",
                            meta.len()
                        ),
                    ));
                }
                let mut bytes = Vec::new();
                crate::output::open_no_follow(&path)
                    .and_then(|f| f.take(MAX_FILE + 1).read_to_end(&mut bytes))
                    .map_err(|e| error(404, format!("cannot read `{p}`: {e}")))?;
                let text = String::from_utf8(bytes)
                    .map_err(|_| error(415, format!("`{p}` is not UTF-8 text")))?;
                Ok(reply_json(200, &json!({ "path": p, "text": text })))
            }
            Some(t) => {
                let text = t
                    .as_str()
                    .ok_or_else(|| error(400, "`text` must be a string"))?;
                let path = self.resolve(p, true)?;
                if path.is_dir() {
                    return Err(error(400, format!("`{p}` is a folder")));
                }
                save(&path, text.as_bytes())
                    .map_err(|e| error(500, format!("cannot write `{p}`: {e}")))?;
                Ok(reply_json(200, &json!({ "path": p, "bytes": text.len() })))
            }
        }
    }
}

fn read_text(p: &Path) -> Result<String, ExitCode> {
    let bytes = crate::read(&p.to_path_buf())?;
    String::from_utf8(bytes).map_err(|_| {
        say!("error: `{}` is not UTF-8 text", p.display());
        ExitCode::from(2)
    })
}

/// Writes a file of the editor whole or not at all (a new file beside it, renamed over it),
/// keeping the permissions of the file it replaces.
fn save(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    use std::io::Write;
    let mut f = crate::output::AtomicFile::create(path)?.durable();
    f.write_all(bytes)?;
    if let Ok(meta) = std::fs::metadata(path) {
        f.set_permissions(meta.permissions())?;
    }
    f.commit()
}

/// Who may use the server: a request must name this server in its `Host` (a page that
/// reaches it through DNS rebinding names its own site), must not come from another
/// site's page (`Origin`, `Sec-Fetch-Site`), and must carry the token.
struct Gate {
    token: String,
    port: u16,
    /// The host names this server answers to (lower case, IPv6 without brackets).
    names: Vec<String>,
    /// Listening on every address: any IP address names this server.
    any_ip: bool,
    /// The cookie that holds the token once the printed URL was opened.
    cookie: String,
}

/// The host and port of an authority (`host[:port]`, `[v6]:port`), port 80 by default.
fn authority(a: &str) -> Option<(String, u16)> {
    let a = a.trim();
    let (host, port) = if let Some(rest) = a.strip_prefix('[') {
        let (h, after) = rest.split_once(']')?;
        let port = match after.strip_prefix(':') {
            Some(p) => p.parse().ok()?,
            None if after.is_empty() => 80,
            None => return None,
        };
        (h, port)
    } else {
        match a.rsplit_once(':') {
            Some((h, p)) => (h, p.parse().ok()?),
            None => (a, 80),
        }
    };
    Some((host.to_ascii_lowercase(), port))
}

/// Compares two strings in time that does not depend on where they differ.
fn same_secret(a: &str, b: &str) -> bool {
    a.len() == b.len() && a.bytes().zip(b.bytes()).fold(0u8, |d, (x, y)| d | (x ^ y)) == 0
}

impl Gate {
    fn new(token: String, bound: SocketAddr, host_arg: &str) -> Gate {
        let mut names: Vec<String> = ["127.0.0.1", "localhost", "::1"]
            .iter()
            .map(|s| s.to_string())
            .collect();
        let arg = host_arg.trim_start_matches('[').trim_end_matches(']');
        names.push(arg.to_ascii_lowercase());
        names.push(bound.ip().to_string());
        Gate {
            token,
            port: bound.port(),
            names,
            any_ip: bound.ip().is_unspecified(),
            cookie: format!("latticesim-token-{}", bound.port()),
        }
    }

    fn names_this_server(&self, a: &str) -> bool {
        authority(a).is_some_and(|(host, port)| {
            port == self.port
                && (self.names.contains(&host) || (self.any_ip && host.parse::<IpAddr>().is_ok()))
        })
    }

    fn token_in<'r>(
        &self,
        req: &'r http::Request,
        query: &HashMap<&'r str, &'r str>,
    ) -> Option<&'r str> {
        let cookie = req.header("cookie").and_then(|c| {
            c.split(';')
                .filter_map(|kv| kv.trim().split_once('='))
                .find(|(k, _)| *k == self.cookie)
                .map(|(_, v)| v)
        });
        let auth = req.header("authorization").and_then(|a| {
            a.strip_prefix("token ")
                .or_else(|| a.strip_prefix("Bearer "))
        });
        [
            query.get("token").copied(),
            req.header("x-latticesim-token"),
            auth,
            cookie,
        ]
        .into_iter()
        .flatten()
        .find(|t| same_secret(t.trim(), &self.token))
    }

    /// Lets a request through (`Ok`, with the headers to add to its answer) or answers it.
    fn admit(
        &self,
        req: &http::Request,
        path: &str,
        query: &HashMap<&str, &str>,
    ) -> Result<Vec<(&'static str, String)>, Reply> {
        let Some(host) = req.header("host") else {
            return Err(error(400, "the request has no Host header"));
        };
        if !self.names_this_server(host) {
            return Err(error(
                403,
                format!(
                    "`Host: {host}` does not name this server (it answers at 127.0.0.1:{}, localhost:{0} and the address it listens on); a page of another site that reaches it by DNS rebinding is refused",
                    self.port
                ),
            ));
        }
        let foreign_origin = req.header("origin").is_some_and(|o| {
            !o.strip_prefix("http://")
                .is_some_and(|a| self.names_this_server(a.trim_end_matches('/')))
        });
        if foreign_origin || req.header("sec-fetch-site") == Some("cross-site") {
            return Err(error(
                403,
                format!(
                    "cross-origin request from `{}` refused: only the viewer's own pages may use this server",
                    req.header("origin").unwrap_or("another site")
                ),
            ));
        }
        if self.token_in(req, query).is_none() {
            return Err(error(
                403,
                "this server needs its token: open the URL that `latticesim serve` printed (it ends in ?token=...), or send the token in an X-Latticesim-Token header",
            ));
        }
        let cookie = format!(
            "{}={}; Path=/; HttpOnly; SameSite=Strict",
            self.cookie, self.token
        );
        if query.contains_key("token") && req.method == "GET" && matches!(path, "/" | "/index.html")
        {
            // Keep the token in a cookie and take it out of the address bar.
            return Err(Reply {
                status: 303,
                ctype: "application/json",
                headers: vec![("Set-Cookie", cookie), ("Location", "/".into())],
                body: b"{}".to_vec(),
            });
        }
        Ok(Vec::new())
    }
}

/// A new random token: 24 bytes from the system, in hexadecimal.
fn new_token() -> Result<String, String> {
    let mut b = [0u8; 24];
    getrandom::fill(&mut b).map_err(|e| format!("cannot make a random token: {e}"))?;
    Ok(b.iter().map(|x| format!("{x:02x}")).collect())
}

/// Answers one request: the gate, then the session's handler under its lock.
fn answer(gate: &Gate, session: &Mutex<Session>, r: &http::Request) -> Reply {
    let (path, query) = r.target.split_once('?').unwrap_or((&r.target, ""));
    let query: HashMap<&str, &str> = query
        .split('&')
        .filter_map(|kv| kv.split_once('='))
        .collect();
    let extra = match gate.admit(r, path, &query) {
        Ok(h) => h,
        Err(reply) => return reply,
    };
    let req = Req {
        method: &r.method,
        path,
        query,
        body: &r.body,
    };
    let mut s = session.lock().unwrap_or_else(|e| e.into_inner());
    let s = &mut *s;
    let mut reply = match std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| s.handle(&req)))
    {
        Ok(r) => r,
        Err(_) => {
            s.run = None;
            error(
                500,
                "internal error while handling the request (details on the server's terminal); the run was stopped, apply the files to start again",
            )
        }
    };
    reply.headers.extend(extra);
    reply
}

pub fn serve(args: ServeArgs) -> ExitCode {
    let root = match std::env::current_dir().and_then(|d| d.canonicalize()) {
        Ok(r) => r,
        Err(e) => {
            say!("error: cannot open the working folder: {e}");
            return ExitCode::from(2);
        }
    };
    let threads = crate::threads(args.threads, usize::MAX, "");
    let mut session = Session {
        root,
        allowed: Vec::new(),
        opts: Options {
            threads,
            order: Order::ActionsFirst,
            static_first: false,
            trace: false,
        },
        keyframe_every: args.keyframe_every.max(1),
        rules_path: "rules.txt".into(),
        agents_path: "agents.txt".into(),
        rules: String::new(),
        agents: String::new(),
        run: None,
    };
    if let (Some(r), Some(a)) = (&args.rules, &args.agents) {
        let (rules, agents) = match (read_text(r), read_text(a)) {
            (Ok(r), Ok(a)) => (r, a),
            (Err(c), _) | (_, Err(c)) => return c,
        };
        session.allowed = [r, a]
            .iter()
            .filter_map(|p| p.canonicalize().ok())
            .collect();
        session.rules_path = r.display().to_string();
        session.agents_path = a.display().to_string();
        session.rules = rules;
        session.agents = agents;
        let (verdict, running) = session.apply();
        if !running {
            say!(
                "{}, {}: {} error(s); fix them in the editor",
                session.rules_path,
                session.agents_path,
                verdict["errors"]
            );
        }
    }
    let token = match args.token.clone().map_or_else(new_token, Ok) {
        Ok(t)
            if !t.is_empty()
                && t.bytes()
                    .all(|b| b.is_ascii_alphanumeric() || b"-._~".contains(&b)) =>
        {
            t
        }
        Ok(_) => {
            say!("error: --token: use letters, digits and - . _ ~ only, at least one");
            return ExitCode::from(2);
        }
        Err(e) => {
            say!("error: {e}");
            return ExitCode::from(2);
        }
    };
    let host = args.host.trim_start_matches('[').trim_end_matches(']');
    let listener = match (host, args.port)
        .to_socket_addrs()
        .and_then(|mut a| a.next().ok_or_else(|| std::io::Error::other("no address")))
        .and_then(TcpListener::bind)
    {
        Ok(l) => l,
        Err(e) => {
            say!("error: cannot listen on {}:{}: {e}", args.host, args.port);
            return ExitCode::from(2);
        }
    };
    let bound = match listener.local_addr() {
        Ok(a) => a,
        Err(e) => {
            say!("error: cannot listen on {}:{}: {e}", args.host, args.port);
            return ExitCode::from(2);
        }
    };
    let loopback = host == "localhost" || bound.ip().is_loopback();
    if !loopback {
        say!(
            "warning: listening on {}: anyone who can reach it and has the token can read and write files in {}",
            args.host,
            session.root.display()
        );
    }
    let shown = if bound.ip().is_unspecified() || host == "localhost" {
        format!("127.0.0.1:{}", bound.port())
    } else {
        bound.to_string()
    };
    crate::output::stdout(
        format!("latticesim: serving http://{shown}/?token={token} (Ctrl-C stops)\n").as_bytes(),
    );
    let gate = Gate::new(token, bound, &args.host);
    let session = Arc::new(Mutex::new(session));
    http::serve(listener, LIMITS, move |r| answer(&gate, &session, r));
    ExitCode::SUCCESS
}
