//! `latticesim-fuzz`: a mutation fuzzer on stable Rust for the readers of outside input
//! (`latticesim::fuzzing`: rules, agents files, checkpoints, the language server's stream,
//! the viewer's HTTP transport). Each target starts from its seeds (the examples, the
//! committed corpus in `fuzz/corpus/TARGET/`, checkpoints made from examples), mutates
//! them (bits, bytes, ranges, tokens of the format, numbers, splices; checkpoints with
//! their checksums made right again, so that mutations reach past them) and keeps a
//! mutant that shows something no input showed before (a diagnostic code, an error kind,
//! a status). A panic, an abort (e.g. an allocation of what a forged length says) or an
//! input that runs longer than `--timeout` is a failure: the input is saved under
//! `target/fuzz/TARGET/` with the command that replays it, and the exit code is 1.
//! docs/testing.md says how to run it.

use clap::Parser;
use latticesim::fuzzing::{checkpoint_seeds, TARGETS};
use std::collections::HashSet;
use std::hash::{Hash, Hasher};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicI32, AtomicPtr, AtomicU64, AtomicUsize, Ordering};
use std::sync::Mutex;
use std::time::{Duration, Instant};

#[derive(Parser)]
#[command(
    name = "latticesim-fuzz",
    about = "Fuzz latticesim's readers of outside input"
)]
struct Args {
    /// The targets (rules, agents, checkpoint, lsp, http); all when none is given.
    targets: Vec<String>,
    /// How long to fuzz each target.
    #[arg(long, default_value_t = 20.0)]
    seconds: f64,
    /// The seed of the mutations (the same seed, build and time give the same inputs).
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// The longest one input may run, in seconds, before it is called a hang.
    #[arg(long, default_value_t = 10.0)]
    timeout: f64,
    /// Run this one input through the (one) target given, and show what happens.
    #[arg(long)]
    replay: Option<PathBuf>,
    /// Where failing inputs are saved.
    #[arg(long, default_value = "target/fuzz")]
    artifacts: PathBuf,
}

/// The workspace's folder (the examples and the corpus are found from it).
fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// The largest input made by mutation.
const MAX_INPUT: usize = 1 << 16;
/// The most inputs kept per target.
const MAX_CORPUS: usize = 4096;

/// The seeds of a target: its committed corpus, and examples of its format.
fn seeds(target: &str) -> Vec<Vec<u8>> {
    let mut out = Vec::new();
    let mut files = |dir: PathBuf, keep: &dyn Fn(&str) -> bool| {
        let mut paths: Vec<PathBuf> = std::fs::read_dir(&dir)
            .map(|d| d.flatten().map(|e| e.path()).collect())
            .unwrap_or_default();
        paths.sort();
        for p in paths {
            let name = p.file_name().and_then(|n| n.to_str()).unwrap_or("");
            if p.is_file() && keep(name) {
                if let Ok(b) = std::fs::read(&p) {
                    if b.len() <= MAX_INPUT {
                        out.push(b);
                    }
                }
            }
        }
    };
    files(root().join("fuzz/corpus").join(target), &|_| true);
    let mut examples: Vec<PathBuf> = std::fs::read_dir(root().join("examples"))
        .map(|d| d.flatten().map(|e| e.path()).collect())
        .unwrap_or_default();
    examples.sort();
    for dir in examples {
        match target {
            "rules" => files(dir, &|n| n.starts_with("rules") && n.ends_with(".txt")),
            "agents" => files(dir, &|n| n.starts_with("agents") && n.ends_with(".txt")),
            _ => {}
        }
    }
    if target == "checkpoint" {
        out.extend(checkpoint_seeds());
    }
    out
}

