//! The session: the files open in the editor, the run of them (a [`History`] that can go
//! back to any step), and the handlers of the API, which work on it one request at a time.

use super::*;
use latticesim_compiler::lints::Lints;
use latticesim_runtime::{Record, RecordKind};

/// The run shown: its history and the names of its rules.
pub(super) struct Run {
    pub(super) hist: History,
    /// The states' colours, handed out as they first appear in the run.
    pub(super) palette: Palette,
    /// The last binary frame sent, for deltas.
    pub(super) sent: Option<super::binary::Sent>,
    /// Why the last forward stepping stopped early, if it did.
    pub(super) note: Option<String>,
    /// How long the last request took to reach its step (a jump and the steps after).
    pub(super) took: Duration,
    /// The series of the steps reached, for the live charts.
    pub(super) series: super::plots::Series,
}

impl Run {
    /// One step forward: its states coloured and counted, and the series told of it when
    /// it is a step not reached before.
    pub(super) fn step(&mut self) {
        let new = self.hist.steps() == self.hist.reached();
        let before = new.then(|| self.hist.engine().stats.clone());
        self.hist.step();
        let counts = self.palette.observe_counting(&self.hist.engine().lat.state);
        if let (Some(before), Some(rep)) = (before, self.hist.last_report()) {
            let cost = latticesim_runtime::StepCost::of(&before, &self.hist.engine().stats, rep);
            self.series.push(&cost, counts);
        }
    }
}

/// Everything the server holds.
pub(super) struct Session {
    /// The working folder: files outside it are neither read nor written.
    pub(super) root: PathBuf,
    /// Files named on the command line, which may lie outside the working folder.
    pub(super) allowed: Vec<PathBuf>,
    pub(super) opts: Options,
    pub(super) keyframe_every: u64,
    /// The most bytes the steps kept backwards hold (`--history-mb`).
    pub(super) history_bytes: usize,
    pub(super) rules_path: String,
    pub(super) agents_path: String,
    pub(super) rules: String,
    pub(super) agents: String,
    pub(super) run: Option<Run>,
    /// The palette each run starts from (`--palette`, or the default).
    pub(super) palette: Palette,
    /// Lint levels (`--allow`, `--warn`, `--deny`; after the rules file's own).
    pub(super) lints: Lints,
    /// The tab's breakpoints.
    pub(super) breaks: super::breaks::Breaks,
    /// The configuration being edited by mouse, while the run is the one its last edit
    /// started and at its step 0.
    pub(super) edit: Option<super::edit::Edit>,
    /// Runs started so far (an edit belongs to the run it started).
    pub(super) runs: u64,
}

/// A request: method, path, query parameters and body.
pub(super) struct Req<'a> {
    pub(super) method: &'a str,
    pub(super) path: &'a str,
    pub(super) query: HashMap<&'a str, &'a str>,
    pub(super) body: &'a [u8],
}

impl Req<'_> {
    pub(super) fn json(&self) -> Result<Value, Reply> {
        let v: Value = serde_json::from_slice(self.body)
            .map_err(|e| error(400, format!("the request body is not valid JSON: {e}")))?;
        if !v.is_object() {
            return Err(error(400, "the request body must be a JSON object"));
        }
        Ok(v)
    }

    pub(super) fn number(&self, name: &str) -> Result<Option<u64>, Reply> {
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

pub(super) fn text_field<'v>(v: &'v Value, name: &str) -> Result<&'v str, Reply> {
    v.get(name).and_then(Value::as_str).ok_or_else(|| {
        error(
            400,
            format!("the request body needs a string field `{name}`"),
        )
    })
}

impl Session {
    /// The text of a file the editor sent (`name`), or, when it sent null (a file too
    /// large to edit in the page), the file at `path` as it is on disk.
    pub(super) fn text_or_file(&self, v: &Value, name: &str, path: &str) -> Result<String, Reply> {
        if !v.get(name).is_some_and(Value::is_null) {
            return text_field(v, name).map(str::to_string);
        }
        let (file, _) = self.file_of(path)?;
        read_utf8(&file, path)
    }

    /// The file `p` names (in the working folder, or named on the command line) and its
    /// size: 404 when it cannot be opened, 400 when it is not a file.
    fn file_of(&self, p: &str) -> Result<(PathBuf, u64), Reply> {
        let path = self.resolve(p, false)?;
        let meta =
            std::fs::metadata(&path).map_err(|e| error(404, format!("cannot open `{p}`: {e}")))?;
        if !meta.is_file() {
            return Err(error(400, format!("`{p}` is not a file")));
        }
        Ok((path, meta.len()))
    }
}

