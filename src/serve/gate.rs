//! Who may use the server: a request must name this server in its `Host` (against DNS
//! rebinding), must not come from another site's page (`Origin`, `Sec-Fetch-Site`), and
//! must carry the session's token (query, header, or the cookie the printed URL sets).

use super::*;

/// Who may use the server: a request must name this server in its `Host` (a page that
/// reaches it through DNS rebinding names its own site), must not come from another
/// site's page (`Origin`, `Sec-Fetch-Site`), and must carry the token.
pub(super) struct Gate {
    pub(super) token: String,
    pub(super) port: u16,
    /// The host names this server answers to (lower case, IPv6 without brackets).
    pub(super) names: Vec<String>,
    /// Listening on every address: any IP address names this server.
    pub(super) any_ip: bool,
    /// The cookie that holds the token once the printed URL was opened.
    pub(super) cookie: String,
}

/// The host and port of an authority (`host[:port]`, `[v6]:port`), port 80 by default.
pub(super) fn authority(a: &str) -> Option<(String, u16)> {
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
pub(super) fn same_secret(a: &str, b: &str) -> bool {
    a.len() == b.len() && a.bytes().zip(b.bytes()).fold(0u8, |d, (x, y)| d | (x ^ y)) == 0
}

impl Gate {
    pub(super) fn new(token: String, bound: SocketAddr, host_arg: &str) -> Gate {
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

    pub(super) fn names_this_server(&self, a: &str) -> bool {
        authority(a).is_some_and(|(host, port)| {
            port == self.port
                && (self.names.contains(&host) || (self.any_ip && host.parse::<IpAddr>().is_ok()))
        })
    }

    pub(super) fn token_in<'r>(
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
    pub(super) fn admit(
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
pub(super) fn new_token() -> Result<String, String> {
    let mut b = [0u8; 24];
    getrandom::fill(&mut b).map_err(|e| format!("cannot make a random token: {e}"))?;
    Ok(b.iter().map(|x| format!("{x:02x}")).collect())
}
