// A server started with --token: the page without the token says that a token is needed; with
// ?token= in the address the socket, the rig download and the API work, and the links keep it.
// A server with API keys (facecast keys create): the page asks for the key on 401, keeps it for the
// tab (sessionStorage) and sends it as Bearer and in the WebSocket subprotocol list.

import { execFileSync } from 'node:child_process';
import { mkdtempSync, rmSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { join } from 'node:path';
import { run, startServer, launchBrowser, newPage, screenshot, check, waitFor, binary } from './lib.mjs';

await run('token', async () => {
  const token = 'web-test-token';
  const server = await startServer({ extraArgs: ['--token', token] });
  const browser = await launchBrowser();

  // ---- Without the token.
  const denied = await newPage(browser);
  denied.allow(/WebSocket connection to .* failed|401|Failed to load resource/);
  await denied.goto(`${server.url}/`);
  await waitFor(denied, () => document.querySelector('.alert[data-code="unauthorized"]'), null, { timeout: 20000, what: 'the token message' });
  check('without a token the page says one is needed', /token/i.test(await denied.textContent('.alert[data-code="unauthorized"]')), await denied.textContent('.alert[data-code="unauthorized"] .msg'));
  check('the connection state says so', (await denied.textContent('#conn-text')) === 'Token required', await denied.textContent('#conn-text'));
  check('speaking is disabled', await denied.isDisabled('#speak'));
  await screenshot(denied, 'token-01-required');
  check('no unexpected console errors without the token', denied.problems.length === 0, denied.problems.join(' | '));

  // ---- With the token.
  const page = await newPage(browser);
  await page.goto(`${server.url}/?token=${token}`);
  await waitFor(page, () => window.__facecast?.ready && window.__facecast.connection === 'open', null, { timeout: 90000, what: 'the page to connect with the token' });
  check('with ?token= the page connects and loads the rig', true);
  await page.fill('#text', '你好, hello!');
  await page.click('#speak');
  const peak = await page
    .waitForFunction(() => window.__facecast.mouth() > 0.1 && window.__facecast.mouth(), null, { timeout: 30000, polling: 40 })
    .then((h) => h.jsonValue())
    .catch(() => 0);
  check('it speaks', peak > 0.1, `mouth ${Number(peak).toFixed(3)}`);
  const link = await page.getAttribute('nav a[href*="rig.html"]', 'href');
  check('the link to the rig builder keeps the token', link.includes(`token=${token}`), link);
  await page.click('nav a[href*="rig.html"]');
  await waitFor(page, () => window.__rig?.templateReady, null, { timeout: 90000, what: 'the rig builder with the token' });
  check('the rig builder loads the template with the token', true);
  check('no console errors with the token', page.problems.length === 0, page.problems.join(' | '));

  // ---- API keys: the page asks for one.
  const data = mkdtempSync(join(tmpdir(), 'facecast-web-keys-'));
  const key = execFileSync(binary, ['keys', 'create', '--tenant', 'web', '--scopes', 'speak,rigs:read', '--data', data], { encoding: 'utf8', stdio: ['ignore', 'pipe', 'ignore'] }).trim();
  const keyed = await startServer({ data });
  const asking = await newPage(browser);
  asking.allow(/WebSocket connection to .* failed|401|Failed to load resource/);
  let prompts = 0;
  asking.on('dialog', (d) => {
    prompts += 1;
    d.accept(key);
  });
  await asking.goto(`${keyed.url}/`);
  await waitFor(asking, () => window.__facecast?.ready && window.__facecast.connection === 'open', null, { timeout: 90000, what: 'the page to connect with the key it asked for' });
  check('the page asked for the key once', prompts === 1, `${prompts} prompts`);
  check('the key is kept for the tab only', (await asking.evaluate(() => sessionStorage.getItem('facecast.key'))) === key);
  check('the address carries no key', !asking.url().includes(key));
  await asking.fill('#text', 'hello!');
  await asking.click('#speak');
  const spoken = await asking
    .waitForFunction(() => window.__facecast.mouth() > 0.1 && window.__facecast.mouth(), null, { timeout: 30000, polling: 40 })
    .then((h) => h.jsonValue())
    .catch(() => 0);
  check('it speaks with the key', spoken > 0.1, `mouth ${Number(spoken).toFixed(3)}`);
  await screenshot(asking, 'token-02-key');
  await keyed.stop();
  rmSync(data, { recursive: true, force: true });
});

