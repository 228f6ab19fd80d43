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

mod binary;
mod breaks;
mod edit;
mod gate;
mod http;
mod plots;
mod routes;
mod session;
mod tabs;
mod views;

use crate::output::say;
use crate::palette::Palette;
use http::{error, Response as Reply};
use latticesim_compiler::{compile, Checked};
use latticesim_runtime::{Engine, History, Jump, Lattice, Options, Order};
use serde::Serialize;
use serde_json::{json, Value};
use std::collections::HashMap;
use std::io::Read;
use std::net::{IpAddr, SocketAddr, TcpListener, ToSocketAddrs};
use std::path::{Component, Path, PathBuf};
use std::process::ExitCode;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use gate::*;
use session::*;
use tabs::Tabs;
use views::*;

/// The largest request body accepted (rules and agents texts travel in bodies).
pub const MAX_BODY: usize = 8 << 20;
/// The largest file the editor shows for editing: a larger one stays on the server, read
/// from its file when checked or applied (a browser's text box slows the whole page down
/// with tens of megabytes in it).
const MAX_FILE: u64 = 4 << 20;
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
    #[command(flatten)]
    lints: crate::LintArgs,
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
    /// Memory for each step reached kept backwards (what it changed), so that going back
    /// or to any step reached costs what the steps changed, not steps of the engine; past
    /// it the oldest are dropped and going there steps again from a keyframe (0: keep
    /// none). Keyframes hold at most 1 GiB besides.
    #[arg(long, value_name = "MB", default_value_t = (latticesim_runtime::DELTA_BUDGET >> 20) as u64)]
    history_mb: u64,
    /// The colours of the states: a file of `#rrggbb` lines (the colours handed out in
    /// order of first appearance) and `STATE #rrggbb` lines (a state's own colour).
    #[arg(long, value_name = "FILE")]
    palette: Option<PathBuf>,
}

fn reply_json<T: Serialize>(status: u16, v: &T) -> Reply {
    Reply {
        status,
        ctype: "application/json",
        headers: Vec::new(),
        body: serde_json::to_vec(v).expect("plain data"),
    }
}

/// A request target's path and its query's `key=value` pairs.
fn path_and_query(target: &str) -> (&str, HashMap<&str, &str>) {
    let (path, query) = target.split_once('?').unwrap_or((target, ""));
    let query = (query.split('&'))
        .filter_map(|kv| kv.split_once('='))
        .collect();
    (path, query)
}

/// The transport and the gate over `input` as one connection sends it, each request that
/// passes answered 200 (for the fuzz harness, `crate::fuzzing`): the statuses answered.
pub(crate) fn replay(input: &[u8]) -> Vec<String> {
    let token = "0123456789abcdef0123456789abcdef";
    let gate = Gate::new(
        token.into(),
        SocketAddr::from(([127, 0, 0, 1], 8321)),
        "127.0.0.1",
    );
    let handler = |r: &http::Request| {
        let (path, query) = path_and_query(&r.target);
        match gate.admit(r, path, &query) {
            Ok(_) => reply_json(200, &json!({ "path": path, "bytes": r.body.len() })),
            Err(reply) => reply,
        }
    };
    let limits = http::Limits {
        body: 64 << 10,
        ..LIMITS
    };
    let mut wire = http::Memory {
        input,
        output: Vec::new(),
    };
    http::connection(&mut wire, limits, &handler, &|_| {});
    // The statuses at the start of each answer (after the last one's JSON body, or after
    // a `100 Continue`), not those quoted in a body.
    let out = &wire.output;
    (0..out.len())
        .filter(|&i| out[i..].starts_with(b"HTTP/1.1 "))
        .filter(|&i| i == 0 || out[..i].ends_with(b"}") || out[..i].ends_with(b"\r\n\r\n"))
        .filter_map(|i| out.get(i + 9..i + 12))
        .filter(|s| s.iter().all(u8::is_ascii_digit))
        .map(|s| format!("status {}", String::from_utf8_lossy(s)))
        .collect()
}

/// Answers one request: the gate, then a new tab (`POST /api/tab`), or the handler of the
/// request's session (its tab's, or the default one) under that session's lock.
fn answer(gate: &Gate, tabs: &Tabs, r: &http::Request) -> Reply {
    let (path, query) = path_and_query(&r.target);
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
    let session = match routes::tab_route(tabs, &req) {
        Some(reply) => Err(reply),
        None => tabs.get(r.header("x-latticesim-tab")),
    };
    let session = match session {
        Ok(s) => s,
        Err(mut reply) => {
            reply.headers.extend(extra);
            return reply;
        }
    };
    let mut s = session.lock().unwrap_or_else(|e| e.into_inner());
    let s = &mut *s;
    let mut reply = match std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        routes::route(s, &req)
    })) {
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
    let palette = match args.palette.as_deref().map(Palette::read).transpose() {
        Ok(p) => p.unwrap_or_default(),
        Err(e) => {
            say!("error: --palette {e}");
            return ExitCode::from(2);
        }
    };
    let threads = crate::threads(args.threads, usize::MAX, "");
    let lints = match args.lints.lints() {
        Ok(l) => l,
        Err(c) => return c,
    };
    let mut session = Session {
        root,
        allowed: Vec::new(),
        opts: Options {
            threads,
            order: Order::ActionsFirst,
            static_first: false,
            trace: false,
            skip: Default::default(),
            space_order: Default::default(),
            records_per_step: None,
        },
        keyframe_every: args.keyframe_every.max(1),
        history_bytes: usize::try_from(args.history_mb.saturating_mul(1 << 20))
            .unwrap_or(usize::MAX),
        rules_path: "rules.txt".into(),
        agents_path: "agents.txt".into(),
        rules: String::new(),
        agents: String::new(),
        run: None,
        palette,
        lints,
        breaks: Default::default(),
        edit: None,
        runs: 0,
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
    let tabs = Tabs::new(session);
    http::serve(listener, LIMITS, move |r| answer(&gate, &tabs, r));
    ExitCode::SUCCESS
}
