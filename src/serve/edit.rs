//! Editing the configuration by mouse (`POST /api/edit`): placing and removing agents,
//! setting a state and counters, making and breaking bonds, with undo and redo. The first
//! edit takes the configuration shown (the run's current step); each edit makes the
//! agents text again (canonical, as `latticesim fmt` writes it), checks it with the rules,
//! and starts the run from it at step 0, so the page shows what it edits and the checker's
//! diagnostics as it goes. An edit the checker refuses (or that cannot be: a cell taken, a
//! bond with no neighbour) changes nothing and says why. Messages in flight are not part of
//! an agents file: the edited run starts without them.

use super::*;
use latticesim_runtime::LatticeBuilder;
use latticesim_vm::model::{Bounds, Dim, Dir};

/// One agent as edited.
#[derive(Debug, Clone, PartialEq)]
struct Agent {
    pos: [i32; 3],
    state: [u8; 5],
    attach: u8,
    counters: Vec<(u8, i32)>,
}

/// A change of the agents: a primitive of an edit, and of its undoing.
#[derive(Debug, Clone)]
enum Change {
    Insert(usize, Agent),
    Remove(usize),
    Replace(usize, Agent),
}

/// The configuration being edited, and the edits to undo and redo (each a list of changes
/// that undoes, or does again, one edit).
pub(super) struct Edit {
    /// The run its last edit started (`Session::runs`).
    run: u64,
    dim: Dim,
    universe: Option<Bounds>,
    agents: Vec<Agent>,
    cells: HashMap<[i32; 3], usize>,
    undo: Vec<Vec<Change>>,
    redo: Vec<Vec<Change>>,
}

/// The most edits kept to undo.
const UNDO_MAX: usize = 200;

impl Edit {
    /// The configuration of `lat`, to edit.
    pub(super) fn of(lat: &Lattice, run: u64) -> Edit {
        let counters = lat.counter_numbers();
        let agents: Vec<Agent> = (0..lat.len())
            .map(|a| Agent {
                pos: lat.pos[a],
                state: lat.state[a],
                attach: lat.attach[a],
                counters: (counters.iter())
                    .map(|&c| (c, lat.counter(a as u32, c)))
                    .filter(|&(_, v)| v != 0)
                    .collect(),
            })
            .collect();
        let cells = cells_of(&agents);
        Edit {
            run,
            dim: lat.dim,
            universe: lat.universe,
            agents,
            cells,
            undo: Vec::new(),
            redo: Vec::new(),
        }
    }

    /// The configuration as a lattice.
    fn lattice(&self) -> Lattice {
        let mut b = LatticeBuilder::new(self.dim, self.universe, self.agents.len());
        for a in &self.agents {
            b.push(a.pos, a.state, a.attach, &a.counters);
        }
        b.finish()
    }

    /// Does `changes`, and returns the changes that undo them.
    fn apply(&mut self, changes: Vec<Change>) -> Vec<Change> {
        let mut back = Vec::with_capacity(changes.len());
        for c in changes {
            back.push(match c {
                Change::Insert(i, a) => {
                    self.agents.insert(i, a);
                    Change::Remove(i)
                }
                Change::Remove(i) => Change::Insert(i, self.agents.remove(i)),
                Change::Replace(i, a) => {
                    Change::Replace(i, std::mem::replace(&mut self.agents[i], a))
                }
            });
        }
        back.reverse();
        self.cells = cells_of(&self.agents);
        back
    }

