// latticesim viewer and editor: talks to the JSON API of `latticesim serve` (docs/viewer.md).
'use strict';

const $ = (id) => document.getElementById(id);

async function api(method, path, body) {
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

// ---------------------------------------------------------------- state

const S = {
  frame: null,       // the configuration shown (see Frame in src/serve.rs)
  scale: 20,         // pixels per cell
  ox: 0, oy: 0,      // screen position of the world origin
  theta: 0,          // rotation about the vertical axis (3D)
  selected: null,    // the inspected agent id
  highlight: new Set(),
  activeRecord: -1,
  running: false,
  target: null,      // step asked for while a request is under way
  busy: false,
  faces: [],         // 3D: drawn faces, for picking
  session: null,
  fitted: false,
};

// ---------------------------------------------------------------- stepping

function setNote(text) { $('note').textContent = text || ''; }

async function gotoStep(n) {
  if (n < 0) n = 0;
  S.target = n;
  if (S.busy) return; // the loop below picks the newest target up
  S.busy = true;
  try {
    while (S.target !== null) {
      const t = S.target;
      S.target = null;
      const r = await api('GET', '/api/frame?step=' + t);
      if (!r.ok) { setNote(r.v.error); S.running = false; break; }
      showFrame(r.v);
    }
  } finally {
    S.busy = false;
    updateRunButton();
  }
}

function currentStep() {
  if (S.target !== null) return S.target;
  return S.frame ? S.frame.step : 0;
}

function showFrame(f) {
  S.frame = f;
  $('step-number').textContent = f.step;
  $('jump').value = f.step;
  setNote(f.note || (f.quiescent ? 'quiescent: no agent has a rule to execute' : ''));
  $('rotate').hidden = f.dim !== 3;
  if (!S.fitted) { fit(); S.fitted = true; }
  S.activeRecord = -1;
  S.highlight = new Set();
  showLegend(f);
  showRecords(f);
  showStats(f);
  draw();
  if (S.selected !== null) inspect(S.selected);
}

async function runLoop() {
  while (S.running) {
    const t0 = performance.now();
    const before = currentStep();
    await gotoStep(before + 1);
    const f = S.frame;
    if (!f || f.quiescent || f.note || f.step === before) { S.running = false; break; }
    const wait = 1000 / Number($('speed').value) - (performance.now() - t0);
    if (wait > 0) await new Promise((res) => setTimeout(res, wait));
  }
  updateRunButton();
}

function updateRunButton() {
  $('run').innerHTML = S.running ? '&#x23F8; Pause' : '&#x25B6; Run';
}

function toggleRun() {
  S.running = !S.running;
  updateRunButton();
  if (S.running) runLoop();
}

// ---------------------------------------------------------------- side panel

function el(tag, attrs, ...children) {
  const e = document.createElement(tag);
  for (const [k, v] of Object.entries(attrs || {})) {
    if (k === 'class') e.className = v; else if (k.startsWith('on')) e[k] = v; else e.setAttribute(k, v);
  }
  for (const c of children) e.append(c);
  return e;
}

function showLegend(f) {
  const ul = $('legend');
  ul.replaceChildren();
  const states = f.states.slice().sort((a, b) => (a.name < b.name ? -1 : a.name > b.name ? 1 : 0));
  for (const s of states) {
    const sw = el('span', { class: 'swatch' });
    sw.style.background = s.colour;
    ul.append(el('li', {}, sw, s.name, el('span', { class: 'muted' }, ' ' + s.count)));
  }
}

function showRecords(f) {
  const ul = $('records');
  ul.replaceChildren();
  if (f.records.length === 0) {
    ul.append(el('li', { class: 'muted' }, f.step === 0 ? 'none before the first step' : 'none'));
    return;
  }
  f.records.forEach((r, i) => {
    const li = el('li', { class: r.severity, title: 'Highlight its agents' },
      el('b', {}, r.kind), ': ' + r.message + ' (agents ' + r.agents.join(', ') + ')');
    li.onclick = () => {
      const on = S.activeRecord !== i;
      S.activeRecord = on ? i : -1;
      S.highlight = new Set(on ? r.agents : []);
      for (const c of ul.children) c.classList.remove('active');
      if (on) li.classList.add('active');
      draw();
    };
    ul.append(li);
  });
}

function showStats(f) {
  const s = f.stats;
  $('stats').innerHTML = '';
  $('stats').append(
    `${f.pos.length / f.dim} agents, ${f.states.length} states`, el('br'),
    `firings ${s.firings}, moves ${s.moves}, swaps ${s.swaps}`, el('br'),
    `messages ${s.sent} sent, ${s.delivered} delivered, ${s.dropped} dropped`, el('br'),
    `records: ${s.errors} errors, ${s.warnings} warnings`, el('br'),
    `keyframes ${f.keyframes[0]}, every ${f.keyframes[1]} steps`);
}

async function inspect(id) {
  S.selected = id;
  const r = await api('GET', '/api/agent?id=' + id);
  const box = $('inspector');
  if (!r.ok) { box.textContent = r.v.error; return; }
  const a = r.v;
  const row = (k, v, vid) => el('tr', {}, el('td', {}, k), el('td', vid ? { id: vid, class: 'mono' } : { class: 'mono' }, String(v)));
  const list = (xs) => xs.length ? xs.map((c) => c.name + '=' + c.value).join(' ') : '-';
  const next = a.next
    ? a.next.rules.join(', ') + ' (priority ' + a.next.priority + ')'
    : 'none';
  box.replaceChildren(el('table', {},
    row('id', a.id, 'insp-id'),
    row('position', a.pos.join(', '), 'insp-pos'),
    row('state', a.state, 'insp-state'),
    row('attached', a.attached || '-', 'insp-attached'),
    row('counters', list(a.counters), 'insp-counters'),
    row('messages', list(a.messages), 'insp-messages'),
    row('rules in step ' + a.next_step, next, 'insp-rules')));
  box.classList.remove('muted');
  draw();
}

// ---------------------------------------------------------------- drawing

const canvas = $('canvas');
const ctx = canvas.getContext('2d');

function resize() {
  const r = canvas.getBoundingClientRect();
  const dpr = window.devicePixelRatio || 1;
  canvas.width = Math.max(1, Math.round(r.width * dpr));
  canvas.height = Math.max(1, Math.round(r.height * dpr));
  ctx.setTransform(dpr, 0, 0, dpr, 0, 0);
  draw();
}

function agentCount(f) { return f.pos.length / f.dim; }

function bbox(f) {
  const n = agentCount(f), d = f.dim;
  const lo = [Infinity, Infinity, Infinity], hi = [-Infinity, -Infinity, -Infinity];
  for (let i = 0; i < n; i++) {
    for (let k = 0; k < d; k++) {
      const v = f.pos[i * d + k];
      if (v < lo[k]) lo[k] = v;
      if (v > hi[k]) hi[k] = v;
    }
  }
  if (n === 0) return { lo: [0, 0, 0], hi: [0, 0, 0] };
  if (d === 2) { lo[2] = 0; hi[2] = 0; }
  return { lo, hi };
}

// 3D: rotation about the centre of the agents, then an isometric projection.
function project(x, y, z) {
  const c = S.centre;
  const dx = x - c[0], dy = y - c[1];
  const cs = Math.cos(S.theta), sn = Math.sin(S.theta);
  const xr = dx * cs - dy * sn, yr = dx * sn + dy * cs;
  return [S.ox + (xr - yr) * 0.866 * S.scale, S.oy + ((xr + yr) * 0.5 - (z - c[2])) * S.scale, xr + yr];
}

// Shows every agent, and the universe's bounds when they are not much larger.
function fit() {
  const f = S.frame;
  if (!f) return;
  const r = canvas.getBoundingClientRect();
  const b = bbox(f);
  const lo = b.lo.slice(), hi = b.hi.slice();
  if (f.universe) {
    const u = f.universe;
    const small = u.every(([l, h], k) => h - l <= 4 * (b.hi[k] - b.lo[k] + 1) + 16);
    if (small) u.forEach(([l, h], k) => { lo[k] = Math.min(lo[k], l); hi[k] = Math.max(hi[k], h); });
  }
  S.centre = [(lo[0] + hi[0] + 1) / 2, (lo[1] + hi[1] + 1) / 2, (lo[2] + hi[2] + 1) / 2];
  if (f.dim === 2) {
    const w = hi[0] - lo[0] + 1, h = hi[1] - lo[1] + 1;
    S.scale = Math.max(0.02, Math.min(60, 0.9 * Math.min(r.width / w, r.height / h)));
    S.ox = r.width / 2 - S.centre[0] * S.scale;
    S.oy = r.height / 2 + S.centre[1] * S.scale;
  } else {
    // The box's corners projected at scale 1 give the extent to fit.
    S.scale = 1;
    S.ox = 0;
    S.oy = 0;
    const pts = CORNERS.map((c) => project(c[0] ? hi[0] + 1 : lo[0], c[1] ? hi[1] + 1 : lo[1], c[2] ? hi[2] + 1 : lo[2]));
    const us = pts.map((p) => p[0]), vs = pts.map((p) => p[1]);
    const [u0, u1, v0, v1] = [Math.min(...us), Math.max(...us), Math.min(...vs), Math.max(...vs)];
    S.scale = Math.max(0.05, Math.min(60, 0.9 * Math.min(r.width / (u1 - u0), r.height / (v1 - v0))));
    S.ox = r.width / 2 - ((u0 + u1) / 2) * S.scale;
    S.oy = r.height / 2 - ((v0 + v1) / 2) * S.scale;
  }
  draw();
}

function shade(hex, k) {
  const v = parseInt(hex.slice(1), 16);
  const c = [(v >> 16) & 255, (v >> 8) & 255, v & 255].map((x) => Math.round(x * k));
  return `rgb(${c[0]},${c[1]},${c[2]})`;
}

function draw() {
  const f = S.frame;
  const r = canvas.getBoundingClientRect();
  ctx.clearRect(0, 0, r.width, r.height);
  if (!f) return;
  if (f.dim === 2) draw2d(f, r); else draw3d(f, r);
}

// The 2D frame as an image of one pixel per cell (north up), made once per frame; none
// when the agents' bounding box has more than 16 million cells.
function bitmap(f) {
  if (S.bmp && S.bmp.frame === f) return S.bmp;
  const b = bbox(f);
  const w = b.hi[0] - b.lo[0] + 1, h = b.hi[1] - b.lo[1] + 1;
  S.bmp = { frame: f, canvas: null, lo: b.lo, hi: b.hi };
  if (agentCount(f) === 0 || w * h > 16e6) return S.bmp;
  const c = document.createElement('canvas');
  c.width = w;
  c.height = h;
  const cx = c.getContext('2d');
  const img = cx.createImageData(w, h);
  const px = new Uint32Array(img.data.buffer);
  // RGBA bytes in a little-endian word: 0xAABBGGRR.
  const cols = f.states.map((st) => {
    const v = parseInt(st.colour.slice(1), 16);
    return (0xff000000 | ((v & 0xff) << 16) | (v & 0xff00) | (v >> 16)) >>> 0;
  });
  for (let i = 0; i < agentCount(f); i++) {
    px[(b.hi[1] - f.pos[2 * i + 1]) * w + (f.pos[2 * i] - b.lo[0])] = cols[f.state[i]];
  }
  cx.putImageData(img, 0, 0);
  S.bmp.canvas = c;
  return S.bmp;
}

function draw2d(f, r) {
  const s = S.scale, n = agentCount(f);
  const gap = s >= 6 ? Math.max(1, s * 0.06) : 0;
  // Cells on screen, to skip agents outside the view.
  const x0 = Math.floor(-S.ox / s) - 1, x1 = Math.ceil((r.width - S.ox) / s) + 1;
  const y0 = Math.floor((S.oy - r.height) / s) - 1, y1 = Math.ceil(S.oy / s) + 1;
  if (f.universe) {
    const u = f.universe;
    ctx.strokeStyle = '#888';
    ctx.lineWidth = 1;
    const clamp = (v) => Math.max(-1e6, Math.min(1e6, v));
    ctx.strokeRect(clamp(S.ox + u[0][0] * s), clamp(S.oy - (u[1][1] + 1) * s),
      clamp((u[0][1] - u[0][0] + 1) * s), clamp((u[1][1] - u[1][0] + 1) * s));
  }
  const bmp = bitmap(f);
  if (bmp.canvas) {
    // One pixel per cell, scaled up without smoothing: one image whatever the agent count.
    const [lo, hi] = [bmp.lo, bmp.hi];
    ctx.imageSmoothingEnabled = false;
    ctx.drawImage(bmp.canvas, S.ox + lo[0] * s, S.oy - (hi[1] + 1) * s,
      (hi[0] - lo[0] + 1) * s, (hi[1] - lo[1] + 1) * s);
    if (gap > 0) {
      // The gaps between cells, as white lines over the visible part of the image.
      ctx.fillStyle = '#fff';
      for (let x = Math.max(x0, lo[0]); x <= Math.min(x1, hi[0] + 1); x++) {
        ctx.fillRect(S.ox + x * s - gap, S.oy - (hi[1] + 1) * s, 2 * gap, (hi[1] - lo[1] + 1) * s);
      }
      for (let y = Math.max(y0, lo[1]); y <= Math.min(y1, hi[1] + 1); y++) {
        ctx.fillRect(S.ox + lo[0] * s, S.oy - y * s - gap, (hi[0] - lo[0] + 1) * s, 2 * gap);
      }
    }
  } else {
    // Agents spread too far for an image: a square each, only those on screen.
    const groups = f.states.map(() => []);
    for (let i = 0; i < n; i++) {
      const x = f.pos[2 * i], y = f.pos[2 * i + 1];
      if (x < x0 || x > x1 || y < y0 || y > y1) continue;
      groups[f.state[i]].push(i);
    }
    const w = Math.max(s - 2 * gap, 0.6);
    groups.forEach((g, k) => {
      ctx.fillStyle = f.states[k].colour;
      for (const i of g) {
        ctx.fillRect(S.ox + f.pos[2 * i] * s + gap, S.oy - (f.pos[2 * i + 1] + 1) * s + gap, w, w);
      }
    });
  }
  if (f.attach) {
    ctx.strokeStyle = '#333';
    ctx.lineWidth = Math.max(1, s * 0.1);
    ctx.beginPath();
    for (let i = 0; i < n; i++) {
      const x = f.pos[2 * i], y = f.pos[2 * i + 1];
      if (!f.attach[i] || x < x0 || x > x1 || y < y0 || y > y1) continue;
      const cx = S.ox + (x + 0.5) * s, cy = S.oy - (y + 0.5) * s;
      if (f.attach[i] & 1) { ctx.moveTo(cx, cy); ctx.lineTo(cx, cy - s); } // north
      if (f.attach[i] & 4) { ctx.moveTo(cx, cy); ctx.lineTo(cx + s, cy); } // east
    }
    ctx.stroke();
  }
  const ring = (i, colour, width) => {
    ctx.strokeStyle = colour;
    ctx.lineWidth = width;
    ctx.strokeRect(S.ox + f.pos[2 * i] * s - 1, S.oy - (f.pos[2 * i + 1] + 1) * s - 1, s + 2, s + 2);
  };
  for (const i of S.highlight) { ring(i, '#000', 4); ring(i, '#ffd400', 2); }
  if (S.selected !== null && S.selected < n) { ring(S.selected, '#fff', 4); ring(S.selected, '#0050ff', 2); }
}

const CORNERS = [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]];
// Faces as corner indices with their outward normal in (x, y); the top has none.
const SIDES = [
  { c: [0, 3, 7, 4], n: [-1, 0] }, { c: [1, 2, 6, 5], n: [1, 0] },
  { c: [0, 1, 5, 4], n: [0, -1] }, { c: [3, 2, 6, 7], n: [0, 1] },
];
const TOP = [4, 5, 6, 7];