/// The format's own words, inserted by one of the mutations.
fn dictionary(target: &str) -> &'static [&'static str] {
    match target {
        "rules" | "agents" => &[
            "S",
            "SLEAD0",
            "C00 ",
            "C01",
            "C13",
            " 0000",
            " 9999",
            "-0001",
            ">",
            "<",
            "=",
            ">=",
            "==",
            "N",
            "E",
            "W",
            "U",
            "D",
            "*",
            "P1,0",
            "P0,0,1",
            "P-1,0",
            "X",
            "T1,0,",
            "B",
            "M",
            "Mpath!",
            "#*01",
            "#N01",
            "A",
            "+",
            "-",
            "!",
            "\n",
            "\n\n",
            "\r\n",
            " ",
            "\t",
            "//",
            "// latticesim: counters 32\n",
            "// latticesim: allow W603\n",
            "// latticesim: deny warnings\n",
            "U-1,100000,-14,100000\n",
            "1,0 ",
            "0,0,1 ",
            "2147483647",
            "-2147483648",
            "32768",
            "\u{feff}",
            "é",
            "\u{0}",
        ],
        "lsp" => &[
            "Content-Length: ",
            "Content-Length: 99999999999999",
            "\r\n",
            "\r\n\r\n",
            "\n",
            "{\"jsonrpc\":\"2.0\",",
            "\"id\":1,",
            "\"id\":null,",
            "\"method\":\"",
            "textDocument/didOpen",
            "textDocument/didChange",
            "textDocument/hover",
            "textDocument/definition",
            "textDocument/references",
            "textDocument/rename",
            "textDocument/completion",
            "textDocument/formatting",
            "textDocument/codeAction",
            "textDocument/semanticTokens/full",
            "textDocument/documentSymbol",
            "textDocument/foldingRange",
            "\"params\":{",
            "\"uri\":\"file:///tmp/r/rules.txt\"",
            "\"uri\":\"file:///tmp/r/agents.txt\"",
            "\"text\":\"",
            "\"position\":{\"line\":",
            "\"character\":",
            "4294967295",
            "-1",
            "\\ud800",
            "\\udc00",
            "\\u0000",
            "}",
            "]",
        ],
        "http" => &[
            "GET ",
            "POST ",
            "HEAD ",
            "PUT ",
            " HTTP/1.1\r\n",
            " HTTP/1.0\r\n",
            "\r\n",
            "\r\n\r\n",
            "\n",
            "Host: 127.0.0.1:8321\r\n",
            "Host: evil.example\r\n",
            "Host: [::1]:8321\r\n",
            "Content-Length: ",
            "Content-Length: 99999999999999\r\n",
            "Transfer-Encoding: chunked\r\n",
            "Expect: 100-continue\r\n",
            "Connection: close\r\n",
            "Connection: keep-alive\r\n",
            "X-Latticesim-Token: 0123456789abcdef0123456789abcdef\r\n",
            "Cookie: latticesim-token-8321=0123456789abcdef0123456789abcdef\r\n",
            "Origin: http://evil.example\r\n",
            "Sec-Fetch-Site: cross-site\r\n",
            "Accept-Encoding: zstd\r\n",
            "/api/session",
            "/api/frame?step=",
            "?token=",
            "&",
            "%00",
            "\u{0}",
            ":",
            " ",
        ],
        _ => &[],
    }
}

/// xorshift64*: small, fast, and the same everywhere.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_f491_4f6c_dd1d)
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }
    fn chance(&mut self, per_cent: u64) -> bool {
        self.next() % 100 < per_cent
    }
}

const NUMBERS: [&str; 10] = [
    "0",
    "-1",
    "1",
    "32767",
    "32768",
    "2147483648",
    "4294967296",
    "99999999999999999999",
    "9223372036854775808",
    "00000000000000000000001",
];
const INTEGERS: [u64; 10] = [
    0,
    1,
    0x7f,
    0xff,
    0x7fff,
    0xffff,
    0x7fff_ffff,
    0x8000_0000,
    0xffff_ffff,
    u64::MAX,
];

