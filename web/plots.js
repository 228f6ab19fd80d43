// Plots and exports. Live charts of the run's series beside the view (`GET /api/series`):
// the agents in each state, and per step the agents executing, moves, swaps, messages
// sent and records; a vertical line marks the step shown, and a click on a chart goes to
// that step. Exports: the step shown as SVG (drawn by the server as `latticesim render`
// draws it), a range of steps as GIF (the same), or as WebM, recorded from the view as
// shown (zoom, colours, Follow) while the page steps through the range.

import { $, api, download, el, saveBlob } from './api.js';
import { composeView } from './draw.js';
import { gotoStep, stopRun } from './player.js';
import { player, selection } from './state.js';

// The series held: columns by name, and per state its name, colour and counts.
const series = { run: null, stride: 0, step: [], executing: [], moves: [], swaps: [], sent: [], records: [], states: [] };
const SCALARS = [['executing', '#000000'], ['moves', '#0072b2'], ['swaps', '#cc79a7'], ['sent', '#009e73'], ['records', '#d55e00']];
// The most state lines drawn (the states with the most agents at some step).
const MOST_STATES = 6;

let timer = null, asked = 0;

// The series held (for tests and scripts).
export function heldSeries() { return series; }

// Asks for the new points at most every 300 ms while frames come in.
export function refreshPlots() {
  if (timer) return;
  timer = setTimeout(() => { timer = null; fetchSeries(); }, 300);
}

async function fetchSeries() {
  const seq = ++asked;
  const last = series.step.length ? series.step[series.step.length - 1] : null;
  const r = await api('GET', '/api/series' + (last === null ? '' : '?since=' + last));
  if (seq !== asked || !r.ok) return;
  const v = r.v;
  // A new run (applied, edited), or points thinned out: everything again.
  if (v.run !== series.run || v.stride !== series.stride) {
    if (last !== null) {
      Object.assign(series, { run: v.run, stride: v.stride, step: [], executing: [], moves: [], swaps: [], sent: [], records: [], states: [] });
      return fetchSeries();
    }
    Object.assign(series, { run: v.run, stride: v.stride });
  }
  for (const k of ['step', ...SCALARS.map((s) => s[0])]) series[k].push(...v[k]);
  const before = series.step.length - v.step.length;
  v.states.forEach((s, i) => {
    if (!series.states[i]) series.states[i] = { name: s.name, colour: s.colour, counts: new Array(before).fill(0) };
    series.states[i].colour = s.colour;
    series.states[i].counts.push(...s.counts);
  });
  drawPlots();
}

// One chart: lines of `lines` ({values, colour}) over the steps, the step shown marked.
function chart(canvas, lines) {
  const dpr = window.devicePixelRatio || 1, w = canvas.clientWidth, h = canvas.clientHeight;
  if (canvas.width !== Math.round(w * dpr)) { canvas.width = Math.round(w * dpr); canvas.height = Math.round(h * dpr); }
  const c = canvas.getContext('2d');
  c.setTransform(dpr, 0, 0, dpr, 0, 0);
  c.clearRect(0, 0, w, h);
  const xs = series.step, n = xs.length;
  if (!n) return;
  const x0 = xs[0], x1 = Math.max(xs[n - 1], x0 + 1);
  const top = Math.max(1, ...lines.map((l) => Math.max(...l.values)));
  const [L, R, T, B] = [34, 4, 4, 14];
  const X = (s) => L + ((s - x0) / (x1 - x0)) * (w - L - R), Y = (v) => h - B - (v / top) * (h - T - B);
  c.font = '10px sans-serif';
  c.fillStyle = '#666';
  c.fillText(String(top), 2, T + 8);
  c.fillText('0', 2, h - B);
  c.fillText(String(x0), L, h - 2);
  c.fillText(String(xs[n - 1]), w - R - c.measureText(String(xs[n - 1])).width, h - 2);
  c.strokeStyle = '#ccc';
  c.strokeRect(L, T, w - L - R, h - T - B);
  for (const l of lines) {
    c.strokeStyle = l.colour;
    c.lineWidth = 1.5;
    c.beginPath();
    l.values.forEach((v, i) => (i ? c.lineTo(X(xs[i]), Y(v)) : c.moveTo(X(xs[i]), Y(v))));
    c.stroke();
  }
  if (player.frame) {
    c.strokeStyle = '#0050ff';
    c.lineWidth = 1;
    c.beginPath();
    c.moveTo(X(player.frame.step), T);
    c.lineTo(X(player.frame.step), h - B);
    c.stroke();
  }
  canvas.dataset.steps = `${x0}..${xs[n - 1]}`;
  canvas.onclick = (e) => {
    const r = canvas.getBoundingClientRect();
    const s = Math.round(x0 + ((e.clientX - r.left - L) / (w - L - R)) * (x1 - x0));
    stopRun();
    gotoStep(Math.max(x0, Math.min(xs[n - 1], s)));
  };
}