function draw3d(f, r) {
  const n = agentCount(f);
  const cs = Math.cos(S.theta), sn = Math.sin(S.theta);
  // Sides facing the viewer (who looks from +x'+y', above), and their shade.
  const sides = SIDES.filter((sd) => {
    const xr = sd.n[0] * cs - sd.n[1] * sn, yr = sd.n[0] * sn + sd.n[1] * cs;
    return xr + yr > 1e-9;
  }).map((sd) => {
    const xr = sd.n[0] * cs - sd.n[1] * sn;
    return { c: sd.c, k: xr > 0 ? 0.78 : 0.62 };
  });
  if (f.universe) {
    const u = f.universe;
    const p = (x, y, z) => project(x, y, z);
    const xs = [u[0][0], u[0][1] + 1], ys = [u[1][0], u[1][1] + 1], zs = [u[2][0], u[2][1] + 1];
    const far = 1e6;
    if (Math.max(...xs.map(Math.abs), ...ys.map(Math.abs), ...zs.map(Math.abs)) < far) {
      ctx.strokeStyle = '#bbb';
      ctx.lineWidth = 1;
      ctx.beginPath();
      for (const [a, b] of [[0, 1], [1, 2], [2, 3], [3, 0], [4, 5], [5, 6], [6, 7], [7, 4], [0, 4], [1, 5], [2, 6], [3, 7]]) {
        const A = CORNERS[a], B = CORNERS[b];
        const pa = p(xs[A[0]], ys[A[1]], zs[A[2]]), pb = p(xs[B[0]], ys[B[1]], zs[B[2]]);
        ctx.moveTo(pa[0], pa[1]);
        ctx.lineTo(pb[0], pb[1]);
      }
      ctx.stroke();
    }
  }
  const order = [];
  for (let i = 0; i < n; i++) {
    const c = project(f.pos[3 * i] + 0.5, f.pos[3 * i + 1] + 0.5, f.pos[3 * i + 2] + 0.5);
    if (c[0] < -S.scale * 2 || c[0] > r.width + S.scale * 2 || c[1] < -S.scale * 2 || c[1] > r.height + S.scale * 2) continue;
    order.push([c[2] + f.pos[3 * i + 2], i]);
  }
  order.sort((a, b) => a[0] - b[0]);
  S.faces = [];
  ctx.lineJoin = 'round';
  for (const [, i] of order) {
    const x = f.pos[3 * i], y = f.pos[3 * i + 1], z = f.pos[3 * i + 2];
    const pts = CORNERS.map((c) => project(x + c[0], y + c[1], z + c[2]));
    const colour = f.states[f.state[i]].colour;
    const polys = [];
    const face = (idx, fill) => {
      ctx.beginPath();
      idx.forEach((k, j) => (j ? ctx.lineTo(pts[k][0], pts[k][1]) : ctx.moveTo(pts[k][0], pts[k][1])));
      ctx.closePath();
      ctx.fillStyle = fill;
      ctx.fill();
      if (S.scale >= 5) { ctx.strokeStyle = shade(colour, 0.45); ctx.lineWidth = 1; ctx.stroke(); }
      polys.push(idx.map((k) => pts[k]));
    };
    for (const sd of sides) face(sd.c, shade(colour, sd.k));
    face(TOP, colour);
    S.faces.push([i, polys]);
    const mark = S.highlight.has(i) ? '#ffd400' : S.selected === i ? '#0050ff' : null;
    if (mark) {
      ctx.strokeStyle = mark;
      ctx.lineWidth = 3;
      for (const poly of polys) {
        ctx.beginPath();
        poly.forEach((p, j) => (j ? ctx.lineTo(p[0], p[1]) : ctx.moveTo(p[0], p[1])));
        ctx.closePath();
        ctx.stroke();
      }
    }
  }
  if (f.attach) {
    ctx.strokeStyle = '#222';
    ctx.lineWidth = Math.max(1, S.scale * 0.12);
    ctx.beginPath();
    const bonds = [[1, [0, 1, 0]], [4, [1, 0, 0]], [16, [0, 0, 1]]]; // N, E, A
    for (let i = 0; i < n; i++) {
      const x = f.pos[3 * i] + 0.5, y = f.pos[3 * i + 1] + 0.5, z = f.pos[3 * i + 2] + 0.5;
      for (const [bit, d] of bonds) {
        if (!(f.attach[i] & bit)) continue;
        const a = project(x, y, z), b = project(x + d[0], y + d[1], z + d[2]);
        ctx.moveTo(a[0], a[1]);
        ctx.lineTo(b[0], b[1]);
      }
    }
    ctx.stroke();
  }
}

