//! What the viewer draws and shows, as JSON: the frame of a step, the inspector's view of
//! one agent, and the checker's verdict with each diagnostic's editor.

use super::*;

/// The checker's verdict: counts, dimension and every diagnostic with the editor it
/// belongs to (`rules` or `agents`).
pub(super) fn check_json(c: &Checked, rules_name: &str) -> Value {
    let diags: Vec<Value> = latticesim_compiler::diagnostics::to_json(&c.diags, &c.sources)
        .into_iter()
        .map(|d| {
            let editor = if d.file == rules_name {
                "rules"
            } else {
                "agents"
            };
            let mut v = serde_json::to_value(d).expect("plain data");
            v["editor"] = json!(editor);
            v
        })
        .collect();
    json!({
        "errors": c.errors(),
        "warnings": c.warnings(),
        "dimension": c.dim.dim.name(),
        "rules": c.rule_count,
        "agents": c.agent_count,
        "diagnostics": diags,
        "not_shown": crate::not_shown_json(c),
    })
}

/// A configuration as the viewer draws it.
#[derive(Serialize)]
pub(super) struct Frame {
    pub(super) step: u64,
    pub(super) dim: usize,
    pub(super) quiescent: bool,
    /// Positions, `dim` numbers per agent.
    pub(super) pos: Vec<i32>,
    /// Per agent: its index in `states`.
    pub(super) state: Vec<u32>,
    pub(super) states: Vec<StateInfo>,
    /// Attachment bits per agent (bit i = direction i of N, W, E, S, A, B), or none when
    /// no agent is attached.
    pub(super) attach: Option<Vec<u8>>,
    pub(super) universe: Option<Vec<[i32; 2]>>,
    pub(super) records: Vec<Value>,
    pub(super) stats: Value,
    pub(super) keyframes: [u64; 2],
    pub(super) history: Value,
    pub(super) note: Option<String>,
}

#[derive(Serialize)]
pub(super) struct StateInfo {
    pub(super) name: String,
    pub(super) colour: String,
    pub(super) count: u64,
}

pub(super) fn state_name(s: &[u8; 5]) -> String {
    String::from_utf8_lossy(s).into_owned()
}

/// Each agent's state as an index into the run's states, and those states (every state
/// the run has shown, in order of first appearance, so an index keeps its state for the
/// run) with their colours and how many agents are in each now.
pub(super) fn states_view(run: &Run) -> (Vec<u32>, Vec<StateInfo>) {
    let palette = &run.palette;
    let state = palette.indices(&run.hist.engine().lat.state);
    let mut counts = vec![0u64; palette.order().len()];
    for &i in &state {
        counts[i as usize] += 1;
    }
    let states = (palette.order().iter().zip(counts))
        .map(|(s, count)| StateInfo {
            name: state_name(s),
            colour: crate::palette::hex(palette.get(s)),
            count,
        })
        .collect();
    (state, states)
}

pub(super) fn frame(run: &Run) -> Frame {
    let e = run.hist.engine();
    let lat = &e.lat;
    let coords = lat.dim.coords();
    let (state, states) = states_view(run);
    let mut pos = Vec::with_capacity(lat.len() * coords);
    for p in &lat.pos {
        pos.extend_from_slice(&p[..coords]);
    }
    let attach = lat
        .attach
        .iter()
        .any(|&b| b != 0)
        .then(|| lat.attach.clone());
    let universe = lat
        .universe
        .map(|b| b[..coords].iter().map(|&(lo, hi)| [lo, hi]).collect());
    let records = records_view(run);
    let s = &e.stats;
    let stats = stats_view(e);
    let (k, every) = run.hist.keyframes();
    Frame {
        step: run.hist.steps(),
        dim: coords,
        quiescent: s.quiescent,
        pos,
        state,
        states,
        attach,
        universe,
        records,
        stats,
        keyframes: [k as u64, every],
        history: history_view(run),
        note: run.note.clone(),
    }
}