/// The text of the file at `path` (`p` as the page named it): 404 when it cannot be read,
/// 415 when it is not UTF-8.
fn read_utf8(path: &Path, p: &str) -> Result<String, Reply> {
    let mut bytes = Vec::new();
    crate::output::open_no_follow(path)
        .and_then(|mut f| f.read_to_end(&mut bytes))
        .map_err(|e| error(404, format!("cannot read `{p}`: {e}")))?;
    String::from_utf8(bytes).map_err(|_| error(415, format!("`{p}` is not UTF-8 text")))
}

/// Checks the editor's texts: the verdict, and the lattice when there are no errors.
pub(super) fn check_texts(
    rules_name: &str,
    rules: &str,
    (agents_name, agents): (&str, &str),
    levels: &Lints,
) -> (Checked, Option<Lattice>) {
    let l = crate::agents_file::load(
        (rules_name, rules.as_bytes()),
        agents_name,
        crate::agents_file::Source::Bytes(agents.as_bytes()),
        crate::run::io_threads(None),
        levels,
    )
    .expect("reading memory does not fail");
    (l.checked, l.lattice)
}

impl Session {
    /// A session of the same files (read again from disk where they can be, so that
    /// saved changes show), options and palette, not running yet.
    pub(super) fn fork(&self) -> Session {
        let fresh = |path: &str, kept: &str| -> String {
            (self.resolve(path, false).ok())
                .and_then(|p| std::fs::read_to_string(p).ok())
                .unwrap_or_else(|| kept.to_string())
        };
        Session {
            root: self.root.clone(),
            allowed: self.allowed.clone(),
            opts: self.opts,
            keyframe_every: self.keyframe_every,
            history_bytes: self.history_bytes,
            rules_path: self.rules_path.clone(),
            agents_path: self.agents_path.clone(),
            rules: fresh(&self.rules_path, &self.rules),
            agents: fresh(&self.agents_path, &self.agents),
            run: None,
            palette: self.palette.clone(),
            lints: self.lints.clone(),
            breaks: Default::default(),
            edit: None,
            runs: 0,
        }
    }

    pub(super) fn info(&self) -> Value {
        // A file too large to edit in the page goes as null and its size.
        fn editable(t: &str) -> Option<&str> {
            (t.len() as u64 <= MAX_FILE).then_some(t)
        }
        json!({
            "root": self.root.display().to_string(),
            "rules_path": self.rules_path,
            "agents_path": self.agents_path,
            "rules": editable(&self.rules),
            "agents": editable(&self.agents),
            "rules_bytes": self.rules.len(),
            "agents_bytes": self.agents.len(),
            "check": check_json(
                &check_texts(
                    &self.rules_path,
                    &self.rules,
                    (&self.agents_path, &self.agents),
                    &self.lints
                )
                .0,
                &self.rules_path,
            ),
            "running": self.run.is_some(),
        })
    }

    /// Checks the texts and, when they have no errors, starts a run of them from step 0
    /// (true); with errors the run stays as it was (false).
    pub(super) fn apply(&mut self) -> (Value, bool) {
        let (c, lat) = check_texts(
            &self.rules_path,
            &self.rules,
            (&self.agents_path, &self.agents),
            &self.lints,
        );
        let verdict = check_json(&c, &self.rules_path);
        if let (Some(p), Some(lat)) = (c.rules.as_ref(), lat) {
            if let Ok(prog) = compile(p) {
                let mut hist = History::new(prog, lat, self.opts, self.keyframe_every, 256);
                hist.set_delta_budget(self.history_bytes);
                let mut palette = self.palette.clone();
                let counts = palette.observe_counting(&hist.engine().lat.state);
                self.runs += 1;
                self.run = Some(Run {
                    series: super::plots::Series::new(hist.engine(), counts),
                    hist,
                    palette,
                    sent: None,
                    note: None,
                    took: Duration::ZERO,
                });
                return (verdict, true);
            }
        }
        (verdict, false)
    }

