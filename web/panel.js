// The side panel: legend, records, statistics and the inspector of the selected agent.

import { $, api, el } from './api.js';
import { draw } from './draw.js';
import { selection } from './state.js';

// ---------------------------------------------------------------- side panel


export function showLegend(f) {
  const ul = $('legend');
  ul.replaceChildren();
  const states = f.states.slice().sort((a, b) => (a.name < b.name ? -1 : a.name > b.name ? 1 : 0));
  for (const s of states) {
    const sw = el('span', { class: 'swatch' });
    sw.style.background = s.colour;
    ul.append(el('li', {}, sw, s.name, el('span', { class: 'muted' }, ' ' + s.count)));
  }
}

export function showRecords(f) {
  const ul = $('records');
  ul.replaceChildren();
  if (f.records.length === 0) {
    ul.append(el('li', { class: 'muted' }, f.step === 0 ? 'none before the first step' : 'none'));
    return;
  }
  f.records.forEach((r, i) => {
    const li = el('li', { class: r.severity, title: 'Highlight its agents' },
      el('b', {}, r.kind), ': ' + r.message + ' (agents ' + r.agents.join(', ') + ')');
    li.onclick = () => {
      const on = selection.activeRecord !== i;
      selection.activeRecord = on ? i : -1;
      selection.highlight = new Set(on ? r.agents : []);
      for (const c of ul.children) c.classList.remove('active');
      if (on) li.classList.add('active');
      draw();
    };
    ul.append(li);
  });
}

export function showStats(f) {
  const s = f.stats;
  $('stats').innerHTML = '';
  $('stats').append(
    `${f.pos.length / f.dim} agents, ${f.states.length} states`, el('br'),
    `firings ${s.firings}, moves ${s.moves}, swaps ${s.swaps}`, el('br'),
    `messages ${s.sent} sent, ${s.delivered} delivered, ${s.dropped} dropped`, el('br'),
    `records: ${s.errors} errors, ${s.warnings} warnings`, el('br'),
    `keyframes ${f.keyframes[0]}, every ${f.keyframes[1]} steps`);
}

export async function inspect(id) {
  selection.selected = id;
  const r = await api('GET', '/api/agent?id=' + id);
  const box = $('inspector');
  if (!r.ok) { box.textContent = r.v.error; return; }
  const a = r.v;
  const row = (k, v, vid) => el('tr', {}, el('td', {}, k), el('td', vid ? { id: vid, class: 'mono' } : { class: 'mono' }, String(v)));
  const list = (xs) => xs.length ? xs.map((c) => c.name + '=' + c.value).join(' ') : '-';
  const next = a.next
    ? a.next.rules.join(', ') + ' (priority ' + a.next.priority + ')'
    : 'none';
  box.replaceChildren(el('table', {},
    row('id', a.id, 'insp-id'),
    row('position', a.pos.join(', '), 'insp-pos'),
    row('state', a.state, 'insp-state'),
    row('attached', a.attached || '-', 'insp-attached'),
    row('counters', list(a.counters), 'insp-counters'),
    row('messages', list(a.messages), 'insp-messages'),
    row('rules in step ' + a.next_step, next, 'insp-rules')));
  box.classList.remove('muted');
  draw();
}
