// What the viewer's scripts share: starting `latticesim serve` and launching Chromium.
import { chromium } from 'playwright-core';
import { spawn } from 'node:child_process';

// Debian's Chromium as the machine runs it: headless, and without the background
// connections a closed network refuses.
export const FLAGS = ['--no-sandbox', '--disable-gpu', '--disable-quic', '--no-first-run',
  '--disable-background-networking', '--disable-component-update', '--disable-sync'];

export function launch() {
  return chromium.launch({ executablePath: process.env.CHROMIUM || '/usr/bin/chromium', args: FLAGS });
}

// Starts `BIN serve RULES AGENTS` on a free port: the process and a promise of its URL.
export function serve(bin, rules, agents, extra = []) {
  const p = spawn(bin, ['serve', rules, agents, '--port', '0', ...extra], { stdio: ['ignore', 'pipe', 'inherit'] });
  const url = new Promise((resolve, reject) => {
    let out = '';
    p.stdout.on('data', (d) => {
      out += d;
      const m = out.match(/http:\/\/[^\s]+/);
      if (m) resolve(m[0]);
    });
    p.on('exit', (code) => reject(new Error(`latticesim serve exited with ${code}: ${out}`)));
  });
  return { process: p, url };
}