/// One mutation of `b` (`other`: another input of the corpus, for splices).
fn mutate(b: &mut Vec<u8>, other: &[u8], dict: &[&str], rng: &mut Rng) {
    let len = b.len();
    let at = rng.below(len + 1);
    match rng.below(12) {
        0 if len > 0 => {
            let i = rng.below(len);
            b[i] ^= 1 << rng.below(8);
        }
        1 if len > 0 => {
            let i = rng.below(len);
            b[i] = *[
                0,
                0xff,
                0x7f,
                0x80,
                b'0',
                b'9',
                b'\n',
                b' ',
                b'*',
                rng.next() as u8,
            ]
            .get(rng.below(10))
            .expect("in range");
        }
        2 if len > 0 => {
            let n = 1 + rng.below(16.min(len - at.min(len - 1)));
            let from = at.min(len - 1);
            b.drain(from..(from + n).min(len));
        }
        3 => {
            let n = 1 + rng.below(8);
            let byte = rng.next() as u8;
            let bytes: Vec<u8> = if rng.chance(50) {
                vec![byte; n]
            } else {
                (0..n).map(|_| rng.next() as u8).collect()
            };
            b.splice(at..at, bytes);
        }
        4 if len > 0 => {
            let from = rng.below(len);
            let n = 1 + rng.below((len - from).min(256));
            let piece = b[from..from + n].to_vec();
            let to = rng.below(len + 1);
            b.splice(to..to, piece);
        }
        5 | 6 if !dict.is_empty() => {
            let word = dict[rng.below(dict.len())].as_bytes().to_vec();
            if rng.chance(30) && at < len {
                let end = (at + word.len()).min(len);
                b.splice(at..end, word);
            } else {
                b.splice(at..at, word);
            }
        }
        7 if !other.is_empty() => {
            let cut = rng.below(other.len());
            b.truncate(at);
            b.extend_from_slice(&other[cut..]);
        }
        8 => {
            // A number in the text made another.
            let digits: Vec<usize> = (0..len).filter(|&i| b[i].is_ascii_digit()).collect();
            if let Some(&i) = digits.get(rng.below(digits.len())) {
                let end = (i..len).find(|&j| !b[j].is_ascii_digit()).unwrap_or(len);
                let n = NUMBERS[rng.below(NUMBERS.len())].as_bytes().to_vec();
                b.splice(i..end, n);
            }
        }
        9 if len > 0 => {
            // A forged integer of 1, 2, 4 or 8 bytes, often in the first bytes (headers).
            let width = [1, 2, 4, 8][rng.below(4)];
            let i = if rng.chance(50) {
                rng.below(len.min(64))
            } else {
                rng.below(len)
            };
            let v = INTEGERS[rng.below(INTEGERS.len())].wrapping_add(rng.below(3) as u64);
            for (k, byte) in v.to_le_bytes().iter().take(width).enumerate() {
                if let Some(x) = b.get_mut(i + k) {
                    *x = *byte;
                }
            }
        }
        10 => b.truncate(at),
        _ if len > 0 => {
            // Two lines swapped.
            let starts: Vec<usize> = std::iter::once(0)
                .chain((0..len).filter(|&i| b[i] == b'\n').map(|i| i + 1))
                .filter(|&i| i < len)
                .collect();
            if starts.len() >= 2 {
                let line = |s: usize| (s, (s..len).find(|&j| b[j] == b'\n').unwrap_or(len));
                let (i, j) = (rng.below(starts.len()), rng.below(starts.len()));
                let (x, y) = (line(starts[i.min(j)]), line(starts[i.max(j)]));
                if x.1 < y.0 {
                    let mut out = b[..x.0].to_vec();
                    out.extend_from_slice(&b[y.0..y.1]);
                    out.extend_from_slice(&b[x.1..y.0]);
                    out.extend_from_slice(&b[x.0..x.1]);
                    out.extend_from_slice(&b[y.1..]);
                    *b = out;
                }
            }
        }
        _ => b.push(rng.next() as u8),
    }
    b.truncate(MAX_INPUT);
}

/// A checkpoint's two checksums made right again (the header's and the whole file's), so
/// that a mutation behind them is read.
fn fix_checksums(b: &mut [u8]) {
    if b.len() >= 61 {
        let crc = crc32(&b[..57]);
        b[57..61].copy_from_slice(&crc.to_le_bytes());
    }
    if b.len() >= 65 {
        let end = b.len() - 4;
        let crc = crc32(&b[..end]);
        b[end..].copy_from_slice(&crc.to_le_bytes());
    }
}

/// A message stream's `Content-Length`s made right again (each the length up to the next
/// `Content-Length`), so that a mutation inside a message is read as that message.
fn fix_lengths(b: &mut Vec<u8>) {
    const KEY: &[u8] = b"Content-Length: ";
    let find = |b: &[u8], from: usize, what: &[u8]| {
        (from..b.len().saturating_sub(what.len() - 1)).find(|&i| b[i..].starts_with(what))
    };
    let mut out = Vec::with_capacity(b.len());
    let mut at = 0;
    while let Some(k) = find(b, at, KEY) {
        out.extend_from_slice(&b[at..k]);
        let Some(blank) = find(b, k, b"\r\n\r\n") else {
            at = k;
            break;
        };
        let body = blank + 4;
        let end = find(b, body, KEY).unwrap_or(b.len());
        out.extend_from_slice(format!("Content-Length: {}\r\n\r\n", end - body).as_bytes());
        out.extend_from_slice(&b[body..end]);
        at = end;
    }
    out.extend_from_slice(&b[at..]);
    *b = out;
}

