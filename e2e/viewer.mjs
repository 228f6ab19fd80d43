// End-to-end test of `latticesim serve` in headless Chromium (Debian's package), driven by
// playwright-core. Run from the repository's root after `cargo build`:
//
//   node e2e/viewer.mjs
//
// LATTICESIM names the binary (default target/debug/latticesim), CHROMIUM the browser
// (default /usr/bin/chromium). With SCREENSHOTS=DIR it also writes the viewer's screenshots
// shown in the README (viewer-2d.png, viewer-3d.png, viewer-editor.png) into DIR.
import { execFileSync } from 'node:child_process';
import { launch } from './common.mjs';
import { BIN, open, serve, servers, stepNumber, waitStep } from './page.mjs';
import assert from 'node:assert/strict';
import path from 'node:path';
import fs from 'node:fs';
import os from 'node:os';

const RULES = 'examples/leader-election/rules.txt';
const AGENTS = 'examples/leader-election/agents-30.txt';


// The agents after `steps` steps, as `latticesim run` writes them: one line per agent, in
// id order (a universe line, if any, first).
function agentsAfter(steps) {
  const out = execFileSync(BIN, ['run', RULES, AGENTS, '--max-steps', String(steps), '--quiet'], { encoding: 'utf8' });
  return out.split('\n').filter((l) => l && !l.startsWith('U'));
}

function parseAgent(line) {
  const words = line.split(/\s+/);
  const a = { pos: words[0], state: null, counters: {} };
  for (let i = 1; i < words.length; i++) {
    if (words[i].startsWith('S')) a.state = words[i].slice(1);
    if (/^C\d\d$/.test(words[i])) a.counters[words[i]] = Number(words[++i]);
  }
  return a;
}


// The places where the 2D image differs from the frame shown: agents not in their state's
// colour, empty cells among them with something drawn (none: the image, patched step by
// step where agents changed, is the frame).
function imageWrongs(page) {
  return page.evaluate(() => {
    const L = window.latticesim, f = L.frame();
    const c = document.getElementById('canvas'), r = c.getBoundingClientRect();
    const ctx = c.getContext('2d'), dpr = window.devicePixelRatio || 1;
    // '' for a pixel nothing was drawn on (the page's white shows through).
    const at = (x, y) => {
      const d = ctx.getImageData(Math.round((x - r.left) * dpr), Math.round((y - r.top) * dpr), 1, 1).data;
      return d[3] === 0 ? '' : Array.from(d.slice(0, 3)).map((v) => v.toString(16).padStart(2, '0')).join('');
    };
    const taken = new Set();
    const bad = [];
    for (let i = 0; i < f.pos.length / 2; i++) {
      taken.add(f.pos[2 * i] + ',' + f.pos[2 * i + 1]);
      const [x, y] = L.screenOf(i);
      if ('#' + at(x, y) !== f.states[f.state[i]].colour) bad.push(i);
    }
    // Every empty cell among the agents: nothing drawn there (or white), no agent left
    // behind by the patches.
    const [x0, y0] = L.screenOf(0), s = L.cell();
    const xs = [], ys = [];
    for (let i = 0; i < f.pos.length / 2; i++) { xs.push(f.pos[2 * i]); ys.push(f.pos[2 * i + 1]); }
    for (let x = Math.min(...xs); x <= Math.max(...xs); x++) {
      for (let y = Math.min(...ys); y <= Math.max(...ys); y++) {
        if (taken.has(x + ',' + y)) continue;
        const px = at(x0 + (x - f.pos[0]) * s, y0 - (y - f.pos[1]) * s);
        if (px !== '' && px !== 'ffffff') bad.push(`empty ${x},${y}: #${px}`);
      }
    }
    return bad;
  });
}