    /// The changes an edit asks for, or why it cannot be.
    fn changes(&self, v: &Value) -> Result<Vec<Change>, String> {
        let op = v["op"].as_str().unwrap_or("");
        let id = || -> Result<usize, String> {
            let id = v["id"].as_u64().ok_or("`id` is missing")? as usize;
            if id >= self.agents.len() {
                return Err(format!("there is no agent {id}"));
            }
            Ok(id)
        };
        match op {
            "place" => {
                let pos = self.position(&v["pos"])?;
                if let Some(&other) = self.cells.get(&pos) {
                    return Err(format!("agent {other} stands on {}", self.cell_text(pos)));
                }
                let state = state(v["state"].as_str().unwrap_or("00000"))?;
                let agent = Agent {
                    pos,
                    state,
                    attach: 0,
                    counters: Vec::new(),
                };
                Ok(vec![Change::Insert(self.agents.len(), agent)])
            }
            "remove" => {
                let i = id()?;
                // Its bonds go with it; ids after it move down one.
                let mut changes = self.unbond_all(i);
                changes.push(Change::Remove(i));
                Ok(changes)
            }
            "set" => {
                let i = id()?;
                let mut a = self.agents[i].clone();
                if let Some(s) = v["state"].as_str() {
                    a.state = state(s)?;
                }
                if let Some(cs) = v["counters"].as_str() {
                    a.counters = counters(cs)?;
                }
                Ok(vec![Change::Replace(i, a)])
            }
            "bond" => {
                let i = id()?;
                let d = v["dir"].as_str().unwrap_or("");
                let dir = (Dir::ALL[..self.dim.dirs()].iter())
                    .find(|x| x.letter().to_string() == d)
                    .copied()
                    .ok_or_else(|| format!("`{d}` is not a direction of this dimension"))?;
                let on = v["on"].as_bool().unwrap_or(true);
                let o = dir.offset();
                let p = self.agents[i].pos;
                let there = [p[0] + o[0], p[1] + o[1], p[2] + o[2]];
                let &j = self.cells.get(&there).ok_or_else(|| {
                    format!(
                        "no agent stands {} of agent {i} (on {}) to bond with",
                        dir.letter(),
                        self.cell_text(there)
                    )
                })?;
                let (mut a, mut b) = (self.agents[i].clone(), self.agents[j].clone());
                let (bit, back) = (1u8 << dir.index(), 1u8 << dir.opposite().index());
                if on {
                    (a.attach, b.attach) = (a.attach | bit, b.attach | back);
                } else {
                    (a.attach, b.attach) = (a.attach & !bit, b.attach & !back);
                }
                Ok(vec![Change::Replace(i, a), Change::Replace(j, b)])
            }
            "" => Err("`op` is missing".into()),
            op => Err(format!(
                "`{op}` is not an edit: place, remove, set, bond, undo, redo, save or stop"
            )),
        }
    }

    /// The changes that break every bond of agent `i` (on its neighbours' side too).
    fn unbond_all(&self, i: usize) -> Vec<Change> {
        let a = &self.agents[i];
        let mut changes = Vec::new();
        for d in &Dir::ALL[..self.dim.dirs()] {
            if a.attach & (1 << d.index()) == 0 {
                continue;
            }
            let o = d.offset();
            let there = [a.pos[0] + o[0], a.pos[1] + o[1], a.pos[2] + o[2]];
            if let Some(&j) = self.cells.get(&there) {
                let mut b = self.agents[j].clone();
                b.attach &= !(1 << d.opposite().index());
                changes.push(Change::Replace(j, b));
            }
        }
        let mut me = a.clone();
        me.attach = 0;
        changes.push(Change::Replace(i, me));
        changes
    }

    fn position(&self, p: &Value) -> Result<[i32; 3], String> {
        let coords: Vec<i64> = (p
            .as_array()
            .ok_or("`pos` is missing: [x, y] or [x, y, z]")?)
        .iter()
        .map(|c| c.as_i64().ok_or("a coordinate is not a whole number"))
        .collect::<Result<_, _>>()?;
        let n = if self.dim == Dim::Three { 3 } else { 2 };
        if coords.len() != n {
            return Err(format!("the run is {n}D: a position has {n} coordinates"));
        }
        let mut pos = [0i32; 3];
        for (k, &c) in coords.iter().enumerate() {
            pos[k] = i32::try_from(c).map_err(|_| format!("{c} is out of range"))?;
        }
        if let Some(u) = self.universe {
            if (0..n).any(|k| pos[k] < u[k].0 || pos[k] > u[k].1) {
                return Err(format!("{} is outside the universe", self.cell_text(pos)));
            }
        }
        Ok(pos)
    }

    fn cell_text(&self, p: [i32; 3]) -> String {
        match self.dim {
            Dim::Three => format!("{},{},{}", p[0], p[1], p[2]),
            Dim::Two => format!("{},{}", p[0], p[1]),
        }
    }
}

/// Which agent stands on each cell.
fn cells_of(agents: &[Agent]) -> HashMap<[i32; 3], usize> {
    agents.iter().enumerate().map(|(i, a)| (a.pos, i)).collect()
}

/// A state as typed: five characters.
fn state(s: &str) -> Result<[u8; 5], String> {
    let s = s.trim();
    let s = s.strip_prefix('S').filter(|r| r.len() == 5).unwrap_or(s);
    <[u8; 5]>::try_from(s.as_bytes())
        .ok()
        .filter(|b| b.iter().all(|c| c.is_ascii_graphic()))
        .ok_or_else(|| format!("`{s}` is not a state: five letters or digits, as `STOP0`"))
}

/// Counters as typed: `C00 5 C03 -2` (those not named are 0).
fn counters(s: &str) -> Result<Vec<(u8, i32)>, String> {
    let words: Vec<&str> = s.split_whitespace().collect();
    if !words.len().is_multiple_of(2) {
        return Err(format!("`{s}`: counters go in pairs, as `C00 5 C01 -2`"));
    }
    let mut out: Vec<(u8, i32)> = Vec::new();
    for pair in words.chunks(2) {
        let c = crate::gen::parse_counter(pair[0])?;
        let v: i32 = (pair[1].parse())
            .map_err(|_| format!("`{}` is not a value of {}", pair[1], pair[0]))?;
        out.retain(|&(k, _)| k != c);
        if v != 0 {
            out.push((c, v));
        }
    }
    out.sort();
    Ok(out)
}

