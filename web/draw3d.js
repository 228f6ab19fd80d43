// Drawing a 3D frame: isometric cubes sorted back to front (the faces that face the
// viewer, shaded), the universe's box, bonds and the marks of selected agents; and which
// agent's faces cover a point.

import { agentCount, camera, CORNERS, project } from './camera.js';
import { selection, stateColours } from './state.js';

function shade(hex, k) {
  const v = parseInt(hex.slice(1), 16);
  const c = [(v >> 16) & 255, (v >> 8) & 255, v & 255].map((x) => Math.round(x * k));
  return `rgb(${c[0]},${c[1]},${c[2]})`;
}

// Faces as corner indices with their outward normal in (x, y); the top has none.
const SIDES = [
  { c: [0, 3, 7, 4], n: [-1, 0] }, { c: [1, 2, 6, 5], n: [1, 0] },
  { c: [0, 1, 5, 4], n: [0, -1] }, { c: [3, 2, 6, 7], n: [0, 1] },
];
const TOP = [4, 5, 6, 7];

export function draw3d(ctx, f, r) {
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
  const colours = stateColours(f);
  const order = [];
  for (let i = 0; i < n; i++) {
    if (colours[f.state[i]] === null) continue; // a hidden state
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
    const colour = colours[f.state[i]];
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

// The agent whose drawn faces cover canvas point (x, y), the nearest first, or null.
export function pick3d(x, y) {
  for (let k = camera.faces.length - 1; k >= 0; k--) {
    const [i, polys] = camera.faces[k];
    if (polys.some((p) => inside(p, x, y))) return i;
  }
  return null;
}

// Where agent `id` is drawn (the centre of its top face), in canvas coordinates.
export function centre3d(id) {
  const entry = camera.faces.find((e) => e[0] === id);
  const top = entry[1][entry[1].length - 1];
  return [top.reduce((s, p) => s + p[0], 0) / top.length, top.reduce((s, p) => s + p[1], 0) / top.length];
}
