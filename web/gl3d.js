// Drawing a 3D frame with WebGL2: the visible faces of the cubes (and small boxes for the
// bonds in the gaps between them) as instanced quads with a depth buffer, so that what is
// nearer hides what is behind it whatever the view; picking by drawing agent ids into an
// offscreen buffer and reading the pixel under the pointer. The view is the camera's
// (camera.js): the same projection as the canvas drawing of draw3d.js, which stays the
// fallback where WebGL2 is missing.

import { camera } from './camera.js';
import { agentColour, MARKS, selection, stateColours } from './state.js';
import { BOND, BOND_RGB, DIRS, MARGIN, shown } from './draw3d.js';

const VS = `#version 300 es
in vec3 centre; in vec3 halves; in float face; in vec3 colour; in float id;
uniform vec2 rot;     // cos, sin of theta
uniform vec2 elev;    // cos, sin of phi
uniform vec3 middle;  // the camera's centre
uniform vec4 screen;  // scale, ox, oy (pixels), depth range
uniform vec2 size;    // canvas size in pixels
out vec3 c; flat out float pid;
const vec3 N[6] = vec3[6](vec3(-1,0,0), vec3(1,0,0), vec3(0,-1,0), vec3(0,1,0), vec3(0,0,-1), vec3(0,0,1));
const vec2 Q[6] = vec2[6](vec2(-1,-1), vec2(1,-1), vec2(1,1), vec2(-1,-1), vec2(1,1), vec2(-1,1));
void main() {
  int f = int(face);
  vec3 n = N[f];
  vec3 u = n.x != 0.0 ? vec3(0,1,0) : vec3(1,0,0);
  vec3 v = n.z != 0.0 ? vec3(0,1,0) : vec3(0,0,1);
  vec2 q = Q[gl_VertexID];
  vec3 p = centre + n * halves + (u * halves) * q.x + (v * halves) * q.y - middle;
  float xr = p.x * rot.x - p.y * rot.y, yr = p.x * rot.y + p.y * rot.x;
  float a = (xr - yr) * 0.70710678, b = (xr + yr) * 0.70710678;
  float sx = screen.y + a * 1.22474487 * screen.x;
  float sy = screen.z + (b * elev.y - p.z * elev.x) * 1.22474487 * screen.x;
  float depth = b * elev.x + p.z * elev.y;
  gl_Position = vec4(sx / size.x * 2.0 - 1.0, 1.0 - sy / size.y * 2.0, -depth / screen.w, 1.0);
  float nr = n.x * rot.x - n.y * rot.y;
  float k = n.z != 0.0 ? 1.0 : (nr > 0.0 ? 0.78 : 0.62);
  float lum = dot(colour, vec3(0.2126, 0.7152, 0.0722));
  c = mix(colour * k, vec3(1.0), (1.0 - k) * (1.0 - lum) * 0.6); // as draw3d.js shade()
  pid = id;
}`;

const FS = `#version 300 es
precision highp float;
in vec3 c; flat in float pid;
uniform int picking;
out vec4 o;
void main() {
  if (picking == 1) {
    float i = pid;
    o = vec4(mod(i, 256.0), mod(floor(i / 256.0), 256.0), floor(i / 65536.0), 255.0) / 255.0;
  } else {
    o = vec4(c, 1.0);
  }
}`;

let gl = null, prog = null, buffers = null, count = 0, built = null, pickFb = null;

// The renderer WebGL2 would use, when the browser says (e.g. "ANGLE (..., SwiftShader
// driver)" where there is no GPU).
export function rendererName(ctx) {
  const e = ctx.getExtension('WEBGL_debug_renderer_info');
  return e ? String(ctx.getParameter(e.UNMASKED_RENDERER_WEBGL)) : '';
}