/// CRC-32 (IEEE), as checkpoints use it.
fn crc32(bytes: &[u8]) -> u32 {
    let mut crc = !0u32;
    for &b in bytes {
        crc ^= b as u32;
        for _ in 0..8 {
            crc = (crc >> 1) ^ (0xedb8_8320 & (crc & 1).wrapping_neg());
        }
    }
    !crc
}

fn fingerprint(x: impl Hash) -> u64 {
    let mut h = std::collections::hash_map::DefaultHasher::new();
    x.hash(&mut h);
    h.finish()
}

/// The input being run, for the watchdog and for the handler of an abort.
static CURRENT: Mutex<Vec<u8>> = Mutex::new(Vec::new());
static CURRENT_PTR: AtomicPtr<u8> = AtomicPtr::new(std::ptr::null_mut());
static CURRENT_LEN: AtomicUsize = AtomicUsize::new(0);
/// The file an aborting input is written to (-1: none).
static ABORT_FD: AtomicI32 = AtomicI32::new(-1);
/// When the input being run started, in ms since [`epoch`] (0: none runs).
static STARTED: AtomicU64 = AtomicU64::new(0);
/// The last panic's message and place.
static PANIC: Mutex<Option<String>> = Mutex::new(None);
/// Whether panics are reported (when replaying) or only kept.
static LOUD: AtomicBool = AtomicBool::new(false);

fn epoch() -> Instant {
    static E: std::sync::OnceLock<Instant> = std::sync::OnceLock::new();
    *E.get_or_init(Instant::now)
}

fn now_ms() -> u64 {
    epoch().elapsed().as_millis() as u64 + 1
}

extern "C" fn on_abort(_: libc::c_int) {
    let (fd, p, n) = (
        ABORT_FD.load(Ordering::SeqCst),
        CURRENT_PTR.load(Ordering::SeqCst),
        CURRENT_LEN.load(Ordering::SeqCst),
    );
    // SAFETY: the buffer is the one `CURRENT` holds, unchanged while its input runs; only
    // async-signal-safe calls follow, and the default action ends the process.
    unsafe {
        if fd >= 0 && !p.is_null() {
            libc::write(fd, p as *const libc::c_void, n);
            const SAY: &[u8] = b"\nlatticesim-fuzz: the input ABORTED the process; it is saved as `aborted` in the target's artifacts folder\n";
            libc::write(2, SAY.as_ptr() as *const libc::c_void, SAY.len());
        }
        libc::signal(libc::SIGABRT, libc::SIG_DFL);
        libc::raise(libc::SIGABRT);
    }
}

/// Guards against what cannot be caught: an abort leaves its input on disk, an allocation
/// past 8 GiB fails at once (rather than the machine swapping), a hang is ended by the
/// watchdog.
fn install(timeout: Duration, artifacts: PathBuf) {
    std::panic::set_hook(Box::new(|info| {
        let msg = info
            .payload()
            .downcast_ref::<&str>()
            .map(|s| s.to_string())
            .or_else(|| info.payload().downcast_ref::<String>().cloned())
            .unwrap_or_else(|| "a panic".into());
        let at = info
            .location()
            .map(|l| format!(" at {}:{}", l.file(), l.line()))
            .unwrap_or_default();
        let text = format!("{msg}{at}");
        if LOUD.load(Ordering::SeqCst) {
            eprintln!(
                "panicked: {text}\n{}",
                std::backtrace::Backtrace::force_capture()
            );
        }
        *PANIC.lock().unwrap_or_else(|p| p.into_inner()) = Some(text);
    }));
    // SAFETY: plain libc calls with valid arguments.
    unsafe {
        let most = 8u64 << 30;
        let limit = libc::rlimit {
            rlim_cur: most,
            rlim_max: libc::RLIM_INFINITY,
        };
        libc::setrlimit(libc::RLIMIT_AS, &limit);
        libc::signal(
            libc::SIGABRT,
            on_abort as extern "C" fn(libc::c_int) as libc::sighandler_t,
        );
    }
    std::thread::spawn(move || loop {
        std::thread::sleep(Duration::from_millis(100));
        let started = STARTED.load(Ordering::SeqCst);
        if started != 0 && now_ms().saturating_sub(started) > timeout.as_millis() as u64 {
            let input = CURRENT.lock().unwrap_or_else(|p| p.into_inner()).clone();
            let path = artifacts.join(format!("hang-{:016x}", fingerprint(&input)));
            let _ = std::fs::create_dir_all(&artifacts);
            let _ = std::fs::write(&path, &input);
            eprintln!(
                "latticesim-fuzz: an input ran past {} s (a hang); saved as {}",
                timeout.as_secs_f64(),
                path.display()
            );
            std::process::exit(1);
        }
    });
}

