// How fluid the viewer is with many agents: `node e2e/fluid.mjs RULES AGENTS [STEPS]`
// (from the repository's root, after `cargo build --release`) serves the files, presses
// Run at the highest speed in headless Chromium and waits for step STEPS, as a user
// would, then prints the steps per second, the median time between frames shown, the
// bytes a frame took on the wire, and the time of a redraw alone (zooming, panning,
// turning) at three zooms. docs/viewer.md reports its figures. LATTICESIM names the binary
// (default target/release/latticesim), CHROMIUM the browser.
import { open } from './cdp.mjs';
import { serve } from './common.mjs';
import path from 'node:path';

const [rules, agents, stepsArg] = process.argv.slice(2);
if (!rules || !agents) {
  console.error('usage: node e2e/fluid.mjs RULES AGENTS [STEPS]');
  process.exit(2);
}
const steps = Number(stepsArg || 20);
const BIN = path.resolve(process.env.LATTICESIM || 'target/release/latticesim');
const { process: server, url: served } = serve(BIN, rules, agents, (process.env.SERVE_ARGS || '').split(' ').filter(Boolean));
const url = await served;
const page = await open(url);
try {
  for (let i = 0; !(await page.evaluate('!!(window.latticesim && window.latticesim.ready)')); i++) {
    if (i > 600) throw new Error('the page did not start within a minute');
    await new Promise((res) => setTimeout(res, 100));
  }
  const r = await page.evaluate(`(async (steps) => {
    const L = window.latticesim, $ = (id) => document.getElementById(id);
    const ctx2d = $('canvas').getContext('2d');
    // Reading a pixel back waits until the drawing is really done (WebGL's too, in 3D).
    const gl = L.webgl() && L.frame().dim === 3 ? $('gl').getContext('webgl2') : null;
    const px = new Uint8Array(4);
    const finish = () => { ctx2d.getImageData(0, 0, 1, 1); if (gl) gl.readPixels(0, 0, 1, 1, gl.RGBA, gl.UNSIGNED_BYTE, px); };
    // Run at the highest speed, as a user presses it; the time each frame is shown.
    const shown = [];
    new MutationObserver(() => shown.push(performance.now())).observe($('step-number'), { childList: true, characterData: true, subtree: true });
    $('speed').value = $('speed').max;
    performance.clearResourceTimings();
    const t0 = performance.now();
    $('run').click();
    while (L.frame().step < steps && $('run').textContent.includes('Pause')) await new Promise((res) => setTimeout(res, 2));
    finish();
    const elapsed = performance.now() - t0, reached = L.frame().step;
    if ($('run').textContent.includes('Pause')) $('run').click();
    const gaps = shown.slice(1).map((t, i) => t - shown[i]).sort((a, b) => a - b);
    const frames = performance.getEntriesByType('resource').filter((e) => e.name.includes('/api/frame'));
    const wire = frames.reduce((s, e) => s + e.encodedBodySize, 0) / Math.max(1, frames.length);
    const drawAt = (zoom) => {
      L.zoom(zoom);
      const t = performance.now();
      for (let i = 0; i < 10; i++) { L.draw(); finish(); }
      return (performance.now() - t) / 10;
    };
    return {
      webgl: !!gl, agents: L.frame().pos.length / L.frame().dim, dim: L.frame().dim, reached,
      rate: reached / (elapsed / 1000), gap: gaps[Math.floor(gaps.length / 2)] || 0, wire,
      drawFit: drawAt(1), drawZoom8: drawAt(8), drawZoomOut: drawAt(1 / 8),
    };
  })(${steps})`);
  const ms = (v) => v.toFixed(1) + ' ms';
  console.log(`${r.agents} agents (${r.dim}D), Run at the highest speed to step ${r.reached}: ${r.rate.toFixed(1)} steps/s, median ${ms(r.gap)} between frames, ${(r.wire / 1e3).toFixed(1)} kB a frame on the wire`);
  console.log(`drawing alone${r.webgl ? ' (WebGL2)' : ''}: fitted ${ms(r.drawFit)} (${(1000 / r.drawFit).toFixed(0)} frames/s), zoomed in 8x ${ms(r.drawZoom8)}, zoomed out 8x ${ms(r.drawZoomOut)}`);
} finally {
  page.close();
  server.kill();
}
