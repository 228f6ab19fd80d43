// Drawing a 3D frame: isometric cubes sorted back to front (the faces that face the
// viewer, shaded), the universe's box, bonds and the marks of selected agents; and which
// agent's faces cover a point.

import { agentCount, bbox, camera, CORNERS, project } from './camera.js';
import { agentColour, MARKS, selection, stateColours } from './state.js';

// A side face's colour: darkened by `k` (1 for the top), and for a dark colour lifted
// toward white by what it lost, the more the darker it is: the sides of a dark colour
// (Tol's indigo #332288) stay apart from black and from each other. The WebGL shader
// (gl3d.js) does the same.
export function shade(hex, k) {
  const v = parseInt(hex.slice(1), 16);
  const rgb = [(v >> 16) & 255, (v >> 8) & 255, v & 255].map((x) => x / 255);
  const lum = 0.2126 * rgb[0] + 0.7152 * rgb[1] + 0.0722 * rgb[2];
  const lift = (1 - k) * (1 - lum) * 0.6;
  const c = rgb.map((x) => Math.round(255 * (x * k * (1 - lift) + lift)));
  return `rgb(${c[0]},${c[1]},${c[2]})`;
}

// Faces as corner indices with their outward normal; cubes are drawn a little smaller than
// their cells, so that bonds show in the gaps between them.
const FACES = [
  { c: [0, 3, 7, 4], n: [-1, 0, 0] }, { c: [1, 2, 6, 5], n: [1, 0, 0] },
  { c: [0, 1, 5, 4], n: [0, -1, 0] }, { c: [3, 2, 6, 7], n: [0, 1, 0] },
  { c: [0, 1, 2, 3], n: [0, 0, -1] }, { c: [4, 5, 6, 7], n: [0, 0, 1] },
];
export const MARGIN = 0.1;
// A bond: a bar across the gap, `BOND` of a cell from its axis to its side, in the grey the
// palette keeps away from (no state is drawn in it), light against dark faces and dark
// against light ones.
export const BOND = 0.12;
export const BOND_RGB = [150 / 255, 150 / 255, 150 / 255];
// The six neighbours' offsets, and the bonds' bits with their directions (N W E S A B).
export const DIRS = [[0, 1, 0], [-1, 0, 0], [1, 0, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]];

// Cells to agents: a grid over the agents' bounding box (a map when that box is huge);
// `at(x, y, z)` is the agent there or -1.
function cellIndex(f, n) {
  const b = bbox(f);
  const w = b.hi[0] - b.lo[0] + 3, h = b.hi[1] - b.lo[1] + 3, d = b.hi[2] - b.lo[2] + 3;
  const id = (x, y, z) => ((x - b.lo[0] + 1) * h + (y - b.lo[1] + 1)) * d + (z - b.lo[2] + 1);
  const inside = (x, y, z) => x >= b.lo[0] - 1 && x <= b.hi[0] + 1 && y >= b.lo[1] - 1 && y <= b.hi[1] + 1 && z >= b.lo[2] - 1 && z <= b.hi[2] + 1;
  if (w * h * d <= 1 << 24) {
    const grid = new Int32Array(w * h * d).fill(-1);
    return { set: (x, y, z, i) => { grid[id(x, y, z)] = i; }, at: (x, y, z) => (inside(x, y, z) ? grid[id(x, y, z)] : -1) };
  }
  const map = new Map();
  return { set: (x, y, z, i) => map.set(id(x, y, z), i), at: (x, y, z) => (inside(x, y, z) ? map.get(id(x, y, z)) ?? -1 : -1) };
}

// The agents drawn: not of a hidden state, inside the slabs of camera.clip, and not
// hidden on every side by other agents drawn (a solid block shows only its skin); with
// the index of the cells of the agents kept (for bonds). Made again only when the frame,
// the legend's looks or the slabs change, not when the view turns.
export function shown(f, colours) {
  const clipKey = JSON.stringify(camera.clip);
  const c = camera.shown;
  if (c && c.frame === f && c.looks === selection.looksVersion && c.clip === clipKey) return c;
  const n = agentCount(f);
  const clip = camera.clip;
  const cells = cellIndex(f, n);
  const keep = new Uint8Array(n);
  for (let i = 0; i < n; i++) {
    if (colours[f.state[i]] === null) continue;
    let ok = true;
    for (let k = 0; k < 3; k++) {
      const s = clip[k], v = f.pos[3 * i + k];
      if (s && (v < s[0] || v > s[1])) ok = false;
    }
    if (!ok) continue;
    keep[i] = 1;
    cells.set(f.pos[3 * i], f.pos[3 * i + 1], f.pos[3 * i + 2], i);
  }
  const out = [];
  for (let i = 0; i < n; i++) {
    if (!keep[i]) continue;
    const x = f.pos[3 * i], y = f.pos[3 * i + 1], z = f.pos[3 * i + 2];
    if (DIRS.every((d) => cells.at(x + d[0], y + d[1], z + d[2]) >= 0)) continue;
    out.push(i);
  }
  camera.shown = { frame: f, looks: selection.looksVersion, clip: clipKey, out, cells };
  return camera.shown;
}

