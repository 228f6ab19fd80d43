// The tabs and the two editors: texts, diagnostics underlined as you type, apply.

import { $, api, el, escapeHtml } from './api.js';
import { camera } from './camera.js';
import { resize } from './draw.js';
import { showFrame, stopRun } from './player.js';
import { selection } from './state.js';

// ---------------------------------------------------------------- tabs

export function showTab(which) {
  $('view').hidden = which !== 'view';
  $('edit').hidden = which !== 'edit';
  $('tab-view').classList.toggle('active', which === 'view');
  $('tab-edit').classList.toggle('active', which === 'edit');
  if (which === 'view') resize();
}
$('tab-view').onclick = () => showTab('view');
$('tab-edit').onclick = () => showTab('edit');

// ---------------------------------------------------------------- editor

export const editors = {};
for (const name of ['agents', 'rules']) {
  const root = $('editor-template').content.firstElementChild.cloneNode(true);
  root.id = 'ed-' + name;
  root.querySelector('.which').textContent = name;
  document.querySelector('.editors').append(root);
  const ed = {
    name,
    root,
    text: root.querySelector('textarea'),
    backdrop: root.querySelector('.backdrop'),
    gutter: root.querySelector('.gutter'),
    path: root.querySelector('.path'),
    diags: root.querySelector('.diags'),
    msg: root.querySelector('.filemsg'),
    list: [],
    large: null, // the size of a file too large to edit here (its text stays on the server)
  };
  ed.text.addEventListener('input', () => { paint(ed); scheduleCheck(); });
  for (const ev of ['click', 'keyup', 'select']) ed.text.addEventListener(ev, () => showCurrent(ed));
  ed.text.addEventListener('scroll', () => {
    ed.backdrop.scrollTop = ed.text.scrollTop;
    ed.backdrop.scrollLeft = ed.text.scrollLeft;
    ed.gutter.scrollTop = ed.text.scrollTop;
  });
  root.querySelector('.load').onclick = async () => {
    const r = await api('POST', '/api/file', { path: ed.path.value });
    if (!r.ok) { ed.msg.textContent = r.v.error; return; }
    setText(ed, r.v.text, r.v.bytes);
    ed.msg.textContent = 'loaded';
    scheduleCheck();
  };
  root.querySelector('.save').onclick = async () => {
    if (ed.large !== null) { ed.msg.textContent = 'nothing to save: this file is edited elsewhere'; return; }
    const r = await api('POST', '/api/file', { path: ed.path.value, text: ed.text.value });
    ed.msg.textContent = r.ok ? `saved ${r.v.bytes} bytes` : r.v.error;
  };
  editors[name] = ed;
}


// Puts a file's text in its editor; a text of null is a file too large to edit here
// (`bytes` long): the editor is then read-only and says so, and checking and applying
// read the file from disk.
export function setText(ed, text, bytes) {
  ed.large = text === null ? bytes : null;
  ed.text.value = text === null ? '' : text;
  ed.text.readOnly = text === null;
  ed.text.placeholder = text === null
    ? `This file has ${(bytes / 1e6).toFixed(1)} MB, too much to edit in the page: checking and Apply read it from the file. Edit it in another editor, save it, and Apply (or Load) here.`
    : '';
  paint(ed);
}

// The string index of 1-based (line, column), columns counting characters.
function indexOf(text, line, col) {
  let i = 0;
  for (let l = 1; l < line; l++) {
    const nl = text.indexOf('\n', i);
    if (nl < 0) return text.length;
    i = nl + 1;
  }
  for (let c = 1; c < col && i < text.length && text[i] !== '\n'; c++) {
    i += text.codePointAt(i) > 0xffff ? 2 : 1;
  }
  return i;
}

