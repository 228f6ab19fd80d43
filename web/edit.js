// Editing the agents by mouse (docs/viewer.md#editing): Edit (or E) turns it on; a click
// on an empty cell places an agent in the state chosen, a click on an agent selects it
// (its state, counters and bonds can then be set, or it removed); Undo and Redo; Save
// writes the agents file through the server's safe save. Each edit goes to the server
// (`POST /api/edit`), which checks the edited agents with the rules and starts the run
// from them at step 0: the page shows the run of what it edits, and the checker's
// diagnostics as it goes. An edit that cannot be (a taken cell, a state the checker
// refuses) changes nothing and says why.

import { $, api, el } from './api.js';
import { cellAt2d } from './draw2d.js';
import { pick } from './draw.js';
import { editors, setText, showDiagnostics } from './editor.js';
import { typing } from './input.js';
import { inspect } from './panel.js';
import { showFrame, stopRun } from './player.js';
import { player, selection } from './state.js';

let agent = null; // the selected agent as the inspector read it

function setEditing(on) {
  player.editing = on;
  $('edit-mode').setAttribute('aria-pressed', String(on));
  $('edit-mode').classList.toggle('active', on);
  $('edit-panel').hidden = !on;
  if (on) {
    stopRun();
    if (!$('ed-path').value) $('ed-path').value = editors.agents.path.value;
    $('ed-pos').placeholder = player.frame && player.frame.dim === 3 ? 'x,y,z' : 'x,y';
  }
}

let answers = 0;

// What the last edit came to (`data-n` counts the answers, for tests).
function say(text, bad) {
  $('ed-summary').textContent = text;
  $('ed-summary').className = bad ? 'bad' : 'muted';
  $('ed-summary').dataset.n = String(++answers);
}

// Sends one edit; shows its run, its diagnostics and the undo depth.
export async function edit(body) {
  const r = await api('POST', '/api/edit', body);
  if (!r.ok) { say(r.v.error, true); return r; }
  const v = r.v;
  if (v.check) showDiagnostics(v.check);
  if (v.agents !== undefined && v.agents !== null) setText(editors.agents, v.agents, v.agents_bytes);
  $('ed-undo').disabled = !v.undo;
  $('ed-redo').disabled = !v.redo;
  if (v.frame) {
    showFrame(v.frame);
    if (selection.selected !== null && selection.selected >= v.frame.pos.length / v.frame.dim) selection.selected = null;
  }
  if (!v.applied) { say(`not done: ${v.error}`, true); return r; }
  const c = v.check;
  const diags = c ? c.diagnostics : [];
  say(c ? `edited: ${c.agents} agents, ${c.errors} errors, ${c.warnings} warnings; the run starts again from them` : 'done', false);
  $('ed-diags').replaceChildren(...diags.slice(0, 20).map((d) =>
    el('li', { class: d.severity }, `${d.editor === 'agents' ? 'agents' : 'rules'} ${d.line}:${d.column}: ${d.severity}[${d.code}]: ${d.message}`)));
  if (selection.selected === null) $('ed-agent').hidden = true;
  return r;
}

function cells(text) {
  return text.split(',').map((t) => Number(t.trim()));
}

document.addEventListener('latticesim:edit-click', async (e) => {
  const f = player.frame;
  if (!f) return;
  const { x, y } = e.detail;
  const id = pick(x, y);
  if (f.dim === 3) {
    if (id !== null) inspect(id);
    return;
  }
  const [cx, cy] = cellAt2d(x, y);
  // The agent on the cell clicked, if any (not merely a near one): that one is selected.
  if (id !== null && f.pos[2 * id] === cx && f.pos[2 * id + 1] === cy) { inspect(id); return; }
  await edit({ op: 'place', pos: [cx, cy], state: $('ed-state').value });
});

// The inspector read an agent: the editing fields show it.
document.addEventListener('latticesim:agent', (e) => {
  agent = e.detail;
  if (!player.editing) return;
  $('ed-agent').hidden = false;
  $('ed-which').textContent = `agent ${agent.id} on ${agent.pos.join(',')}`;
  $('ed-agent-state').value = agent.state;
  $('ed-agent-counters').value = agent.counters.filter((c) => c.value !== 0).map((c) => `${c.name} ${c.value}`).join(' ');
  const dirs = player.frame.dim === 3 ? 'NWESAB' : 'NWES';
  $('ed-bonds').replaceChildren('bonds', ...[...dirs].map((d) => {
    const box = el('input', { type: 'checkbox', 'data-dir': d });
    box.checked = agent.attached.includes(d);
    box.onchange = () => edit({ op: 'bond', id: agent.id, dir: d, on: box.checked });
    return el('label', {}, box, d);
  }));
});

$('edit-mode').onclick = () => setEditing(!player.editing);
$('ed-place').onclick = () => edit({ op: 'place', pos: cells($('ed-pos').value), state: $('ed-state').value });
$('ed-set').onclick = () => agent && edit({ op: 'set', id: agent.id, state: $('ed-agent-state').value, counters: $('ed-agent-counters').value });
$('ed-remove').onclick = () => remove();
$('ed-undo').onclick = () => edit({ op: 'undo' });
$('ed-redo').onclick = () => edit({ op: 'redo' });
$('ed-save').onclick = async () => {
  const r = await api('POST', '/api/edit', { op: 'save', path: $('ed-path').value });
  if (r.ok) { say(`saved ${r.v.saved} (${r.v.bytes} bytes)`, false); editors.agents.path.value = r.v.saved; } else say(r.v.error, true);
};

async function remove() {
  if (selection.selected === null) return;
  const id = selection.selected;
  selection.selected = null;
  $('ed-agent').hidden = true;
  $('inspector').textContent = 'Click an agent.';
  await edit({ op: 'remove', id });
}

document.addEventListener('keydown', (e) => {
  if (typing(e.target) || $('view').hidden) return;
  if (e.key === 'e' && !e.ctrlKey && !e.metaKey) { e.preventDefault(); setEditing(!player.editing); return; }
  if (!player.editing) return;
  const undo = (e.ctrlKey || e.metaKey) && e.key.toLowerCase() === 'z';
  if (undo) { e.preventDefault(); edit({ op: e.shiftKey ? 'redo' : 'undo' }); return; }
  if ((e.ctrlKey || e.metaKey) && e.key === 'y') { e.preventDefault(); edit({ op: 'redo' }); return; }
  if (e.key === 'Delete' || e.key === 'Backspace') { e.preventDefault(); remove(); }
});
