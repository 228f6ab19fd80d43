// The JSON API of `latticesim serve` (docs/viewer.md), and small DOM helpers.

export const $ = (id) => document.getElementById(id);

// This tab's session id (POST /api/tab), sent with every request: each tab has its own
// files and run on the server.
let tab = null;
export function setTab(id) { tab = id; }

// Called with the message when the server says this tab's run is gone (410).
let onGone = null;
export function whenGone(f) { onGone = f; }

// Sends a request with this tab's id; `read` turns a successful answer into its value.
// `{ok, status, v}`: `v` that value, or `{error}` from the server's JSON (or the status).
// A 410 (this tab's run is gone) is also told to the page at once.
async function send(method, path, body, read) {
  const init = { method, headers: {} };
  if (tab) init.headers['X-Latticesim-Tab'] = tab;
  if (body !== undefined) {
    init.headers['Content-Type'] = 'application/json';
    init.body = JSON.stringify(body);
  }
  let r;
  try {
    r = await fetch(path, init);
  } catch (e) {
    return { ok: false, status: 0, v: { error: 'the server does not answer: ' + e.message } };
  }
  let v;
  try {
    v = r.ok ? await read(r) : await r.json();
  } catch (e) {
    v = { error: 'HTTP ' + r.status };
  }
  if (r.status === 410 && onGone) onGone(v.error);
  return { ok: r.ok, status: r.status, v };
}

// A JSON request of the API.
export function api(method, path, body) {
  return send(method, path, body, (r) => r.json());
}

// Saves what a GET answers as a file (the browser's download), named as the server says
// (Content-Disposition) or `name`: `{ok, status, v}` like `api`, `v` the file's name and size.
export async function download(path, name) {
  const r = await send('GET', path, undefined, async (res) => {
    const m = (res.headers.get('Content-Disposition') || '').match(/filename="([^"]+)"/);
    return { name: m ? m[1] : name, blob: await res.blob() };
  });
  if (r.ok) saveBlob(r.v.blob, r.v.name);
  return r.ok ? { ...r, v: { name: r.v.name, bytes: r.v.blob.size } } : r;
}

// The browser's download of `blob` as `name`.
export function saveBlob(blob, name) {
  const a = document.createElement('a');
  a.href = URL.createObjectURL(blob);
  a.download = name;
  a.click();
  setTimeout(() => URL.revokeObjectURL(a.href), 10_000);
}

export function el(tag, attrs, ...children) {
  const e = document.createElement(tag);
  for (const [k, v] of Object.entries(attrs || {})) {
    if (k === 'class') e.className = v; else if (k.startsWith('on')) e[k] = v; else e.setAttribute(k, v);
  }
  for (const c of children) e.append(c);
  return e;
}

// Asks for the frame of step `step` in the binary layout (docs/viewer.md,
// src/serve/binary.rs), as a delta on the frame of step `since` (the one the page holds)
// when the server finds that smaller: `{ok, status, v}` like `api`, `v` the bytes, to be
// decoded with decodeFrame onto that frame.
export function requestFrame(step, since, counter) {
  const q = (since !== null && since !== undefined ? '&since=' + since : '') + (counter ? '&counter=' + counter : '');
  return send('GET', '/api/frame?format=bin&step=' + step + q, undefined, (r) => r.arrayBuffer());
}

// The frame of step `step`, decoded onto `held` (the frame shown): `{ok, status, v}`, `v`
// a frame (see decodeFrame).
export async function frameAt(step, held, counter) {
  return decoded(await requestFrame(step, held ? held.step : null, counter), held);
}

// An answer of requestFrame decoded onto `held`.
export function decoded(r, held) {
  if (!r.ok) return r;
  try {
    return { ...r, v: decodeFrame(r.v, held) };
  } catch (e) {
    return { ok: false, status: r.status, v: { error: 'a frame could not be read: ' + e.message } };
  }
}

// Scratch arrays reused from frame to frame (a million-agent frame would otherwise
// allocate and clear megabytes each step): `count` elements of `Type`, the one of `name`.
// What a frame keeps of them (its changed ids and their old cells) is only read until the
// next frame is decoded.
const scratch = {};
function reused(name, Type, count) {
  if (!scratch[name] || scratch[name].length < count) scratch[name] = new Type(Math.max(count, 1024) * 1.25 | 0);
  return scratch[name].subarray(0, count);
}

// The ids of a bit set (bit i mod 8 of byte i div 8 is agent i), `count` of them.
function bitIds(bytes, count, name) {
  const ids = reused(name, Uint32Array, count);
  let k = 0;
  for (let j = 0; j < bytes.length; j++) {
    for (let b = bytes[j]; b; b &= b - 1) ids[k++] = 8 * j + (31 - Math.clz32(b & -b));
  }
  return ids;
}

// The ids in either of two ascending lists, ascending.
function union(a, b) {
  if (!a.length) return b;
  if (!b.length) return a;
  const out = new Uint32Array(a.length + b.length);
  let i = 0, j = 0, k = 0;
  while (i < a.length || j < b.length) {
    const x = j >= b.length || (i < a.length && a[i] <= b[j]) ? a[i] : b[j];
    if (i < a.length && a[i] === x) i++;
    if (j < b.length && b[j] === x) j++;
    out[k++] = x;
  }
  return out.subarray(0, k);
}