/// What the run's history holds and how the step shown was reached, for the timeline.
pub(super) fn history_view(run: &Run) -> Value {
    let h = &run.hist;
    let k = h.kept();
    let steps = |n: u64| {
        if n == 1 {
            "1 step".to_string()
        } else {
            format!("{n} steps")
        }
    };
    let how = match h.jump() {
        Jump::Stepped(0) => String::new(),
        Jump::Stepped(n) => format!("{} forward", steps(n)),
        Jump::Rewound { from, deltas: 0 } => format!("the keyframe of step {from}"),
        Jump::Rewound { from, deltas } => format!("{} back from step {from}", steps(deltas)),
        Jump::Replayed { from, steps: n } => format!("{} again from step {from}", steps(n)),
    };
    json!({
        "reached": h.reached(),
        "keyframes": k.keyframes,
        "every": k.every,
        "deltas_from": k.deltas_from,
        "bytes": { "keyframes": k.keyframe_bytes, "deltas": k.delta_bytes, "log": k.log_bytes },
        "how": how,
        "ms": run.took.as_secs_f64() * 1e3,
    })
}

/// The records of the step that led to the configuration shown, as the viewer lists them.
pub(super) fn records_view(run: &Run) -> Vec<Value> {
    (run.hist.last_report())
        .map(|rep| {
            let prog = &run.hist.engine().prog;
            rep.records.iter().map(|r| record_view(r, prog)).collect()
        })
        .unwrap_or_default()
}

/// One record as the viewer lists it (its step too, for the run's log).
pub(super) fn record_view(r: &latticesim_runtime::Record, prog: &latticesim_vm::Verified) -> Value {
    json!({
        "step": r.step,
        "kind": r.kind.name(),
        "severity": if r.is_error() { "error" } else { "warning" },
        "message": r.message,
        "agents": r.agents.iter().map(|(id, _)| id).collect::<Vec<_>>(),
        "rules": r.rules.iter().map(|&i| prog.rules[i as usize].name.as_str()).collect::<Vec<_>>(),
    })
}

/// The run's totals, as the viewer shows them.
pub(super) fn stats_view(e: &Engine) -> Value {
    let s = &e.stats;
    json!({
        "firings": s.firings.iter().sum::<u64>(),
        "moves": s.moves,
        "swaps": s.swaps,
        "sent": s.sent,
        "delivered": s.delivered,
        "dropped": s.dropped,
        "errors": s.errors(),
        "warnings": s.warnings(),
    })
}

/// What the inspector shows of agent `a`: its columns, its inbox, and the rules it executes
/// in the next step (found by running that step on a copy with tracing).
pub(super) fn inspect(run: &Run, a: u32) -> Value {
    let e = run.hist.engine();
    let lat = &e.lat;
    let i = a as usize;
    let dirs = lat.dim.dirs();
    let letters = ['N', 'W', 'E', 'S', 'A', 'B'];
    let attached: String = (0..dirs)
        .filter(|d| lat.attach[i] & (1 << d) != 0)
        .map(|d| letters[d])
        .collect();
    let counters: Vec<Value> = lat
        .counter_numbers()
        .into_iter()
        .map(|c| json!({ "name": format!("C{c:02}"), "value": lat.counter(a, c) }))
        .collect();
    let mut messages: Vec<Value> = Vec::new();
    for (d, letter) in letters.iter().enumerate().take(dirs) {
        for s in lat.slot_numbers() {
            let v = lat.inbox(a, d as u8, s);
            if v != 0 {
                messages.push(json!({ "name": format!("#{letter}{:02}", s + 1), "value": v }));
            }
        }
        if let Some(t) = lat.inbox_text(a, d as u8) {
            messages.push(json!({ "name": format!("#{letter}"), "value": state_name(&t) }));
        }
    }
    // The next step's selection alone, on a copy.
    let next = Engine::new(e.prog.clone(), lat.clone(), e.opts).next_rules(a);
    let fires = next.map(|(rules, priority)| json!({ "rules": rules, "priority": priority }));
    let p = lat.pos[i];
    json!({
        "id": a,
        "pos": &p[..lat.dim.coords()],
        "state": state_name(&lat.state[i]),
        "attached": attached,
        "counters": counters,
        "messages": messages,
        "next": fires,
        "next_step": run.hist.steps() + 1,
    })
}