function inside(poly, x, y) {
  let sign = 0;
  for (let j = 0; j < poly.length; j++) {
    const a = poly[j], b = poly[(j + 1) % poly.length];
    const c = (b[0] - a[0]) * (y - a[1]) - (b[1] - a[1]) * (x - a[0]);
    if (c !== 0) {
      if (sign === 0) sign = Math.sign(c); else if (Math.sign(c) !== sign) return false;
    }
  }
  return true;
}

// The agent drawn at canvas point (x, y), or null.
function pick(x, y) {
  const f = S.frame;
  if (!f) return null;
  if (f.dim === 2) {
    const cx = Math.floor((x - S.ox) / S.scale), cy = Math.floor((S.oy - y) / S.scale);
    for (let i = 0; i < agentCount(f); i++) {
      if (f.pos[2 * i] === cx && f.pos[2 * i + 1] === cy) return i;
    }
    return null;
  }
  for (let k = S.faces.length - 1; k >= 0; k--) {
    const [i, polys] = S.faces[k];
    if (polys.some((p) => inside(p, x, y))) return i;
  }
  return null;
}

// Where agent `id` is drawn, in page coordinates (for tests and scripts).
function screenOf(id) {
  const f = S.frame, r = canvas.getBoundingClientRect();
  if (f.dim === 2) {
    return [r.left + S.ox + (f.pos[2 * id] + 0.5) * S.scale, r.top + S.oy - (f.pos[2 * id + 1] + 0.5) * S.scale];
  }
  const entry = S.faces.find((e) => e[0] === id);
  const top = entry[1][entry[1].length - 1];
  const cx = top.reduce((s, p) => s + p[0], 0) / top.length, cy = top.reduce((s, p) => s + p[1], 0) / top.length;
  return [r.left + cx, r.top + cy];
}

