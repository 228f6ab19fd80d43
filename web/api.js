// The JSON API of `latticesim serve` (docs/viewer.md), and small DOM helpers.

export const $ = (id) => document.getElementById(id);

export async function api(method, path, body) {
  const init = { method };
  if (body !== undefined) {
    init.headers = { 'Content-Type': 'application/json' };
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