/// Runs one input: what it showed, or the panic's message.
fn run_one(target: latticesim::fuzzing::Target, input: &[u8]) -> Result<Vec<String>, String> {
    {
        let mut cur = CURRENT.lock().unwrap_or_else(|p| p.into_inner());
        cur.clear();
        cur.extend_from_slice(input);
        CURRENT_PTR.store(cur.as_mut_ptr(), Ordering::SeqCst);
        CURRENT_LEN.store(cur.len(), Ordering::SeqCst);
    }
    STARTED.store(now_ms(), Ordering::SeqCst);
    let r = std::panic::catch_unwind(|| target(input));
    STARTED.store(0, Ordering::SeqCst);
    r.map_err(|_| {
        PANIC
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .take()
            .unwrap_or_else(|| "a panic".into())
    })
}

/// What fuzzing one target found.
struct Outcome {
    runs: u64,
    corpus: usize,
    seeds: usize,
    failures: Vec<(String, PathBuf)>,
}

fn fuzz(
    name: &str,
    target: latticesim::fuzzing::Target,
    seconds: f64,
    seed: u64,
    artifacts: &Path,
) -> Outcome {
    let dir = artifacts.join(name);
    let _ = std::fs::create_dir_all(&dir);
    let aborted = dir.join("aborted");
    if let Ok(f) = std::fs::File::create(&aborted) {
        use std::os::fd::IntoRawFd;
        ABORT_FD.store(f.into_raw_fd(), Ordering::SeqCst);
    }
    let mut corpus = seeds(name);
    let seeds = corpus.len();
    if corpus.is_empty() {
        corpus.push(Vec::new());
    }
    let mut features: HashSet<u64> = HashSet::new();
    let mut failures = Vec::new();
    let fail = |input: &[u8], why: String, failures: &mut Vec<(String, PathBuf)>| {
        let path = dir.join(format!("crash-{:016x}", fingerprint(input)));
        let _ = std::fs::write(&path, input);
        failures.push((why, path));
    };
    let mut runs = 0u64;
    for input in corpus.clone() {
        runs += 1;
        match run_one(target, &input) {
            Ok(seen) => features.extend(seen.iter().map(fingerprint)),
            Err(why) => fail(&input, why, &mut failures),
        }
    }
    let mut rng = Rng(seed.wrapping_mul(0x9e37_79b9_7f4a_7c15) ^ fingerprint(name) | 1);
    let dict = dictionary(name);
    let end = Instant::now() + Duration::from_secs_f64(seconds);
    while Instant::now() < end && failures.len() < 5 {
        let mut b = corpus[rng.below(corpus.len())].clone();
        let other = &corpus[rng.below(corpus.len())];
        for _ in 0..1 + rng.below(4) {
            mutate(&mut b, other, dict, &mut rng);
        }
        if name == "checkpoint" && rng.chance(80) {
            fix_checksums(&mut b);
        }
        if name == "lsp" && rng.chance(70) {
            fix_lengths(&mut b);
        }
        runs += 1;
        match run_one(target, &b) {
            Ok(seen) => {
                let mut new = false;
                for f in seen.iter().map(fingerprint) {
                    new |= features.insert(f);
                }
                if new && corpus.len() < MAX_CORPUS {
                    corpus.push(b);
                }
            }
            Err(why) => fail(&b, why, &mut failures),
        }
    }
    let fd = ABORT_FD.swap(-1, Ordering::SeqCst);
    if fd >= 0 {
        // SAFETY: the descriptor was opened above and is closed once.
        unsafe { libc::close(fd) };
    }
    let _ = std::fs::remove_file(&aborted);
    let _ = std::fs::remove_dir(&dir);
    Outcome {
        runs,
        corpus: corpus.len(),
        seeds,
        failures,
    }
}