// ---------------------------------------------------------------- mouse and keys

let drag = null;
canvas.addEventListener('mousedown', (e) => {
  drag = { x: e.clientX, y: e.clientY, moved: false, rotate: e.shiftKey || e.button === 2 };
  canvas.style.cursor = 'grabbing';
});
window.addEventListener('mousemove', (e) => {
  if (!drag) return;
  const dx = e.clientX - drag.x, dy = e.clientY - drag.y;
  if (Math.abs(dx) + Math.abs(dy) > 3) drag.moved = true;
  if (!drag.moved) return;
  if (drag.rotate && S.frame && S.frame.dim === 3) S.theta += dx * 0.01;
  else { S.ox += dx; S.oy += dy; }
  drag.x = e.clientX;
  drag.y = e.clientY;
  draw();
});
window.addEventListener('mouseup', (e) => {
  if (!drag) return;
  const clicked = !drag.moved;
  drag = null;
  canvas.style.cursor = 'grab';
  if (!clicked) return;
  const r = canvas.getBoundingClientRect();
  const id = pick(e.clientX - r.left, e.clientY - r.top);
  if (id !== null) inspect(id);
});
canvas.addEventListener('contextmenu', (e) => e.preventDefault());
// Zooms by `k` keeping canvas point (mx, my) (default: the centre) in place.
function zoom(k, mx, my) {
  const r = canvas.getBoundingClientRect();
  if (mx === undefined) { mx = r.width / 2; my = r.height / 2; }
  const s = Math.max(0.02, Math.min(200, S.scale * k));
  const q = s / S.scale;
  S.ox = mx - (mx - S.ox) * q;
  S.oy = my - (my - S.oy) * q;
  S.scale = s;
  draw();
}

