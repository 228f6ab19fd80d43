//! A session per browser tab: each page asks for a tab (`POST /api/tab`) and sends its id
//! with every request (the `X-Latticesim-Tab` header), so that each tab has its own files
//! and run, and two tabs never step or replace each other's run. Requests without a tab
//! id share the default session (scripts, `curl`, the server's tests).
//!
//! Tabs are bounded: at most [`MAX_TABS`], and runs of at most [`MEMORY`] bytes in all;
//! a tab idle for [`IDLE`] is closed, and when a new tab needs room the least recently
//! used ones are closed first. A request of a closed tab is answered 410 with a message
//! that says why, which the page shows at once.

use super::*;
use std::time::{Duration, Instant};

/// Tabs open at once, besides the default session.
pub(super) const MAX_TABS: usize = 16;
/// A tab unused this long is closed.
pub(super) const IDLE: Duration = Duration::from_secs(30 * 60);
/// The memory of all tabs' runs together (engines and keyframes), about.
pub(super) const MEMORY: usize = 8 << 30;

struct Tab {
    session: Arc<Mutex<Session>>,
    used: Instant,
}

/// The sessions: the default one, and one per tab.
pub(super) struct Tabs {
    default: Arc<Mutex<Session>>,
    open: Mutex<HashMap<String, Tab>>,
    /// Why tabs were closed, by id (kept for the next request of each, then dropped).
    closed: Mutex<HashMap<String, &'static str>>,
}

/// Bytes a session's run holds, about.
fn bytes(s: &Session) -> usize {
    s.run.as_ref().map_or(0, |r| r.hist.bytes())
}

impl Tabs {
    pub(super) fn new(default: Session) -> Tabs {
        Tabs {
            default: Arc::new(Mutex::new(default)),
            open: Mutex::new(HashMap::new()),
            closed: Mutex::new(HashMap::new()),
        }
    }

    /// The session of tab `id` (the default one for none).
    pub(super) fn get(&self, id: Option<&str>) -> Result<Arc<Mutex<Session>>, Reply> {
        let Some(id) = id else {
            return Ok(self.default.clone());
        };
        let mut open = self.open.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(t) = open.get_mut(id) {
            t.used = Instant::now();
            return Ok(t.session.clone());
        }
        let why = (self.closed.lock().unwrap_or_else(|e| e.into_inner()))
            .remove(id)
            .unwrap_or("the server does not know it (it was restarted, or the tab is too old)");
        Err(error(
            410,
            format!("this tab's run is gone: {why}; reload the page to start again"),
        ))
    }

    /// Opens a tab: a session of the files the default one was started with (read again,
    /// so that saved changes show), running from step 0; its id.
    pub(super) fn open(&self) -> Result<String, Reply> {
        let mut session = {
            let d = self.default.lock().unwrap_or_else(|e| e.into_inner());
            d.fork()
        };
        session.apply();
        let id = new_token().map_err(|e| error(500, e))?;
        let mut open = self.open.lock().unwrap_or_else(|e| e.into_inner());
        self.make_room(&mut open, bytes(&session));
        open.insert(
            id.clone(),
            Tab {
                session: Arc::new(Mutex::new(session)),
                used: Instant::now(),
            },
        );
        Ok(id)
    }

    /// Closes idle tabs, then the least recently used ones while there are too many or
    /// their runs and `more` bytes would hold too much memory.
    fn make_room(&self, open: &mut HashMap<String, Tab>, more: usize) {
        let mut closed = self.closed.lock().unwrap_or_else(|e| e.into_inner());
        let now = Instant::now();
        open.retain(|id, t| {
            let keep = now.duration_since(t.used) < IDLE;
            if !keep {
                closed.insert(id.clone(), "it was closed after 30 minutes without use");
            }
            keep
        });
        loop {
            // A tab busy with a request is not counted (nor closed): it is in use.
            let held: usize = (open.values())
                .filter_map(|t| t.session.try_lock().ok().map(|s| bytes(&s)))
                .sum();
            if open.len() < MAX_TABS && held + more <= MEMORY {
                break;
            }
            let Some(oldest) = (open.iter())
                .min_by_key(|(_, t)| t.used)
                .map(|(id, _)| id.clone())
            else {
                break;
            };
            open.remove(&oldest);
            closed.insert(
                oldest,
                "it was closed to make room for a newer tab (at most 16 tabs, 8 GB of runs)",
            );
        }
        // Reasons are kept for a while, not for ever.
        if closed.len() > 4 * MAX_TABS {
            closed.clear();
        }
    }
}
