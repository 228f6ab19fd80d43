// What the browser tests share (viewer.mjs, workbench.mjs): the binary, its servers, a page
// of the viewer with the errors it logs, and waiting for a step.
import { serve as start } from './common.mjs';
import path from 'node:path';

export const BIN = path.resolve(process.env.LATTICESIM || 'target/debug/latticesim');
export const servers = [];

// Starts `latticesim serve` on a free port; resolves to its URL.
export function serve(rules, agents) {
  const s = start(BIN, rules, agents);
  servers.push(s.process);
  return s.url;
}

// A page of the viewer at `url`, ready, and the script errors it will have.
export async function open(browser, url, viewport = { width: 1100, height: 640 }) {
  const page = await browser.newPage({ viewport });
  const errors = [];
  page.on('pageerror', (e) => errors.push(e.message));
  // Messages the page logs as errors (a resource not found, a request refused) too.
  page.on('console', (m) => { if (m.type() === 'error') errors.push(m.text()); });
  await page.goto(url);
  await page.waitForFunction(() => window.latticesim && window.latticesim.ready);
  return { page, errors };
}

export async function stepNumber(page) {
  return Number(await page.textContent('#step-number'));
}

export async function waitStep(page, n) {
  await page.waitForFunction((n) => document.getElementById('step-number').textContent === String(n), n);
}
