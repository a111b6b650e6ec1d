// facecast-client in Node against a real `facecast serve` ($FACECAST_EXE): speak, the iterator and
// the events, incremental text, a channel, cancel, errors; and malformed messages from a fake socket.
// Run: FACECAST_EXE=build/app/facecast node --experimental-websocket --test clients/js/tests/

import assert from 'node:assert/strict';
import { after, before, describe, test } from 'node:test';
import { FacecastClient, FacecastError, connect } from '../facecast.js';
import { KEY, PRODUCER, startServer, viewerToken } from './server.mjs';

const TEXT = 'Hello, papa. Open wide.';
const WS = globalThis.WebSocket;
const skip = !process.env.FACECAST_EXE ? 'FACECAST_EXE is not set' : !WS ? 'no WebSocket: run node --experimental-websocket' : false;

/** Reads `items` (an iterator, left open) until `stop(item)`; returns what it read. */
async function readUntil(items, stop) {
  const seen = [];
  for (let r = await items.next(); !r.done; r = await items.next()) {
    seen.push(r.value);
    if (stop(r.value)) return seen;
  }
  throw new Error(`closed after ${seen.length} items`);
}

function checkContiguous(result) {
  const indices = result.frames.map((f) => f.index);
  assert.deepEqual(indices, [...indices.keys()]);
  assert.equal(result.end.frames, indices.length);
  assert.equal(result.end.dropped, 0);
}

