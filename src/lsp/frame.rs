//! The language server's framing on standard input and output, in place of lsp-server's
//! own (which allocates whatever `Content-Length` says, and ends the session on a message
//! it cannot parse): every length is bounded before anything is allocated, a message too
//! long is skipped with an error reply, and a message that is not JSON-RPC gets an error
//! reply (id null, as JSON-RPC says when the id cannot be known) while the session goes on.
//! A lone UTF-16 surrogate escape (`\ud800`), which editors can send for a document cut
//! mid-character, is read as U+FFFD.

use lsp_server::{Connection, Message};
use std::io::{self, BufRead, Read, Write};
use std::sync::{Arc, Mutex};

/// The longest message body read (a document of 64 MiB is far past what an editor sends).
pub(super) const MAX_CONTENT: usize = 64 << 20;
/// The longest header line.
const MAX_HEADER: u64 = 8 << 10;

/// One frame read.
#[derive(Debug)]
pub(super) enum Frame {
    Message(Message),
    /// A frame whose message could not be taken: the error reply's code and message.
    Refused(i32, String),
}

/// Reads the next frame; `None` at the end of the input.
pub(super) fn read(r: &mut impl BufRead) -> io::Result<Option<Frame>> {
    let mut size: Option<usize> = None;
    let mut bad_length: Option<String> = None;
    let mut too_long: Option<u64> = None;
    loop {
        let mut line = Vec::new();
        let got = r.by_ref().take(MAX_HEADER).read_until(b'\n', &mut line)?;
        if got == 0 {
            return Ok(None);
        }
        if !line.ends_with(b"\n") {
            return Err(io::Error::new(
                io::ErrorKind::InvalidData,
                format!("a header line longer than {MAX_HEADER} bytes"),
            ));
        }
        // Bare LF line ends are taken as CRLF.
        let text = String::from_utf8_lossy(&line);
        let text = text.trim_end_matches(['\r', '\n']);
        if text.is_empty() {
            if size.is_none() && bad_length.is_none() {
                continue; // blank lines between frames
            }
            break;
        }
        let Some((name, value)) = text.split_once(':') else {
            continue;
        };
        if name.trim().eq_ignore_ascii_case("Content-Length") {
            match value.trim().parse::<u64>() {
                Ok(n) if n <= MAX_CONTENT as u64 => size = Some(n as usize),
                Ok(n) => {
                    too_long = Some(n);
                    bad_length = Some(format!(
                        "a message of {n} bytes is longer than the {MAX_CONTENT} read"
                    ));
                    size = None;
                }
                Err(_) => bad_length = Some(format!("Content-Length `{}`", value.trim())),
            }
        }
    }
    if let Some(why) = bad_length {
        // Its body skipped unread, a piece at a time (up to the end of the input).
        if let Some(n) = too_long {
            io::copy(&mut r.by_ref().take(n), &mut io::sink())?;
        }
        return Ok(Some(Frame::Refused(-32600, why)));
    }
    let size = size.expect("a header");
    let mut body = vec![0u8; size];
    r.read_exact(&mut body)?;
    let body = lone_surrogates_replaced(&body);
    Ok(Some(match serde_json::from_slice::<Message>(&body) {
        Ok(m) => Frame::Message(m),
        Err(e) => Frame::Refused(-32700, format!("not a JSON-RPC message: {e}")),
    }))
}

/// `body` with each `\uD800`-`\uDFFF` escape that is not half of a pair written `\uFFFD`.
fn lone_surrogates_replaced(body: &[u8]) -> std::borrow::Cow<'_, [u8]> {
    let hex = |at: usize| -> Option<u16> {
        let h = body.get(at..at + 4)?;
        u16::from_str_radix(std::str::from_utf8(h).ok()?, 16).ok()
    };
    let escape = |at: usize| -> Option<u16> {
        (body.get(at) == Some(&b'\\') && body.get(at + 1) == Some(&b'u'))
            .then(|| hex(at + 2))
            .flatten()
    };
    let mut out: Option<Vec<u8>> = None;
    let mut i = 0;
    while i < body.len() {
        if body[i] != b'\\' {
            // On to the next escape at once (a 20 MB document has a million `\n`).
            let next = memchr::memchr(b'\\', &body[i..]).map_or(body.len(), |k| i + k);
            if let Some(o) = &mut out {
                o.extend_from_slice(&body[i..next]);
            }
            i = next;
            continue;
        }
        // An escape: `\\` and the others are two bytes, `\uXXXX` six.
        let (len, lone) = match escape(i) {
            Some(0xD800..=0xDBFF) => match escape(i + 6) {
                Some(0xDC00..=0xDFFF) => (12, false),
                _ => (6, true),
            },
            Some(0xDC00..=0xDFFF) => (6, true),
            Some(_) => (6, false),
            None => (2, false),
        };
        let len = len.min(body.len() - i);
        if lone {
            out.get_or_insert_with(|| body[..i].to_vec())
                .extend_from_slice(b"\\uFFFD");
        } else if let Some(o) = &mut out {
            o.extend_from_slice(&body[i..i + len]);
        }
        i += len;
    }
    match out {
        Some(o) => o.into(),
        None => body.into(),
    }
}

/// Writes an error reply with a null id.
fn refuse(out: &Mutex<io::Stdout>, code: i32, message: &str) -> io::Result<()> {
    let body = serde_json::json!({
        "jsonrpc": "2.0",
        "id": null,
        "error": { "code": code, "message": message },
    })
    .to_string();
    let mut w = out.lock().unwrap_or_else(|p| p.into_inner());
    write!(w, "Content-Length: {}\r\n\r\n{body}", body.len())?;
    w.flush()
}

