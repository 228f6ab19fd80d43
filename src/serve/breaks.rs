//! Breakpoints of a tab (`POST /api/breaks`): a run stepping forwards pauses at the step
//! where a record of a chosen kind occurs, an agent enters a chosen state, a counter
//! condition (the paper's comparison of a counter with a number, `>C00 0005`) comes to hold
//! for some agent, or a chosen step is reached. (A run always pauses at quiescence.)

use latticesim_runtime::{History, Lattice, RecordKind};
use serde_json::{json, Value};

/// A tab's breakpoints.
#[derive(Debug, Clone, Default, PartialEq)]
pub(super) struct Breaks {
    kinds: Vec<RecordKind>,
    states: Vec<[u8; 5]>,
    /// `<`, `>` or `=`, the counter, the number; and the text as written.
    counter: Option<(char, u8, i32, String)>,
    step: Option<u64>,
}

impl Breaks {
    /// Read from the request's JSON (`{kinds, states, counter, step}`, each may be left
    /// out), or why not.
    pub(super) fn from_json(v: &Value) -> Result<Breaks, String> {
        let strings = |name: &str| -> Result<Vec<String>, String> {
            match v.get(name) {
                None | Some(Value::Null) => Ok(Vec::new()),
                Some(Value::Array(a)) => (a.iter())
                    .map(|x| {
                        x.as_str()
                            .map(str::to_string)
                            .ok_or(format!("`{name}` holds strings"))
                    })
                    .collect(),
                Some(_) => Err(format!("`{name}` is a list of strings")),
            }
        };
        let kinds = (strings("kinds")?.iter())
            .map(|k| {
                (RecordKind::ALL.iter().copied())
                    .find(|r| r.name() == k)
                    .ok_or(format!("`{k}` is not a kind of record"))
            })
            .collect::<Result<_, _>>()?;
        let states = (strings("states")?.iter())
            .map(|s| {
                let b: [u8; 5] = s
                    .as_bytes()
                    .try_into()
                    .map_err(|_| format!("`{s}` is not a state: a state is five characters"))?;
                Ok(b)
            })
            .collect::<Result<_, String>>()?;
        let counter = match v.get("counter").and_then(Value::as_str).map(str::trim) {
            None | Some("") => None,
            Some(c) => Some(comparison(c)?),
        };
        let step = match v.get("step") {
            None | Some(Value::Null) => None,
            Some(s) => Some(s.as_u64().ok_or("`step` is a step number")?),
        };
        Ok(Breaks {
            kinds,
            states,
            counter,
            step,
        })
    }

    /// As the page shows them.
    pub(super) fn to_json(&self) -> Value {
        json!({
            "kinds": self.kinds.iter().map(|k| k.name()).collect::<Vec<_>>(),
            "states": self.states.iter().map(|s| String::from_utf8_lossy(s)).collect::<Vec<_>>(),
            "counter": self.counter.as_ref().map(|c| c.3.clone()),
            "step": self.step,
        })
    }

    /// What a step must keep from before it for [`Breaks::hit`]: the states (when states
    /// are watched) and whether the counter condition held.
    pub(super) fn before(&self, lat: &Lattice) -> Before {
        Before {
            states: (!self.states.is_empty()).then(|| lat.state.clone()),
            held: self.holds(lat),
        }
    }

    /// Why the step just made (`before` it: [`Breaks::before`]) pauses the run, if it
    /// does.
    pub(super) fn hit(&self, hist: &History, before: &Before) -> Option<String> {
        let (e, s) = (hist.engine(), hist.steps());
        if self.step == Some(s) {
            return Some(format!("step {s}"));
        }
        if let Some(rep) = hist.last_report() {
            if let Some(r) = rep.records.iter().find(|r| self.kinds.contains(&r.kind)) {
                let a = r
                    .agents
                    .first()
                    .map_or(String::new(), |a| format!(" (agent {})", a.0));
                return Some(format!("a {} record{a}", r.kind.name()));
            }
        }
        if let Some(old) = &before.states {
            let now = &e.lat.state;
            let entered = (0..now.len().min(old.len()))
                .find(|&a| now[a] != old[a] && self.states.contains(&now[a]));
            if let Some(a) = entered {
                return Some(format!(
                    "agent {a} entered `{}`",
                    String::from_utf8_lossy(&now[a])
                ));
            }
        }
        if !before.held && self.holds(&e.lat) {
            let c = self.counter.as_ref().map_or("", |c| c.3.as_str());
            return Some(format!("`{c}` holds"));
        }
        None
    }

    /// Whether some agent's counter satisfies the counter condition.
    fn holds(&self, lat: &Lattice) -> bool {
        let Some((op, c, v, _)) = &self.counter else {
            return false;
        };
        (0..lat.len() as u32).any(|a| {
            let x = lat.counter(a, *c);
            match op {
                '<' => x < *v,
                '>' => x > *v,
                _ => x == *v,
            }
        })
    }
}

/// What [`Breaks::hit`] compares a step's result with.
pub(super) struct Before {
    states: Option<Vec<[u8; 5]>>,
    held: bool,
}

/// `>C00 0005`: the sign, the counter and the number.
fn comparison(text: &str) -> Result<(char, u8, i32, String), String> {
    let bad = || {
        format!(
            "`{text}` is not a counter condition: write a sign (<, > or =), a counter and a \
             number, e.g. `>C00 0005`"
        )
    };
    let mut chars = text.chars();
    let op = chars
        .next()
        .filter(|c| "<>=".contains(*c))
        .ok_or_else(bad)?;
    let rest = chars.as_str();
    let (counter, number) = rest.split_once(char::is_whitespace).ok_or_else(bad)?;
    let c = (counter.strip_prefix('C'))
        .filter(|d| d.len() == 2)
        .and_then(|d| d.parse::<u8>().ok())
        .filter(|&c| c < 32)
        .ok_or_else(bad)?;
    let v: i32 = number.trim().parse().map_err(|_| bad())?;
    Ok((op, c, v, text.to_string()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn breakpoints_are_read_and_refused_as_written() {
        let b = Breaks::from_json(&json!({
            "kinds": ["state-conflict"], "states": ["STOP0"], "counter": "<C03 -2", "step": 7
        }))
        .unwrap();
        assert_eq!(
            b.counter.as_ref().map(|c| (c.0, c.1, c.2)),
            Some(('<', 3, -2))
        );
        assert_eq!(b.to_json()["states"], json!(["STOP0"]));
        for bad in [
            json!({ "kinds": ["nope"] }),
            json!({ "states": ["LONGSTATE"] }),
            json!({ "counter": "C00 > 5" }),
            json!({ "counter": ">C00" }),
            json!({ "step": -1 }),
        ] {
            assert!(Breaks::from_json(&bad).is_err(), "{bad}");
        }
        assert_eq!(Breaks::from_json(&json!({})).unwrap(), Breaks::default());
    }
}
