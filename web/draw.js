// The canvas: drawing the frame shown (2D in draw2d.js, 3D in draw3d.js, both through
// the camera of camera.js), fitting, zooming and picking.

import { $ } from './api.js';
import { camera, fitTo, project as projectCell, zoomAt } from './camera.js';
import { centre2d, draw2d, pick2d } from './draw2d.js';
import { centre3d, draw3d, pick3d } from './draw3d.js';
import { player } from './state.js';

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

export function draw() {
  const f = player.frame;
  const r = canvas.getBoundingClientRect();
  ctx.clearRect(0, 0, r.width, r.height);
  if (!f) return;
  if (f.dim === 2) draw2d(ctx, f, r); else draw3d(ctx, f, r);
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
  return f.dim === 2 ? pick2d(f, x, y) : pick3d(x, y);
}

// Where the centre of agent `id`'s cell is projected in 3D, in page coordinates, whether it
// is drawn or not (for tests and scripts).
export function project(id) {
  const f = player.frame, r = canvas.getBoundingClientRect();
  const p = projectCell(f.pos[3 * id] + 0.5, f.pos[3 * id + 1] + 0.5, f.pos[3 * id + 2] + 0.5);
  return [r.left + p[0], r.top + p[1]];
}

// Where agent `id` is drawn, in page coordinates (for tests and scripts).
export function screenOf(id) {
  const f = player.frame, r = canvas.getBoundingClientRect();
  const [x, y] = f.dim === 2 ? centre2d(f, id) : centre3d(id);
  return [r.left + x, r.top + y];
}
