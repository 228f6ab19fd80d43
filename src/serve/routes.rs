//! The one table of the server's routes: the pages of the app (embedded in the binary) and
//! the API, each with its method. A path in the table asked for with another method is
//! 405 (saying which it takes); any other path is 404.

use super::*;

/// The app's files: path, content type, content (the script is ES modules, `web/*.js`).
const ASSETS: [(&str, &str, &str); 21] = [
    ("/", HTML, include_str!("../../web/index.html")),
    ("/index.html", HTML, include_str!("../../web/index.html")),
    (
        "/app.css",
        "text/css; charset=utf-8",
        include_str!("../../web/app.css"),
    ),
    ("/app.js", JS, include_str!("../../web/app.js")),
    ("/api.js", JS, include_str!("../../web/api.js")),
    ("/state.js", JS, include_str!("../../web/state.js")),
    ("/player.js", JS, include_str!("../../web/player.js")),
    ("/panel.js", JS, include_str!("../../web/panel.js")),
    ("/camera.js", JS, include_str!("../../web/camera.js")),
    ("/draw.js", JS, include_str!("../../web/draw.js")),
    ("/draw2d.js", JS, include_str!("../../web/draw2d.js")),
    ("/draw3d.js", JS, include_str!("../../web/draw3d.js")),
    ("/gl3d.js", JS, include_str!("../../web/gl3d.js")),
    ("/input.js", JS, include_str!("../../web/input.js")),
    ("/editor.js", JS, include_str!("../../web/editor.js")),
    ("/log.js", JS, include_str!("../../web/log.js")),
    ("/breaks.js", JS, include_str!("../../web/breaks.js")),
    ("/timeline.js", JS, include_str!("../../web/timeline.js")),
    ("/edit.js", JS, include_str!("../../web/edit.js")),
    ("/plots.js", JS, include_str!("../../web/plots.js")),
    ("/minimap.js", JS, include_str!("../../web/minimap.js")),
];
const HTML: &str = "text/html; charset=utf-8";
const JS: &str = "text/javascript; charset=utf-8";

/// A handler of the API.
type Handler = fn(&mut Session, &Req) -> Result<Reply, Reply>;

/// The API: method, path, handler (documented in docs/viewer.md).
const API: [(&str, &str, Handler); 11] = [
    ("GET", "/api/session", |s, _| Ok(reply_json(200, &s.info()))),
    ("POST", "/api/check", Session::api_check),
    ("POST", "/api/apply", Session::api_apply),
    ("GET", "/api/frame", Session::api_frame),
    ("GET", "/api/agent", Session::api_agent),
    ("GET", "/api/log", Session::api_log),
    ("POST", "/api/breaks", Session::api_breaks),
    ("POST", "/api/edit", Session::api_edit),
    ("GET", "/api/series", Session::api_series),
    ("GET", "/api/export", Session::api_export),
    ("POST", "/api/file", Session::api_file),
];

/// `POST /api/tab`: a new tab's session (docs/viewer.md), its id as `{"tab": ID}`; the
/// answer, or `None` for any other request (405 for another method on this path).
pub(super) fn tab_route(tabs: &Tabs, req: &Req) -> Option<Reply> {
    if req.path != "/api/tab" {
        return None;
    }
    if req.method != "POST" {
        return Some(error(
            405,
            format!("{} is not allowed on /api/tab; it takes POST", req.method),
        ));
    }
    Some(match tabs.open() {
        Ok(id) => reply_json(200, &json!({ "tab": id })),
        Err(r) => r,
    })
}

/// The answer to a request that passed the gate.
pub(super) fn route(s: &mut Session, req: &Req) -> Reply {
    let asset = ASSETS.iter().find(|a| a.0 == req.path);
    let api = API.iter().find(|a| a.1 == req.path);
    let result = match (asset, api) {
        (Some(&(_, ctype, text)), _) if req.method == "GET" => Ok(Reply {
            status: 200,
            ctype,
            headers: Vec::new(),
            body: text.as_bytes().to_vec(),
        }),
        (_, Some(&(method, _, handler))) if req.method == method => handler(s, req),
        (Some(_), _) | (_, Some(_)) => {
            let takes = api.map_or("GET", |a| a.0);
            Err(error(
                405,
                format!(
                    "{} is not allowed on {}; it takes {takes}",
                    req.method, req.path
                ),
            ))
        }
        (None, None) => Err(error(404, format!("no such page or API: {}", req.path))),
    };
    result.unwrap_or_else(|r| r)
}
