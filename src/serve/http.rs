//! The viewer's HTTP/1.1 transport: accepts connections, reads requests within limits and
//! deadlines, hands each whole request to a handler and writes its answer. It knows nothing
//! of the API; `serve.rs` decides what a request means and who may make it.
//!
//! Every connection has its own thread, at most [`Limits::connections`] at once. When all
//! are taken, the one that has waited longest for a request (idle, or still sending one)
//! is closed to make room, so connections that send nothing cannot lock clients out; only
//! when every connection is busy answering is a new one answered 503 and closed. A
//! request's head must arrive within [`Limits::read`] of the
//! moment the server starts waiting for it and be at most [`Limits::head`] bytes (else 408
//! or 431); its body (`Content-Length` only) at most [`Limits::body`] bytes, arriving
//! within the same deadline (else 413 or 408); an answer must be taken by the client within
//! [`Limits::write`] (else the connection is closed). So a slow or stalled client holds
//! only its own thread, never the others. Every error this layer answers itself is JSON
//! `{"error": ...}`, like the API's own.

use std::collections::HashMap;
use std::io::{ErrorKind, Read, Write};
use std::net::{TcpListener, TcpStream};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// How much a client may send, and how slowly.
#[derive(Clone, Copy, Debug)]
pub struct Limits {
    /// The largest request head (request line and headers), in bytes.
    pub head: usize,
    /// The most header lines in one request.
    pub headers: usize,
    /// The largest request body, in bytes.
    pub body: usize,
    /// The time a whole request (head and body) may take to arrive, counted from when the
    /// server starts waiting for it (so it is also the idle time of a kept-alive connection).
    pub read: Duration,
    /// The time the client may take to receive an answer.
    pub write: Duration,
    /// The most connections served at once.
    pub connections: usize,
}

/// What a connection reads from and writes to: a TCP stream, or bytes in memory (the
/// fuzz harness's).
pub(crate) trait Wire: Read + Write {
    /// Reads wait at most this long.
    fn read_timeout(&mut self, t: Duration) -> std::io::Result<()>;
    /// Writes wait at most this long.
    fn write_timeout(&mut self, t: Duration) -> std::io::Result<()>;
}

impl Wire for TcpStream {
    fn read_timeout(&mut self, t: Duration) -> std::io::Result<()> {
        self.set_read_timeout(Some(t))
    }
    fn write_timeout(&mut self, t: Duration) -> std::io::Result<()> {
        self.set_write_timeout(Some(t))
    }
}

/// A connection in memory: it reads `input` and keeps what is written (the fuzz
/// harness's; see `crate::fuzzing`).
pub(crate) struct Memory<'a> {
    pub(crate) input: &'a [u8],
    pub(crate) output: Vec<u8>,
}

impl Read for Memory<'_> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        self.input.read(buf)
    }
}

impl Write for Memory<'_> {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.output.extend_from_slice(buf);
        Ok(buf.len())
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

impl Wire for Memory<'_> {
    fn read_timeout(&mut self, _: Duration) -> std::io::Result<()> {
        Ok(())
    }
    fn write_timeout(&mut self, _: Duration) -> std::io::Result<()> {
        Ok(())
    }
}

/// A whole request as received.
pub struct Request {
    /// `GET`, `POST`, ...
    pub method: String,
    /// The request target as sent: path and query.
    pub target: String,
    /// Header names in lower case, with their values.
    pub headers: Vec<(String, String)>,
    pub body: Vec<u8>,
}

impl Request {
    /// The first header of this name (lower case), if any.
    pub fn header(&self, name: &str) -> Option<&str> {
        self.headers
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, v)| v.as_str())
    }
}

