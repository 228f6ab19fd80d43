// End-to-end test of the viewer as a workbench (issue 34) in headless Chromium: finding
// one's way (the keys, the Pause glyph, no errors in the console), Follow and PNG, the
// run's log, breakpoints. Run from the repository's root after `cargo build`:
//
//   node e2e/workbench.mjs
//
// LATTICESIM names the binary (default target/debug/latticesim), CHROMIUM the browser;
// the timeline's timings use LATTICESIM_TIMED (default target/release/latticesim when it
// is there: a debug build's timings say little).
import { launch, serve as startServer } from './common.mjs';
import { BIN, open, serve, servers, stepNumber, waitStep } from './page.mjs';
import { execFileSync } from 'node:child_process';
import assert from 'node:assert/strict';
import path from 'node:path';
import fs from 'node:fs';
import os from 'node:os';

const RULES = 'examples/leader-election/rules.txt';
const AGENTS = 'examples/leader-election/agents-30.txt';

// A page of the viewer on these texts of a rules and an agents file (written into a new
// temporary folder), and the errors it logs.
async function opened(browser, rules, agents) {
  const dir = fs.mkdtempSync(path.join(os.tmpdir(), 'latticesim-workbench-'));
  const [r, a] = [path.join(dir, 'rules.txt'), path.join(dir, 'agents.txt')];
  fs.writeFileSync(r, rules);
  fs.writeFileSync(a, agents);
  const url = await serve(r, a);
  return { ...await open(browser, url), url };
}
// Finding one's way (issue 34): `?` shows the keys and Esc hides them, the Pause button
// draws its glyph (not a character fonts lack), applying files with errors says so in the
// page and logs nothing in the console, the favicon costs no request that fails.
async function testWayfinding(browser) {
  const url = await serve(RULES, AGENTS);
  const { page, errors } = await open(browser, url);
  const failed = [];
  page.on('response', (r) => { if (r.status() >= 400) failed.push(`${r.status()} ${r.url()}`); });
  await page.keyboard.press('?');
  await page.waitForSelector('#help', { state: 'visible' });
  assert.match(await page.textContent('#help'), /Space/);
  await page.keyboard.press('Escape');
  await page.waitForSelector('#help', { state: 'hidden' });
  await page.click('#keys');
  await page.waitForSelector('#help', { state: 'visible' });
  await page.click('#keys');
  await page.waitForSelector('#help', { state: 'hidden' });
  await page.click('#run');
  assert.match(await page.innerHTML('#run'), /<svg[^>]*class="glyph"/, 'the Pause glyph is drawn');
  await page.click('#run');
  assert.match(await page.textContent('#run'), /Run/);
  await page.click('#tab-edit');
  await page.fill('#ed-rules textarea', 'x');
  await page.click('#apply');
  await page.waitForFunction(() => /error/.test(document.getElementById('check-summary').textContent));
  assert.ok(await page.isVisible('#edit'), 'files with errors are not applied: the editor stays');
  const favicon = await page.evaluate(() => document.querySelector('link[rel="icon"]').href.startsWith('data:'));
  assert.ok(favicon, 'the favicon is in the page');
  assert.deepEqual(failed, [], 'no request failed');
  assert.deepEqual(errors, [], 'no errors in the console');
  console.log('ok: `?` shows the keys and Esc hides them; the Pause glyph is drawn; files with errors applied: said in the page, nothing in the console; no request failed');
  await page.close();
}