fn main() -> std::process::ExitCode {
    let args = Args::parse();
    let names: Vec<String> = if args.targets.is_empty() {
        TARGETS.iter().map(|(n, _)| n.to_string()).collect()
    } else {
        args.targets.clone()
    };
    let mut chosen = Vec::new();
    for n in &names {
        match TARGETS.iter().find(|(t, _)| t == n) {
            Some(&t) => chosen.push(t),
            None => {
                let all: Vec<&str> = TARGETS.iter().map(|(t, _)| *t).collect();
                eprintln!("error: no target `{n}`; the targets are {}", all.join(", "));
                return std::process::ExitCode::from(2);
            }
        }
    }
    install(
        Duration::from_secs_f64(args.timeout),
        args.artifacts.clone(),
    );
    if let Some(path) = &args.replay {
        let [(name, target)] = chosen[..] else {
            eprintln!("error: --replay takes one target");
            return std::process::ExitCode::from(2);
        };
        let input = match std::fs::read(path) {
            Ok(b) => b,
            Err(e) => {
                eprintln!("error: cannot read `{}`: {e}", path.display());
                return std::process::ExitCode::from(2);
            }
        };
        LOUD.store(true, Ordering::SeqCst);
        return match run_one(target, &input) {
            Ok(seen) => {
                println!("{name}: no failure; it showed: {}", seen.join(", "));
                std::process::ExitCode::SUCCESS
            }
            Err(_) => std::process::ExitCode::from(1),
        };
    }
    let mut failed = false;
    for (name, target) in chosen {
        let t = Instant::now();
        let o = fuzz(name, target, args.seconds, args.seed, &args.artifacts);
        let secs = t.elapsed().as_secs_f64();
        println!(
            "{name}: {} inputs in {secs:.1} s ({:.0}/s), {} kept of which {} seeds, {} failures",
            o.runs,
            o.runs as f64 / secs,
            o.corpus,
            o.seeds,
            o.failures.len()
        );
        for (why, path) in &o.failures {
            failed = true;
            let short: String = why.chars().take(400).collect();
            let cut = if short.len() < why.len() { " ..." } else { "" };
            println!("  panicked: {short}{cut}");
            println!(
                "    saved as {0}; replay: cargo run --release -p latticesim-fuzz -- {name} --replay {0}",
                path.display()
            );
        }
    }
    if failed {
        println!("once fixed, add each failing input to fuzz/corpus/TARGET/ (it is replayed by `cargo test`)");
        std::process::ExitCode::from(1)
    } else {
        std::process::ExitCode::SUCCESS
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every seed (the committed corpus, which holds the inputs that once failed, and the
    /// examples) goes through its target without a failure.
    #[test]
    fn the_corpus_passes_every_target() {
        for (name, target) in TARGETS {
            let seeds = seeds(name);
            assert!(!seeds.is_empty(), "{name} has no seeds");
            for (i, s) in seeds.iter().enumerate() {
                let r = std::panic::catch_unwind(|| target(s));
                assert!(r.is_ok(), "{name}: seed {i} fails");
            }
        }
    }

    #[test]
    fn checksums_are_made_right_again() {
        let seed = checkpoint_seeds().remove(0);
        let mut b = seed.clone();
        b[70] ^= 1;
        fix_checksums(&mut b);
        assert_ne!(b, seed);
        let mut again = b.clone();
        fix_checksums(&mut again);
        assert_eq!(b, again);
        assert_eq!(crc32(b"123456789"), 0xcbf4_3926);
    }

    #[test]
    fn lengths_are_made_right_again() {
        let mut b = b"Content-Length: 2\r\n\r\n{}xyzContent-Length: 99\r\n\r\n[1]".to_vec();
        fix_lengths(&mut b);
        assert_eq!(
            b,
            b"Content-Length: 5\r\n\r\n{}xyzContent-Length: 3\r\n\r\n[1]".to_vec()
        );
        let mut cut = b"Content-Length: 2\r\n{".to_vec();
        fix_lengths(&mut cut);
        assert_eq!(cut, b"Content-Length: 2\r\n{".to_vec());
    }

    #[test]
    fn mutations_stay_within_bounds_and_change_inputs() {
        let mut rng = Rng(7);
        let mut changed = 0;
        for i in 0..20_000 {
            let start: Vec<u8> = b"walk\n1\nSWALK0 N**0*\nP1,0\n"[..i % 26].to_vec();
            let mut b = start.clone();
            mutate(&mut b, b"other\n", dictionary("rules"), &mut rng);
            assert!(b.len() <= MAX_INPUT);
            changed += usize::from(b != start);
        }
        assert!(changed > 15_000, "{changed}");
    }
}
