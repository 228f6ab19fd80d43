// How fluid the viewer is with many agents: `node e2e/fluid.mjs RULES AGENTS [STEPS]`
// (from the repository's root, after `cargo build --release`) serves the files, runs STEPS
// steps in headless Chromium as the Run button does (binary frames, deltas where smaller),
// and prints the steps per second, the median step and the drawing time at other zooms. docs/viewer.md
// reports its figures. LATTICESIM names the binary (default target/release/latticesim).
import { launch, serve } from './common.mjs';
import path from 'node:path';

const [rules, agents, stepsArg] = process.argv.slice(2);
if (!rules || !agents) {
  console.error('usage: node e2e/fluid.mjs RULES AGENTS [STEPS]');
  process.exit(2);
}
const steps = Number(stepsArg || 20);
const BIN = path.resolve(process.env.LATTICESIM || 'target/release/latticesim');
const { process: server, url: served } = serve(BIN, rules, agents);
const url = await served;
const browser = await launch();
try {
  const page = await browser.newPage({ viewport: { width: 1280, height: 800 } });
  await page.goto(url);
  await page.waitForFunction(() => window.latticesim && window.latticesim.ready);
  const r = await page.evaluate(async (steps) => {
    const L = window.latticesim;
    const ctx2d = document.getElementById('canvas').getContext('2d');
    // Reading a pixel back waits until the drawing is really done (WebGL's too, in 3D).
    const gl = L.webgl() && L.frame().dim === 3 ? document.getElementById('gl').getContext('webgl2') : null;
    const px = new Uint8Array(4);
    const ctx = { getImageData: () => { ctx2d.getImageData(0, 0, 1, 1); if (gl) gl.readPixels(0, 0, 1, 1, gl.RGBA, gl.UNSIGNED_BYTE, px); } };
    // As the Run button steps: the binary frame (a delta where smaller), decoded, shown.
    const per = [];
    const t0 = performance.now();
    for (let s = 1; s <= steps; s++) {
      const t = performance.now();
      await L.goto(s);
      ctx.getImageData(0, 0, 1, 1);
      per.push(performance.now() - t);
    }
    const rate = steps / ((performance.now() - t0) / 1000);
    const med = per.slice().sort((a, b) => a - b)[Math.floor(per.length / 2)];
    const last = await (await fetch('/api/frame?format=bin&step=' + steps)).arrayBuffer();
    const drawAt = (zoom) => {
      L.zoom(zoom);
      const t = performance.now();
      // Reading a pixel back waits until the drawing is really done.
      for (let i = 0; i < 10; i++) { L.draw(); ctx.getImageData(0, 0, 1, 1); }
      return (performance.now() - t) / 10;
    };
    return {
      webgl: !!gl,
      agents: L.frame().pos.length / L.frame().dim, dim: L.frame().dim,
      rate, step: med, bytes: last.byteLength,
      drawFit: drawAt(1), drawZoom8: drawAt(8), drawZoomOut: drawAt(1 / 8),
    };
  }, steps);
  const ms = (v) => v.toFixed(1) + ' ms';
  console.log(`${r.agents} agents (${r.dim}D), ${steps} steps as Run takes them: ${r.rate.toFixed(1)} steps/s, median step ${ms(r.step)} (request, decoding, legend, drawing; a whole frame is ${(r.bytes / 1e6).toFixed(2)} MB)`);
  console.log(`drawing alone${r.webgl ? ' (WebGL2)' : ''}: fitted ${ms(r.drawFit)} (${(1000 / r.drawFit).toFixed(0)} frames/s), zoomed in 8x ${ms(r.drawZoom8)}, zoomed out 8x ${ms(r.drawZoomOut)}`);
} finally {
  await browser.close();
  server.kill();
}