impl Session {
    /// `POST /api/edit {op, ...}`: an edit of the configuration shown (see the module).
    /// `place {pos, state}`, `remove {id}`, `set {id, state?, counters?}`, `bond {id, dir,
    /// on}`, `undo`, `redo`, `save {path}` (the edited agents text, through the safe
    /// save), `stop` (forget the edits' undo). Answers `{applied, error, check, agents,
    /// agents_bytes, undo, redo, frame}`; an edit that cannot be is `applied: false` and
    /// why, not a failed request.
    pub(super) fn api_edit(&mut self, req: &Req) -> Result<Reply, Reply> {
        let v = req.json()?;
        let op = v["op"].as_str().unwrap_or("").to_string();
        if op == "stop" {
            self.edit = None;
            return Ok(reply_json(200, &json!({ "applied": true })));
        }
        if op == "save" {
            let p = v["path"].as_str().unwrap_or(&self.agents_path).to_string();
            let path = self.resolve(&p, true)?;
            save(&path, self.agents.as_bytes())
                .map_err(|e| error(500, format!("cannot write `{p}`: {e}")))?;
            self.agents_path = p.clone();
            return Ok(reply_json(
                200,
                &json!({ "applied": true, "saved": p, "bytes": self.agents.len() }),
            ));
        }
        // The configuration shown: the edits' own while their run is at its step 0, else
        // the step shown, edited afresh.
        let runs = self.runs;
        let at_start = self.run_mut()?.hist.steps() == 0;
        if !self
            .edit
            .as_ref()
            .is_some_and(|e| e.run == runs && at_start)
        {
            let lat = &self.run_mut()?.hist.engine().lat;
            self.edit = Some(Edit::of(lat, runs));
        }
        let edit = self.edit.as_mut().expect("made above");
        let changes = match op.as_str() {
            "undo" | "redo" => {
                let stack = if op == "undo" {
                    &mut edit.undo
                } else {
                    &mut edit.redo
                };
                match stack.pop() {
                    Some(c) => Ok(c),
                    None => Err(format!("nothing to {op}")),
                }
            }
            _ => edit.changes(&v),
        };
        let changes = match changes {
            Ok(c) => c,
            Err(why) => return Ok(self.edit_answer(Some(why), None)),
        };
        let back = edit.apply(changes);
        let text = edit.lattice().to_agents_text();
        let before = std::mem::replace(&mut self.agents, text);
        let (verdict, started) = self.apply();
        let edit = self.edit.as_mut().expect("kept");
        if !started {
            // The checker refuses it: undone, and the run stays as it was.
            edit.apply(back);
            self.agents = before;
            let first = (verdict["diagnostics"].as_array())
                .and_then(|ds| ds.iter().find(|d| d["severity"] == "error"))
                .map_or("the checker refuses it".to_string(), |d| {
                    d["message"].as_str().unwrap_or("").to_string()
                });
            return Ok(self.edit_answer(Some(first), Some(verdict)));
        }
        edit.run = self.runs;
        match op.as_str() {
            "undo" => edit.redo.push(back),
            "redo" => edit.undo.push(back),
            _ => {
                edit.undo.push(back);
                edit.redo.clear();
            }
        }
        if edit.undo.len() > UNDO_MAX {
            edit.undo.remove(0);
        }
        Ok(self.edit_answer(None, Some(verdict)))
    }

    fn edit_answer(&self, error: Option<String>, check: Option<Value>) -> Reply {
        let (undo, redo) = self
            .edit
            .as_ref()
            .map_or((0, 0), |e| (e.undo.len(), e.redo.len()));
        let agents = (self.agents.len() as u64 <= MAX_FILE).then_some(&self.agents);
        reply_json(
            200,
            &json!({
                "applied": error.is_none(),
                "error": error,
                "check": check,
                "agents": agents,
                "agents_bytes": self.agents.len(),
                "agents_path": self.agents_path,
                "undo": undo,
                "redo": redo,
                "frame": self.run.as_ref().map(frame),
            }),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn states_and_counters_as_typed() {
        assert_eq!(state("STOP0").unwrap(), *b"STOP0");
        assert_eq!(state("SSTOP0").unwrap(), *b"STOP0");
        assert!(state("STOP").is_err());
        assert_eq!(
            counters("C03 -2 C00 5 C01 0").unwrap(),
            vec![(0, 5), (3, -2)]
        );
        assert!(counters("C00").is_err());
        assert!(counters("C45 1").is_err());
        assert!(counters("C00 x").is_err());
    }
}