async function test(browser) {
  const url = await serve(RULES, AGENTS);
  const { page, errors } = await open(browser, url, { width: 1280, height: 760 });
  assert.equal(await stepNumber(page), 0);

  // Five steps forward, two back.
  for (let i = 1; i <= 5; i++) {
    await page.click('#step');
    await waitStep(page, i);
  }
  for (let i = 4; i >= 3; i--) {
    await page.click('#back');
    await waitStep(page, i);
  }
  assert.equal(await stepNumber(page), 3);

  // An agent whose state changed since step 0, inspected by clicking it.
  const before = agentsAfter(0).map(parseAgent);
  const after = agentsAfter(3).map(parseAgent);
  const id = after.findIndex((a, i) => a.state !== before[i].state);
  assert.ok(id >= 0, 'some agent changes state in three steps');
  const [x, y] = await page.evaluate((id) => window.latticesim.screenOf(id), id);
  await page.mouse.click(x, y);
  await page.waitForFunction((id) => document.getElementById('insp-id')?.textContent === String(id), id);
  assert.equal(await page.textContent('#insp-state'), after[id].state);
  assert.equal((await page.textContent('#insp-pos')).replace(/\s/g, ''), after[id].pos);
  const counters = Object.entries(after[id].counters).map(([k, v]) => `${k}=${v}`).join(' ');
  assert.equal(await page.textContent('#insp-counters'), counters);
  console.log(`ok: step 3 after 5 forward and 2 back; agent ${id} inspected: ${after[id].state}, ${counters}`);

  // A syntax error typed into the rules editor is marked on its line; fixing it clears it.
  await page.click('#tab-edit');
  assert.ok(await page.isHidden('#view') && await page.isVisible('#ed-rules'), 'the editor tab replaces the universe');
  const area = '#ed-rules textarea';
  const text = await page.inputValue(area);
  const lines = text.split('\n');
  const line = lines.findIndex((l) => l === 'SINIT0') + 1; // the first rule's precondition
  assert.ok(line > 0);
  const end = lines.slice(0, line).join('\n').length;
  await page.focus(area);
  await page.evaluate(([sel, end]) => document.querySelector(sel).setSelectionRange(end, end), [area, end]);
  await page.keyboard.type(' (');
  const mark = `#ed-rules .backdrop mark.error[data-line="${line}"]`;
  await page.waitForSelector(mark);
  assert.match(await page.textContent('#check-summary'), /^1 error/);
  assert.match(await page.textContent('#ed-rules .diags li'), new RegExp(`^${line}:8: error\\[E203\\]`));
  // The caret stands in the marked span: its message is the current one.
  assert.match(await page.textContent('#ed-rules .diags li.current'), /E203/);
  if (process.env.SCREENSHOTS) {
    await page.screenshot({ path: path.join(process.env.SCREENSHOTS, 'viewer-editor.png') });
  }
  await page.keyboard.press('Backspace');
  await page.keyboard.press('Backspace');
  await page.waitForSelector('#ed-rules .backdrop mark', { state: 'detached' });
  assert.equal(await page.inputValue(area), text);
  assert.match(await page.textContent('#check-summary'), /^0 errors/);
  console.log(`ok: a syntax error typed on line ${line} is marked there, and cleared when fixed`);

  // Apply restarts the run from step 0 in the universe view.
  await page.click('#apply');
  await page.waitForSelector('#view', { state: 'visible' });
  assert.ok(await page.isHidden('#edit'));
  await waitStep(page, 0);
  await page.click('#step');
  await waitStep(page, 1);
  console.log('ok: apply restarts from step 0');
  assert.deepEqual(errors, [], 'no script errors in the page');
  await page.close();
}

