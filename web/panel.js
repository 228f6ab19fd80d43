// The side panel: legend, records, statistics and the inspector of the selected agent.

import { $, api, el } from './api.js';
import { bbox, camera } from './camera.js';
import { draw } from './draw.js';
import { selection, valueRange } from './state.js';

// ---------------------------------------------------------------- side panel


// The legend: a swatch (a colour picker: the page's own palette) and the name and count of
// each state; clicking the name highlights the state (the others fade), again hides it
// (its agents are neither drawn nor picked), again shows it as it was.
export function showLegend(f) {
  // The counters the agents can be coloured by, and the scale when they are.
  const sel = $('colour-by');
  const names = ['', ...(f.counters || [])];
  if ([...sel.options].map((o) => o.value).join() !== names.join()) {
    sel.replaceChildren(...names.map((c) => el('option', { value: c }, c || 'state')));
  }
  sel.value = selection.colourBy || '';
  const range = selection.colourBy ? valueRange(f) : null;
  $('scale').hidden = !range;
  if (range) {
    $('scale').querySelector('.lo').textContent = range[0];
    $('scale').querySelector('.hi').textContent = range[1];
  }
  const ul = $('legend');
  ul.replaceChildren();
  const states = f.states.filter((s) => s.count > 0)
    .sort((a, b) => (a.name < b.name ? -1 : a.name > b.name ? 1 : 0));
  for (const s of states) {
    const look = selection.looks.get(s.name) || {};
    const sw = el('input', { type: 'color', class: 'swatch', title: 'Choose its colour' });
    sw.value = look.colour || s.colour;
    sw.oninput = () => setLook(s.name, { colour: sw.value }, f);
    const name = el('span', { class: 'state-name', title: 'Highlight, hide or show it' }, s.name);
    const li = el('li', { class: look.mode || '', 'data-state': s.name }, sw, name,
      el('span', { class: 'muted' }, ' ' + s.count));
    name.onclick = () => {
      const next = { undefined: 'highlight', highlight: 'hidden', hidden: undefined }[look.mode];
      setLook(s.name, { mode: next }, f);
    };
    ul.append(li);
  }
}

function setLook(name, change, f) {
  const look = { ...(selection.looks.get(name) || {}), ...change };
  if (!look.mode) delete look.mode;
  selection.looks.set(name, look);
  selection.looksVersion += 1;
  showLegend(f);
  draw();
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
      el('b', {}, r.kind), ': ' + r.message + ' (agent' + (r.agents.length === 1 ? ' ' : 's ') + r.agents.join(', ') + ')');
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
    `${f.pos.length / f.dim} agents, ${f.states.filter((s) => s.count > 0).length} states`, el('br'),
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
  document.dispatchEvent(new CustomEvent('latticesim:agent', { detail: a }));
}

// 3D slabs: per axis, the cells from `lo` to `hi` are drawn (and picked), so that agents
// inside a shape can be seen. The sliders span the agents' extent; at full extent an axis
// is not cut.
export function showSlabs(f) {
  $('slabs').hidden = f.dim !== 3;
  if (f.dim !== 3) return;
  const b = bbox(f);
  for (const row of document.querySelectorAll('#slabs .slab')) {
    const k = Number(row.dataset.axis);
    const [lo, hi] = [row.querySelector('.lo'), row.querySelector('.hi')];
    for (const s of [lo, hi]) { s.min = b.lo[k]; s.max = b.hi[k]; s.step = 1; }
    const c = camera.clip[k];
    lo.value = c ? c[0] : b.lo[k];
    hi.value = c ? c[1] : b.hi[k];
    row.querySelector('.val').textContent = `${lo.value}..${hi.value}`;
    const change = () => {
      let [l, h] = [Number(lo.value), Number(hi.value)];
      if (l > h) [l, h] = [h, l];
      const whole = l <= Number(lo.min) && h >= Number(hi.max);
      camera.clip[k] = whole ? null : [l, h];
      row.querySelector('.val').textContent = `${l}..${h}`;
      draw();
    };
    lo.oninput = change;
    hi.oninput = change;
  }
}
