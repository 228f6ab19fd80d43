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

export function el(tag, attrs, ...children) {
  const e = document.createElement(tag);
  for (const [k, v] of Object.entries(attrs || {})) {
    if (k === 'class') e.className = v; else if (k.startsWith('on')) e[k] = v; else e.setAttribute(k, v);
  }
  for (const c of children) e.append(c);
  return e;
}

// The frame of step `step` in the binary layout (docs/viewer.md, src/serve/binary.rs),
// as a delta on `held` (the frame shown) when the server finds that smaller: `{ok, status,
// v}` like `api`, `v` a frame with typed arrays for pos, state and attach.
export function frameAt(step, held, counter) {
  const since = (held ? '&since=' + held.step : '') + (counter ? '&counter=' + counter : '');
  return send('GET', '/api/frame?format=bin&step=' + step + since, undefined,
    async (r) => decodeFrame(await r.arrayBuffer(), held));
}

export function decodeFrame(buf, held) {
  const dv = new DataView(buf);
  const len = dv.getUint32(4, true);
  const head = JSON.parse(new TextDecoder().decode(new Uint8Array(buf, 8, len)));
  const { n, dim } = head;
  const c = head.delta ? head.changed : n;
  let off = (8 + len + 3) & ~3;
  let ids = null;
  if (head.delta) { ids = new Uint32Array(buf, off, c); off += 4 * c; }
  const pos = new Int32Array(buf, off, c * dim);
  off += 4 * c * dim;
  const wide = head.state_bytes === 4;
  const st = wide ? new Uint32Array(buf, off, c) : new Uint16Array(buf, off, c);
  off = (off + head.state_bytes * c + 3) & ~3;
  const at = head.attach ? new Uint8Array(buf, off, c) : null;
  if (at) off += c;
  // The counter asked for, of every agent.
  const values = head.counter ? new Int16Array(buf, (off + 1) & ~1, n) : null;
  const f = head;
  f.values = values;
  if (!head.delta) {
    f.pos = pos; f.state = st; f.attach = at;
    return f;
  }
  // The frame held is done with: its columns become the new frame's, patched in place (no
  // copy of a million positions per step). What changed, and the old cells of the agents
  // that changed, are kept so that drawings can be patched, not redone.
  f.base = held;
  f.changedIds = ids;
  f.oldPos = new Int32Array(c * dim);
  for (let k = 0; k < c; k++) {
    for (let d = 0; d < dim; d++) f.oldPos[k * dim + d] = held.pos[ids[k] * dim + d];
  }
  held.base = null;
  held.changedIds = null;
  held.oldPos = null;
  f.pos = held.pos;
  f.state = wide && !(held.state instanceof Uint32Array) ? Uint32Array.from(held.state) : held.state;
  f.attach = head.attach ? (held.attach || new Uint8Array(n)) : null;
  for (let k = 0; k < c; k++) {
    const i = ids[k];
    for (let d = 0; d < dim; d++) f.pos[i * dim + d] = pos[k * dim + d];
    f.state[i] = st[k];
    if (at) f.attach[i] = at[k];
  }
  return f;
}

export const escapeHtml = (s) => s.replace(/[&<>]/g, (c) => ({ '&': '&amp;', '<': '&lt;', '>': '&gt;' }[c]));