// 3D: stepped, rotated both ways and zoomed; clicking where agents are drawn inspects
// those agents (picking through the drawn faces), with no script error.
async function test3d(browser) {
  const url = await serve('examples/spanning-tree/rules-3d.txt', 'examples/spanning-tree/agents-3d.txt');
  const { page, errors } = await open(browser, url);
  for (let i = 1; i <= 3; i++) {
    await page.click('#step');
    await waitStep(page, i);
  }
  await page.click('#rot-right');
  await page.click('#rot-right');
  await page.click('#rot-left');
  await page.evaluate(() => window.latticesim.zoom(1.3));
  // Agents of the top layer: nothing is drawn over their top faces. An agent with another
  // directly above it: that one covers its top face, and a click there picks another.
  const pos = await page.evaluate(() => Array.from(window.latticesim.frame().pos));
  const zs = pos.filter((_, k) => k % 3 === 2), top = Math.max(...zs);
  const layer = zs.map((z, i) => (z === top ? i : -1)).filter((i) => i >= 0);
  const at = (i) => pos.slice(3 * i, 3 * i + 3).join(',');
  const cells = new Set(zs.map((_, i) => at(i)));
  const inner = zs.findIndex((z, i) => cells.has([pos[3 * i], pos[3 * i + 1], z + 1].join(',')));
  assert.ok(layer.length > 0 && inner >= 0, 'a shape of several layers');
  const picked = [...new Set([layer[0], layer[layer.length - 1]])];
  for (const id of picked) {
    const [x, y] = await page.evaluate((id) => window.latticesim.screenOf(id), id);
    await page.mouse.click(x, y);
    await page.waitForFunction((id) => document.getElementById('insp-id')?.textContent === String(id), id);
  }
  // The covered agent: its top face's centre picks an agent drawn over it.
  const over = await page.evaluate((id) => {
    const r = document.getElementById('canvas').getBoundingClientRect();
    const [x, y] = window.latticesim.screenOf(id);
    return window.latticesim.pick(x - r.left, y - r.top);
  }, inner);
  assert.ok(over !== null && over !== inner, `agent ${inner} is covered (picked ${over})`);
  // The orbit: a drag turns and tilts about the centre (an agent's place on screen moves,
  // not by the drag); a shift-drag pans (it moves by the drag exactly); a drag straight
  // down far enough looks from above: the top layer's agents are all drawn and picked.
  const drag = async (dx, dy, shift) => {
    const r = await page.evaluate(() => { const b = document.getElementById('canvas').getBoundingClientRect(); return [b.left + 40, b.top + 40]; });
    if (shift) await page.keyboard.down('Shift');
    await page.mouse.move(r[0], r[1]);
    await page.mouse.down();
    await page.mouse.move(r[0] + dx / 2, r[1] + dy / 2);
    await page.mouse.move(r[0] + dx, r[1] + dy);
    await page.mouse.up();
    if (shift) await page.keyboard.up('Shift');
  };
  const where = (id) => page.evaluate((id) => window.latticesim.screenOf(id), id);
  const a0 = await where(layer[0]);
  await drag(60, 0, true);
  const a1 = await where(layer[0]);
  assert.ok(Math.abs(a1[0] - a0[0] - 60) < 0.5 && Math.abs(a1[1] - a0[1]) < 0.5, `a shift-drag pans: ${a0} -> ${a1}`);
  await drag(90, 0, false);
  const a2 = await where(layer[0]);
  assert.ok(Math.hypot(a2[0] - a1[0] - 90, a2[1] - a1[1]) > 5, `a drag turns the view: ${a1} -> ${a2}`);
  await drag(0, 400, false);
  for (const id of layer) {
    const got = await page.evaluate((id) => {
      const r = document.getElementById('canvas').getBoundingClientRect();
      const [x, y] = window.latticesim.screenOf(id);
      return window.latticesim.pick(x - r.left, y - r.top);
    }, id);
    assert.equal(got, id, `seen from above, top-layer agent ${id} is picked where it is drawn`);
  }
  assert.deepEqual(errors, [], 'no script errors in the page');
  console.log(`ok: 3D stepped, rotated and zoomed; top-layer agents ${picked.join(" and ")} picked where they are drawn, agent ${inner} covered by agent ${over}; dragging orbits, shift-drag pans, from above every top-layer agent is picked`);
  await page.close();
}