/// An answer.
pub struct Response {
    pub status: u16,
    pub ctype: &'static str,
    /// Extra headers (`Set-Cookie`, `Location`, ...).
    pub headers: Vec<(&'static str, String)>,
    pub body: Vec<u8>,
}

/// A JSON `{"error": msg}` answer.
pub fn error(status: u16, msg: impl Into<String>) -> Response {
    Response {
        status,
        ctype: "application/json",
        headers: Vec::new(),
        body: serde_json::to_vec(&serde_json::json!({ "error": msg.into() })).expect("plain data"),
    }
}

fn reason(status: u16) -> &'static str {
    match status {
        100 => "Continue",
        200 => "OK",
        303 => "See Other",
        400 => "Bad Request",
        403 => "Forbidden",
        404 => "Not Found",
        405 => "Method Not Allowed",
        408 => "Request Timeout",
        409 => "Conflict",
        411 => "Length Required",
        413 => "Content Too Large",
        415 => "Unsupported Media Type",
        421 => "Misdirected Request",
        422 => "Unprocessable Content",
        431 => "Request Header Fields Too Large",
        500 => "Internal Server Error",
        501 => "Not Implemented",
        503 => "Service Unavailable",
        505 => "HTTP Version Not Supported",
        _ => "",
    }
}

/// The open connections: for each, a handle to close it by and, while it waits for a
/// request, since when.
#[derive(Default)]
struct Open {
    next: u64,
    conns: HashMap<u64, (TcpStream, Option<Instant>)>,
}

/// The table of open connections, shared by the acceptor and the connections' threads.
#[derive(Clone, Default)]
struct Table(Arc<Mutex<Open>>);

impl Table {
    fn lock(&self) -> std::sync::MutexGuard<'_, Open> {
        self.0.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// A slot for `stream` among at most `most`, if need be by closing the connection that
    /// has waited longest for a request; `None` when every one is busy answering.
    fn admit(&self, stream: &TcpStream, most: usize) -> Option<u64> {
        let handle = stream.try_clone().ok()?;
        let mut open = self.lock();
        if open.conns.len() >= most {
            let (&oldest, _) = (open.conns.iter())
                .filter_map(|(id, (_, waiting))| waiting.map(|w| (id, w)))
                .min_by_key(|&(_, w)| w)?;
            if let Some((s, _)) = open.conns.remove(&oldest) {
                let _ = s.shutdown(std::net::Shutdown::Both);
            }
        }
        let id = open.next;
        open.next += 1;
        open.conns.insert(id, (handle, Some(Instant::now())));
        Some(id)
    }

    /// Marks connection `id` as waiting for a request (`true`) or answering one.
    fn waiting(&self, id: u64, waiting: bool) {
        if let Some((_, w)) = self.lock().conns.get_mut(&id) {
            *w = waiting.then(Instant::now);
        }
    }

    fn close(&self, id: u64) {
        self.lock().conns.remove(&id);
    }
}

/// Accepts connections for ever, each on its own thread, calling `handler` for each request.
pub fn serve<H>(listener: TcpListener, limits: Limits, handler: H)
where
    H: Fn(&Request) -> Response + Send + Sync + 'static,
{
    let handler = Arc::new(handler);
    let table = Table::default();
    for stream in listener.incoming() {
        let Ok(mut stream) = stream else { continue };
        let Some(id) = table.admit(&stream, limits.connections) else {
            let r = error(
                503,
                format!(
                    "the server is answering {} requests at once; try again later",
                    limits.connections
                ),
            );
            let _ = write_response(&mut stream, &r, false, Instant::now() + limits.write);
            continue;
        };
        let _ = stream.set_nodelay(true);
        let (handler, t) = (handler.clone(), table.clone());
        let spawned = std::thread::Builder::new()
            .name("latticesim-http".into())
            .spawn(move || {
                connection(&mut stream, limits, &*handler, &|w| t.waiting(id, w));
                t.close(id);
            });
        if spawned.is_err() {
            table.close(id);
        }
    }
}

/// What reading a request gave.
enum Incoming {
    Request(Request, bool),
    /// The client closed or went quiet before sending anything: close without an answer.
    Gone,
    /// Answer this, then close.
    Fail(Response),
}

