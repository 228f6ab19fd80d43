// The JSON API of `latticesim serve` (docs/viewer.md), and small DOM helpers.

export const $ = (id) => document.getElementById(id);

// This tab's session id (POST /api/tab), sent with every request: each tab has its own
// files and run on the server.
let tab = null;
export function setTab(id) { tab = id; }

// Called with the message when the server says this tab's run is gone (410).
let onGone = null;
export function whenGone(f) { onGone = f; }

export async function api(method, path, body) {
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
    v = await r.json();
  } catch (e) {
    v = { error: 'HTTP ' + r.status };
  }
  if (r.status === 410 && onGone) onGone(v.error);
  return { ok: r.ok, status: r.status, v };
}

export function el(tag, attrs, ...children) {
  const e = document.createElement(tag);
  for (const [k, v] of Object.entries(attrs || {})) {
    if (k === 'class') e.className = v; else if (k.startsWith('on')) e[k] = v; else e.setAttribute(k, v);
  }
  for (const c of children) e.append(c);
  return e;
}

export const escapeHtml = (s) => s.replace(/[&<>]/g, (c) => ({ '&': '&amp;', '<': '&lt;', '>': '&gt;' }[c]));