// The controls: every key press counts, one run loop whatever the clicks, Back and Go
// pause a run, the keys step after the slider was touched, the achieved rate is shown.
async function testControls(browser) {
  const url = await serve('examples/bouncing/rules.txt', 'examples/bouncing/agents.txt');
  const { page, errors } = await open(browser, url);
  await page.click('#stage');
  for (let i = 0; i < 30; i++) await page.keyboard.press('ArrowRight');
  await waitStep(page, 30);
  await page.waitForTimeout(300);
  assert.equal(await stepNumber(page), 30, '30 presses of the right arrow are 30 steps');
  // The frame shown, patched from binary deltas step by step, is the run's step 30.
  const cli = execFileSync(BIN, ['run', 'examples/bouncing/rules.txt', 'examples/bouncing/agents.txt', '--max-steps', '30', '--quiet'], { encoding: 'utf8' })
    .split('\n').filter((l) => l && !l.startsWith('U')).map(parseAgent);
  const shown = await page.evaluate(() => {
    const f = window.latticesim.frame();
    return Array.from({ length: f.pos.length / 2 }, (_, i) => ({ pos: `${f.pos[2 * i]},${f.pos[2 * i + 1]}`, state: f.states[f.state[i]].name }));
  });
  assert.deepEqual(shown, cli.map((a) => ({ pos: a.pos, state: a.state })), 'the frame shown is the run at step 30');
  assert.deepEqual(await imageWrongs(page), [], 'the patched image is the frame');
  console.log('ok: 30 quick presses of the right arrow land on step 30, the frame equal to latticesim run --max-steps 30');

  // Touch the slider, then the arrows step and leave the speed alone.
  await page.fill('#jump', '0');
  await page.click('#go');
  await waitStep(page, 0);
  await page.$eval('#speed', (s) => { s.value = '5'; s.dispatchEvent(new Event('input')); });
  await page.click('#speed');
  const speed = await page.inputValue('#speed');
  await page.keyboard.press('ArrowRight');
  await waitStep(page, 1);
  assert.equal(await page.inputValue('#speed'), speed, 'the arrow keys do not change the speed');
  await page.$eval('#speed', (s) => { s.value = '5'; s.dispatchEvent(new Event('input')); });

  // Run, then Pause and Run at once, twice: one loop, at 5 steps/s, not two.
  await page.click('#run');
  await page.waitForTimeout(300);
  for (let k = 0; k < 2; k++) {
    await page.click('#run');
    await page.click('#run');
  }
  const s0 = await stepNumber(page);
  await page.waitForTimeout(3000);
  const s1 = await stepNumber(page);
  const rate = (s1 - s0) / 3;
  assert.ok(rate >= 3 && rate <= 6.5, `one loop at speed 5: ${rate.toFixed(1)} steps/s`);
  assert.match(await page.textContent('#rate'), /\(\d+\.\d achieved\)/);
  assert.match(await page.textContent('#run'), /Pause/);
  // Back while running pauses, one step back from where the run was.
  await page.click('#back');
  await page.waitForFunction(() => document.getElementById('run').textContent.includes('Run'));
  await page.waitForTimeout(500);
  const back = await stepNumber(page);
  await page.waitForTimeout(600);
  assert.equal(await stepNumber(page), back, 'the run is paused after Back');
  assert.ok(back >= s1 - 1, `Back went one step back (${s1} -> ${back})`);
  assert.deepEqual(errors, [], 'no script errors in the page');
  // Gravity: late steps move few agents, sent as deltas and patched into the image.
  const g = await open(browser, await serve('examples/gravity/rules.txt', 'examples/gravity/agents.txt'));
  for (let i = 1; i <= 10; i++) {
    await g.page.keyboard.press('ArrowRight');
    await waitStep(g.page, i);
    assert.deepEqual(await imageWrongs(g.page), [], `gravity's image at step ${i}`);
  }
  assert.ok(await g.page.evaluate(() => window.latticesim.patches()) > 0, 'some steps were patched in');
  await g.page.close();
  console.log(`ok: Pause/Run races give one loop (${rate.toFixed(1)} steps/s at speed 5); Back pauses; the slider keeps no arrow keys`);
  await page.close();
}