// Follow: two agents walking east leave the view fitted at step 0, unless Follow is on,
// when the view is fitted again as they go (in 2D and in 3D).
async function testFollow(browser) {
  for (const d3 of [false, true]) {
    const { page, errors } = await opened(browser,
      `walk\n1\nSWALK0\nP1,0${d3 ? ',0' : ''}\n`,
      d3 ? '0,0,0 SWALK0\n0,2,0 SWALK0\n' : '0,0 SWALK0\n0,2 SWALK0\n');
    // Where agent 0 is, drawn or not (in 3D its projected centre).
    const inside = () => page.evaluate(() => {
      const L = window.latticesim, r = document.getElementById('canvas').getBoundingClientRect();
      const [x, y] = L.frame().dim === 3 ? L.project(0) : L.screenOf(0);
      return x >= r.left && x <= r.right && y >= r.top && y <= r.bottom;
    });
    await page.fill('#jump', '40');
    await page.click('#go');
    await waitStep(page, 40);
    assert.ok(!await inside(), `${d3 ? '3D' : '2D'}: without Follow, the walker leaves the view`);
    await page.check('#follow');
    for (const step of [41, 60, 90]) {
      await page.fill('#jump', String(step));
      await page.click('#go');
      await waitStep(page, step);
      assert.ok(await inside(), `${d3 ? '3D' : '2D'}: following, the walker is in view at step ${step}`);
    }
    // PNG: the view as shown, the canvas's size, named after the step.
    const [download] = await Promise.all([page.waitForEvent('download'), page.click('#png')]);
    assert.equal(download.suggestedFilename(), 'latticesim-step-90.png');
    const png = fs.readFileSync(await download.path());
    assert.equal(png.subarray(1, 4).toString(), 'PNG');
    const size = await page.evaluate(() => { const c = document.getElementById('canvas'); return [c.width, c.height]; });
    assert.deepEqual([png.readUInt32BE(16), png.readUInt32BE(20)], size, 'the image is the canvas');
    assert.deepEqual(errors, [], 'no errors in the page');
    await page.close();
  }
  console.log('ok: walkers leave the view fitted at step 0; with Follow they stay in it (2D and 3D); PNG saves the view');
}

// The run's log: two rules of one priority set the state differently, so that each of
// three agents has a state conflict every step, and two others a fourth agent; at step 6
// the log holds 24 records, 6 about agent 1, 18 of rule `a`, 6 of rule `c`; an entry of
// step 3 goes there with its agent inspected and centred.
async function testLog(browser) {
  const { page, errors } = await opened(browser,
    '// latticesim: allow W505\na\n1\nSAAAA0\nSB****\n\nb\n1\nSAAAA0\nSC****\n\nc\n1\nSDDDD0\nSE****\n\nd\n1\nSDDDD0\nSF****\n',
    '0,0 SAAAA0\n5,0 SAAAA0\n10,0 SAAAA0\n15,0 SDDDD0\n');
  await page.fill('#jump', '6');
  await page.click('#go');
  await waitStep(page, 6);
  await page.waitForFunction(() => /^24 of 24 records, steps 1\.\.6/.test(document.getElementById('log-summary').textContent));
  assert.equal(await page.locator('#log li').count(), 24);
  await page.selectOption('#log-rule', 'c');
  await page.waitForFunction(() => /^6 of 24/.test(document.getElementById('log-summary').textContent));
  assert.match(await page.locator('#log li').first().textContent(), /\(rules c, d\)$/);
  await page.selectOption('#log-rule', 'a');
  await page.waitForFunction(() => /^18 of 24/.test(document.getElementById('log-summary').textContent));
  await page.fill('#log-agent', '1');
  await page.waitForFunction(() => /^6 of 24/.test(document.getElementById('log-summary').textContent));
  await page.selectOption('#log-kind', 'move-conflict');
  await page.waitForFunction(() => /^0 of 24/.test(document.getElementById('log-summary').textContent));
  await page.selectOption('#log-kind', 'state-conflict');
  await page.waitForFunction(() => /^6 of 24/.test(document.getElementById('log-summary').textContent));
  const entry = page.locator('#log li', { hasText: /^3 / });
  assert.match(await entry.textContent(), /state-conflict/);
  await entry.click();
  await waitStep(page, 3);
  await page.waitForFunction(() => document.getElementById('insp-id') && document.getElementById('insp-id').textContent === '1');
  const centred = await page.evaluate(() => {
    const L = window.latticesim, r = document.getElementById('canvas').getBoundingClientRect();
    const [x, y] = L.screenOf(1);
    return Math.hypot(x - (r.left + r.width / 2), y - (r.top + r.height / 2));
  });
  assert.ok(centred < 2, `agent 1 is centred (${centred.toFixed(1)} pixels off)`);
  assert.deepEqual(errors, [], 'no errors in the page');
  console.log('ok: the run\'s log holds every record so far (24 at step 6), filtered by rule, agent and kind; an entry goes to its step, its agent inspected and centred');
  await page.close();
}