canvas.addEventListener('wheel', (e) => {
  e.preventDefault();
  const r = canvas.getBoundingClientRect();
  zoom(Math.exp(-e.deltaY * 0.0015), e.clientX - r.left, e.clientY - r.top);
}, { passive: false });

document.addEventListener('keydown', (e) => {
  if (!$('view').hidden && e.target.tagName !== 'INPUT' && e.target.tagName !== 'TEXTAREA') {
    if (e.key === ' ') { e.preventDefault(); toggleRun(); }
    if (e.key === 'ArrowRight') gotoStep(currentStep() + 1);
    if (e.key === 'ArrowLeft') gotoStep(currentStep() - 1);
    if (e.key === 'Home') gotoStep(0);
    if (e.key === '+' || e.key === '=') zoom(1.25);
    if (e.key === '-') zoom(0.8);
  }
});

$('step').onclick = () => gotoStep(currentStep() + 1);
$('back').onclick = () => gotoStep(currentStep() - 1);
$('reset').onclick = () => { S.running = false; gotoStep(0); };
$('run').onclick = toggleRun;
$('go').onclick = () => gotoStep(Number($('jump').value) || 0);
$('jump').addEventListener('keydown', (e) => { if (e.key === 'Enter') $('go').onclick(); });
$('speed').oninput = () => { $('speed-label').textContent = $('speed').value; };
$('fit').onclick = fit;
$('rot-left').onclick = () => { S.theta -= Math.PI / 12; draw(); };
$('rot-right').onclick = () => { S.theta += Math.PI / 12; draw(); };