// sRGB '#rrggbb' as OKLab (Ottosson), to measure how far apart the state colours are.
function oklab(hex) {
  const v = parseInt(hex.slice(1), 16);
  const lin = (c) => { c /= 255; return c <= 0.04045 ? c / 12.92 : ((c + 0.055) / 1.055) ** 2.4; };
  const [r, g, b] = [lin(v >> 16), lin((v >> 8) & 255), lin(v & 255)];
  const l = Math.cbrt(0.4122214708 * r + 0.5363325363 * g + 0.0514459929 * b);
  const m = Math.cbrt(0.2119034982 * r + 0.6806995451 * g + 0.1073969566 * b);
  const s = Math.cbrt(0.0883024619 * r + 0.2817188376 * g + 0.6299787005 * b);
  return [0.2104542553 * l + 0.793617785 * m - 0.0040720468 * s,
    1.9779984951 * l - 2.428592205 * m + 0.4505937099 * s,
    0.0259040371 * l + 0.7827717662 * m - 0.808675766 * s];
}

// The palette: the spanning tree's states at step 9 (TREEA, TREEE, TREES, TREEW, TROOT...,
// once a few degrees of hue apart) are far apart in OKLab; the legend highlights and hides
// a state, and a hidden state's agents are not picked.
async function testPalette(browser) {
  const url = await serve('examples/spanning-tree/rules-3d.txt', 'examples/spanning-tree/agents-3d.txt');
  const { page, errors } = await open(browser, url);
  await page.fill('#jump', '9');
  await page.click('#go');
  await waitStep(page, 9);
  const states = await page.evaluate(() => window.latticesim.frame().states.map((s) => [s.name, s.colour]));
  assert.ok(states.length >= 5, `several states at step 9: ${states.map((s) => s[0])}`);
  let min = Infinity, pair = null;
  for (let i = 0; i < states.length; i++) {
    for (let j = 0; j < i; j++) {
      const [a, b] = [oklab(states[i][1]), oklab(states[j][1])];
      const d = Math.hypot(a[0] - b[0], a[1] - b[1], a[2] - b[2]);
      if (d < min) { min = d; pair = [states[i][0], states[j][0]]; }
    }
  }
  assert.ok(min >= 0.15, `the closest states ${pair} are ${min.toFixed(3)} apart in OKLab`);
  // The mark of a highlighted state's agents is a colour no state is drawn in.
  const marks = await page.evaluate(() => window.latticesim.marks);
  const far = Math.min(...states.map((s) => { const [a, b] = [oklab(s[1]), oklab(marks.highlight[1])]; return Math.hypot(a[0] - b[0], a[1] - b[1], a[2] - b[2]); }));
  assert.ok(far >= 0.15, `the highlight ${marks.highlight[1]} is ${far.toFixed(3)} from a state's colour`);
  // The darkest side face of every colour in use, and of the palette's darkest (Tol's
  // indigo), stays apart from black.
  const sides = await page.evaluate((cs) => cs.map((c) => window.latticesim.shade(c, 0.62)), [...states.map((s) => s[1]), '#332288']);
  const hex = (rgb) => '#' + rgb.match(/\d+/g).map((v) => Number(v).toString(16).padStart(2, '0')).join('');
  const black = oklab('#000000');
  const dark = Math.min(...sides.map((s) => { const a = oklab(hex(s)); return Math.hypot(a[0] - black[0], a[1] - black[1], a[2] - black[2]); }));
  assert.ok(dark >= 0.35, `a side face is ${dark.toFixed(3)} from black`);
  // Highlight, then hide the state of agent 0; hidden, it is not picked where it was drawn.
  const f = await page.evaluate(() => { const f = window.latticesim.frame(); return { s: f.states[f.state[0]].name }; });
  const [x, y] = await page.evaluate(() => window.latticesim.screenOf(0));
  const name = `#legend li[data-state="${f.s}"] .state-name`;
  await page.click(name);
  await page.waitForSelector(`#legend li.highlight[data-state="${f.s}"]`);
  await page.click(name);
  await page.waitForSelector(`#legend li.hidden[data-state="${f.s}"]`);
  const picked = await page.evaluate(([x, y]) => {
    const r = document.getElementById('canvas').getBoundingClientRect();
    return window.latticesim.pick(x - r.left, y - r.top);
  }, [x, y]);
  const hiddenState = await page.evaluate((id) => { const f = window.latticesim.frame(); return id === null ? null : f.states[f.state[id]].name; }, picked);
  assert.notEqual(hiddenState, f.s, 'an agent of a hidden state is not picked');
  await page.click(name);
  await page.waitForSelector(`#legend li[data-state="${f.s}"]:not(.hidden):not(.highlight)`);
  assert.deepEqual(errors, [], 'no script errors in the page');
  console.log(`ok: ${states.length} states at step 9, the closest (${pair}) ${min.toFixed(3)} apart in OKLab, the highlight ${far.toFixed(3)} from them all, side faces at least ${dark.toFixed(3)} from black; a state highlighted, hidden (not picked) and shown again`);
  await page.close();
}