// Breakpoints: two walkers count down (C00 20 and 10) and stop (STOP0) at zero. Run
// pauses at a chosen step, when `<C00 0008` comes to hold (agent 1 at step 3), when an
// agent enters STOP0 (agent 1 at step 11); a condition written wrongly is refused in the
// page. The note says why it paused.
async function testBreaks(browser) {
  const { page, errors } = await opened(browser,
    'walk\n1\nSWALK0 >C00 0000\nP1,0 C00 - C00 0001\n\nstop\n1\nSWALK0 =C00 0000\nSSTOP0\n',
    '0,0 SWALK0 C00 20\n0,2 SWALK0 C00 10\n');
  await page.waitForFunction(() => document.getElementById('bp-kind').options.length > 1);
  const runTo = async (n, why) => {
    await page.click('#run');
    await waitStep(page, n);
    await page.waitForFunction(() => /Run/.test(document.getElementById('run').textContent));
    assert.equal(await stepNumber(page), n);
    assert.match(await page.textContent('#note'), why);
  };
  await page.fill('#bp-counter', 'C00 > 5');
  await page.click('#bp-set');
  await page.waitForFunction(() => /not a counter condition/.test(document.getElementById('bp-summary').textContent));
  await page.fill('#bp-counter', '<C00 0008');
  await page.click('#bp-set');
  await page.waitForFunction(() => /<C00 0008 for some agent/.test(document.getElementById('bp-summary').textContent));
  await page.$eval('#speed', (s) => { s.value = s.max; });
  await runTo(3, /breakpoint: `<C00 0008` holds/);
  await page.fill('#bp-counter', '');
  await page.fill('#bp-state', 'STOP0');
  await page.fill('#bp-step', '14');
  await page.click('#bp-set');
  await page.waitForFunction(() => /STOP0/.test(document.getElementById('bp-summary').textContent));
  await runTo(11, /breakpoint: agent 1 entered `STOP0`/);
  await runTo(14, /breakpoint: step 14/);
  assert.deepEqual(errors, [], 'no errors in the page');
  console.log('ok: breakpoints pause a run when a counter condition comes to hold (step 3), an agent enters a state (step 11), at a step (14); a condition written wrongly is refused');
  await page.close();
}