// ---------------------------------------------------------------- tabs

function showTab(which) {
  $('view').hidden = which !== 'view';
  $('edit').hidden = which !== 'edit';
  $('tab-view').classList.toggle('active', which === 'view');
  $('tab-edit').classList.toggle('active', which === 'edit');
  if (which === 'view') resize();
}
$('tab-view').onclick = () => showTab('view');
$('tab-edit').onclick = () => showTab('edit');

// ---------------------------------------------------------------- editor

const editors = {};
for (const name of ['agents', 'rules']) {
  const root = $('editor-template').content.firstElementChild.cloneNode(true);
  root.id = 'ed-' + name;
  root.querySelector('.which').textContent = name;
  document.querySelector('.editors').append(root);
  const ed = {
    name,
    root,
    text: root.querySelector('textarea'),
    backdrop: root.querySelector('.backdrop'),
    gutter: root.querySelector('.gutter'),
    path: root.querySelector('.path'),
    diags: root.querySelector('.diags'),
    msg: root.querySelector('.filemsg'),
    list: [],
  };
  ed.text.addEventListener('input', () => { paint(ed); scheduleCheck(); });
  for (const ev of ['click', 'keyup', 'select']) ed.text.addEventListener(ev, () => showCurrent(ed));
  ed.text.addEventListener('scroll', () => {
    ed.backdrop.scrollTop = ed.text.scrollTop;
    ed.backdrop.scrollLeft = ed.text.scrollLeft;
    ed.gutter.scrollTop = ed.text.scrollTop;
  });
  root.querySelector('.load').onclick = async () => {
    const r = await api('POST', '/api/file', { path: ed.path.value });
    if (!r.ok) { ed.msg.textContent = r.v.error; return; }
    ed.text.value = r.v.text;
    ed.msg.textContent = 'loaded';
    paint(ed);
    scheduleCheck();
  };
  root.querySelector('.save').onclick = async () => {
    const r = await api('POST', '/api/file', { path: ed.path.value, text: ed.text.value });
    ed.msg.textContent = r.ok ? `saved ${r.v.bytes} bytes` : r.v.error;
  };
  editors[name] = ed;
}