/// Serves the requests of one connection; `waiting` is told when it starts waiting for a
/// request (`true`) and when it has one to answer.
pub(crate) fn connection(
    stream: &mut impl Wire,
    limits: Limits,
    handler: &dyn Fn(&Request) -> Response,
    waiting: &dyn Fn(bool),
) {
    // Bytes already read past the previous request (pipelining).
    let mut buf: Vec<u8> = Vec::new();
    loop {
        let deadline = Instant::now() + limits.read;
        waiting(true);
        let incoming = read_request(stream, &mut buf, &limits, deadline);
        waiting(false);
        match incoming {
            Incoming::Gone => return,
            Incoming::Fail(r) => {
                let _ = write_response(stream, &r, false, Instant::now() + limits.write);
                return;
            }
            Incoming::Request(req, keep) => {
                let r = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| handler(&req)))
                    .unwrap_or_else(|_| error(500, "internal error while handling the request"));
                let head_only = req.method == "HEAD";
                let r = compressed(&req, r);
                let r = if head_only {
                    Response {
                        body: Vec::new(),
                        ..r
                    }
                } else {
                    r
                };
                if write_response(stream, &r, keep, Instant::now() + limits.write).is_err() || !keep
                {
                    return;
                }
            }
        }
    }
}

/// Bodies smaller than this go as they are.
const COMPRESS_FROM: usize = 16 * 1024;

/// Whether the client takes this content coding (`Accept-Encoding`, a q of 0 refusing it).
fn accepts(req: &Request, coding: &str) -> bool {
    (req.header("accept-encoding").unwrap_or("").split(','))
        .filter_map(|item| {
            let mut parts = item.split(';').map(str::trim);
            let name = parts.next()?;
            let refused = parts.any(|p| p.replace(' ', "") == "q=0" || p == "q=0.0");
            (name.eq_ignore_ascii_case(coding) && !refused).then_some(())
        })
        .next()
        .is_some()
}

/// The answer compressed with zstd (at its fastest level: a million agents' frame in a few
/// milliseconds) when it is large and the client takes zstd, as browsers do.
fn compressed(req: &Request, mut r: Response) -> Response {
    if r.body.len() < COMPRESS_FROM || !accepts(req, "zstd") {
        return r;
    }
    if let Ok(z) = zstd::bulk::compress(&r.body, 1) {
        if z.len() < r.body.len() {
            r.body = z;
            r.headers.push(("Content-Encoding", "zstd".into()));
        }
    }
    r.headers.push(("Vary", "Accept-Encoding".into()));
    r
}

/// One read into `buf`, of what is waiting (at least one byte), never past `max` bytes in
/// all; false at the deadline, an error or the end of the stream.
fn read_some(stream: &mut impl Wire, buf: &mut Vec<u8>, max: usize, deadline: Instant) -> bool {
    let mut chunk = [0u8; 16 * 1024];
    loop {
        let left = deadline.saturating_duration_since(Instant::now());
        if left.is_zero() || stream.read_timeout(left).is_err() {
            return false;
        }
        let cap = chunk.len().min(max.saturating_sub(buf.len())).max(1);
        match stream.read(&mut chunk[..cap]) {
            Ok(0) => return false,
            Ok(n) => {
                buf.extend_from_slice(&chunk[..n]);
                return true;
            }
            Err(e) if e.kind() == ErrorKind::Interrupted => {}
            Err(_) => return false,
        }
    }
}

/// Reads into `buf` until it holds at least `want` bytes; false as [`read_some`].
fn fill(stream: &mut impl Wire, buf: &mut Vec<u8>, want: usize, deadline: Instant) -> bool {
    while buf.len() < want {
        if !read_some(stream, buf, want, deadline) {
            return false;
        }
    }
    true
}