    /// A path from the browser, made absolute and checked to lie in the working folder
    /// (or to be a file named on the command line). `new` allows a file that does not
    /// exist yet (its folder must).
    pub(super) fn resolve(&self, p: &str, new: bool) -> Result<PathBuf, Reply> {
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

    pub(super) fn api_check(&mut self, req: &Req) -> Result<Reply, Reply> {
        let v = req.json()?;
        let rules_path = v["rules_path"].as_str().unwrap_or(&self.rules_path);
        let agents_path = v["agents_path"].as_str().unwrap_or(&self.agents_path);
        let rules = self.text_or_file(&v, "rules", rules_path)?;
        let agents = self.text_or_file(&v, "agents", agents_path)?;
        let (c, _) = check_texts(rules_path, &rules, (agents_path, &agents), &self.lints);
        Ok(reply_json(200, &check_json(&c, rules_path)))
    }

    pub(super) fn api_apply(&mut self, req: &Req) -> Result<Reply, Reply> {
        let v = req.json()?;
        let rules_path = v["rules_path"]
            .as_str()
            .unwrap_or(&self.rules_path)
            .to_string();
        let agents_path = v["agents_path"]
            .as_str()
            .unwrap_or(&self.agents_path)
            .to_string();
        self.rules = self.text_or_file(&v, "rules", &rules_path)?;
        self.agents = self.text_or_file(&v, "agents", &agents_path)?;
        (self.rules_path, self.agents_path) = (rules_path, agents_path);
        match self.apply() {
            (verdict, true) => {
                let run = self.run.as_ref().expect("just started");
                Ok(reply_json(
                    200,
                    &json!({ "applied": true, "check": verdict, "frame": frame(run) }),
                ))
            }
            // Files with errors are an answer, not a failure of the request (a 4xx status
            // would be logged as an error in the page's console).
            (verdict, false) => Ok(reply_json(
                200,
                &json!({
                    "applied": false,
                    "error": format!("the files have {} error(s); the run goes on as it was until they are fixed", verdict["errors"]),
                    "check": verdict,
                }),
            )),
        }
    }

    pub(super) fn run_mut(&mut self) -> Result<&mut Run, Reply> {
        self.run.as_mut().ok_or_else(|| {
            error(
                409,
                "nothing is running: the files have errors, or none were applied",
            )
        })
    }

    /// `GET /api/log?kind=K&agent=A&rule=R&limit=N`: the run's log (every record of the
    /// steps reached so far), those of kind `K` (its name, `move-conflict`) about agent `A`
    /// whose agents executed rule `R` (its name) in that step, the first `N` (500 unless
    /// said, at most 10,000), with how many match, and the kinds and rules to choose from.
    pub(super) fn api_log(&mut self, req: &Req) -> Result<Reply, Reply> {
        let kind = req.query.get("kind").copied().filter(|k| !k.is_empty());
        if let Some(k) = kind.filter(|k| !RecordKind::ALL.iter().any(|r| r.name() == *k)) {
            return Err(error(400, format!("`{k}` is not a kind of record")));
        }
        let agent = req.number("agent")?;
        let limit = req.number("limit")?.unwrap_or(500).min(10_000) as usize;
        let rule_name = req.query.get("rule").copied().filter(|r| !r.is_empty());
        let run = self.run_mut()?;
        let prog = &run.hist.engine().prog;
        let rule = match rule_name {
            None => None,
            Some(name) => Some(
                (prog.rules.iter().position(|r| r.name == name))
                    .ok_or_else(|| error(400, format!("there is no rule `{name}`")))?
                    as u32,
            ),
        };
        let (log, more, reached) = run.hist.log();
        let about = |r: &&Record| {
            kind.is_none_or(|k| r.kind.name() == k)
                && agent.is_none_or(|a| r.agents.iter().any(|&(id, _)| id as u64 == a))
                && rule.is_none_or(|x| r.rules.contains(&x))
        };
        let matching = log.iter().filter(about).count();
        let records: Vec<Value> = (log.iter().filter(about).take(limit))
            .map(|r| super::views::record_view(r, prog))
            .collect();
        Ok(reply_json(
            200,
            &json!({
                "reached": reached,
                "logged": log.len(),
                "more": more,
                "matching": matching,
                "records": records,
                "kinds": RecordKind::ALL.iter().map(|k| k.name()).collect::<Vec<_>>(),
                "rules": prog.rules.iter().map(|r| r.name.as_str()).collect::<Vec<_>>(),
            }),
        ))
    }

    /// `POST /api/breaks {kinds, states, counter, step}`: the tab's breakpoints, as read;
    /// one written wrongly is an answer (`set: false` and why, the breakpoints as they
    /// were), not a failed request, which the page's console would log as an error.
    pub(super) fn api_breaks(&mut self, req: &Req) -> Result<Reply, Reply> {
        let v = req.json()?;
        let kinds: Vec<&str> = RecordKind::ALL.iter().map(|k| k.name()).collect();
        let read = super::breaks::Breaks::from_json(&v);
        let error = read.as_ref().err().cloned();
        if let Ok(b) = read {
            self.breaks = b;
        }
        Ok(reply_json(
            200,
            &json!({ "set": error.is_none(), "error": error, "breaks": self.breaks.to_json(), "kinds": kinds }),
        ))
    }

    pub(super) fn api_frame(&mut self, req: &Req) -> Result<Reply, Reply> {
        let target = req.number("step")?;
        let breaks = self.breaks.clone();
        let run = self.run_mut()?;
        run.note = None;
        if let Some(t) = target {
            let started = Instant::now();
            // A step reached, or a jump of more than a step or two: through the history
            // (its deltas and keyframes, no breakpoints: those steps were run through
            // before); then on past the furthest step reached, one step at a time.
            let s = run.hist.steps();
            if t < s || t > s + 2 {
                run.hist.goto(t.min(run.hist.reached()));
            }
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
                let before = breaks.before(&run.hist.engine().lat);
                run.step();
                if let Some(why) = breaks.hit(&run.hist, &before) {
                    run.note = Some(format!("paused at a breakpoint: {why}"));
                    break;
                }
            }
            if run.hist.steps() != s {
                run.took = started.elapsed();
            }
        }
        match req.query.get("format") {
            Some(&"bin") => Ok(Reply {
                status: 200,
                ctype: "application/octet-stream",
                headers: Vec::new(),
                body: super::binary::frame_bin(run, req.number("since")?, counter_asked(req, run)?),
            }),
            Some(&"json") | None => Ok(reply_json(200, &frame(run))),
            Some(f) => Err(error(
                400,
                format!("`format` is `json` (the default) or `bin`, not `{f}`"),
            )),
        }
    }

