// The run's log: every record of the steps reached so far (`GET /api/log`), filtered by
// kind, agent and rule (the rules its agents executed in that step); each entry goes to
// its step with its agents selected and centred.

import { $, api, el } from './api.js';
import { centreOn, draw } from './draw.js';
import { inspect } from './panel.js';
import { gotoStep, stopRun } from './player.js';
import { player, selection } from './state.js';

let timer = null;
let asked = 0;

// Asks for the log again, at most every 400 ms while frames come in.
export function refreshLog() {
  if (timer) return;
  timer = setTimeout(() => { timer = null; showLog(); }, 400);
}

async function showLog() {
  const seq = ++asked;
  const q = new URLSearchParams();
  if ($('log-kind').value) q.set('kind', $('log-kind').value);
  if ($('log-agent').value !== '') q.set('agent', $('log-agent').value);
  if ($('log-rule').value) q.set('rule', $('log-rule').value);
  const r = await api('GET', '/api/log?' + q);
  if (seq !== asked) return; // a newer answer is on its way
  const ol = $('log');
  ol.replaceChildren();
  if (!r.ok) { $('log-summary').textContent = r.v.error; return; }
  const v = r.v;
  if ($('log-kind').options.length === 1) {
    for (const k of v.kinds) $('log-kind').append(el('option', { value: k }, k));
  }
  // The rules of this run (a new run may have others).
  const names = [...$('log-rule').options].slice(1).map((o) => o.value);
  if (names.join('\n') !== v.rules.join('\n')) {
    const keep = $('log-rule').value;
    $('log-rule').replaceChildren(el('option', { value: '' }, 'every rule'), ...v.rules.map((r) => el('option', { value: r }, r)));
    $('log-rule').value = v.rules.includes(keep) ? keep : '';
  }
  const more = v.more ? ` (and ${v.more} past the log's size)` : '';
  $('log-summary').textContent = `${v.matching} of ${v.logged} records, steps 1..${v.reached}${more}`;
  for (const rec of v.records) {
    const li = el('li', { class: rec.severity, title: 'Go to this step, its agents selected' },
      el('span', { class: 'mono' }, `${rec.step} `), el('b', {}, rec.kind), ': ' + rec.message,
      rec.rules.length ? el('span', { class: 'muted' }, ` (rules ${rec.rules.join(', ')})`) : '');
    li.onclick = () => goTo(rec);
    ol.append(li);
  }
}

// To the record's step, its agents highlighted, the first inspected and centred.
async function goTo(rec) {
  stopRun();
  await gotoStep(rec.step);
  await player.idle;
  selection.highlight = new Set(rec.agents);
  selection.selected = rec.agents[0];
  centreOn(rec.agents[0]);
  draw();
  inspect(rec.agents[0]);
}

$('log-kind').onchange = showLog;
$('log-agent').oninput = showLog;
$('log-rule').onchange = showLog;
document.addEventListener('latticesim:frame', refreshLog);
