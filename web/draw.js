// The canvas: drawing the frame shown (2D in draw2d.js, 3D in draw3d.js, both through
// the camera of camera.js), fitting, zooming and picking.

import { $ } from './api.js';
import { camera, fitTo, project as projectCell, zoomAt } from './camera.js';
import { centre2d, draw2d, pick2d } from './draw2d.js';
import { centre3d, draw3d, pick3d, universeBox } from './draw3d.js';
import { centreGL, drawGL, glReady, pickGL } from './gl3d.js';
import { player } from './state.js';

export const canvas = $('canvas');
const ctx = canvas.getContext('2d');
// Under the canvas: WebGL2 draws 3D frames there (the canvas then holds only the
// universe's box), where the browser has it on a GPU (or the page's URL has `?webgl`);
// else, or with `?canvas3d`, the canvas draws them itself.
const glCanvas = $('gl');
let useGL = null;
function webgl() {
  if (useGL === null) {
    const q = new URLSearchParams(location.search);
    try { useGL = !q.has('canvas3d') && glReady(glCanvas, q.has('webgl')); } catch (e) { console.warn('WebGL2 3D view unavailable: ' + e.message); useGL = false; }
  }
  return useGL;
}

export function resize() {
  const r = canvas.getBoundingClientRect();
  const dpr = window.devicePixelRatio || 1;
  canvas.width = Math.max(1, Math.round(r.width * dpr));
  canvas.height = Math.max(1, Math.round(r.height * dpr));
  glCanvas.width = canvas.width;
  glCanvas.height = canvas.height;
  ctx.setTransform(dpr, 0, 0, dpr, 0, 0);
  draw();
}

export function draw() {
  const f = player.frame;
  const r = canvas.getBoundingClientRect();
  ctx.clearRect(0, 0, r.width, r.height);
  const gl3 = !!f && f.dim === 3 && webgl();
  glCanvas.hidden = !gl3;
  if (!f) return;
  if (f.dim === 2) draw2d(ctx, f, r);
  else if (gl3) { drawGL(glCanvas, f, r.width, r.height); universeBox(ctx, f); }
  else draw3d(ctx, f, r);
  document.dispatchEvent(new CustomEvent('latticesim:drawn'));
}

// The view as shown, as a PNG image (a Blob): the WebGL layer under the canvas when it
// draws, the canvas over it, on white.
export function viewImage() {
  const out = composeView(document.createElement('canvas'));
  return new Promise((done) => out.toBlob(done, 'image/png'));
}

// The view as shown (the WebGL layer under the 2D one, on white), drawn into canvas `out`
// (made the view's size): for PNG and the WebM recording.
export function composeView(out) {
  draw();
  if (out.width !== canvas.width || out.height !== canvas.height) {
    out.width = canvas.width;
    out.height = canvas.height;
  }
  const c = out.getContext('2d');
  c.fillStyle = '#fff';
  c.fillRect(0, 0, out.width, out.height);
  if (!glCanvas.hidden) c.drawImage(glCanvas, 0, 0);
  c.drawImage(canvas, 0, 0);
  return out;
}

// Puts agent `id` of the frame shown in the middle of the view, at the same zoom.
export function centreOn(id) {
  const f = player.frame, r = canvas.getBoundingClientRect();
  if (!f || id >= f.pos.length / f.dim) return;
  const p = [0, 1, 2].map((k) => (k < f.dim ? f.pos[f.dim * id + k] + 0.5 : 0.5));
  if (f.dim === 2) {
    camera.ox = r.width / 2 - p[0] * camera.scale;
    camera.oy = r.height / 2 + p[1] * camera.scale;
  } else {
    camera.centre = p;
    camera.ox = r.width / 2;
    camera.oy = r.height / 2;
  }
}

// Shows every agent, and the universe's bounds when they are not much larger.
export function fit() {
  if (!player.frame) return;
  fitTo(player.frame, canvas.getBoundingClientRect());
  draw();
}

// Zooms by `k` keeping canvas point (mx, my) (default: the centre) in place.
export function zoom(k, mx, my) {
  zoomAt(k, mx, my, canvas.getBoundingClientRect());
  draw();
}

// The agent drawn at canvas point (x, y), or null.
export function pick(x, y) {
  const f = player.frame;
  if (!f) return null;
  if (f.dim === 2) return pick2d(f, x, y);
  if (webgl()) { const r = canvas.getBoundingClientRect(); return pickGL(glCanvas, f, x, y, r.width, r.height); }
  return pick3d(x, y);
}

// Where the point at height `h` (0 to 1, default the middle) above the centre of agent
// `id`'s cell is projected in 3D, in page coordinates, whether the agent is drawn or not
// (for tests and scripts).
export function project(id, h = 0.5) {
  const f = player.frame, r = canvas.getBoundingClientRect();
  const p = projectCell(f.pos[3 * id] + 0.5, f.pos[3 * id + 1] + 0.5, f.pos[3 * id + 2] + h);
  return [r.left + p[0], r.top + p[1]];
}

// Where agent `id` is drawn, in page coordinates (for tests and scripts).
// Whether WebGL2 draws the 3D view (for tests).
export function usesWebGL() { return webgl(); }

export function screenOf(id) {
  const f = player.frame, r = canvas.getBoundingClientRect();
  const [x, y] = f.dim === 2 ? centre2d(f, id) : webgl() ? centreGL(f, id, projectCell) : centre3d(id);
  return [r.left + x, r.top + y];
}
