// Starts a real `facecast serve` ($FACECAST_EXE) on a free port with a temporary data folder and a
// channel "show", for the client's tests.

import { spawn } from 'node:child_process';
import { mkdtempSync, rmSync, writeFileSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { join } from 'node:path';

export const KEY = 'test-admin-key-0123456789';
export const PRODUCER = 'producer-secret-1';

const sleep = (ms) => new Promise((r) => setTimeout(r, ms));

/** {url (ws), http, stop()}; null when FACECAST_EXE is not set. */
export async function startServer() {
  const exe = process.env.FACECAST_EXE;
  if (!exe) return null;
  const dir = mkdtempSync(join(tmpdir(), 'facecast-jsclient-'));
  const config = join(dir, 'server.json');
  writeFileSync(config, JSON.stringify({ channel_idle: 0, channels: { show: { producer_token: PRODUCER } } }));
  const args = ['serve', '--config', config, '--port', '0', '--token', KEY, '--data', join(dir, 'data'), '--log-level', 'warn'];
  const proc = spawn(exe, args, { stdio: ['ignore', 'pipe', 'pipe'] });
  let out = '';
  let err = '';
  proc.stdout.on('data', (d) => (out += d));
  proc.stderr.on('data', (d) => (err += d));
  let exited = false;
  const gone = new Promise((resolve) => proc.on('exit', () => resolve((exited = true))));
  const stop = async () => {
    if (!exited) proc.kill('SIGINT'); // closes every socket at once (SIGTERM would drain)
    await Promise.race([gone, sleep(10000)]);
    if (!exited) proc.kill('SIGKILL');
    rmSync(dir, { recursive: true, force: true });
  };
  const deadline = Date.now() + 30000;
  let http = null;
  while (!http && !exited && Date.now() < deadline) {
    http = /facecast: listening on (http:\/\/\S+)/.exec(out)?.[1] ?? null;
    if (!http) await sleep(50);
  }
  while (http && !exited && Date.now() < deadline) {
    const ready = await fetch(`${http}/readyz`).then((r) => r.ok, () => false);
    if (ready) return { http, url: `${http.replace('http://', 'ws://')}/ws`, stop };
    await sleep(100);
  }
  await stop();
  throw new Error(`facecast serve did not start:\n${err.slice(-2000)}`);
}

/** A short-lived viewer token (POST /api/tokens) that may only subscribe to `channel`. */
export async function viewerToken(http, channel) {
  const r = await fetch(`${http}/api/tokens`, {
    method: 'POST',
    headers: { Authorization: `Bearer ${KEY}`, 'Content-Type': 'application/json' },
    body: JSON.stringify({ scope: 'channels:subscribe', channel }),
  });
  if (r.status !== 201) throw new Error(`POST /api/tokens: ${r.status} ${await r.text()}`);
  return (await r.json()).token;
}