// Draws the marks of the editor's diagnostics under its text, and the line numbers.
function paint(ed) {
  const text = ed.text.value;
  const spans = ed.list.map((d) => {
    let a = indexOf(text, d.line, d.column), b = indexOf(text, d.end_line, d.end_column);
    if (b < a) b = a; // an empty span gets a marker of its own
    return { a, b, d };
  }).sort((x, y) => x.a - y.a);
  let html = '', at = 0;
  for (const { a, b, d } of spans) {
    if (a < at) continue; // overlapping: the first one is shown
    html += escapeHtml(text.slice(at, a));
    const cls = d.severity + (b > a ? '' : ' empty');
    html += `<mark class="${cls}" data-line="${d.line}" data-code="${d.code}">${escapeHtml(text.slice(a, b))}</mark>`;
    at = b;
  }
  html += escapeHtml(text.slice(at)) + '\n';
  ed.backdrop.innerHTML = html;
  const bad = new Set(ed.list.filter((d) => d.severity === 'error').map((d) => d.line));
  const lines = text.split('\n').length;
  let g = '';
  for (let l = 1; l <= lines; l++) g += bad.has(l) ? `<span class="bad">${l}</span>\n` : `${l}\n`;
  ed.gutter.innerHTML = g;
  ed.backdrop.scrollTop = ed.text.scrollTop;
  ed.gutter.scrollTop = ed.text.scrollTop;
}

// Marks the messages of the diagnostics whose span holds the caret.
function showCurrent(ed) {
  const t = ed.text.value, at = ed.text.selectionStart;
  ed.list.forEach((d, i) => {
    const a = indexOf(t, d.line, d.column), b = indexOf(t, d.end_line, d.end_column);
    const li = ed.diags.children[i];
    const on = at >= a && at <= Math.max(a + 1, b);
    li.classList.toggle('current', on);
    if (on) li.scrollIntoView({ block: 'nearest' });
  });
}

export function showDiagnostics(check) {
  for (const ed of Object.values(editors)) {
    ed.list = check.diagnostics.filter((d) => d.editor === ed.name);
    ed.diags.replaceChildren();
    for (const d of ed.list) {
      const li = el('li', { class: d.severity },
        `${d.line}:${d.column}: ${d.severity}[${d.code}]: ${d.message}`);
      if (d.help) li.append(el('div', { class: 'help' }, 'help: ' + d.help));
      li.onclick = () => {
        const t = ed.text.value;
        ed.text.focus();
        ed.text.setSelectionRange(indexOf(t, d.line, d.column), indexOf(t, d.end_line, d.end_column));
      };
      ed.diags.append(li);
    }
    paint(ed);
    if (document.activeElement === ed.text) showCurrent(ed);
  }
  const s = $('check-summary');
  s.textContent = `${check.errors} error${check.errors === 1 ? '' : 's'}, ${check.warnings} warning${check.warnings === 1 ? '' : 's'}; ${check.rules} rules, ${check.agents} agents, ${check.dimension}`;
  s.className = check.errors ? 'bad' : 'good';
}

let checkTimer = null, checkSeq = 0;
function scheduleCheck() {
  clearTimeout(checkTimer);
  checkTimer = setTimeout(runCheck, 250);
}

function texts() {
  return {
    // null: the file on disk (too large to edit here).
    rules: editors.rules.large === null ? editors.rules.text.value : null,
    agents: editors.agents.large === null ? editors.agents.text.value : null,
    rules_path: editors.rules.path.value,
    agents_path: editors.agents.path.value,
  };
}

async function runCheck() {
  const seq = ++checkSeq;
  const r = await api('POST', '/api/check', texts());
  if (seq !== checkSeq) return; // a newer check is under way
  if (r.ok) showDiagnostics(r.v); else $('check-summary').textContent = r.v.error;
}

$('apply').onclick = async () => {
  clearTimeout(checkTimer);
  checkSeq++;
  const r = await api('POST', '/api/apply', texts());
  if (r.v.check) showDiagnostics(r.v.check);
  if (!r.ok || !r.v.applied) { $('check-summary').textContent = r.v.error; $('check-summary').className = 'bad'; return; }
  stopRun();
  selection.selected = null;
  camera.fitted = false;
  camera.clip = [null, null, null];
  $('inspector').textContent = 'Click an agent.';
  showTab('view');
  showFrame(r.v.frame);
  showStatus();
};

export function showStatus() {
  $('status').textContent = `${editors.rules.path.value} + ${editors.agents.path.value}`;
}