/// Reads one request from `stream` (with what `buf` holds already; what follows it stays
/// in `buf`), within `limits` and by `deadline`.
fn read_request(
    stream: &mut impl Wire,
    buf: &mut Vec<u8>,
    limits: &Limits,
    deadline: Instant,
) -> Incoming {
    let head_end = match read_head(stream, buf, limits, deadline) {
        Ok(end) => end,
        Err(i) => return i,
    };
    let (method, target, version, headers) = match parse_head(&buf[..head_end], limits) {
        Ok(head) => head,
        Err(i) => return i,
    };
    let get = |name: &str| {
        headers
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, v)| v.as_str())
    };
    let connection = get("connection").unwrap_or("").to_ascii_lowercase();
    let keep = if version == 1 {
        !connection.contains("close")
    } else {
        connection.contains("keep-alive")
    };
    if get("transfer-encoding").is_some() {
        return Incoming::Fail(error(
            411,
            "send the request body with a Content-Length, not a Transfer-Encoding",
        ));
    }
    let length = match get("content-length").map(|v| v.trim().parse::<usize>()) {
        None => 0,
        Some(Ok(n)) => n,
        Some(Err(_)) => return Incoming::Fail(error(400, "the Content-Length is not a number")),
    };
    if length > limits.body {
        return Incoming::Fail(error(
            413,
            format!("the request body is larger than {} bytes", limits.body),
        ));
    }
    if length > 0
        && get("expect").is_some_and(|e| e.eq_ignore_ascii_case("100-continue"))
        && buf.len() == head_end
    {
        let _ = stream.write_timeout(limits.write);
        let _ = stream.write_all(b"HTTP/1.1 100 Continue\r\n\r\n");
    }
    let end = head_end + length;
    if !fill(stream, buf, end, deadline) {
        return Incoming::Fail(error(
            408,
            format!(
                "the request body ({length} bytes announced) did not arrive within {} s",
                limits.read.as_secs()
            ),
        ));
    }
    let body = buf[head_end..end].to_vec();
    buf.drain(..end);
    Incoming::Request(
        Request {
            method,
            target,
            headers,
            body,
        },
        keep,
    )
}

/// Reads into `buf` up to the blank line that ends the request's head, at most
/// `limits.head` bytes; where the head ends.
fn read_head(
    stream: &mut impl Wire,
    buf: &mut Vec<u8>,
    limits: &Limits,
    deadline: Instant,
) -> Result<usize, Incoming> {
    // The head: up to the blank line, at most `limits.head` bytes.
    let mut searched = 0;
    let head_end = loop {
        if let Some(i) = find_blank_line(buf, searched) {
            break i;
        }
        searched = buf.len().saturating_sub(3);
        if buf.len() > limits.head {
            return Err(Incoming::Fail(error(
                431,
                format!("the request's head is larger than {} bytes", limits.head),
            )));
        }
        if !read_some(stream, buf, limits.head + 1, deadline) {
            return Err(if buf.iter().all(|b| b.is_ascii_whitespace()) {
                Incoming::Gone
            } else if Instant::now() >= deadline {
                Incoming::Fail(error(
                    408,
                    format!(
                        "the request did not arrive within {} s",
                        limits.read.as_secs()
                    ),
                ))
            } else {
                Incoming::Gone
            });
        }
    };
    if head_end > limits.head {
        return Err(Incoming::Fail(error(
            431,
            format!("the request's head is larger than {} bytes", limits.head),
        )));
    }
    Ok(head_end)
}

/// The method, target, HTTP minor version and headers (names in lower case) of a head.
#[allow(clippy::type_complexity)]
fn parse_head(
    head: &[u8],
    limits: &Limits,
) -> Result<(String, String, u8, Vec<(String, String)>), Incoming> {
    let mut headers = vec![httparse::EMPTY_HEADER; limits.headers];
    let mut parsed = httparse::Request::new(&mut headers);
    match parsed.parse(head) {
        Ok(httparse::Status::Complete(_)) => {}
        Ok(httparse::Status::Partial) => {
            return Err(Incoming::Fail(error(
                400,
                "the request's head is cut short",
            )))
        }
        Err(httparse::Error::TooManyHeaders) => {
            return Err(Incoming::Fail(error(
                431,
                format!("the request has more than {} headers", limits.headers),
            )))
        }
        Err(e) => {
            return Err(Incoming::Fail(error(
                400,
                format!("malformed request: {e}"),
            )))
        }
    }
    let method = parsed.method.unwrap_or("").to_string();
    let target = parsed.path.unwrap_or("").to_string();
    let version = parsed.version.unwrap_or(0);
    let headers: Vec<(String, String)> = parsed
        .headers
        .iter()
        .map(|h| {
            (
                h.name.to_ascii_lowercase(),
                String::from_utf8_lossy(h.value).into_owned(),
            )
        })
        .collect();
    Ok((method, target, version, headers))
}

