// latticesim viewer and editor: the entry point. Modules (each imports only those
// listed before it): api (the JSON API, DOM helpers), state (the run shown, the
// selection), camera, draw2d, draw3d, gl3d (3D in WebGL2), draw (the canvas), panel (legend, records,
// inspector), player (stepping, running), editor, input; log, breaks, timeline, edit,
// plots and minimap (the workbench's panels).

import { $, api, setTab, whenGone } from './api.js';
import { camera } from './camera.js';
import { draw, pick, project, resize, screenOf, usesWebGL, zoom } from './draw.js';
import { shade } from './draw3d.js';
import { editors, setText, showDiagnostics, showStatus, showTab } from './editor.js';
import { gotoStep, setNote, showFrame, stopRun } from './player.js';
import { MARKS, player } from './state.js';
import './input.js';
import './log.js';
import './breaks.js';
import './timeline.js';
import './edit.js';
import { heldSeries } from './plots.js';
import './minimap.js';

// ---------------------------------------------------------------- start

async function start() {
  // This tab's own session: its files and run, untouched by other tabs.
  whenGone((message) => {
    stopRun();
    $('status').textContent = message;
    $('status').className = 'gone';
    setNote(message);
  });
  const t = await api('POST', '/api/tab');
  if (!t.ok) { setNote(t.v.error); return; }
  setTab(t.v.tab);
  player.tab = t.v.tab;
  const r = await api('GET', '/api/session');
  if (!r.ok) { setNote(r.v.error); return; }
  const s = r.v;
  player.session = s;
  setText(editors.rules, s.rules, s.rules_bytes);
  setText(editors.agents, s.agents, s.agents_bytes);
  editors.rules.path.value = s.rules_path;
  editors.agents.path.value = s.agents_path;
  showDiagnostics(s.check);
  showStatus();
  resize();
  if (s.running) {
    await gotoStep(0);
  } else {
    setNote(s.rules ? 'the files have errors: see the editor' : 'open a rules and an agents file in the editor');
    showTab('edit');
  }
  window.latticesim.ready = true;
}

// For tests and measurements (e2e/): where an agent is drawn (page coordinates), the agent
// drawn at a canvas point, the frame, showing a frame, going to a step as the controls do,
// drawing and zooming.
window.latticesim = { marks: MARKS, shade, screenOf, pick, project, cell: () => camera.scale, patches: () => camera.patches || 0, webgl: usesWebGL, frame: () => player.frame, show: showFrame, goto: gotoStep, draw, zoom, series: heldSeries, ready: false };
window.addEventListener('resize', resize);
start();
