// Drawing a 2D frame: an image of one pixel per cell scaled up (a square per agent when
// they spread too far), the universe's outline, bonds and the marks of selected agents;
// and which agent stands at a point.

import { agentCount, bbox, camera } from './camera.js';
import { agentColour, MARKS, selection, stateColours } from './state.js';

// RGBA bytes of each state's colour in a little-endian word (0xAABBGGRR); 0 (transparent)
// for a hidden state.
function word(hex) {
  if (hex === null) return 0;
  const v = parseInt(hex.slice(1), 16);
  return (0xff000000 | ((v & 0xff) << 16) | (v & 0xff00) | (v >> 16)) >>> 0;
}

function words(f) {
  return stateColours(f).map(word);
}

// The image of the frame before, patched where agents changed (a delta frame whose agents
// all stay inside that image): their old cells cleared, their new cells painted. True when
// it was done. (The loops read local variables: a frame is a large object, slow to look
// into a million times.)
function patched(f) {
  const b = camera.bmp;
  if (!b || !b.canvas || !f.base || b.frame !== f.base || b.looks !== selection.looksVersion || f.values) return false;
  const ids = f.changedIds, pos = f.pos, state = f.state, old = f.oldPos, px = b.px;
  const [lx, ly] = b.lo, [hx, hy] = b.hi, w = hx - lx + 1;
  for (let k = 0; k < ids.length; k++) {
    const x = pos[2 * ids[k]], y = pos[2 * ids[k] + 1];
    if (x < lx || x > hx || y < ly || y > hy) return false;
  }
  const cols = words(f);
  for (let k = 0; k < ids.length; k++) px[(hy - old[2 * k + 1]) * w + (old[2 * k] - lx)] = 0;
  for (let k = 0; k < ids.length; k++) {
    const i = ids[k];
    px[(hy - pos[2 * i + 1]) * w + (pos[2 * i] - lx)] = cols[state[i]];
  }
  if (ids.length) b.ctx.putImageData(b.img, 0, 0);
  b.frame = f;
  camera.patches = (camera.patches || 0) + 1;
  return true;
}

// The 2D frame as an image of one pixel per cell (north up), made once per frame (or
// patched from the one before); none when the agents' bounding box has more than 16
// million cells.
function bitmap(f) {
  if (camera.bmp && camera.bmp.frame === f && camera.bmp.looks === selection.looksVersion) return camera.bmp;
  if (patched(f)) return camera.bmp;
  const b = bbox(f);
  const w = b.hi[0] - b.lo[0] + 1, h = b.hi[1] - b.lo[1] + 1;
  camera.bmp = { frame: f, canvas: null, lo: b.lo, hi: b.hi, looks: selection.looksVersion };
  if (agentCount(f) === 0 || w * h > 16e6) return camera.bmp;
  const c = document.createElement('canvas');
  c.width = w;
  c.height = h;
  const cx = c.getContext('2d');
  const img = cx.createImageData(w, h);
  const px = new Uint32Array(img.data.buffer);
  const cols = words(f);
  const states = stateColours(f);
  const pos = f.pos, state = f.state, lx = b.lo[0], hy = b.hi[1], n = agentCount(f);
  const byValue = selection.colourBy && f.values;
  for (let i = 0; i < n; i++) {
    const c = byValue ? agentColour(f, states, i) : null;
    px[(hy - pos[2 * i + 1]) * w + (pos[2 * i] - lx)] = c === null ? cols[state[i]] : word(c);
  }
  cx.putImageData(img, 0, 0);
  Object.assign(camera.bmp, { canvas: c, ctx: cx, img, px });
  return camera.bmp;
}

export function draw2d(ctx, f, r) {
  const s = camera.scale, n = agentCount(f);
  const gap = s >= 6 ? Math.max(1, s * 0.06) : 0;
  // Cells on screen, to skip agents outside the view.
  const x0 = Math.floor(-camera.ox / s) - 1, x1 = Math.ceil((r.width - camera.ox) / s) + 1;
  const y0 = Math.floor((camera.oy - r.height) / s) - 1, y1 = Math.ceil(camera.oy / s) + 1;
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
    const colours = stateColours(f);
    const groups = f.states.map(() => []);
    for (let i = 0; i < n; i++) {
      const x = f.pos[2 * i], y = f.pos[2 * i + 1];
      if (x < x0 || x > x1 || y < y0 || y > y1) continue;
      groups[f.state[i]].push(i);
    }
    const w = Math.max(s - 2 * gap, 0.6);
    groups.forEach((g, k) => {
      if (colours[k] === null) return;
      ctx.fillStyle = colours[k];
      for (const i of g) {
        if (selection.colourBy && f.values) ctx.fillStyle = agentColour(f, colours, i);
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
  // The universe's outline, on top of the agents and the gaps between them.
  if (f.universe) {
    const u = f.universe;
    ctx.strokeStyle = '#888';
    ctx.lineWidth = 2;
    const clamp = (v) => Math.max(-1e6, Math.min(1e6, v));
    ctx.strokeRect(clamp(camera.ox + u[0][0] * s), clamp(camera.oy - (u[1][1] + 1) * s),
      clamp((u[0][1] - u[0][0] + 1) * s), clamp((u[1][1] - u[1][0] + 1) * s));
  }
  const ring = (i, colour, width) => {
    ctx.strokeStyle = colour;
    ctx.lineWidth = width;
    ctx.strokeRect(camera.ox + f.pos[2 * i] * s - 1, camera.oy - (f.pos[2 * i + 1] + 1) * s - 1, s + 2, s + 2);
  };
  const [ho, hi] = MARKS.highlight, [so, si] = MARKS.selected;
  for (const i of selection.highlight) { ring(i, ho, 4); ring(i, hi, 2); }
  if (selection.selected !== null && selection.selected < n) { ring(selection.selected, so, 4); ring(selection.selected, si, 2); }
}

// The agent at canvas point (x, y) of frame `f`, or null.
// The agent on the cell under the point; else the nearest drawn within `PICK_PX` pixels
// (at the fitted zoom of a large configuration a cell is smaller than a pixel, and a click
// would hit nothing). Agents of hidden states are not picked.
export const PICK_PX = 6;

// The cell under canvas point (x, y).
export function cellAt2d(x, y) {
  return [Math.floor((x - camera.ox) / camera.scale), Math.floor((camera.oy - y) / camera.scale)];
}

export function pick2d(f, x, y) {
  const [cx, cy] = cellAt2d(x, y);
  const colours = stateColours(f);
  let best = null, bestD = PICK_PX * PICK_PX;
  for (let i = 0; i < agentCount(f); i++) {
    if (colours[f.state[i]] === null) continue;
    const px = f.pos[2 * i], py = f.pos[2 * i + 1];
    if (px === cx && py === cy) return i;
    const dx = camera.ox + (px + 0.5) * camera.scale - x, dy = camera.oy - (py + 0.5) * camera.scale - y;
    const d = dx * dx + dy * dy;
    if (d < bestD) { bestD = d; best = i; }
  }
  return best;
}

// Where agent `id` of frame `f` is drawn, in canvas coordinates.
export function centre2d(f, id) {
  return [camera.ox + (f.pos[2 * id] + 0.5) * camera.scale, camera.oy - (f.pos[2 * id + 1] + 0.5) * camera.scale];
}