const escapeHtml = (s) => s.replace(/[&<>]/g, (c) => ({ '&': '&amp;', '<': '&lt;', '>': '&gt;' }[c]));

// The string index of 1-based (line, column), columns counting characters.
function indexOf(text, line, col) {
  let i = 0;
  for (let l = 1; l < line; l++) {
    const nl = text.indexOf('\n', i);
    if (nl < 0) return text.length;
    i = nl + 1;
  }
  for (let c = 1; c < col && i < text.length && text[i] !== '\n'; c++) {
    i += text.codePointAt(i) > 0xffff ? 2 : 1;
  }
  return i;
}

// Draws the marks of the editor's diagnostics under its text, and the line numbers.
function paint(ed) {
  const text = ed.text.value;
  const spans = ed.list.map((d) => {
    let a = indexOf(text, d.line, d.column), b = indexOf(text, d.end_line, d.end_column);
    if (b < a) b = a; // an empty span gets a marker of its own
    return { a, b, d };
  }).sort((x, y) => x.a - y.a);
  let html = '', at = 0;
  for (const { a, b, d } of spans) {
    if (a < at) continue; // overlapping: the first one is shown
    html += escapeHtml(text.slice(at, a));
    const cls = d.severity + (b > a ? '' : ' empty');
    html += `<mark class="${cls}" data-line="${d.line}" data-code="${d.code}">${escapeHtml(text.slice(a, b))}</mark>`;
    at = b;
  }
  html += escapeHtml(text.slice(at)) + '\n';
  ed.backdrop.innerHTML = html;
  const bad = new Set(ed.list.filter((d) => d.severity === 'error').map((d) => d.line));
  const lines = text.split('\n').length;
  let g = '';
  for (let l = 1; l <= lines; l++) g += bad.has(l) ? `<span class="bad">${l}</span>\n` : `${l}\n`;
  ed.gutter.innerHTML = g;
  ed.backdrop.scrollTop = ed.text.scrollTop;
  ed.gutter.scrollTop = ed.text.scrollTop;
}