// The states drawn: those with the most agents at some step.
function topStates() {
  return series.states
    .map((s) => ({ ...s, peak: Math.max(0, ...s.counts) }))
    .filter((s) => s.peak > 0 && (selection.looks.get(s.name) || {}).mode !== 'hidden')
    .sort((a, b) => b.peak - a.peak)
    .slice(0, MOST_STATES)
    .map((s) => ({ ...s, colour: (selection.looks.get(s.name) || {}).colour || s.colour }));
}

export function drawPlots() {
  if ($('plots').hidden) return;
  const states = topStates();
  chart($('plot-states'), states.map((s) => ({ values: s.counts, colour: s.colour })));
  chart($('plot-steps'), SCALARS.map(([k, colour]) => ({ values: series[k], colour })));
  $('plot-states-key').replaceChildren(...states.map((s) => el('span', { class: 'key' }, el('i', { style: `background:${s.colour}` }), s.name)));
  // The values at the step shown.
  const i = player.frame ? series.step.lastIndexOf(player.frame.step) : -1;
  $('plot-steps-key').replaceChildren(...SCALARS.map(([k, colour]) =>
    el('span', { class: 'key' }, el('i', { style: `background:${colour}` }), i >= 0 ? `${k} ${series[k][i]}` : k)));
}

document.addEventListener('latticesim:frame', () => { refreshPlots(); drawPlots(); });
$('plots-toggle').onclick = () => {
  $('plots').hidden = !$('plots').hidden;
  $('plots-toggle').textContent = $('plots').hidden ? 'show' : 'hide';
  drawPlots();
};

// ---------------------------------------------------------------- exports

function exported(r) {
  $('export-note').textContent = r.ok ? `saved ${r.v.name} (${(r.v.bytes / 1024).toFixed(0)} KB)` : r.v.error;
  $('export-note').dataset.n = String(Number($('export-note').dataset.n || 0) + 1);
}

function range() {
  const f = player.frame ? player.frame.step : 0;
  const from = $('ex-from').value === '' ? 0 : Number($('ex-from').value);
  const to = $('ex-to').value === '' ? f : Number($('ex-to').value);
  return [from, to];
}

const counterQuery = () => (selection.colourBy ? '&counter=' + selection.colourBy : '');

$('svg').onclick = async () => {
  const s = player.frame ? player.frame.step : 0;
  exported(await download(`/api/export?format=svg&step=${s}${counterQuery()}`, `latticesim-step-${s}.svg`));
};
$('gif').onclick = async () => {
  const [from, to] = range();
  $('export-note').textContent = `drawing steps ${from} to ${to}...`;
  exported(await download(`/api/export?format=gif&from=${from}&to=${to}&fps=${$('speed').value}${counterQuery()}`, `latticesim-steps-${from}-${to}.gif`));
};

// WebM: the view as shown, recorded while the page goes to each step of the range, at
// the speed set (steps a second).
$('webm').onclick = async () => {
  const [from, to] = range();
  if (typeof MediaRecorder === 'undefined') { exported({ ok: false, v: { error: 'this browser cannot record video (no MediaRecorder)' } }); return; }
  stopRun();
  const fps = Number($('speed').value) || 5;
  const out = composeView(document.createElement('canvas'));
  const stream = out.captureStream(0);
  const track = stream.getVideoTracks()[0];
  const type = ['video/webm;codecs=vp9', 'video/webm;codecs=vp8', 'video/webm'].find((t) => MediaRecorder.isTypeSupported(t));
  const rec = new MediaRecorder(stream, type ? { mimeType: type } : undefined);
  const chunks = [];
  rec.ondataavailable = (e) => { if (e.data.size) chunks.push(e.data); };
  const stopped = new Promise((done) => { rec.onstop = done; });
  rec.start();
  let last = from;
  for (let s = from; s <= to; s++) {
    $('export-note').textContent = `recording step ${s} of ${from}..${to}`;
    await gotoStep(s);
    if (!player.frame || player.frame.step !== s) break; // quiescent, or a breakpoint
    last = s;
    composeView(out);
    track.requestFrame();
    await new Promise((done) => setTimeout(done, 1000 / fps));
  }
  rec.stop();
  await stopped;
  const blob = new Blob(chunks, { type: 'video/webm' });
  const name = `latticesim-steps-${from}-${last}.webm`;
  saveBlob(blob, name);
  exported({ ok: true, v: { name, bytes: blob.size } });
};
