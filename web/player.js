// Stepping: the frame shown, going to a step, running and pausing.

import { $, frameAt } from './api.js';
import { camera } from './camera.js';
import { draw, fit } from './draw.js';
import { inspect, showLegend, showRecords, showSlabs, showStats } from './panel.js';
import { player, selection } from './state.js';

// ---------------------------------------------------------------- stepping

export function setNote(text) { $('note').textContent = text || ''; }

// The step the user asked for last (absolute), until it is shown: every key press and
// click adds to it, even while a request is under way.
export async function gotoStep(n) {
  if (n < 0) n = 0;
  player.target = n;
  if (player.busy) return; // the loop below picks the newest target up
  player.busy = true;
  try {
    while (player.target !== null && (!player.frame || player.frame.step !== player.target)) {
      const t = player.target;
      const r = await frameAt(t, player.frame, selection.colourBy);
      if (!r.ok) { setNote(r.v.error); player.target = null; stopRun(); break; }
      showFrame(r.v);
      // A run that ended before the step asked for: the target is where it ended.
      if (player.target === t && r.v.step !== t) player.target = r.v.step;
    }
  } finally {
    player.target = null;
    player.busy = false;
    updateRunButton();
  }
}

// The frame of the current step asked for again, whole (after the counter to colour by
// changed).
export async function refreshFrame() {
  if (!player.frame) return;
  const r = await frameAt(player.frame.step, null, selection.colourBy);
  if (r.ok) showFrame(r.v); else setNote(r.v.error);
}

export function currentStep() {
  if (player.target !== null) return player.target;
  return player.frame ? player.frame.step : 0;
}

export function showFrame(f) {
  player.frame = f;
  $('step-number').textContent = f.step;
  $('jump').value = f.step;
  setNote(f.note || (f.quiescent ? 'quiescent: no agent has a rule to execute' : ''));
  $('rotate').hidden = f.dim !== 3;
  if (!camera.fitted) { fit(); camera.fitted = true; }
  selection.activeRecord = -1;
  selection.highlight = new Set();
  showLegend(f);
  showRecords(f);
  showStats(f);
  showSlabs(f);
  draw();
  if (selection.selected !== null) inspect(selection.selected);
}

// Running: one loop at a time. Each start takes a new generation; a loop goes on only
// while its generation is the current one, so Pause then Run at once ends the old loop
// before the new one takes its first step.
async function runLoop(gen) {
  const done = [];
  while (player.running && player.runGen === gen) {
    const t0 = performance.now();
    const before = currentStep();
    await gotoStep(before + 1);
    if (player.runGen !== gen) return;
    const f = player.frame;
    if (!f || f.quiescent || f.note || f.step === before) break;
    done.push(performance.now());
    while (done.length && done[0] < performance.now() - 2000) done.shift();
    showRate(done);
    const wait = 1000 / Number($('speed').value) - (performance.now() - t0);
    if (wait > 0) await new Promise((res) => setTimeout(res, wait));
  }
  if (player.runGen === gen) stopRun();
}

// The steps per second achieved over the last two seconds, beside the speed asked for.
function showRate(done) {
  const span = done.length > 1 ? (done[done.length - 1] - done[0]) / 1000 : 0;
  $('rate').textContent = span > 0 ? `(${((done.length - 1) / span).toFixed(1)} achieved)` : '';
}

function updateRunButton() {
  $('run').innerHTML = player.running ? '&#x23F8; Pause' : '&#x25B6; Run';
}

// Stops the run, if any: its loop ends at its next check.
export function stopRun() {
  player.running = false;
  player.runGen += 1;
  $('rate').textContent = '';
  updateRunButton();
}

export function toggleRun() {
  if (player.running) { stopRun(); return; }
  player.running = true;
  player.runGen += 1;
  updateRunButton();
  runLoop(player.runGen);
}
