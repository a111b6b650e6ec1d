// Shared support for the browser tests: start the real `facecast serve`, drive Debian's Chromium
// (headless, software WebGL) with playwright-core, collect console errors, save screenshots.
//
// Every test is `node tests/web/<name>.mjs FACECAST_BINARY SOURCE_DIR ARTIFACT_DIR`.

import { spawn, execFileSync } from 'node:child_process';
import { mkdtempSync, mkdirSync, rmSync, readFileSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { join } from 'node:path';
import { createRequire } from 'node:module';

const [, , binaryArg, sourceArg, artifactsArg] = process.argv;
if (!binaryArg || !sourceArg) {
  console.error('usage: node <test>.mjs FACECAST_BINARY SOURCE_DIR [ARTIFACT_DIR]');
  process.exit(2);
}
export const binary = binaryArg;

// Until the server exists (issue 7) the browser tests are skipped (ctest SKIP_RETURN_CODE 77).
export const SKIP = 77;
{
  let help = '';
  try {
    help = execFileSync(binaryArg, ['--help'], { encoding: 'utf8' });
  } catch (e) {
    help = String(e.stdout || '');
  }
  if (!/^\s*serve\b/m.test(help)) {
    console.log(`${binaryArg} has no 'serve' subcommand: skipping the browser test`);
    process.exit(SKIP);
  }
}
export const sourceDir = sourceArg;
export const artifacts = artifactsArg || join(tmpdir(), 'facecast-web-artifacts');
mkdirSync(artifacts, { recursive: true });

// playwright-core from the project's node_modules (the test file may live outside the source tree's
// module resolution when run from the build folder).
const require = createRequire(join(sourceDir, 'package.json'));
const { chromium } = require('playwright-core');

export const CHROMIUM = process.env.FACECAST_CHROMIUM || '/usr/bin/chromium';

const cleanups = [];
const servers = [];
let failures = 0;
let passes = 0;
const started = Date.now();

export function log(...a) {
  const t = ((Date.now() - started) / 1000).toFixed(1).padStart(6);
  console.log(`[${t}s]`, ...a);
}

/** Records one named check; a failed check does not stop the test (the summary counts them). */
export function check(name, ok, detail = '') {
  if (ok) {
    passes += 1;
    log(`ok    ${name}${detail ? ` — ${detail}` : ''}`);
  } else {
    failures += 1;
    log(`FAIL  ${name}${detail ? ` — ${detail}` : ''}`);
  }
  return ok;
}

/** Throws (ends the test) when a precondition fails. */
export function must(name, ok, detail = '') {
  if (!check(name, ok, detail)) throw new Error(`${name} failed; later checks depend on it`);
}

export const sleep = (ms) => new Promise((r) => setTimeout(r, ms));

// ---------------------------------------------------------------------------------------------------
// The server.

/**
 * Starts `facecast serve --port PORT --data DIR` (port 0: the server picks one and prints it) and
 * waits until /healthz answers. Returns {url, port, data, proc, stop()}.
 */
export async function startServer({ port = 0, data = null, extraArgs = [] } = {}) {
  const dir = data || mkdtempSync(join(tmpdir(), 'facecast-web-data-'));
  const owned = !data;
  const args = ['serve', '--port', String(port), '--data', dir, ...extraArgs];
  log(`starting ${binary} ${args.join(' ')}`);
  const proc = spawn(binary, args, { cwd: sourceDir, stdio: ['ignore', 'pipe', 'pipe'] });
  let out = '';
  // The server's log is kept and printed when the test fails (FACECAST_WEB_VERBOSE=1: as it comes).
  const onData = (d) => {
    out += d.toString();
    if (process.env.FACECAST_WEB_VERBOSE) for (const line of d.toString().split('\n')) if (line.trim()) log(`  server: ${line.trim()}`);
  };
  proc.stdout.on('data', onData);
  proc.stderr.on('data', onData);
  let exited = null;
  proc.on('exit', (code, sig) => (exited = { code, sig }));

  const deadline = Date.now() + 60000;
  let chosen = port || null;
  while (!chosen) {
    if (exited) throw new Error(`facecast serve exited (${exited.code ?? exited.sig}) before printing its port:\n${out}`);
    if (Date.now() > deadline) throw new Error(`facecast serve printed no port within 60 s:\n${out}`);
    chosen = parsePort(out);
    if (!chosen) await sleep(50);
  }
  const url = `http://127.0.0.1:${chosen}`;
  for (;;) {
    if (exited) throw new Error(`facecast serve exited (${exited.code ?? exited.sig}):\n${out}`);
    if (Date.now() > deadline) throw new Error(`facecast serve did not answer /healthz within 60 s:\n${out}`);
    try {
      const r = await fetch(`${url}/healthz`);
      if (r.ok) break;
    } catch {
      // not listening yet
    }
    await sleep(100);
  }
  log(`server up at ${url} (${out.split('\n').find((l) => l.includes(String(chosen)))?.trim() ?? ''})`);
  const server = {
    url,
    port: chosen,
    data: dir,
    proc,
    get output() {
      return out;
    },
    get exited() {
      return exited;
    },
    async stop() {
      if (!exited) {
        proc.kill('SIGTERM');
        for (let i = 0; i < 100 && !exited; i++) await sleep(50);
        if (!exited) {
          log('server ignored SIGTERM for 5 s; killing it');
          proc.kill('SIGKILL');
          for (let i = 0; i < 40 && !exited; i++) await sleep(50);
        }
      }
      return exited;
    },
  };
  servers.push(server);
  cleanups.push(async () => {
    await server.stop();
    if (owned) rmSync(dir, { recursive: true, force: true });
  });
  return server;
}

/** The port from the server's start-up line (a bare number, or "...port 1234", or a URL). */
export function parsePort(text) {
  for (const line of text.split('\n')) {
    const t = line.trim();
    if (/^\d{2,5}$/.test(t)) return Number(t);
    const m = /(?:https?|wss?):\/\/[^\s/:]+:(\d{2,5})/.exec(t) || /\bport\b\D{0,12}(\d{2,5})\b/i.exec(t);
    if (m && Number(m[1]) > 0) return Number(m[1]);
  }
  return null;
}

// ---------------------------------------------------------------------------------------------------
// The browser.

/** `args`: extra Chromium switches (e.g. a fake webcam). */
export async function launchBrowser({ args = [] } = {}) {
  const browser = await chromium.launch({
    executablePath: CHROMIUM,
    headless: true,
    args: [
      '--no-sandbox', // root in CI
      '--use-angle=swiftshader', // software WebGL, as CI has no GPU
      '--enable-unsafe-swiftshader',
      '--autoplay-policy=no-user-gesture-required',
      '--disable-gpu-sandbox',
      '--mute-audio', // play (the audio clock runs) but make no sound
      ...args,
    ],
  });
  cleanups.push(() => browser.close().catch(() => {}));
  return browser;
}

/**
 * A page that records console errors and uncaught exceptions in `page.problems`.
 * `page.allow(re)` tolerates messages matching re (e.g. while the server is deliberately down).
 */
export async function newPage(browser, { width = 1400, height = 860 } = {}) {
  const context = await browser.newContext({ viewport: { width, height }, deviceScaleFactor: 1 });
  const page = await context.newPage();
  // A page's first load waits for the server beside other tests' work (rig.html took over 30 s,
  // Playwright's default, with the slow photo tests on both cores).
  page.setDefaultNavigationTimeout(120000);
  page.problems = [];
  page.allowed = [];
  page.allow = (re) => page.allowed.push(re);
  page.on('console', (m) => {
    if (m.type() !== 'error') return;
    const text = m.text();
    if (page.allowed.some((re) => re.test(text))) return;
    page.problems.push(`console.error: ${text}`);
    log(`  page console.error: ${text}`);
  });
  page.on('pageerror', (e) => {
    page.problems.push(`uncaught: ${e.message}`);
    log(`  page uncaught: ${e.message}`);
  });
  return page;
}

export async function screenshot(page, name) {
  const path = join(artifacts, `${name}.png`);
  await page.screenshot({ path });
  log(`screenshot ${path}`);
  return path;
}

/** Polls fn() in the page until it returns a truthy value; returns it (or throws after timeout). */
export async function waitFor(page, fn, arg, { timeout = 30000, what = 'condition' } = {}) {
  try {
    const h = await page.waitForFunction(fn, arg, { timeout, polling: 50 });
    return await h.jsonValue();
  } catch (e) {
    throw new Error(`timed out after ${timeout} ms waiting for ${what}`);
  }
}

async function cleanupAll() {
  for (const c of cleanups.splice(0).reverse()) {
    try {
      await c();
    } catch (e) {
      log(`cleanup: ${e.message}`);
    }
  }
}

// Whatever ends the test (its own time limit, ctest's, Ctrl+C), the server and browser go with it.
for (const sig of ['SIGTERM', 'SIGINT']) {
  process.on(sig, () => {
    log(`${sig}: stopping`);
    cleanupAll().finally(() => process.exit(1));
  });
}
process.on('exit', () => {
  for (const srv of servers) if (!srv.exited) srv.proc.kill('SIGKILL');
});

/** Runs the test body, then cleans up and prints the closing line ctest and CI read. */
export async function run(name, body) {
  let crashed = null;
  const timer = setTimeout(() => {
    log('test timed out after 600 s');
    cleanupAll().finally(() => process.exit(1));
  }, 600000);
  try {
    await body();
  } catch (e) {
    crashed = e;
    failures += 1;
    log(`ERROR ${e.stack || e}`);
  }
  if (failures || crashed) {
    for (const srv of servers) {
      const lines = srv.output.trim().split('\n');
      log(`server on port ${srv.port}, last ${Math.min(80, lines.length)} of ${lines.length} log lines:`);
      for (const line of lines.slice(-80)) console.log(`    ${line}`);
    }
  }
  await cleanupAll();
  clearTimeout(timer);
  console.log(`${name}: ${passes} passed, ${failures} failed`);
  process.exit(failures || crashed ? 1 : 0);
}

export function readJson(rel) {
  return JSON.parse(readFileSync(join(sourceDir, rel), 'utf8'));
}

/**
 * The share of a canvas's pixels that differ from its corner colour (the background): a WebGL view
 * that draws nothing gives 0.
 */
export async function drawnShare(page, selector) {
  return page.evaluate((sel) => {
    const src = document.querySelector(sel);
    const c = document.createElement('canvas');
    c.width = 160;
    c.height = Math.max(1, Math.round((160 * src.height) / Math.max(1, src.width)));
    const g = c.getContext('2d');
    g.drawImage(src, 0, 0, c.width, c.height);
    const d = g.getImageData(0, 0, c.width, c.height).data;
    const [r, gr, b] = [d[0], d[1], d[2]];
    let n = 0;
    for (let i = 0; i < d.length; i += 4) if (Math.abs(d[i] - r) + Math.abs(d[i + 1] - gr) + Math.abs(d[i + 2] - b) > 30) n += 1;
    return n / (d.length / 4);
  }, selector);
}

/** Opens `/?rig=ID` in a new page, speaks `text` and checks that the mouth moves and the utterance ends without console errors. */
export async function speaksOnMainPage(browser, server, rig, text, shot) {
  const speakPage = await newPage(browser);
  await speakPage.goto(`${server.url}/?rig=${encodeURIComponent(rig)}`);
  await waitFor(speakPage, (id) => window.__facecast?.ready && window.__facecast.rig === id && window.__facecast.connection === 'open', rig, {
    timeout: 90000,
    what: 'the speak page with the new rig',
  });
  await speakPage.fill('#text', text);
  await speakPage.click('#speak');
  const peak = await speakPage
    .waitForFunction(() => window.__facecast.mouth() > 0.1 && window.__facecast.mouth(), null, { timeout: 30000, polling: 40 })
    .then((h) => h.jsonValue())
    .catch(() => 0);
  check('the built rig speaks on the main page', peak > 0.1, `mouth ${Number(peak).toFixed(3)}`);
  await screenshot(speakPage, shot);
  await waitFor(speakPage, () => ['done', 'cancelled', 'error'].includes(window.__facecast.lastUtterance?.state), null, { timeout: 30000, what: 'the end of the utterance' });
  check('no console errors on the speak page', speakPage.problems.length === 0, speakPage.problems.slice(0, 5).join(' | '));
}