// 3D slabs: in a solid 5 x 5 x 5 block the middle agent is hidden; with the z slab cut
// down to its layer it is drawn and picked where it is. Tilting and rotating keep it so.
async function testSlabs(browser) {
  const dir = fs.mkdtempSync(path.join(os.tmpdir(), 'latticesim-e2e-'));
  const rules = path.join(dir, 'rules.txt'), agents = path.join(dir, 'agents.txt');
  fs.writeFileSync(rules, 'noop\n1\nSXXXXX\nSYYYYY\n');
  let text = '';
  for (let x = 0; x < 5; x++) for (let y = 0; y < 5; y++) for (let z = 0; z < 5; z++) text += `${x},${y},${z} SB${x}${y}${z}0\n`;
  fs.writeFileSync(agents, text);
  const url = await serve(rules, agents);
  const { page, errors } = await open(browser, url);
  const middle = 2 * 25 + 2 * 5 + 2; // the agent at 2,2,2
  // The agent drawn where the top of agent `id`'s cell is projected, whether it is drawn
  // or not.
  const pickAt = (id) => page.evaluate((id) => {
    const c = document.getElementById('canvas').getBoundingClientRect();
    return window.latticesim.pick(...window.latticesim.project(id, 0.9).map((v, k) => v - (k ? c.top : c.left)));
  }, id);
  // With WebGL2 (depth buffer, picking by ids; `?webgl` asks for it on this machine's
  // software renderer), then with the canvas drawing.
  for (const gl of [true, false]) {
    await page.goto(new URL(gl ? '/?webgl' : '/?canvas3d', url).href);
    await page.waitForFunction(() => window.latticesim && window.latticesim.ready);
    assert.equal(await page.evaluate(() => window.latticesim.webgl()), gl, gl ? 'WebGL2 draws the 3D view' : 'the canvas draws it');
    assert.notEqual(await pickAt(middle), middle, 'inside the block the middle agent is hidden');
    await page.$eval('#slabs .slab[data-axis="2"] .hi', (s) => { s.value = '2'; s.dispatchEvent(new Event('input')); });
    assert.equal(await page.textContent('#slabs .slab[data-axis="2"] .val'), '0..2');
    assert.equal(await pickAt(middle), middle, 'the slab z 0..2 shows the middle agent on its top');
    await page.click('#tilt-up');
    await page.click('#rot-left');
    assert.equal(await pickAt(middle), middle, 'still after tilting and turning');
    const [x, y] = await page.evaluate((id) => window.latticesim.screenOf(id), middle);
    await page.mouse.click(x, y);
    await page.waitForFunction((id) => document.getElementById('insp-id')?.textContent === String(id), middle);
  }
  assert.deepEqual(errors, [], 'no script errors in the page');
  console.log('ok: 3D slab z 0..2 of a 5x5x5 block: the middle agent, hidden before, is picked and inspected (also tilted and turned), with WebGL2 and with the canvas');
  await page.close();
}