// Whether WebGL2 draws the 3D view (false: the canvas drawing of draw3d.js). A renderer in
// software (SwiftShader, llvmpipe) draws cubes several times slower than the canvas does,
// so it is used only when `force` (the page's `?webgl`).
export function glReady(canvas, force) {
  if (gl) return true;
  if (gl === false) return false;
  const ctx = canvas.getContext('webgl2', { antialias: false, preserveDrawingBuffer: true });
  if (!ctx || (!force && /SwiftShader|llvmpipe|softpipe|Software/i.test(rendererName(ctx)))) {
    gl = false;
    return false;
  }
  gl = ctx;
  const sh = (type, src) => {
    const s = gl.createShader(type);
    gl.shaderSource(s, src);
    gl.compileShader(s);
    if (!gl.getShaderParameter(s, gl.COMPILE_STATUS)) throw new Error(gl.getShaderInfoLog(s));
    return s;
  };
  prog = gl.createProgram();
  gl.attachShader(prog, sh(gl.VERTEX_SHADER, VS));
  gl.attachShader(prog, sh(gl.FRAGMENT_SHADER, FS));
  gl.linkProgram(prog);
  if (!gl.getProgramParameter(prog, gl.LINK_STATUS)) throw new Error(gl.getProgramInfoLog(prog));
  buffers = {};
  for (const [name, size] of [['centre', 3], ['halves', 3], ['face', 1], ['colour', 3], ['id', 1]]) {
    const b = gl.createBuffer();
    const loc = gl.getAttribLocation(prog, name);
    gl.bindBuffer(gl.ARRAY_BUFFER, b);
    gl.enableVertexAttribArray(loc);
    gl.vertexAttribPointer(loc, size, gl.FLOAT, false, 0, 0);
    gl.vertexAttribDivisor(loc, 1);
    buffers[name] = { b, size };
  }
  return true;
}

const rgb = (hex) => { const v = parseInt(hex.slice(1), 16); return [(v >> 16) / 255, ((v >> 8) & 255) / 255, (v & 255) / 255]; };

// The instances of the frame: a quad per cube face with no agent drawn beyond it, and the
// six faces of a small box per bond. Made again when the frame, the looks, the slabs or
// the selection change, not when the view turns.
function instances(f) {
  const colours = stateColours(f);
  const { out, cells } = shown(f, colours);
  const key = `${selection.looksVersion}|${JSON.stringify(camera.clip)}|${selection.selected}|${[...selection.highlight].join(',')}|${selection.colourBy}`;
  if (built && built.frame === f && built.key === key) return;
  const centre = [], half = [], face = [], colour = [], id = [];
  const h = 0.5 - MARGIN;
  const push = (c, hs, fc, col, i) => { centre.push(...c); half.push(...hs); face.push(fc); colour.push(...col); id.push(i + 1); };
  for (const i of out) {
    const x = f.pos[3 * i], y = f.pos[3 * i + 1], z = f.pos[3 * i + 2];
    const col = rgb(selection.selected === i ? MARKS.selected[1] : selection.highlight.has(i) ? MARKS.highlight[1] : agentColour(f, colours, i));
    const c = [x + 0.5, y + 0.5, z + 0.5];
    // Faces: -x +x -y +y -z +z; the neighbours in those directions.
    const around = [[-1, 0, 0], [1, 0, 0], [0, -1, 0], [0, 1, 0], [0, 0, -1], [0, 0, 1]];
    around.forEach((d, fc) => { if (cells.at(x + d[0], y + d[1], z + d[2]) < 0) push(c, [h, h, h], fc, col, i); });
    if (f.attach && f.attach[i]) {
      DIRS.forEach((d, bit) => {
        if (!(f.attach[i] & (1 << bit)) || d.some((v) => v < 0)) return; // each bond once
        if (cells.at(x + d[0], y + d[1], z + d[2]) < 0) return;
        const bc = [c[0] + d[0] * 0.5, c[1] + d[1] * 0.5, c[2] + d[2] * 0.5];
        const bh = d.map((v) => (v ? MARGIN : BOND));
        for (let fc = 0; fc < 6; fc++) push(bc, bh, fc, BOND_RGB, -1);
      });
    }
  }
  for (const [name, data] of [['centre', centre], ['halves', half], ['face', face], ['colour', colour], ['id', id]]) {
    gl.bindBuffer(gl.ARRAY_BUFFER, buffers[name].b);
    gl.bufferData(gl.ARRAY_BUFFER, new Float32Array(data), gl.STATIC_DRAW);
  }
  count = face.length;
  built = { frame: f, key };
}

