// The timeline: a slider over the steps reached. Dragging it (or a click on it) goes to
// that step; the server reaches it through the run's history (each step kept backwards as
// what it changed, and keyframes), so a jump costs what the steps between changed. Beside
// it: the furthest step reached, what the history holds in memory, and how the step shown
// was reached and in how long.

import { $ } from './api.js';
import { gotoStep, stopRun } from './player.js';
import { player } from './state.js';

const slider = $('tl-slider');
let dragging = false;

const mb = (b) => (b / (1 << 20)).toFixed(b < 10 << 20 ? 1 : 0);

function show() {
  const f = player.frame;
  if (!f || !f.history) return;
  const h = f.history;
  const reached = Math.max(h.reached, f.step);
  slider.max = reached;
  if (!dragging) slider.value = f.step;
  $('tl-label').textContent = `step ${f.step} of ${reached} reached`;
  const b = h.bytes;
  const kept = h.deltas_from <= h.reached
    ? `steps ${Math.max(h.deltas_from - 1, 0)} to ${h.reached} kept backwards`
    : 'no steps kept backwards';
  $('tl-memory').textContent =
    `history ${mb(b.keyframes + b.deltas + b.log)} MB (${mb(b.deltas)} MB of deltas: ${kept}; ` +
    `${h.keyframes} keyframe${h.keyframes === 1 ? '' : 's'}, every ${h.every} steps)`;
  $('tl-memory').title = `keyframes ${mb(b.keyframes)} MB, deltas ${mb(b.deltas)} MB, log ${mb(b.log)} MB`;
  $('tl-how').textContent = h.how ? `${h.how} in ${h.ms < 10 ? h.ms.toFixed(1) : Math.round(h.ms)} ms` : '';
}

slider.addEventListener('pointerdown', () => { dragging = true; stopRun(); });
window.addEventListener('pointerup', () => { dragging = false; });
slider.addEventListener('input', () => { stopRun(); gotoStep(Number(slider.value)); });
slider.addEventListener('change', () => { dragging = false; show(); });
document.addEventListener('latticesim:frame', show);