// Marks the messages of the diagnostics whose span holds the caret.
function showCurrent(ed) {
  const t = ed.text.value, at = ed.text.selectionStart;
  ed.list.forEach((d, i) => {
    const a = indexOf(t, d.line, d.column), b = indexOf(t, d.end_line, d.end_column);
    const li = ed.diags.children[i];
    const on = at >= a && at <= Math.max(a + 1, b);
    li.classList.toggle('current', on);
    if (on) li.scrollIntoView({ block: 'nearest' });
  });
}

function showDiagnostics(check) {
  for (const ed of Object.values(editors)) {
    ed.list = check.diagnostics.filter((d) => d.editor === ed.name);
    ed.diags.replaceChildren();
    for (const d of ed.list) {
      const li = el('li', { class: d.severity },
        `${d.line}:${d.column}: ${d.severity}[${d.code}]: ${d.message}`);
      if (d.help) li.append(el('div', { class: 'help' }, 'help: ' + d.help));
      li.onclick = () => {
        const t = ed.text.value;
        ed.text.focus();
        ed.text.setSelectionRange(indexOf(t, d.line, d.column), indexOf(t, d.end_line, d.end_column));
      };
      ed.diags.append(li);
    }
    paint(ed);
    if (document.activeElement === ed.text) showCurrent(ed);
  }
  const s = $('check-summary');
  s.textContent = `${check.errors} error${check.errors === 1 ? '' : 's'}, ${check.warnings} warning${check.warnings === 1 ? '' : 's'}; ${check.rules} rules, ${check.agents} agents, ${check.dimension}`;
  s.className = check.errors ? 'bad' : 'good';
}

let checkTimer = null, checkSeq = 0;
function scheduleCheck() {
  clearTimeout(checkTimer);
  checkTimer = setTimeout(runCheck, 250);
}

function texts() {
  return {
    rules: editors.rules.text.value,
    agents: editors.agents.text.value,
    rules_path: editors.rules.path.value,
    agents_path: editors.agents.path.value,
  };
}

async function runCheck() {
  const seq = ++checkSeq;
  const r = await api('POST', '/api/check', texts());
  if (seq !== checkSeq) return; // a newer check is under way
  if (r.ok) showDiagnostics(r.v); else $('check-summary').textContent = r.v.error;
}

$('apply').onclick = async () => {
  clearTimeout(checkTimer);
  checkSeq++;
  const r = await api('POST', '/api/apply', texts());
  if (r.v.check) showDiagnostics(r.v.check);
  if (!r.ok) { $('check-summary').textContent = r.v.error; $('check-summary').className = 'bad'; return; }
  S.running = false;
  S.selected = null;
  S.fitted = false;
  $('inspector').textContent = 'Click an agent.';
  showTab('view');
  showFrame(r.v.frame);
  showStatus();
};

function showStatus() {
  $('status').textContent = `${editors.rules.path.value} + ${editors.agents.path.value}`;
}

// ---------------------------------------------------------------- start

async function start() {
  const r = await api('GET', '/api/session');
  if (!r.ok) { setNote(r.v.error); return; }
  const s = r.v;
  S.session = s;
  editors.rules.text.value = s.rules;
  editors.agents.text.value = s.agents;
  editors.rules.path.value = s.rules_path;
  editors.agents.path.value = s.agents_path;
  showDiagnostics(s.check);
  showStatus();
  resize();
  if (s.running) {
    await gotoStep(0);
  } else {
    setNote(s.rules ? 'the files have errors: see the editor' : 'open a rules and an agents file in the editor');
    showTab('edit');
  }
  window.latticesim.ready = true;
}

// For tests and measurements (e2e/): where an agent is drawn, the frame, showing a frame,
// drawing and zooming.
window.latticesim = { screenOf, frame: () => S.frame, show: showFrame, draw, zoom, ready: false };
window.addEventListener('resize', resize);
start();