describe('against facecast serve', { skip, timeout: 120000 }, () => {
  let server;
  const clients = [];
  const open = async (options = { key: KEY }) => {
    const client = await connect(server.url, { WebSocket: WS, timeout: 20, ...options });
    clients.push(client);
    return client;
  };
  before(async () => (server = await startServer()));
  after(async () => {
    await Promise.all(clients.map((c) => c.close()));
    await server?.stop();
  });

  test('speak: contiguous frames from 0, jawOpen opens and closes, seen by the iterator and the events', async () => {
    const client = await open();
    assert.equal(client.hello.protocol, 'facecast.v1');
    const events = [];
    client.addEventListener('weights', (e) => events.push(e.detail.index));
    const items = client.messages({ timeout: 20 });
    const id = client.speak(TEXT, { fps: 60, rig: 'default' });
    const seen = await readUntil(items, (m) => m.type === 'stream_end' && m.id === id);
    const start = seen.find((m) => m.type === 'stream_start');
    const result = { start, end: seen.at(-1), frames: seen.filter((m) => m.type === 'weights') };
    assert.equal(start.id, id);
    assert.equal(result.frames.length, start.frames);
    checkContiguous(result);
    assert.deepEqual(events, result.frames.map((f) => f.index));
    const frame = result.frames[10];
    assert.equal(frame.values.length, start.names.length + start.extra.length);
    assert.ok(Math.abs(frame.time - 10 / 60) < 1e-6);
    const jaw = result.frames.map((f) => f.get('jawOpen'));
    const peak = jaw.indexOf(Math.max(...jaw));
    assert.ok(jaw[peak] > 0.3, `jawOpen peaks at ${jaw[peak]}`);
    assert.ok(Math.min(...jaw.slice(peak)) < 0.05, 'jawOpen closes after its peak');
    assert.ok(jaw.at(-1) < 0.05);
    const audio = seen.filter((m) => m.type === 'audio');
    assert.equal(audio.reduce((n, c) => n + c.count, 0), start.audio.samples);
    assert.deepEqual(audio.map((c) => c.first), audio.map((_, i) => audio.slice(0, i).reduce((n, c) => n + c.count, 0)));
  });

  test('an aligned live audio stream: the server\'s own speech streamed back in with its text', async () => {
    const client = await open();
    const spoken = await client.collect(client.speak('Bring me the maps.', { fps: 30 }));
    const pcm = new Int16Array(spoken.audio.reduce((n, c) => n + c.count, 0));
    for (const c of spoken.audio) pcm.set(c.pcm, c.first);
    const rate = spoken.start.audio.sample_rate;
    const step = rate / 10;
    const result = client.collect('audio-');
    for (let at = 0; at < pcm.length; at += step) {
      client.sendAudio(pcm.subarray(at, at + step), rate, at, { aligned: at === 0 });
      if (at === 0) client.audioText('Bring me the maps.', { final: true });
    }
    client.sendAudio(new Int16Array(0), rate, pcm.length, { last: true });
    const { start, frames, end } = await result;
    assert.ok(start.id.startsWith('audio-'));
    assert.equal(frames.length, Math.floor((pcm.length / rate) * 60) + 1);
    assert.equal(end.frames, frames.length);
    assert.ok(Math.max(...frames.map((f) => f.get('jawOpen'))) > 0.1);
  });

  test('incremental text: speak with more, append, end', async () => {
    const client = await open({ key: KEY, via: 'message' });
    const id = client.speak('Good evening.', { more: true, fps: 30 });
    const done = client.collect(id);
    client.append(id, ' Welcome home.');
    client.end(id);
    const result = await done;
    assert.equal(result.start.open, true);
    assert.equal(result.start.frames, null);
    assert.ok(result.others.some((m) => m.type === 'segment'));
    checkContiguous(result);
    assert.ok(result.frames.length > 30);
  });

  test('a channel: the subscriber receives the producer\'s utterance', async () => {
    const viewer = await open({ key: await viewerToken(server.http, 'show') });
    const subscribed = await viewer.subscribe('show');
    assert.ok(subscribed.subscribers >= 1);
    const producer = await open();
    await assert.rejects(producer.produce('show', 'wrong-token-123'), { code: 'unauthorized' });
    assert.equal((await producer.produce('show', PRODUCER)).type, 'producing');
    const utterance = viewer.collect('c1');
    producer.speak('Hello, papa.', { id: 'c1', channel: 'show' });
    const result = await utterance;
    checkContiguous(result);
    assert.ok(result.frames.length > 10);
    assert.equal((await viewer.unsubscribe('show')).type, 'unsubscribed');
    await assert.rejects(viewer.subscribe('other'), { code: 'forbidden' }); // the token names "show" only
    await assert.rejects(producer.subscribe('no-such-channel'), { code: 'not_found' });
  });

  test('cancel: the stream ends early, cancelled', async () => {
    const client = await open();
    const items = client.messages({ timeout: 20 });
    const id = client.speak('This sentence is long enough to be cancelled well before it ends, which takes some seconds.', { fps: 30 });
    const [start] = await readUntil(items, (m) => m.type === 'weights');
    client.cancel(id);
    const [end] = (await readUntil(items, (m) => m.type === 'stream_end')).slice(-1);
    assert.equal(start.type, 'stream_start');
    assert.equal(end.cancelled, true);
    assert.ok(end.frames < start.frames, `${end.frames} of ${start.frames} frames`);
  });

  test('errors carry the server\'s code; the connection stays open', async () => {
    const client = await open();
    const errors = [];
    client.addEventListener('error', (e) => errors.push(e.detail));
    const id = client.speak('Hello.', { rig: 'no-such-rig' });
    const failure = await client.collect(id).catch((e) => e);
    assert.ok(failure instanceof FacecastError);
    assert.equal(failure.code, 'not_found');
    assert.equal(failure.id, id);
    assert.match(failure.message, /no-such-rig/);
    assert.deepEqual(errors.map((e) => [e.code, e.id]), [['not_found', id]]);
    client.cancel('not-playing');
    const [notFound] = (await readUntil(client.messages({ timeout: 10 }), (m) => m.type === 'error')).slice(-1);
    assert.deepEqual([notFound.code, notFound.id], ['not_found', 'not-playing']);
    assert.ok((await client.ping()).rtt >= 0);
  });

  test('refused without a key', async () => {
    const client = new FacecastClient(server.url, { timeout: 10 });
    await assert.rejects(client.open(), { code: 'closed' });
    assert.equal(client.state, 'closed');
    assert.throws(() => client.speak('Hi.'), { code: 'closed' });
  });
});