// The timeline: a slider over the steps reached (a line reconfiguring: moves, bonds and
// messages) goes to any of them, equal to the same
// step reached by stepping (another tab's run); it says how far the run got, what its
// history holds and how the step shown was reached. Then the timings of item 1 (printed,
// not asserted): Back and jumps at 10^5 and 10^6 agents, a cloud falling (the gravity
// example's rules: moves and a counter changing for most agents every step).
async function testTimeline(browser) {
  const { page, errors, url } = await opened(browser,
    fs.readFileSync('examples/reconfigure-line/rules.txt', 'utf8'), fs.readFileSync('examples/reconfigure-line/agents-30.txt', 'utf8'));
  const other = await open(browser, url);
  const frameAt = (p, n) => p.evaluate(async (n) => {
    await window.latticesim.goto(n);
    const f = window.latticesim.frame();
    return { step: f.step, pos: Array.from(f.pos), state: Array.from(f.state).map((i) => f.states[i].name) };
  }, n);
  await frameAt(page, 40);
  assert.equal(await page.getAttribute('#tl-slider', 'max'), '40');
  for (const target of [7, 33, 0, 39, 12]) {
    await page.evaluate((t) => {
      const s = document.getElementById('tl-slider');
      s.value = String(t);
      s.dispatchEvent(new Event('input'));
    }, target);
    await waitStep(page, target);
    const got = await page.evaluate(() => { const f = window.latticesim.frame(); return { step: f.step, pos: Array.from(f.pos), state: Array.from(f.state).map((i) => f.states[i].name) }; });
    assert.deepEqual(got, await frameAt(other.page, target), `step ${target} by the slider equals step ${target} reached by stepping`);
    assert.equal(await page.inputValue('#tl-slider'), String(target));
    assert.equal(await page.textContent('#tl-label'), `step ${target} of 40 reached`);
  }
  assert.match(await page.textContent('#tl-how'), /back from step \d+ in [\d.]+ ms|keyframe of step/);
  assert.match(await page.textContent('#tl-memory'), /^history [\d.]+ MB \([\d.]+ MB of deltas: steps 0 to 40 kept backwards; \d+ keyframes?, every 64 steps\)$/);
  assert.deepEqual(errors.concat(other.errors), [], 'no errors in the pages');
  await other.page.close();
  await page.close();
  console.log('ok: the timeline goes to steps 7, 33, 0, 39 and 12 of 40, each equal to the step reached by stepping; it says what the history holds and how the step was reached');

  // Timings, with an optimised build when there is one.
  const bin = process.env.LATTICESIM_TIMED || (fs.existsSync('target/release/latticesim') ? 'target/release/latticesim' : BIN);
  const dir = fs.mkdtempSync(path.join(os.tmpdir(), 'latticesim-timeline-'));
  // The gravity example's rules (`N***0 >C00 0000` / `P0,-1 C00 - C00 0001`) on a cloud
  // whose agents count their height down as they fall (C00 = y).
  const rules = 'examples/gravity/rules.txt';
  for (const [n, side] of [[100_000, 450], [1_000_000, 1400]]) {
    const agents = path.join(dir, `cloud-${n}.txt`);
    const cloud = execFileSync(bin, ['gen', 'cloud', '--n', String(n), '--width', String(side), '--height', String(side)], { maxBuffer: 1 << 30 }).toString();
    fs.writeFileSync(agents, cloud.split('\n').filter((l) => l).map((l) => `${l} C00 ${l.split(',')[1]}`).join('\n') + '\n');
    const s = startServer(bin, rules, agents);
    servers.push(s.process);
    const { page, errors } = await open(browser, await s.url);
    const timed = (t) => page.evaluate(async (t) => {
      const t0 = performance.now();
      await window.latticesim.goto(t);
      const f = window.latticesim.frame();
      return { step: f.step, page: performance.now() - t0, server: f.history.ms, how: f.history.how };
    }, t);
    const reach = await timed(100);
    assert.equal(reach.step, 100);
    const rows = [`first 100 steps ${Math.round(reach.page)} ms`];
    for (const [what, t] of [['Back', 99], ['Back', 98], ['to 10', 10], ['to 65', 65], ['to 40', 40], ['to 100', 100], ['to 0', 0], ['to 90', 90]]) {
      const r = await timed(t);
      assert.equal(r.step, t);
      rows.push(`${what}: ${Math.round(r.page)} ms (server ${Math.round(r.server)} ms, ${r.how})`);
    }
    const memory = await page.textContent('#tl-memory');
    assert.deepEqual(errors, [], 'no errors in the page');
    await page.close();
    s.process.kill();
    console.log(`timeline, ${n.toLocaleString('en')} agents falling (${path.basename(bin)} ${bin.includes('release') ? 'optimised' : ''}): ${rows.join('; ')}; ${memory}`);
  }
  fs.rmSync(dir, { recursive: true, force: true });
}