const align4 = (x) => (x + 3) & ~3;

// A frame in the binary layout (src/serve/binary.rs), onto `held` (the frame shown) when
// it is a delta: a frame with typed arrays for pos, state and attach.
export function decodeFrame(buf, held) {
  const dv = new DataView(buf);
  if (dv.getUint32(0, true) !== 0x3246534c) throw new Error('not a frame (LSF2)');
  const len = dv.getUint32(4, true);
  const f = JSON.parse(new TextDecoder().decode(new Uint8Array(buf, 8, len)));
  const { n, dim } = f;
  let off = align4(8 + len);
  // Each column: the agents it carries (null: all) and their values.
  const cols = {};
  for (const c of f.columns) {
    let ids = null;
    if (c.set === 'bits') ids = bitIds(new Uint8Array(buf, off, (n + 7) >> 3), c.count, c.name);
    else if (c.set === 'ids') ids = new Uint32Array(buf, off, c.count);
    off = align4(off + (c.set === 'bits' ? (n + 7) >> 3 : c.set === 'ids' ? 4 * c.count : 0));
    const signed = c.name === 'pos';
    const Type = { 1: signed ? Int8Array : Uint8Array, 2: Uint16Array, 4: signed ? Int32Array : Uint32Array }[c.bytes];
    const values = new Type(buf, off, c.count * (c.name === 'pos' ? dim : 1));
    off = align4(off + values.byteLength);
    cols[c.name] = { ids, values };
  }
  // The counter asked for, of every agent.
  f.values = f.counter ? new (f.counter_bytes === 4 ? Int32Array : Int16Array)(buf, off, n) : null;
  if (f.delta && (!held || held.step !== f.base)) throw new Error(`a change to step ${f.base}, but the page holds another`);
  if (!f.delta) {
    f.pos = cols.pos.values;
    f.state = cols.state.values;
    f.attach = cols.attach ? cols.attach.values : null;
    return f;
  }
  // The frame held is done with: its columns become the new frame's, patched in place (no
  // copy of a million positions per step). What changed, and the old cells of the agents
  // that changed, are kept so that drawings can be patched, not redone.
  // (The loops read local variables: a frame is a large object, slow to look into a
  // million times.)
  const { pos, state, attach } = cols;
  const ids = union(union(pos.ids, state.ids), attach ? attach.ids : []);
  const heldPos = held.pos, oldPos = reused('old', Int32Array, ids.length * dim);
  if (dim === 2) {
    for (let k = 0; k < ids.length; k++) {
      const i = 2 * ids[k];
      oldPos[2 * k] = heldPos[i];
      oldPos[2 * k + 1] = heldPos[i + 1];
    }
  } else {
    for (let k = 0; k < ids.length; k++) {
      const i = 3 * ids[k];
      oldPos[3 * k] = heldPos[i];
      oldPos[3 * k + 1] = heldPos[i + 1];
      oldPos[3 * k + 2] = heldPos[i + 2];
    }
  }
  f.base = held;
  f.changedIds = ids;
  f.oldPos = oldPos;
  held.base = null;
  held.changedIds = null;
  held.oldPos = null;
  f.pos = heldPos;
  // State indices grow wider as the run shows more states.
  const wider = held.state.BYTES_PER_ELEMENT < state.values.BYTES_PER_ELEMENT;
  f.state = wider ? state.values.constructor.from(held.state) : held.state;
  f.attach = attach ? (held.attach || new Uint8Array(n)) : null;
  // Moves (i8) are added, positions (i32) put; a loop for each dimension, each kind.
  const [moved, by] = [pos.ids, pos.values];
  const add = by instanceof Int8Array;
  if (dim === 2 && add) {
    for (let k = 0; k < moved.length; k++) {
      const i = 2 * moved[k];
      heldPos[i] += by[2 * k];
      heldPos[i + 1] += by[2 * k + 1];
    }
  } else if (dim === 2) {
    for (let k = 0; k < moved.length; k++) {
      const i = 2 * moved[k];
      heldPos[i] = by[2 * k];
      heldPos[i + 1] = by[2 * k + 1];
    }
  } else {
    for (let k = 0; k < moved.length; k++) {
      const i = 3 * moved[k];
      for (let d = 0; d < 3; d++) heldPos[i + d] = (add ? heldPos[i + d] : 0) + by[3 * k + d];
    }
  }
  const [restated, to, states] = [state.ids, state.values, f.state];
  for (let k = 0; k < restated.length; k++) states[restated[k]] = to[k];
  if (attach) {
    const [ids, bits, all] = [attach.ids, attach.values, f.attach];
    for (let k = 0; k < ids.length; k++) all[ids[k]] = bits[k];
  }
  return f;
}

export const escapeHtml = (s) => s.replace(/[&<>]/g, (c) => ({ '&': '&amp;', '<': '&lt;', '>': '&gt;' }[c]));
