// Stepping: the frame shown, going to a step, running and pausing.

import { $, decoded, frameAt, requestFrame } from './api.js';
import { camera, inView } from './camera.js';
import { canvas, draw, fit } from './draw.js';
import { inspect, showLegend, showRecords, showSlabs, showStats } from './panel.js';
import { player, selection } from './state.js';

// Two bars, drawn (the character U+23F8 is missing from common fonts, which show a box).
const PAUSE = '<svg class="glyph" width="10" height="10" viewBox="0 0 10 10" aria-hidden="true"><rect x="1" width="3" height="10"/><rect x="6" width="3" height="10"/></svg>';

// ---------------------------------------------------------------- stepping

export function setNote(text) { $('note').textContent = text || ''; }

// The step the user asked for last (absolute), until it is shown: every key press and
// click adds to it, even while a request is under way. A run is paused first (one loop
// asks for frames at a time).
export async function gotoStep(n) {
  if (n < 0) n = 0;
  player.target = n;
  if (player.busy) return; // the loop below picks the newest target up
  player.busy = true;
  let done;
  player.idle = new Promise((res) => { done = res; });
  try {
    while (player.target !== null && (!player.frame || player.frame.step !== player.target)) {
      const t = player.target;
      const r = await frameAt(t, player.frame, selection.colourBy);
      if (!r.ok) { setNote(r.v.error); player.target = null; break; }
      showFrame(r.v);
      // A run that ended before the step asked for: the target is where it ended.
      if (player.target === t && r.v.step !== t) player.target = r.v.step;
    }
  } finally {
    player.target = null;
    player.busy = false;
    done();
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
  // Fitted at first, and again when following agents that would leave the view.
  if (!camera.fitted || ($('follow').checked && !inView(f, canvas.getBoundingClientRect()))) {
    fit();
    camera.fitted = true;
  }
  selection.activeRecord = -1;
  selection.highlight = new Set();
  showLegend(f);
  showRecords(f);
  showStats(f);
  showSlabs(f);
  draw();
  if (selection.selected !== null) inspect(selection.selected);
  document.dispatchEvent(new CustomEvent('latticesim:frame'));
}

// Running: one loop at a time. Each start takes a new generation; a loop goes on only
// while its generation is the current one, so Pause then Run at once ends the old loop
// before the new one takes its first step. The loop asks for the next step as soon as a
// frame arrives, before reading and drawing it, so that the server steps while the page
// draws; an answer that arrives after a pause is dropped.
async function runLoop(gen) {
  const done = [];
  if (player.busy) await player.idle;
  let ahead = null; // the request of the step after the one shown: {step, since, reply}
  while (player.running && player.runGen === gen) {
    const t0 = performance.now();
    const held = player.frame;
    const before = held ? held.step : 0;
    const reply = ahead && ahead.step === before + 1 && ahead.since === before
      ? ahead.reply : requestFrame(before + 1, held ? before : null, selection.colourBy);
    ahead = null;
    const r = await reply;
    if (!player.running || player.runGen !== gen) return;
    if (r.ok) ahead = { step: before + 2, since: before + 1, reply: requestFrame(before + 2, before + 1, selection.colourBy) };
    const d = decoded(r, held);
    if (!d.ok) { setNote(d.v.error); break; }
    const f = d.v;
    showFrame(f);
    if (f.quiescent || f.note || f.step === before) break;
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
  $('run').innerHTML = player.running ? PAUSE + ' Pause' : '&#x25B6; Run';
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