// ---- Malformed messages from a fake socket (no server): reported as error items, never thrown.

const HELLO = JSON.stringify({ type: 'hello', protocol: 'facecast.v1' });
const START = JSON.stringify({ type: 'stream_start', id: 'u1', stream: 7, fps: 60, frames: 2, names: ['a', 'b'], extra: ['x'], audio: null });

function media(kind, stream, first, count, pts, payload) {
  const out = new Uint8Array(24 + payload.byteLength);
  const v = new DataView(out.buffer);
  v.setUint8(0, kind);
  v.setUint8(1, 1);
  v.setUint32(4, stream, true);
  v.setUint32(8, first, true);
  v.setUint32(12, count, true);
  v.setFloat64(16, pts, true);
  out.set(new Uint8Array(payload.buffer, payload.byteOffset, payload.byteLength), 24);
  return out.buffer;
}

/** A WebSocket stand-in that opens, delivers FakeSocket.script's first message, then (20 ms later) the rest. */
class FakeSocket extends EventTarget {
  static script = [];
  constructor(url, protocols) {
    super();
    Object.assign(this, { url, protocols, protocol: 'facecast.v1', readyState: 0, sent: [] });
    const [first, ...rest] = FakeSocket.script;
    setTimeout(() => {
      this.readyState = 1;
      this.onopen?.({});
      this.onmessage?.({ data: first });
    });
    setTimeout(() => rest.forEach((data) => this.onmessage?.({ data })), 20);
  }
  send(data) {
    this.sent.push(data);
  }
  close(code = 1000, reason = '') {
    if (this.readyState === 3) return;
    this.readyState = 3;
    setTimeout(() => {
      this.onclose?.({ code, reason });
      this.dispatchEvent(new Event('close'));
    });
  }
}

test('malformed messages are reported as protocol errors, never thrown', async () => {
  const good = media(1, 7, 0, 2, 0.5, new Float32Array([0, 1, 2, 3, 4, 5]));
  FakeSocket.script = [HELLO, new Uint8Array([1, 1]).buffer, good, 'not json', '[1]', media(1, 8, 0, 1, 0, new Float32Array(3)), START,
    good.slice(0, -1), media(2, 7, 0, 2, 0, new Int16Array(2)), media(9, 7, 0, 1, 0, new Uint8Array(4)), good, JSON.stringify({ type: 'pong', t: 1 })];
  const client = await connect('ws://fake/ws', { WebSocket: FakeSocket, key: 'k.1', pingInterval: 0 });
  assert.deepEqual(client._ws.protocols, ['facecast.v1', 'facecast.token.k.1']);
  const errors = [];
  client.addEventListener('error', (e) => errors.push(e.detail));
  const items = await readUntil(client.messages({ timeout: 5 }), (m) => m.type === 'pong');
  const messages = errors.map((e) => e.message);
  assert.ok(errors.every((e) => e.code === 'protocol' && e.id === null), JSON.stringify(errors));
  assert.deepEqual(messages.map((m) => /shorter than|without its stream_start|not JSON|without a type|payload bytes|no audio|unknown kind/.test(m)), messages.map(() => true));
  assert.equal(errors.length, 8, messages.join('\n'));
  const frames = items.filter((m) => m.type === 'weights');
  assert.deepEqual(frames.map((f) => [f.index, [...f.values], f.get('x')]), [[0, [0, 1, 2], 2], [1, [3, 4, 5], 5]]);
  assert.equal(client.state, 'open');
  await client.close();
  assert.equal(client.state, 'closed');
});

test('a key that no subprotocol can carry goes in the first message', async () => {
  FakeSocket.script = [HELLO];
  const client = await connect('ws://fake/ws', { WebSocket: FakeSocket, key: 'has space', pingInterval: 0 });
  assert.deepEqual(client._ws.protocols, ['facecast.v1', 'facecast.token']);
  assert.deepEqual(JSON.parse(client._ws.sent[0]), { type: 'auth', token: 'has space' });
  const items = client.messages();
  await client.close();
  assert.deepEqual(await items.next(), { value: undefined, done: true });
});