/// The method of a notification that carries a whole response already written as JSON
/// (its `params` is the text): the writer sends the text as it is. Large answers
/// (document symbols, semantic tokens) go so, written straight from their data rather
/// than through a `serde_json::Value` of their every element.
pub(super) const RAW: &str = "$/latticesim/raw";

/// The response to request `id` whose `result` is the JSON text `result`, to send as it is.
pub(super) fn raw(id: &lsp_server::RequestId, result: &str) -> Message {
    let id = serde_json::to_string(id).expect("an id is plain data");
    Message::Notification(lsp_server::Notification {
        method: RAW.to_string(),
        params: serde_json::Value::String(format!(
            "{{\"jsonrpc\":\"2.0\",\"id\":{id},\"result\":{result}}}"
        )),
    })
}

/// A thread of the connection: what ended it.
pub(super) type Io = std::thread::JoinHandle<io::Result<()>>;

/// A connection over standard input and output with this framing, and its reader and
/// writer threads.
pub(super) fn stdio() -> (Connection, Io, Io) {
    let (server, client) = Connection::memory();
    let out = Arc::new(Mutex::new(io::stdout()));
    let (to_server, from_server) = (client.sender, client.receiver);
    let reader_out = Arc::clone(&out);
    let reader = std::thread::spawn(move || -> io::Result<()> {
        let stdin = io::stdin();
        let mut r = stdin.lock();
        while let Some(frame) = read(&mut r)? {
            match frame {
                Frame::Message(m) => {
                    let exit = matches!(&m, Message::Notification(n) if n.method == "exit");
                    if to_server.send(m).is_err() || exit {
                        break;
                    }
                }
                Frame::Refused(code, why) => refuse(&reader_out, code, &why)?,
            }
        }
        Ok(())
    });
    let writer = std::thread::spawn(move || -> io::Result<()> {
        for m in from_server {
            let mut w = out.lock().unwrap_or_else(|p| p.into_inner());
            match &m {
                Message::Notification(n) if n.method == RAW => {
                    let body = n.params.as_str().unwrap_or("null");
                    write!(w, "Content-Length: {}\r\n\r\n{body}", body.len())?;
                    w.flush()?;
                }
                _ => m.write(&mut *w)?,
            }
        }
        Ok(())
    });
    (server, reader, writer)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frames(input: &[u8]) -> Vec<String> {
        let mut r = io::BufReader::new(input);
        let mut out = Vec::new();
        while let Some(f) = read(&mut r).unwrap() {
            out.push(match f {
                Frame::Message(m) => format!("{m:?}").chars().take(80).collect(),
                Frame::Refused(c, why) => format!("{c} {why}"),
            });
        }
        out
    }

    fn frame(body: &str) -> String {
        format!("Content-Length: {}\r\n\r\n{body}", body.len())
    }

    const PING: &str = r#"{"jsonrpc":"2.0","method":"ping","params":null}"#;

    /// A forged length is refused without allocating it; the next frame is read.
    #[test]
    fn lengths_are_bounded_and_bad_frames_refused() {
        // (What follows is its body, to the end of the input.)
        let huge = format!("Content-Length: 99999999999999\r\n\r\n{}", frame(PING));
        let got = frames(huge.as_bytes());
        assert_eq!(got.len(), 1, "{got:?}");
        assert!(
            got[0].starts_with("-32600 a message of 99999999999999 bytes"),
            "{got:?}"
        );
        // A body past the limit is skipped and the next frame read.
        let over = MAX_CONTENT + 1;
        let mut big = format!("Content-Length: {over}\r\n\r\n").into_bytes();
        big.resize(big.len() + over, b' ');
        big.extend_from_slice(frame(PING).as_bytes());
        let got = frames(&big);
        assert_eq!(got.len(), 2);
        assert!(got[1].contains("ping"), "{got:?}");
        let got = frames(format!("{}{}", frame("{not json"), frame(PING)).as_bytes());
        assert!(
            got[0].starts_with("-32700 not a JSON-RPC message"),
            "{got:?}"
        );
        assert!(got[1].contains("ping"), "{got:?}");
        let got = frames(format!("Content-Length: x\r\n\r\n{}", frame(PING)).as_bytes());
        assert!(got[0].starts_with("-32600 Content-Length `x`"), "{got:?}");
        // Bare LF line ends.
        let lf = format!("Content-Length: {}\n\n{PING}", PING.len());
        assert!(frames(lf.as_bytes())[0].contains("ping"));
        // A header line without end: an error, not a growing buffer.
        let endless = vec![b'a'; 1 << 20];
        assert!(read(&mut io::BufReader::new(&endless[..])).is_err());
    }

    #[test]
    fn lone_surrogates_are_replacement_characters() {
        let fixed =
            |s: &str| String::from_utf8(lone_surrogates_replaced(s.as_bytes()).to_vec()).unwrap();
        assert_eq!(fixed(r#""a\ud800b""#), r#""a\uFFFDb""#);
        assert_eq!(fixed(r#""\udc00""#), r#""\uFFFD""#);
        assert_eq!(fixed(r#""\ud83d\ude00""#), r#""\ud83d\ude00""#);
        assert_eq!(
            fixed(r#""\\ud800""#),
            r#""\\ud800""#,
            "an escaped backslash"
        );
        assert_eq!(fixed(r#""\ud800\u0041""#), r#""\uFFFD\u0041""#);
        assert_eq!(
            fixed(r#""x\ud800yz\n\ud800w\n""#),
            r#""x\uFFFDyz\n\uFFFDw\n""#,
            "the text between escapes kept"
        );
        let body = r#"{"jsonrpc":"2.0","method":"x","params":{"text":"\ud800"}}"#;
        assert!(frames(frame(body).as_bytes())[0].contains("Notification"));
    }
}
