// Chromium driven over its DevTools pipe with nothing but Runtime.evaluate: for measuring
// (e2e/fluid.mjs). Playwright (e2e/viewer.mjs) turns on the DevTools Network domain,
// which keeps a copy of every response for the inspector: on this machine that added
// about 200 ms to each frame of a million agents, a cost a user's browser does not have.
import { spawn } from 'node:child_process';
import { FLAGS } from './common.mjs';

// Opens `url` in headless Chromium (1280 x 800): `evaluate(expression)` gives the value
// of an expression (a promise's awaited), `close()` ends the browser.
export async function open(url) {
  const args = ['--headless', ...FLAGS, '--remote-debugging-pipe', '--window-size=1280,800', 'about:blank'];
  const browser = spawn(process.env.CHROMIUM || '/usr/bin/chromium', args, { stdio: ['ignore', 'ignore', 'ignore', 'pipe', 'pipe'] });
  const [to, from] = [browser.stdio[3], browser.stdio[4]];
  const waiting = new Map();
  let id = 0, buffered = '';
  from.on('data', (d) => {
    buffered += d;
    for (let end; (end = buffered.indexOf('\0')) >= 0;) {
      const m = JSON.parse(buffered.slice(0, end));
      buffered = buffered.slice(end + 1);
      if (waiting.has(m.id)) { waiting.get(m.id)(m); waiting.delete(m.id); }
    }
  });
  const send = (method, params, sessionId) => new Promise((resolve, reject) => {
    waiting.set(++id, (m) => (m.error ? reject(new Error(`${method}: ${m.error.message}`)) : resolve(m.result)));
    to.write(JSON.stringify({ id, method, params, sessionId }) + '\0');
  });
  const { targetId } = await send('Target.createTarget', { url });
  const { sessionId } = await send('Target.attachToTarget', { targetId, flatten: true });
  const evaluate = async (expression) => {
    const r = await send('Runtime.evaluate', { expression, awaitPromise: true, returnByValue: true }, sessionId);
    if (r.exceptionDetails) throw new Error(r.exceptionDetails.exception?.description || r.exceptionDetails.text);
    return r.result.value;
  };
  return { evaluate, close: () => browser.kill() };
}