/// The end of the head (just past its blank line), searching from `from`. Line ends may be
/// CRLF or bare LF (as httparse reads them): the blank line is `\n` then `\r\n` or `\n`.
fn find_blank_line(buf: &[u8], from: usize) -> Option<usize> {
    let tail = buf.get(from..)?;
    (0..tail.len()).find_map(|i| {
        (tail[i] == b'\n')
            .then(|| match tail.get(i + 1..) {
                Some([b'\n', ..]) => Some(from + i + 2),
                Some([b'\r', b'\n', ..]) => Some(from + i + 3),
                _ => None,
            })
            .flatten()
    })
}

/// Writes an answer in pieces, each within what is left of `deadline`.
fn write_response(
    stream: &mut impl Wire,
    r: &Response,
    keep: bool,
    deadline: Instant,
) -> std::io::Result<()> {
    let mut head = format!(
        "HTTP/1.1 {} {}\r\nContent-Type: {}\r\nContent-Length: {}\r\nCache-Control: no-store\r\nX-Content-Type-Options: nosniff\r\nConnection: {}\r\n",
        r.status,
        reason(r.status),
        r.ctype,
        r.body.len(),
        if keep { "keep-alive" } else { "close" }
    );
    for (name, value) in &r.headers {
        head += &format!("{name}: {value}\r\n");
    }
    head += "\r\n";
    for piece in [head.as_bytes(), &r.body] {
        for chunk in piece.chunks(64 * 1024) {
            let left = deadline.saturating_duration_since(Instant::now());
            if left.is_zero() {
                return Err(ErrorKind::TimedOut.into());
            }
            stream.write_timeout(left)?;
            stream.write_all(chunk)?;
        }
    }
    stream.flush()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn blank_line_found_across_reads() {
        assert_eq!(find_blank_line(b"GET / HTTP/1.1\r\n\r\nx", 0), Some(18));
        assert_eq!(find_blank_line(b"GET / HTTP/1.1\r\n\r", 0), None);
        assert_eq!(find_blank_line(b"ab\r\n\r\n", 1), Some(6));
        assert_eq!(find_blank_line(b"ab", 5), None);
        // Bare LF line ends (a request that waited 30 s for a CRLF).
        assert_eq!(find_blank_line(b"GET / HTTP/1.1\n\nx", 0), Some(16));
        assert_eq!(find_blank_line(b"GET / HTTP/1.1\nHost: a\n\n", 0), Some(24));
        assert_eq!(find_blank_line(b"GET / HTTP/1.1\n", 0), None);
    }

    #[test]
    fn every_status_used_has_a_reason() {
        for s in [
            200, 303, 400, 403, 404, 405, 408, 409, 411, 413, 415, 421, 422, 431, 500, 503,
        ] {
            assert!(!reason(s).is_empty(), "{s}");
        }
    }

    #[test]
    fn zstd_only_for_clients_that_take_it_and_large_answers() {
        let req = |accept: &str| Request {
            method: "GET".into(),
            target: "/".into(),
            headers: vec![("accept-encoding".into(), accept.into())],
            body: Vec::new(),
        };
        for (accept, takes) in [
            ("gzip, deflate, br, zstd", true),
            ("zstd;q=0.5", true),
            ("ZSTD", true),
            ("gzip, zstd;q=0", false),
            ("zstd; q=0.0", false),
            ("gzip", false),
            ("", false),
            ("zstdx", false),
        ] {
            assert_eq!(accepts(&req(accept), "zstd"), takes, "{accept}");
        }
        let answer = |len: usize| Response {
            status: 200,
            ctype: "application/octet-stream",
            headers: Vec::new(),
            body: vec![7; len],
        };
        let big = compressed(&req("zstd"), answer(COMPRESS_FROM));
        assert!(big.headers.contains(&("Content-Encoding", "zstd".into())));
        assert_eq!(
            zstd::decode_all(&big.body[..]).unwrap(),
            vec![7; COMPRESS_FROM]
        );
        let small = compressed(&req("zstd"), answer(COMPRESS_FROM - 1));
        assert!(small.headers.is_empty() && small.body.len() == COMPRESS_FROM - 1);
        let refused = compressed(&req("gzip"), answer(COMPRESS_FROM));
        assert!(refused.headers.is_empty() && refused.body.len() == COMPRESS_FROM);
    }
}