    pub(super) fn api_agent(&mut self, req: &Req) -> Result<Reply, Reply> {
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
    pub(super) fn api_file(&mut self, req: &Req) -> Result<Reply, Reply> {
        let v = req.json()?;
        let p = text_field(&v, "path")?;
        match v.get("text") {
            None => {
                let (path, len) = self.file_of(p)?;
                if len > MAX_FILE {
                    // Too large to edit in the page: checked and applied from the file.
                    return Ok(reply_json(
                        200,
                        &json!({ "path": p, "text": null, "bytes": len }),
                    ));
                }
                let text = read_utf8(&path, p)?;
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
                save(&path, text.as_bytes()).map_err(|e| {
                    // A name the system refuses is the request's fault, not the server's.
                    let code = match e.kind() {
                        std::io::ErrorKind::InvalidFilename | std::io::ErrorKind::InvalidInput => {
                            400
                        }
                        _ => 500,
                    };
                    error(code, format!("cannot write `{p}`: {e}"))
                })?;
                Ok(reply_json(200, &json!({ "path": p, "bytes": text.len() })))
            }
        }
    }
}

pub(super) fn read_text(p: &Path) -> Result<String, ExitCode> {
    let bytes = crate::read(&p.to_path_buf())?;
    String::from_utf8(bytes).map_err(|_| {
        say!("error: `{}` is not UTF-8 text", p.display());
        ExitCode::from(2)
    })
}

/// Writes a file of the editor whole or not at all (a new file beside it, renamed over it),
/// keeping the permissions of the file it replaces.
pub(super) fn save(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    use std::io::Write;
    let mut f = crate::output::AtomicFile::create(path)?.durable();
    f.write_all(bytes)?;
    if let Ok(meta) = std::fs::metadata(path) {
        f.set_permissions(meta.permissions())?;
    }
    f.commit()
}

/// The counter a binary frame is asked to carry (`counter=Cnn`), checked against the run's
/// dimension.
pub(super) fn counter_asked(req: &Req, run: &Run) -> Result<Option<u8>, Reply> {
    let Some(name) = req.query.get("counter") else {
        return Ok(None);
    };
    let nc = run.hist.engine().lat.nc();
    match crate::gen::parse_counter(name) {
        Ok(c) if (c as usize) < nc => Ok(Some(c)),
        Ok(_) => Err(error(
            400,
            format!(
                "`counter`: {name} is not a counter of this run (C00..C{:02})",
                nc - 1
            ),
        )),
        Err(e) => Err(error(400, format!("`counter`: {e}"))),
    }
}
