// Stepping: the frame shown, going to a step, running and pausing.

import { $, api } from './api.js';
import { camera } from './camera.js';
import { draw, fit } from './draw.js';
import { inspect, showLegend, showRecords, showStats } from './panel.js';
import { player, selection } from './state.js';

// ---------------------------------------------------------------- stepping

export function setNote(text) { $('note').textContent = text || ''; }

export async function gotoStep(n) {
  if (n < 0) n = 0;
  player.target = n;
  if (player.busy) return; // the loop below picks the newest target up
  player.busy = true;
  try {
    while (player.target !== null) {
      const t = player.target;
      player.target = null;
      const r = await api('GET', '/api/frame?step=' + t);
      if (!r.ok) { setNote(r.v.error); player.running = false; break; }
      showFrame(r.v);
    }
  } finally {
    player.busy = false;
    updateRunButton();
  }
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
  draw();
  if (selection.selected !== null) inspect(selection.selected);
}

async function runLoop() {
  while (player.running) {
    const t0 = performance.now();
    const before = currentStep();
    await gotoStep(before + 1);
    const f = player.frame;
    if (!f || f.quiescent || f.note || f.step === before) { player.running = false; break; }
    const wait = 1000 / Number($('speed').value) - (performance.now() - t0);
    if (wait > 0) await new Promise((res) => setTimeout(res, wait));
  }
  updateRunButton();
}

function updateRunButton() {
  $('run').innerHTML = player.running ? '&#x23F8; Pause' : '&#x25B6; Run';
}

export function toggleRun() {
  player.running = !player.running;
  updateRunButton();
  if (player.running) runLoop();
}
