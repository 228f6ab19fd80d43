// The camera: scale, origin and rotation, the projection of 3D cells, fitting a frame
// and zooming about a point. It owns no drawing: draw.js and its 2D and 3D parts use it.

export const camera = {
  scale: 20,         // pixels per cell
  ox: 0, oy: 0,      // screen position of the world origin
  theta: 0,          // rotation about the vertical axis (3D)
  phi: Math.asin(1 / Math.sqrt(3)), // elevation of the view (3D; isometric at start)
  clip: [null, null, null], // 3D: per axis, the slab [lo, hi] of cells shown, or null
  faces: [],         // 3D: drawn faces, for picking
  fitted: false,
};

export function agentCount(f) { return f.pos.length / f.dim; }

export function bbox(f) {
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

// 3D: rotation about the vertical axis through the centre of the agents, then a parallel
// projection seen from the elevation `phi` (isometric at start): the screen point and the
// depth (larger is nearer the viewer).
const S = Math.sqrt(1.5);
export function project(x, y, z) {
  const c = camera.centre;
  const dx = x - c[0], dy = y - c[1], dz = z - c[2];
  const cs = Math.cos(camera.theta), sn = Math.sin(camera.theta);
  const xr = dx * cs - dy * sn, yr = dx * sn + dy * cs;
  const a = (xr - yr) / Math.SQRT2, b = (xr + yr) / Math.SQRT2;
  const sp = Math.sin(camera.phi), cp = Math.cos(camera.phi);
  return [camera.ox + a * S * camera.scale, camera.oy + (b * sp - dz * cp) * S * camera.scale, b * cp + dz * sp];
}

// Tilts the 3D view by `d` radians (kept between looking from the side and from above or
// below).
export function tilt(d) {
  camera.phi = Math.max(-1.5, Math.min(1.5, camera.phi + d));
}

// The eight corners of the box of cells `lo..hi` (3D), projected as the camera is.
function boxCorners(lo, hi) {
  return CORNERS.map((c) => project(c[0] ? hi[0] + 1 : lo[0], c[1] ? hi[1] + 1 : lo[1], c[2] ? hi[2] + 1 : lo[2]));
}

// Whether every agent of frame `f` is drawn inside a canvas of size `r` as the camera is.
export function inView(f, r) {
  const b = bbox(f);
  let pts;
  if (f.dim === 2) {
    pts = [[camera.ox + b.lo[0] * camera.scale, camera.oy - (b.hi[1] + 1) * camera.scale],
      [camera.ox + (b.hi[0] + 1) * camera.scale, camera.oy - b.lo[1] * camera.scale]];
  } else {
    pts = boxCorners(b.lo, b.hi);
  }
  return pts.every(([x, y]) => x >= 0 && y >= 0 && x <= r.width && y <= r.height);
}

// Sets the camera to show every agent of frame `f` in a canvas of size `r`, and the
// universe's bounds when they are not much larger.
export function fitTo(f, r) {
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
    const pts = boxCorners(lo, hi);
    const us = pts.map((p) => p[0]), vs = pts.map((p) => p[1]);
    const [u0, u1, v0, v1] = [Math.min(...us), Math.max(...us), Math.min(...vs), Math.max(...vs)];
    camera.scale = Math.max(0.05, Math.min(60, 0.9 * Math.min(r.width / (u1 - u0), r.height / (v1 - v0))));
    camera.ox = r.width / 2 - ((u0 + u1) / 2) * camera.scale;
    camera.oy = r.height / 2 - ((v0 + v1) / 2) * camera.scale;
  }
}

export const CORNERS = [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]];

// Zooms by `k` keeping canvas point (mx, my) (default: the centre of `r`) in place.
export function zoomAt(k, mx, my, r) {
  if (mx === undefined) { mx = r.width / 2; my = r.height / 2; }
  const s = Math.max(0.02, Math.min(200, camera.scale * k));
  const q = s / camera.scale;
  camera.ox = mx - (mx - camera.ox) * q;
  camera.oy = my - (my - camera.oy) * q;
  camera.scale = s;
}