// Editing by mouse: E turns it on; a click on an empty cell places an agent, on an agent
// selects it; its counters and bonds are set, undone and done again (buttons and keys); a
// taken cell, a state mistyped and a counter the checker refuses change nothing and say
// why; Delete removes
// an agent with its bonds; Save writes the canonical agents file, which checks; the run
// goes on from the edited agents.
async function testEditing(browser) {
  const rules = 'fall\n1\nSFALL0 E0,-1\nP0,-1\n';
  const { page, errors } = await opened(browser, rules, '0,5 SFALL0\n2,0 SREST0\n');
  const frame = () => page.evaluate(() => {
    const f = window.latticesim.frame();
    const n = f.pos.length / f.dim;
    return Array.from({ length: n }, (_, i) => ({ pos: [f.pos[2 * i], f.pos[2 * i + 1]], state: f.states[f.state[i]].name, attach: f.attach ? f.attach[i] : 0 }));
  });
  const summary = () => page.textContent('#ed-summary');
  const edited = async (action, check) => {
    const before = await page.getAttribute('#ed-summary', 'data-n');
    await action();
    await page.waitForFunction((b) => document.getElementById('ed-summary').dataset.n !== b, before);
    const s = await summary();
    if (check) assert.match(s, check);
    return s;
  };
  // The screen point of cell (x, y), from agent 0's cell.
  const cell = (x, y) => page.evaluate(([x, y]) => {
    const L = window.latticesim, f = L.frame(), [ax, ay] = L.screenOf(0), k = L.cell();
    return [ax + (x - f.pos[0]) * k, ay - (y - f.pos[1]) * k];
  }, [x, y]);
  const click = async (x, y) => { const [px, py] = await cell(x, y); await page.mouse.click(px, py); };
  await page.keyboard.press('e');
  await page.waitForSelector('#edit-panel', { state: 'visible' });
  await page.fill('#ed-state', 'FALL0');
  await edited(() => click(1, 5), /^edited: 3 agents, 0 errors, \d+ warnings/);
  assert.deepEqual((await frame())[2], { pos: [1, 5], state: 'FALL0', attach: 0 });
  assert.match(await page.inputValue('#ed-agents textarea'), /1,5 SFALL0/);
  // Select it by a click on its cell; set a counter.
  await click(1, 5);
  await page.waitForSelector('#ed-agent', { state: 'visible' });
  assert.equal(await page.textContent('#ed-which'), 'agent 2 on 1,5');
  await page.fill('#ed-agent-counters', 'C00 7');
  await edited(() => page.click('#ed-set'), /^edited/);
  await page.waitForFunction(() => /C00=7/.test(document.getElementById('insp-counters')?.textContent || ''));
  // A neighbour placed by typing its cell; a bond between them, undone and done again.
  await page.fill('#ed-pos', '2,5');
  await edited(() => page.click('#ed-place'), /^edited: 4 agents/);
  await click(1, 5);
  await page.waitForFunction(() => document.getElementById('ed-which').textContent === 'agent 2 on 1,5');
  await edited(() => page.check('#ed-bonds input[data-dir="E"]'), /^edited/);
  let f = await frame();
  assert.deepEqual([f[2].attach, f[3].attach], [4, 2], 'bonded both ways (E on agent 2, W on agent 3)');
  await edited(() => page.keyboard.press('Control+z'), /^edited/);
  f = await frame();
  assert.deepEqual([f[2].attach, f[3].attach], [0, 0], 'undone');
  await edited(() => page.click('#ed-redo'), /^edited/);
  f = await frame();
  assert.deepEqual([f[2].attach, f[3].attach], [4, 2], 'done again');
  // What cannot be: a taken cell, a state the checker refuses.
  await page.fill('#ed-pos', '0,5');
  await edited(() => page.click('#ed-place'), /^not done: agent 0 stands on 0,5/);
  await page.fill('#ed-agent-state', 'FA LL');
  await edited(() => page.click('#ed-set'), /^not done: `FA LL` is not a state/);
  await page.fill('#ed-agent-state', 'FALL0');
  await page.fill('#ed-agent-counters', 'C00 99999');
  await edited(() => page.click('#ed-set'), /^not done: the value 99999 of C00 is outside -32767..32767/);
  assert.equal((await frame()).length, 4, 'nothing changed');
  // Delete removes agent 3 and its bond.
  await click(2, 5);
  await page.waitForFunction(() => document.getElementById('ed-which').textContent === 'agent 3 on 2,5');
  await edited(() => page.keyboard.press('Delete'), /^edited: 3 agents/);
  f = await frame();
  assert.deepEqual(f[2], { pos: [1, 5], state: 'FALL0', attach: 0 }, 'its bond went with it');
  // Save: the canonical agents file, which checks.
  await edited(() => page.click('#ed-save'), /^saved /);
  const saved = (await summary()).match(/^saved (\S+)/)[1];
  const text = fs.readFileSync(saved, 'utf8');
  assert.equal(text, '0,5 SFALL0\n2,0 SREST0\n1,5 SFALL0 C00 7\n');
  execFileSync(BIN, ['check', path.join(path.dirname(saved), 'rules.txt'), '--agents', saved], { stdio: 'pipe' });
  // The run goes on from the edited agents.
  await page.keyboard.press('e');
  await page.click('#step');
  await waitStep(page, 1);
  assert.deepEqual((await frame())[2].pos, [1, 4], 'the placed agent falls');
  assert.deepEqual(errors, [], 'no errors in the page');
  await page.close();
  console.log('ok: editing by mouse: placed (click and typed), selected, a counter set, a bond made, undone (Ctrl+Z) and done again, a taken cell, a mistyped state and a counter the checker refuses change nothing, Delete removes with bonds, Save writes the canonical file (it checks), the run goes on from it');
}

