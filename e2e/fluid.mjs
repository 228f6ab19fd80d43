// How fluid the viewer is with many agents: `node e2e/fluid.mjs RULES AGENTS [STEPS]`
// (from the repository's root, after `cargo build --release`) serves the files, runs STEPS
// steps in headless Chromium as the Run button does, and prints per-step times (request,
// JSON, drawing) and the drawing time at other zooms and while panning. docs/viewer.md
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
    const per = [];
    for (let s = 1; s <= steps; s++) {
      const t0 = performance.now();
      const resp = await fetch('/api/frame?step=' + s);
      const text = await resp.text();
      const t1 = performance.now();
      const f = JSON.parse(text);
      const t2 = performance.now();
      L.show(f);
      document.getElementById('canvas').getContext('2d').getImageData(0, 0, 1, 1);
      const t3 = performance.now();
      per.push([t1 - t0, t2 - t1, t3 - t2, text.length]);
    }
    const med = (k) => per.map((p) => p[k]).sort((a, b) => a - b)[Math.floor(per.length / 2)];
    const drawAt = (zoom) => {
      L.zoom(zoom);
      const t = performance.now();
      // Reading a pixel back waits until the drawing is really done.
      const ctx = document.getElementById('canvas').getContext('2d');
      for (let i = 0; i < 10; i++) { L.draw(); ctx.getImageData(0, 0, 1, 1); }
      return (performance.now() - t) / 10;
    };
    return {
      agents: L.frame().pos.length / L.frame().dim,
      request: med(0), json: med(1), show: med(2), bytes: med(3),
      drawFit: drawAt(1), drawZoom8: drawAt(8), drawZoomOut: drawAt(1 / 8),
    };
  }, steps);
  const ms = (v) => v.toFixed(1) + ' ms';
  console.log(`${r.agents} agents, median of ${steps} steps: request ${ms(r.request)} (${(r.bytes / 1e6).toFixed(1)} MB), JSON ${ms(r.json)}, show (legend, records, drawing) ${ms(r.show)}`);
  console.log(`drawing alone: fitted ${ms(r.drawFit)}, zoomed in 8x ${ms(r.drawZoom8)}, zoomed out 8x ${ms(r.drawZoomOut)}`);
} finally {
  await browser.close();
  server.kill();
}