// The universe's box, in grey lines.
export function universeBox(ctx, f) {
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
}

export function draw3d(ctx, f, r) {
  const cs = Math.cos(camera.theta), sn = Math.sin(camera.theta);
  const sp = Math.sin(camera.phi), cp = Math.cos(camera.phi);
  // The faces that face the viewer, and their shade: the depth of a face's normal > 0.
  const faces = FACES.map((fc) => {
    const [nx, ny, nz] = fc.n;
    const b = ((nx * cs - ny * sn) + (nx * sn + ny * cs)) / Math.SQRT2;
    const toward = b * cp + nz * sp;
    const xr = nx * cs - ny * sn;
    return { c: fc.c, toward, k: nz !== 0 ? 1 : xr > 0 ? 0.78 : 0.62 };
  }).filter((fc) => fc.toward > 1e-9).sort((a, b) => a.toward - b.toward);
  universeBox(ctx, f);
  const colours = stateColours(f);
  const { out, cells } = shown(f, colours);
  const order = [];
  for (const i of out) {
    const c = project(f.pos[3 * i] + 0.5, f.pos[3 * i + 1] + 0.5, f.pos[3 * i + 2] + 0.5);
    if (c[0] < -camera.scale * 2 || c[0] > r.width + camera.scale * 2 || c[1] < -camera.scale * 2 || c[1] > r.height + camera.scale * 2) continue;
    order.push([c[2], i]);
  }
  order.sort((a, b) => a[0] - b[0]);
  camera.faces = [];
  ctx.lineJoin = 'round';
  const lo = MARGIN, hi = 1 - MARGIN;
  for (const [, i] of order) {
    const x = f.pos[3 * i], y = f.pos[3 * i + 1], z = f.pos[3 * i + 2];
    const pts = CORNERS.map((c) => project(x + (c[0] ? hi : lo), y + (c[1] ? hi : lo), z + (c[2] ? hi : lo)));
    const colour = agentColour(f, colours, i);
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
    for (const fc of faces) face(fc.c, fc.k === 1 ? colour : shade(colour, fc.k));
    camera.faces.push([i, polys]);
    const mark = selection.highlight.has(i) ? MARKS.highlight : selection.selected === i ? MARKS.selected : null;
    if (mark) {
      // The outer colour wide, the inner one over it.
      for (const [colour, width] of [[mark[0], 5], [mark[1], 3]]) {
        ctx.strokeStyle = colour;
        ctx.lineWidth = width;
        for (const poly of polys) {
          ctx.beginPath();
          poly.forEach((p, j) => (j ? ctx.lineTo(p[0], p[1]) : ctx.moveTo(p[0], p[1])));
          ctx.closePath();
          ctx.stroke();
        }
      }
    }
    // Its bonds towards nearer neighbours, in the gaps: drawn over this cube, under them.
    if (f.attach && f.attach[i]) {
      ctx.strokeStyle = '#969696';
      ctx.lineWidth = Math.max(2, camera.scale * 2 * BOND);
      ctx.beginPath();
      const c0 = project(x + 0.5, y + 0.5, z + 0.5);
      DIRS.forEach((d, bit) => {
        if (!(f.attach[i] & (1 << bit))) return;
        if (cells.at(x + d[0], y + d[1], z + d[2]) < 0) return;
        const c1 = project(x + 0.5 + d[0], y + 0.5 + d[1], z + 0.5 + d[2]);
        if (c1[2] < c0[2]) return; // the farther cube draws it
        const a = project(x + 0.5 + d[0] * (0.5 - MARGIN), y + 0.5 + d[1] * (0.5 - MARGIN), z + 0.5 + d[2] * (0.5 - MARGIN));
        const b = project(x + 0.5 + d[0] * (0.5 + MARGIN), y + 0.5 + d[1] * (0.5 + MARGIN), z + 0.5 + d[2] * (0.5 + MARGIN));
        ctx.moveTo(a[0], a[1]);
        ctx.lineTo(b[0], b[1]);
      });
      ctx.stroke();
    }
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

// Where agent `id` is drawn (the centre of its nearest face), in canvas coordinates.
export function centre3d(id) {
  const entry = camera.faces.find((e) => e[0] === id);
  const top = entry[1][entry[1].length - 1];
  return [top.reduce((s, p) => s + p[0], 0) / top.length, top.reduce((s, p) => s + p[1], 0) / top.length];
}