function uniforms(w, h, picking) {
  const U = (n) => gl.getUniformLocation(prog, n);
  gl.uniform2f(U('rot'), Math.cos(camera.theta), Math.sin(camera.theta));
  gl.uniform2f(U('elev'), Math.cos(camera.phi), Math.sin(camera.phi));
  gl.uniform3f(U('middle'), ...camera.centre);
  gl.uniform4f(U('screen'), camera.scale, camera.ox, camera.oy, 1e5);
  gl.uniform2f(U('size'), w, h);
  gl.uniform1i(U('picking'), picking ? 1 : 0);
}

// Draws frame `f` into the bound framebuffer of W x H pixels, for a canvas of CSS size
// (w, h): in colours on white, or (`picking`) as agent ids on nothing.
function render(f, W, H, w, h, picking) {
  gl.viewport(0, 0, W, H);
  gl.useProgram(prog);
  instances(f);
  uniforms(w, h, picking);
  gl.enable(gl.DEPTH_TEST);
  gl.clearColor(...(picking ? [0, 0, 0, 0] : [1, 1, 1, 1]));
  gl.clear(gl.COLOR_BUFFER_BIT | gl.DEPTH_BUFFER_BIT);
  gl.drawArraysInstanced(gl.TRIANGLES, 0, 6, count);
}

// Draws frame `f` into the WebGL canvas of CSS size (w, h).
export function drawGL(canvas, f, w, h) {
  render(f, canvas.width, canvas.height, w, h, false);
}

// The agent drawn at CSS point (x, y) of a canvas of CSS size (w, h), or null.
export function pickGL(canvas, f, x, y, w, h) {
  const [W, H] = [canvas.width, canvas.height];
  if (!pickFb || pickFb.w !== W || pickFb.h !== H) {
    const fb = gl.createFramebuffer(), tex = gl.createTexture(), depth = gl.createRenderbuffer();
    gl.bindTexture(gl.TEXTURE_2D, tex);
    gl.texImage2D(gl.TEXTURE_2D, 0, gl.RGBA8, W, H, 0, gl.RGBA, gl.UNSIGNED_BYTE, null);
    gl.bindRenderbuffer(gl.RENDERBUFFER, depth);
    gl.renderbufferStorage(gl.RENDERBUFFER, gl.DEPTH_COMPONENT24, W, H);
    gl.bindFramebuffer(gl.FRAMEBUFFER, fb);
    gl.framebufferTexture2D(gl.FRAMEBUFFER, gl.COLOR_ATTACHMENT0, gl.TEXTURE_2D, tex, 0);
    gl.framebufferRenderbuffer(gl.FRAMEBUFFER, gl.DEPTH_ATTACHMENT, gl.RENDERBUFFER, depth);
    pickFb = { fb, w: W, h: H };
  }
  gl.bindFramebuffer(gl.FRAMEBUFFER, pickFb.fb);
  render(f, W, H, w, h, true);
  const px = new Uint8Array(4);
  gl.readPixels(Math.round(x * W / w), Math.round(H - 1 - y * H / h), 1, 1, gl.RGBA, gl.UNSIGNED_BYTE, px);
  gl.bindFramebuffer(gl.FRAMEBUFFER, null);
  const id = px[0] + px[1] * 256 + px[2] * 65536;
  return id > 0 ? id - 1 : null;
}

// Where agent `id` is drawn: the centre of its face nearest the viewer from above or
// below (its top, or its bottom when the view is from below), in CSS canvas coordinates.
export function centreGL(f, id, project) {
  const up = camera.phi >= 0 ? 1 - MARGIN : MARGIN;
  const p = project(f.pos[3 * id] + 0.5, f.pos[3 * id + 1] + 0.5, f.pos[3 * id + 2] + up);
  return [p[0], p[1]];
}