// A file too large for the page's editor (over 4 MiB): not put in the text box, which
// says so; checking and Apply read it from disk; a run (frames asked for ahead) ends on
// the configuration `latticesim run` gives.
async function testLargeFile(browser) {
  const dir = fs.mkdtempSync(path.join(os.tmpdir(), 'latticesim-e2e-'));
  const rules = path.join(dir, 'rules.txt'), agents = path.join(dir, 'agents.txt');
  fs.copyFileSync('examples/gravity/rules.txt', rules);
  let text = '';
  for (let i = 0; i < 220_000; i++) text += `${i % 500},${Math.floor(i / 500) * 2 + (i % 3)} SGRAV0 C00 ${i % 1000}\n`;
  fs.writeFileSync(agents, text);
  assert.ok(text.length > 4 << 20);
  const url = await serve(rules, agents);
  const { page, errors } = await open(browser, url);
  await page.click('#tab-edit');
  const box = await page.$eval('#ed-agents textarea', (t) => ({ value: t.value, readOnly: t.readOnly, placeholder: t.placeholder }));
  assert.equal(box.value, '');
  assert.ok(box.readOnly, 'the agents editor is read-only');
  assert.match(box.placeholder, /MB, too much to edit in the page/);
  assert.match(await page.textContent('#check-summary'), /0 errors.*220000 agents/);
  await page.click('#apply');
  await waitStep(page, 0);
  await page.$eval('#speed', (s) => { s.value = s.max; });
  await page.click('#run');
  await page.waitForFunction(() => window.latticesim.frame().step >= 6);
  await page.click('#run');
  await page.waitForTimeout(300);
  const step = await stepNumber(page);
  const want = execFileSync(BIN, ['run', rules, agents, '--max-steps', String(step), '--quiet'], { encoding: 'utf8', maxBuffer: 1 << 26 })
    .split('\n').filter((l) => l && !l.startsWith('U')).map((l) => l.split(/\s+/)[0]);
  const got = await page.evaluate(() => {
    const f = window.latticesim.frame(), out = [];
    for (let i = 0; i < f.pos.length / 2; i++) out.push(f.pos[2 * i] + ',' + f.pos[2 * i + 1]);
    return out;
  });
  assert.equal(got.length, want.length);
  assert.ok(got.every((p, i) => p === want[i]), `the positions at step ${step} are those of latticesim run`);
  // Paused: Step goes on from the frame shown (the one asked for ahead was dropped).
  await page.click('#step');
  await waitStep(page, step + 1);
  // At the fitted zoom a cell is under a pixel: a click a few pixels beside an agent picks
  // the agent nearest to it, drawn within those pixels.
  const near = await page.evaluate(() => {
    const L = window.latticesim, r = document.getElementById('canvas').getBoundingClientRect();
    const [x, y] = L.screenOf(7);
    const id = L.pick(x - r.left + 3, y - r.top + 2);
    if (id === null) return { scale: L.cell(), id };
    const [u, v] = L.screenOf(id);
    return { scale: L.cell(), id, d: Math.hypot(u - x - 3, v - y - 2) };
  });
  assert.ok(near.scale < 1, `fitted, a cell is ${near.scale} pixels`);
  assert.ok(near.id !== null && near.d <= 6, `a click 3 pixels beside agent 7 picks an agent drawn there: ${JSON.stringify(near)}`);
  assert.deepEqual(errors, [], 'no script errors in the page');
  console.log(`ok: a 220,000-agent file (${(text.length / 1e6).toFixed(1)} MB) is read from disk, not edited in the page; run to step ${step} equal to latticesim run, then a step; a click beside an agent at ${near.scale.toFixed(2)} pixels a cell picks one`);
  await page.close();
}

