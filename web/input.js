// Mouse and keys on the view, and the toolbar buttons.

import { $, saveBlob } from './api.js';
import { camera, tilt } from './camera.js';
import { canvas, draw, fit, pick, viewImage, zoom } from './draw.js';
import { inspect } from './panel.js';
import { currentStep, gotoStep, refreshFrame, stopRun, toggleRun } from './player.js';
import { player, selection } from './state.js';

// ---------------------------------------------------------------- mouse and keys

let drag = null;
// Dragging pans in 2D; in 3D it orbits (left and right turn about the vertical axis, up
// and down tilt), and shift-drag or right-drag pans.
canvas.addEventListener('mousedown', (e) => {
  const three = player.frame && player.frame.dim === 3;
  drag = { x: e.clientX, y: e.clientY, moved: false, rotate: three && !e.shiftKey && e.button !== 2 };
  canvas.style.cursor = 'grabbing';
});
window.addEventListener('mousemove', (e) => {
  if (!drag) return;
  const dx = e.clientX - drag.x, dy = e.clientY - drag.y;
  if (Math.abs(dx) + Math.abs(dy) > 3) drag.moved = true;
  if (!drag.moved) return;
  if (drag.rotate) { camera.theta += dx * 0.01; tilt(dy * 0.01); }
  else { camera.ox += dx; camera.oy += dy; }
  drag.x = e.clientX;
  drag.y = e.clientY;
  draw();
});
window.addEventListener('mouseup', (e) => {
  if (!drag) return;
  const clicked = !drag.moved;
  drag = null;
  canvas.style.cursor = 'grab';
  if (!clicked) return;
  const r = canvas.getBoundingClientRect();
  const [x, y] = [e.clientX - r.left, e.clientY - r.top];
  // While editing, the editor (edit.js) decides what a click does.
  if (player.editing) {
    document.dispatchEvent(new CustomEvent('latticesim:edit-click', { detail: { x, y } }));
    return;
  }
  const id = pick(x, y);
  if (id !== null) inspect(id);
});
canvas.addEventListener('contextmenu', (e) => e.preventDefault());

canvas.addEventListener('wheel', (e) => {
  e.preventDefault();
  const r = canvas.getBoundingClientRect();
  zoom(Math.exp(-e.deltaY * 0.0015), e.clientX - r.left, e.clientY - r.top);
}, { passive: false });

// Keys go to the universe unless a field that takes typing has focus (the step number,
// the editors); a slider or a button keeps no keys: the arrows step, never the speed.
export function typing(el) {
  return el.tagName === 'TEXTAREA' || (el.tagName === 'INPUT' && !['range', 'checkbox', 'color'].includes(el.type));
}

document.addEventListener('keydown', (e) => {
  if (typing(e.target)) return;
  // `?` shows the keys (in either tab); Esc or `?` again hides them.
  if (e.key === '?' || (e.key === 'Escape' && !$('help').hidden)) {
    e.preventDefault();
    $('help').hidden = e.key === 'Escape' ? true : !$('help').hidden;
    return;
  }
  if ($('view').hidden) return;
  const keys = {
    ' ': toggleRun,
    ArrowRight: () => { stopRun(); gotoStep(currentStep() + 1); },
    ArrowLeft: () => { stopRun(); gotoStep(currentStep() - 1); },
    Home: () => { stopRun(); gotoStep(0); },
    '+': () => zoom(1.25),
    '=': () => zoom(1.25),
    '-': () => zoom(0.8),
  };
  const act = keys[e.key];
  if (!act) return;
  e.preventDefault();
  act();
});

// Step, Back, Reset and Go pause a run.
$('step').onclick = () => { stopRun(); gotoStep(currentStep() + 1); };
$('back').onclick = () => { stopRun(); gotoStep(currentStep() - 1); };
$('reset').onclick = () => { stopRun(); gotoStep(0); };
$('run').onclick = toggleRun;
$('go').onclick = () => { stopRun(); gotoStep(Number($('jump').value) || 0); };
$('jump').addEventListener('keydown', (e) => { if (e.key === 'Enter') $('go').onclick(); });
$('speed').oninput = () => { $('speed-label').textContent = $('speed').value; };
$('fit').onclick = fit;
$('keys').onclick = () => { $('help').hidden = !$('help').hidden; };
// The view saved as `latticesim-step-N.png` (the browser's download).
$('png').onclick = async () => saveBlob(await viewImage(), `latticesim-step-${currentStep()}.png`);
$('colour-by').onchange = () => {
  selection.colourBy = $('colour-by').value || null;
  selection.looksVersion += 1;
  refreshFrame();
};
$('rot-left').onclick = () => { camera.theta -= Math.PI / 12; draw(); };
$('rot-right').onclick = () => { camera.theta += Math.PI / 12; draw(); };
$('tilt-up').onclick = () => { tilt(Math.PI / 18); draw(); };
$('tilt-down').onclick = () => { tilt(-Math.PI / 18); draw(); };
