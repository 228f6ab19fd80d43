// The minimap (2D): when the view shows only part of the agents, a small picture of all of
// them in the corner of the view, the part shown outlined; a click or a drag on it centres
// the view there. Each pixel takes the colour of an agent in its cells (the last drawn).

import { $ } from './api.js';
import { bbox, camera } from './camera.js';
import { canvas, draw } from './draw.js';
import { player, selection, stateColours } from './state.js';

const mini = $('minimap');
const SIDE = 160;
// The picture of the agents, made again when the frame or the looks change.
let made = { frame: null, looks: -1, image: null, box: null, k: 1 };

function picture(f) {
  if (made.frame === f && made.looks === selection.looksVersion) return made;
  const b = boxOf(f);
  const w = b.hi[0] - b.lo[0] + 1, h = b.hi[1] - b.lo[1] + 1;
  const k = Math.min(SIDE / w, SIDE / h);
  const [pw, ph] = [Math.max(1, Math.ceil(w * k)), Math.max(1, Math.ceil(h * k))];
  const img = new ImageData(pw, ph);
  const rgb = stateColours(f).map((c) => (c === null ? null : [1, 3, 5].map((i) => parseInt(c.slice(i, i + 2), 16))));
  const n = f.pos.length / 2;
  for (let i = 0; i < n; i++) {
    const c = rgb[f.state[i]];
    if (!c) continue;
    const x = Math.min(pw - 1, Math.floor((f.pos[2 * i] - b.lo[0]) * k));
    const y = Math.min(ph - 1, Math.floor((b.hi[1] - f.pos[2 * i + 1]) * k));
    const o = 4 * (y * pw + x);
    img.data[o] = c[0]; img.data[o + 1] = c[1]; img.data[o + 2] = c[2]; img.data[o + 3] = 255;
  }
  made = { frame: f, looks: selection.looksVersion, image: img, box: b, k };
  return made;
}

// The agents' box, once a frame.
let boxed = { frame: null, box: null };
function boxOf(f) {
  if (boxed.frame !== f) boxed = { frame: f, box: bbox(f) };
  return boxed.box;
}

// The part of the lattice the view shows, in cells: [x0, y0, x1, y1].
function shown() {
  const r = canvas.getBoundingClientRect();
  return [-camera.ox / camera.scale, (camera.oy - r.height) / camera.scale, (r.width - camera.ox) / camera.scale, camera.oy / camera.scale];
}

function show() {
  const f = player.frame;
  if (!f || f.dim !== 2 || f.pos.length === 0) { mini.hidden = true; return; }
  const b = boxOf(f);
  const [x0, y0, x1, y1] = shown();
  // Everything in view: no minimap.
  if (b.lo[0] >= x0 && b.hi[0] + 1 <= x1 && b.lo[1] >= y0 && b.hi[1] + 1 <= y1) { mini.hidden = true; return; }
  const m = picture(f);
  mini.hidden = false;
  mini.width = m.image.width + 2;
  mini.height = m.image.height + 2;
  const c = mini.getContext('2d');
  c.fillStyle = '#fff';
  c.fillRect(0, 0, mini.width, mini.height);
  c.putImageData(m.image, 1, 1);
  // The view's outline, clipped to the picture.
  const X = (x) => 1 + (x - m.box.lo[0]) * m.k, Y = (y) => 1 + (m.box.hi[1] + 1 - y) * m.k;
  c.strokeStyle = '#0050ff';
  c.lineWidth = 1.5;
  c.strokeRect(X(x0), Y(y1), Math.max(2, (x1 - x0) * m.k), Math.max(2, (y1 - y0) * m.k));
  mini.dataset.view = [x0, y0, x1, y1].map((v) => v.toFixed(1)).join(',');
}

// Centres the view on the cell under minimap point (px, py).
function centre(px, py) {
  const m = made;
  if (!m.box) return;
  const x = m.box.lo[0] + (px - 1) / m.k, y = m.box.hi[1] + 1 - (py - 1) / m.k;
  const r = canvas.getBoundingClientRect();
  camera.ox = r.width / 2 - x * camera.scale;
  camera.oy = r.height / 2 + y * camera.scale;
  draw();
}

let dragging = false;
mini.addEventListener('mousedown', (e) => { dragging = true; centre(e.offsetX, e.offsetY); e.stopPropagation(); });
mini.addEventListener('mousemove', (e) => { if (dragging) centre(e.offsetX, e.offsetY); });
window.addEventListener('mouseup', () => { dragging = false; });
document.addEventListener('latticesim:drawn', show);
