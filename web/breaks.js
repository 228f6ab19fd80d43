// The tab's breakpoints (`POST /api/breaks`): a run pauses at the step where a record of a
// chosen kind occurs, an agent enters a chosen state, a counter condition comes to hold
// for some agent (`>C00 0005`), or a chosen step is reached; the note says which.

import { $, api, el } from './api.js';

function asked() {
  const b = {};
  if ($('bp-kind').value) b.kinds = [$('bp-kind').value];
  const state = $('bp-state').value.trim();
  if (state) b.states = [state];
  const counter = $('bp-counter').value.trim();
  if (counter) b.counter = counter;
  if ($('bp-step').value !== '') b.step = Number($('bp-step').value);
  return b;
}

function describe(b) {
  const parts = [];
  for (const k of b.kinds) parts.push(`a ${k} record`);
  for (const s of b.states) parts.push(`an agent entering ${s}`);
  if (b.counter) parts.push(`${b.counter} for some agent`);
  if (b.step !== null) parts.push(`step ${b.step}`);
  return parts.length ? 'A run pauses at ' + parts.join(', at ') + ' (and at quiescence).' : 'None: a run pauses at quiescence.';
}

async function set(body) {
  const r = await api('POST', '/api/breaks', body);
  const summary = $('bp-summary');
  if (r.ok && r.v.kinds && $('bp-kind').options.length === 1) {
    for (const k of r.v.kinds) $('bp-kind').append(el('option', { value: k }, k));
  }
  if (!r.ok || !r.v.set) { summary.textContent = r.v.error; summary.className = 'bad'; return; }
  summary.textContent = describe(r.v.breaks);
  summary.className = 'muted';
}

$('bp-set').onclick = () => set(asked());
$('bp-clear').onclick = () => {
  for (const id of ['bp-state', 'bp-counter', 'bp-step']) $(id).value = '';
  $('bp-kind').value = '';
  set({});
};
set({});