// Colouring by a counter: leader election's ids (C00) on the viridis scale, the scale's
// ends in the legend, the agent with the largest id drawn in its top colour.
async function testColourBy(browser) {
  const url = await serve(RULES, AGENTS);
  const { page, errors } = await open(browser, url);
  await page.click('#step');
  await waitStep(page, 1);
  await page.selectOption('#colour-by', 'C00');
  await page.waitForFunction(() => window.latticesim.frame().values);
  const after = agentsAfter(1).map(parseAgent);
  const ids = after.map((a) => a.counters.C00 || 0);
  const [lo, hi] = [Math.min(...ids), Math.max(...ids)];
  assert.equal(await page.textContent('#scale .lo'), String(lo));
  assert.equal(await page.textContent('#scale .hi'), String(hi));
  const top = ids.indexOf(hi);
  const rgb = await page.evaluate((id) => {
    const c = document.getElementById('canvas');
    const r = c.getBoundingClientRect();
    const [x, y] = window.latticesim.screenOf(id);
    const dpr = window.devicePixelRatio || 1;
    return Array.from(c.getContext('2d').getImageData(Math.round((x - r.left) * dpr), Math.round((y - r.top) * dpr), 1, 1).data.slice(0, 3));
  }, top);
  assert.deepEqual(rgb, [0xfd, 0xe7, 0x25], `agent ${top} (C00 = ${hi}) in the scale's top colour`);
  await page.selectOption('#colour-by', '');
  await page.waitForFunction(() => !window.latticesim.frame().values);
  assert.ok(await page.isHidden('#scale'));
  assert.deepEqual(errors, [], 'no script errors in the page');
  console.log(`ok: coloured by C00 (${lo}..${hi}), agent ${top} drawn in the scale's top colour; back to states`);
  await page.close();
}

// Two tabs of one server: each steps and applies on its own.
async function testTabs(browser) {
  const url = await serve(RULES, AGENTS);
  const context = await browser.newContext({ viewport: { width: 1100, height: 640 } });
  const [one, two] = [await context.newPage(), await context.newPage()];
  for (const p of [one, two]) {
    await p.goto(url);
    await p.waitForFunction(() => window.latticesim && window.latticesim.ready);
  }
  await two.fill('#jump', '6');
  await two.click('#go');
  await waitStep(two, 6);
  await one.click('#step');
  await waitStep(one, 1);
  assert.equal(await stepNumber(two), 6);
  // The second tab applies other agents; the first goes on with its own.
  await two.click('#tab-edit');
  await two.fill('#ed-agents textarea', '0,0 SINIT0 C00 1\n1,0 SINIT0 C00 2\n');
  await two.click('#apply');
  await waitStep(two, 0);
  assert.equal(await two.evaluate(() => window.latticesim.frame().pos.length / 2), 2);
  await one.click('#step');
  await waitStep(one, 2);
  assert.equal(await one.evaluate(() => window.latticesim.frame().pos.length / 2), 30, 'the first tab still runs its 30 agents');
  assert.match(await one.textContent('#status'), /agents-30\.txt/);
  await context.close();
  console.log('ok: two tabs step and apply without touching each other');
}

async function screenshot(browser, rules, agents, steps, file, setup) {
  const url = await serve(rules, agents);
  const { page } = await open(browser, url);
  await page.fill('#jump', String(steps));
  await page.click('#go');
  await waitStep(page, steps);
  await page.click('#fit');
  if (setup) await setup(page);
  await page.screenshot({ path: path.join(process.env.SCREENSHOTS, file) });
  await page.close();
}





const browser = await launch();
const guard = setTimeout(() => { console.error('e2e: timed out'); process.exit(1); }, 180_000);
try {
  await test(browser);
  await test3d(browser);
  await testControls(browser);
  await testPalette(browser);
  await testColourBy(browser);
  await testTabs(browser);
  await testSlabs(browser);
  await testLargeFile(browser);
  if (process.env.SCREENSHOTS) {
    await screenshot(browser, 'examples/reconfigure-line/rules.txt', 'examples/reconfigure-line/agents-30.txt', 450, 'viewer-2d.png',
      async (page) => {
        const [x, y] = await page.evaluate(() => window.latticesim.screenOf(0));
        await page.mouse.click(x, y);
        await page.waitForSelector('#insp-id');
      });
    await screenshot(browser, 'examples/spanning-tree/rules-3d.txt', 'examples/spanning-tree/agents-3d.txt', 4, 'viewer-3d.png',
      async (page) => {
        await page.click('#rot-right');
        const [x, y] = await page.evaluate(() => window.latticesim.screenOf(0));
        await page.mouse.click(x, y);
        await page.waitForSelector('#insp-id');
      });
  }
  console.log('e2e: all passed');
} catch (e) {
  console.error('e2e: FAILED:', e);
  process.exitCode = 1;
} finally {
  clearTimeout(guard);
  await browser.close();
  for (const s of servers) s.kill();
}
