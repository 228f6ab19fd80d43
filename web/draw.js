// The canvas: the camera (scale, origin, rotation), drawing in 2D and in 3D, picking.

import { $ } from './api.js';
import { player } from './player.js';
import { selection } from './panel.js';

export const camera = {
  scale: 20,         // pixels per cell
  ox: 0, oy: 0,      // screen position of the world origin
  theta: 0,          // rotation about the vertical axis (3D)
  faces: [],         // 3D: drawn faces, for picking
  fitted: false,
};

// ---------------------------------------------------------------- drawing

export const canvas = $('canvas');
const ctx = canvas.getContext('2d');

export function resize() {
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
  const c = camera.centre;
  const dx = x - c[0], dy = y - c[1];
  const cs = Math.cos(camera.theta), sn = Math.sin(camera.theta);
  const xr = dx * cs - dy * sn, yr = dx * sn + dy * cs;
  return [camera.ox + (xr - yr) * 0.866 * camera.scale, camera.oy + ((xr + yr) * 0.5 - (z - c[2])) * camera.scale, xr + yr];
}

// Shows every agent, and the universe's bounds when they are not much larger.
export function fit() {
  const f = player.frame;
  if (!f) return;
  const r = canvas.getBoundingClientRect();
  const b = bbox(f);
  const lo = b.lo.slice(), hi = b.hi.slice();
  if (f.universe) {
    const u = f.universe;
    const small = u.every(([l, h], k) => h - l <= 4 * (b.hi[k] - b.lo[k] + 1) + 16);
    if (small) u.forEach(([l, h], k) => { lo[k] = Math.min(lo[k], l); hi[k] = Math.max(hi[k], h); });
  }
  camera.centre = [(lo[0] + hi[0] + 1) / 2, (lo[1] + hi[1] + 1) / 2, (lo[2] + hi[2] + 1) / 2];
  if (f.dim === 2) {
    const w = hi[0] - lo[0] + 1, h = hi[1] - lo[1] + 1;
    camera.scale = Math.max(0.02, Math.min(60, 0.9 * Math.min(r.width / w, r.height / h)));
    camera.ox = r.width / 2 - camera.centre[0] * camera.scale;
    camera.oy = r.height / 2 + camera.centre[1] * camera.scale;
  } else {
    // The box's corners projected at scale 1 give the extent to fit.
    camera.scale = 1;
    camera.ox = 0;
    camera.oy = 0;
    const pts = CORNERS.map((c) => project(c[0] ? hi[0] + 1 : lo[0], c[1] ? hi[1] + 1 : lo[1], c[2] ? hi[2] + 1 : lo[2]));
    const us = pts.map((p) => p[0]), vs = pts.map((p) => p[1]);
    const [u0, u1, v0, v1] = [Math.min(...us), Math.max(...us), Math.min(...vs), Math.max(...vs)];
    camera.scale = Math.max(0.05, Math.min(60, 0.9 * Math.min(r.width / (u1 - u0), r.height / (v1 - v0))));
    camera.ox = r.width / 2 - ((u0 + u1) / 2) * camera.scale;
    camera.oy = r.height / 2 - ((v0 + v1) / 2) * camera.scale;
  }
  draw();
}

function shade(hex, k) {
  const v = parseInt(hex.slice(1), 16);
  const c = [(v >> 16) & 255, (v >> 8) & 255, v & 255].map((x) => Math.round(x * k));
  return `rgb(${c[0]},${c[1]},${c[2]})`;
}

export function draw() {
  const f = player.frame;
  const r = canvas.getBoundingClientRect();
  ctx.clearRect(0, 0, r.width, r.height);
  if (!f) return;
  if (f.dim === 2) draw2d(f, r); else draw3d(f, r);
}

// The 2D frame as an image of one pixel per cell (north up), made once per frame; none
// when the agents' bounding box has more than 16 million cells.
function bitmap(f) {
  if (camera.bmp && camera.bmp.frame === f) return camera.bmp;
  const b = bbox(f);
  const w = b.hi[0] - b.lo[0] + 1, h = b.hi[1] - b.lo[1] + 1;
  camera.bmp = { frame: f, canvas: null, lo: b.lo, hi: b.hi };
  if (agentCount(f) === 0 || w * h > 16e6) return camera.bmp;
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
  camera.bmp.canvas = c;
  return camera.bmp;
}