// Plots and exports: the live charts' series equal `latticesim run --series` (executing,
// moves, swaps, messages sent, records per step) and the frame's state counts; a click
// on a chart goes to its step; SVG and GIF downloads are the server's pictures of the
// step and the range, and WebM records the view over a range.
async function testPlots(browser) {
  const [rules, agents] = ['examples/reconfigure-line/rules.txt', 'examples/reconfigure-line/agents-30.txt'];
  const { page, errors } = await opened(browser, fs.readFileSync(rules, 'utf8'), fs.readFileSync(agents, 'utf8'));
  await page.evaluate(() => window.latticesim.goto(30));
  await page.waitForFunction(() => document.getElementById('plot-steps').dataset.steps === '0..30');
  const series = await page.evaluate(() => window.latticesim.series());
  const dir = fs.mkdtempSync(path.join(os.tmpdir(), 'latticesim-plots-'));
  const csv = path.join(dir, 's.csv');
  execFileSync(BIN, ['run', rules, agents, '--max-steps', '30', '--series', csv, '--quiet'], { stdio: 'pipe' });
  const lines = fs.readFileSync(csv, 'utf8').trim().split('\n');
  const head = lines[0].split(',');
  const rows = lines.slice(1).map((l) => l.split(',').map(Number));
  for (const k of ['executing', 'moves', 'swaps', 'sent', 'records']) {
    const want = [0, ...rows.map((r) => r[head.indexOf(k)])];
    assert.deepEqual(series[k], want, `${k} per step equals latticesim run --series`);
  }
  assert.deepEqual(series.step, [...Array(31).keys()]);
  const counts = await page.evaluate(() => Object.fromEntries(window.latticesim.frame().states.map((s) => [s.name, s.count])));
  for (const s of series.states) assert.equal(s.counts[30], counts[s.name] || 0, `agents in ${s.name} at step 30`);
  // A click in the middle of the per-step chart goes to step 15 or so.
  const box = await page.locator('#plot-steps').boundingBox();
  await page.mouse.click(box.x + 34 + (box.width - 38) / 2, box.y + box.height / 2);
  await page.waitForFunction(() => Math.abs(Number(document.getElementById('step-number').textContent) - 15) <= 1);
  // Exports.
  const saved = async (button) => {
    const [d] = await Promise.all([page.waitForEvent('download', { timeout: 60_000 }), page.click(button)]);
    return { name: d.suggestedFilename(), bytes: fs.readFileSync(await d.path()) };
  };
  const step = await stepNumber(page);
  const svg = await saved('#svg');
  assert.equal(svg.name, `latticesim-step-${step}.svg`);
  assert.match(svg.bytes.toString(), new RegExp(`^<svg[\\s\\S]*step ${step}<`));
  await page.fill('#ex-from', '2');
  await page.fill('#ex-to', '6');
  const gif = await saved('#gif');
  assert.equal(gif.name, 'latticesim-steps-2-6.gif');
  assert.equal(gif.bytes.subarray(0, 6).toString(), 'GIF89a');
  assert.equal(await stepNumber(page), step, 'the run shows the step it showed');
  const frames = (gif.bytes.toString('latin1').match(/\x21\xf9\x04/g) || []).length;
  assert.equal(frames, 5, 'five frames: steps 2 to 6');
  const webm = await saved('#webm');
  assert.equal(webm.name, 'latticesim-steps-2-6.webm');
  assert.deepEqual([...webm.bytes.subarray(0, 4)], [0x1a, 0x45, 0xdf, 0xa3], 'a WebM (EBML) file');
  assert.equal(await stepNumber(page), 6, 'the recording went through the range');
  assert.deepEqual(errors, [], 'no errors in the page');
  await page.close();
  fs.rmSync(dir, { recursive: true, force: true });
  console.log(`ok: plots: the series equal latticesim run --series and the frame's counts; a click on a chart goes to its step; SVG (${svg.bytes.length} B), GIF of steps 2-6 (5 frames, ${gif.bytes.length} B) and WebM (${webm.bytes.length} B) downloaded`);
}

