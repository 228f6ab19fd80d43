//! Binary frames (`GET /api/frame?format=bin`): what the viewer draws of a step in a few
//! bytes per agent, whole or as the agents changed since the frame the tab holds, so that
//! a million agents step at interactive rates (docs/viewer.md gives the layout).
//!
//! Layout, little-endian: `LSF1`, the length of a JSON head (u32), the head (the frame's
//! step, dim, quiescent, states, universe, records, stats, keyframes, note, and `n`,
//! `delta`, `base`, `changed`, `attach`, `state_bytes`), zero bytes to a multiple of 4,
//! then either every agent's columns or, for a delta, the changed agents' ids (u32) first:
//! positions (i32, `dim` per agent), state indices (u16, or u32 with `state_bytes` 4: an
//! index into `states`, which lists every state the run has shown, in order of first
//! appearance, so an index keeps its state for the run), zero bytes to a multiple of 4,
//! and attachment bits (u8, when `attach`); with `counter` (asked for with `counter=Cnn`),
//! zero bytes to a multiple of 2 and that counter of every agent (i16), delta or not.

use super::*;

/// The columns of the last binary frame sent to a tab, to send the next as a delta.
pub(super) struct Sent {
    step: u64,
    pos: Vec<[i32; 3]>,
    state: Vec<u32>,
    attach: Vec<u8>,
}

fn pad(out: &mut Vec<u8>) {
    while !out.len().is_multiple_of(4) {
        out.push(0);
    }
}

/// The binary frame of the run's current step; a delta when the tab holds the frame of
/// step `since` (the last one sent) and that is smaller.
pub(super) fn frame_bin(run: &mut Run, since: Option<u64>, counter: Option<u8>) -> Vec<u8> {
    let e = run.hist.engine();
    let lat = &e.lat;
    let (n, dim) = (lat.len(), lat.dim.coords());
    let (state, states) = states_view(run);
    let attach = lat.attach.iter().any(|&b| b != 0);
    let wide = states.len() > u16::MAX as usize;
    // The agents changed since the frame the tab holds, if it holds the last one sent.
    let base = run
        .sent
        .as_ref()
        .filter(|s| Some(s.step) == since && s.pos.len() == n);
    let changed: Option<Vec<u32>> = base.map(|b| {
        (0..n)
            .filter(|&i| {
                b.pos[i] != lat.pos[i] || b.state[i] != state[i] || b.attach[i] != lat.attach[i]
            })
            .map(|i| i as u32)
            .collect()
    });
    // A delta costs an id more per changed agent: sent only when smaller.
    let per = 4 * dim + if wide { 4 } else { 2 } + attach as usize;
    let changed = changed.filter(|c| c.len() * (per + 4) < n * per);
    let (k, every) = run.hist.keyframes();
    let s = &e.stats;
    let head = json!({
        "step": run.hist.steps(),
        "dim": dim,
        "quiescent": s.quiescent,
        "n": n,
        "states": states,
        "universe": lat.universe.map(|b| b[..dim].iter().map(|&(lo, hi)| [lo, hi]).collect::<Vec<_>>()),
        "records": records_view(run),
        "stats": stats_view(e),
        "keyframes": [k as u64, every],
        "note": run.note,
        "attach": attach,
        "state_bytes": if wide { 4 } else { 2 },
        "delta": changed.is_some(),
        "base": changed.as_ref().and(since),
        "changed": changed.as_ref().map(Vec::len),
        "counters": lat.counter_numbers().iter().map(|c| format!("C{c:02}")).collect::<Vec<_>>(),
        "counter": counter.map(|c| format!("C{c:02}")),
    });
    let head = head.to_string();
    let ids: Vec<usize> = match &changed {
        Some(c) => c.iter().map(|&i| i as usize).collect(),
        None => (0..n).collect(),
    };
    let mut out = Vec::with_capacity(8 + head.len() + ids.len() * (per + 4) + 8);
    out.extend_from_slice(b"LSF1");
    out.extend_from_slice(&(head.len() as u32).to_le_bytes());
    out.extend_from_slice(head.as_bytes());
    pad(&mut out);
    if let Some(c) = &changed {
        for &i in c {
            out.extend_from_slice(&i.to_le_bytes());
        }
    }
    let at = out.len();
    out.resize(at + ids.len() * 4 * dim, 0);
    for (chunk, &i) in out[at..].chunks_exact_mut(4 * dim).zip(&ids) {
        for (d, &v) in lat.pos[i][..dim].iter().enumerate() {
            chunk[4 * d..4 * d + 4].copy_from_slice(&v.to_le_bytes());
        }
    }
    let width = if wide { 4 } else { 2 };
    let at = out.len();
    out.resize(at + ids.len() * width, 0);
    for (chunk, &i) in out[at..].chunks_exact_mut(width).zip(&ids) {
        chunk.copy_from_slice(&state[i].to_le_bytes()[..width]);
    }
    pad(&mut out);
    if attach {
        out.extend(ids.iter().map(|&i| lat.attach[i]));
    }
    if let Some(c) = counter {
        if out.len() % 2 == 1 {
            out.push(0);
        }
        for a in 0..n as u32 {
            out.extend_from_slice(&lat.counter(a, c).to_le_bytes());
        }
    }
    let step = run.hist.steps();
    match (run.sent.as_mut(), &changed) {
        // A delta: what the tab holds now is the last frame with the changes.
        (Some(sent), Some(c)) => {
            sent.step = step;
            for &i in c {
                let i = i as usize;
                sent.pos[i] = lat.pos[i];
                sent.state[i] = state[i];
                sent.attach[i] = lat.attach[i];
            }
        }
        _ => {
            run.sent = Some(Sent {
                step,
                pos: lat.pos.clone(),
                state,
                attach: lat.attach.clone(),
            })
        }
    }
    out
}