function draw2d(f, r) {
  const s = camera.scale, n = agentCount(f);
  const gap = s >= 6 ? Math.max(1, s * 0.06) : 0;
  // Cells on screen, to skip agents outside the view.
  const x0 = Math.floor(-camera.ox / s) - 1, x1 = Math.ceil((r.width - camera.ox) / s) + 1;
  const y0 = Math.floor((camera.oy - r.height) / s) - 1, y1 = Math.ceil(camera.oy / s) + 1;
  if (f.universe) {
    const u = f.universe;
    ctx.strokeStyle = '#888';
    ctx.lineWidth = 1;
    const clamp = (v) => Math.max(-1e6, Math.min(1e6, v));
    ctx.strokeRect(clamp(camera.ox + u[0][0] * s), clamp(camera.oy - (u[1][1] + 1) * s),
      clamp((u[0][1] - u[0][0] + 1) * s), clamp((u[1][1] - u[1][0] + 1) * s));
  }
  const bmp = bitmap(f);
  if (bmp.canvas) {
    // One pixel per cell, scaled up without smoothing: one image whatever the agent count.
    const [lo, hi] = [bmp.lo, bmp.hi];
    ctx.imageSmoothingEnabled = false;
    ctx.drawImage(bmp.canvas, camera.ox + lo[0] * s, camera.oy - (hi[1] + 1) * s,
      (hi[0] - lo[0] + 1) * s, (hi[1] - lo[1] + 1) * s);
    if (gap > 0) {
      // The gaps between cells, as white lines over the visible part of the image.
      ctx.fillStyle = '#fff';
      for (let x = Math.max(x0, lo[0]); x <= Math.min(x1, hi[0] + 1); x++) {
        ctx.fillRect(camera.ox + x * s - gap, camera.oy - (hi[1] + 1) * s, 2 * gap, (hi[1] - lo[1] + 1) * s);
      }
      for (let y = Math.max(y0, lo[1]); y <= Math.min(y1, hi[1] + 1); y++) {
        ctx.fillRect(camera.ox + lo[0] * s, camera.oy - y * s - gap, (hi[0] - lo[0] + 1) * s, 2 * gap);
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
        ctx.fillRect(camera.ox + f.pos[2 * i] * s + gap, camera.oy - (f.pos[2 * i + 1] + 1) * s + gap, w, w);
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
      const cx = camera.ox + (x + 0.5) * s, cy = camera.oy - (y + 0.5) * s;
      if (f.attach[i] & 1) { ctx.moveTo(cx, cy); ctx.lineTo(cx, cy - s); } // north
      if (f.attach[i] & 4) { ctx.moveTo(cx, cy); ctx.lineTo(cx + s, cy); } // east
    }
    ctx.stroke();
  }
  const ring = (i, colour, width) => {
    ctx.strokeStyle = colour;
    ctx.lineWidth = width;
    ctx.strokeRect(camera.ox + f.pos[2 * i] * s - 1, camera.oy - (f.pos[2 * i + 1] + 1) * s - 1, s + 2, s + 2);
  };
  for (const i of selection.highlight) { ring(i, '#000', 4); ring(i, '#ffd400', 2); }
  if (selection.selected !== null && selection.selected < n) { ring(selection.selected, '#fff', 4); ring(selection.selected, '#0050ff', 2); }
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
  const cs = Math.cos(camera.theta), sn = Math.sin(camera.theta);
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
    if (c[0] < -camera.scale * 2 || c[0] > r.width + camera.scale * 2 || c[1] < -camera.scale * 2 || c[1] > r.height + camera.scale * 2) continue;
    order.push([c[2] + f.pos[3 * i + 2], i]);
  }
  order.sort((a, b) => a[0] - b[0]);
  camera.faces = [];
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
      if (camera.scale >= 5) { ctx.strokeStyle = shade(colour, 0.45); ctx.lineWidth = 1; ctx.stroke(); }
      polys.push(idx.map((k) => pts[k]));
    };
    for (const sd of sides) face(sd.c, shade(colour, sd.k));
    face(TOP, colour);
    camera.faces.push([i, polys]);
    const mark = selection.highlight.has(i) ? '#ffd400' : selection.selected === i ? '#0050ff' : null;
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
    ctx.lineWidth = Math.max(1, camera.scale * 0.12);
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
export function pick(x, y) {
  const f = player.frame;
  if (!f) return null;
  if (f.dim === 2) {
    const cx = Math.floor((x - camera.ox) / camera.scale), cy = Math.floor((camera.oy - y) / camera.scale);
    for (let i = 0; i < agentCount(f); i++) {
      if (f.pos[2 * i] === cx && f.pos[2 * i + 1] === cy) return i;
    }
    return null;
  }
  for (let k = camera.faces.length - 1; k >= 0; k--) {
    const [i, polys] = camera.faces[k];
    if (polys.some((p) => inside(p, x, y))) return i;
  }
  return null;
}

// Where agent `id` is drawn, in page coordinates (for tests and scripts).
export function screenOf(id) {
  const f = player.frame, r = canvas.getBoundingClientRect();
  if (f.dim === 2) {
    return [r.left + camera.ox + (f.pos[2 * id] + 0.5) * camera.scale, r.top + camera.oy - (f.pos[2 * id + 1] + 0.5) * camera.scale];
  }
  const entry = camera.faces.find((e) => e[0] === id);
  const top = entry[1][entry[1].length - 1];
  const cx = top.reduce((s, p) => s + p[0], 0) / top.length, cy = top.reduce((s, p) => s + p[1], 0) / top.length;
  return [r.left + cx, r.top + cy];
}


// Zooms by `k` keeping canvas point (mx, my) (default: the centre) in place.
export function zoom(k, mx, my) {
  const r = canvas.getBoundingClientRect();
  if (mx === undefined) { mx = r.width / 2; my = r.height / 2; }
  const s = Math.max(0.02, Math.min(200, camera.scale * k));
  const q = s / camera.scale;
  camera.ox = mx - (mx - camera.ox) * q;
  camera.oy = my - (my - camera.oy) * q;
  camera.scale = s;
  draw();
}