// The minimap: hidden while every agent is in view; zoomed in on a large block it shows
// all of them with the view outlined, and a click on its corner takes the view there.
async function testMinimap(browser) {
  const block = execFileSync(BIN, ['gen', 'block', '--width', '300', '--height', '200']).toString();
  const { page, errors } = await opened(browser, 'idle\n1\nSIDLE0\nSIDLE1\n', block);
  const hidden = () => page.evaluate(() => document.getElementById('minimap').hidden);
  assert.ok(await hidden(), 'all in view: no minimap');
  for (let i = 0; i < 12; i++) await page.keyboard.press('+');
  await page.waitForFunction(() => !document.getElementById('minimap').hidden);
  const view = () => page.evaluate(() => document.getElementById('minimap').dataset.view.split(',').map(Number));
  const before = await view();
  const box = await page.locator('#minimap').boundingBox();
  await page.mouse.click(box.x + 4, box.y + 4);
  const after = await view();
  // The top left corner of the block (0, 199) is now in the middle of the view.
  const [x0, y0, x1, y1] = after;
  assert.ok(x0 < 2 && x1 > 0 && y0 < 199 && y1 > 197, `the view went to the corner: ${before} -> ${after}`);
  await page.click('#fit');
  assert.ok(await hidden(), 'fitted: no minimap');
  assert.deepEqual(errors, [], 'no errors in the page');
  await page.close();
  console.log(`ok: minimap: hidden when all is in view, shown zoomed in on 60,000 agents, a click on its corner takes the view there (${before.map(Math.round)} -> ${after.map(Math.round)})`);
}

const browser = await launch();
const guard = setTimeout(() => { console.error('workbench: timed out'); process.exit(1); }, 300_000);
try {
  await testWayfinding(browser);
  await testFollow(browser);
  await testLog(browser);
  await testBreaks(browser);
  await testEditing(browser);
  await testPlots(browser);
  await testMinimap(browser);
  await testTimeline(browser);
  console.log('workbench: all passed');
} catch (e) {
  console.error('workbench: FAILED:', e);
  process.exitCode = 1;
} finally {
  clearTimeout(guard);
  await browser.close();
  for (const s of servers) s.kill();
}
