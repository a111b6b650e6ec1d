// Unit tests of facecast-client without a server: the binary frame parser fed bytes directly, the
// JSON checks, and the three.js / three-vrm helpers on stand-in objects.

import assert from 'node:assert/strict';
import { test } from 'node:test';
import { FacecastError, HEADER_BYTES, KIND, applyExpressions, applyWeights, parseHeader, parseMedia, parseText, vrm0Name, vrm1Name } from '../facecast.js';

function message(kind, stream, first, count, pts, payload, { version = 1 } = {}) {
  const out = new Uint8Array(HEADER_BYTES + payload.byteLength);
  const v = new DataView(out.buffer);
  v.setUint8(0, kind);
  v.setUint8(1, version);
  v.setUint32(4, stream, true);
  v.setUint32(8, first, true);
  v.setUint32(12, count, true);
  v.setFloat64(16, pts, true);
  out.set(new Uint8Array(payload.buffer, payload.byteOffset, payload.byteLength), HEADER_BYTES);
  return out.buffer;
}

const START = { type: 'stream_start', id: 'u1', stream: 7, fps: 60, names: ['a', 'b'], extra: ['x'], audio: null };
const SPOKEN = { ...START, stream: 8, audio: { format: 'pcm_s16le', sample_rate: 22050, channels: 1, samples: 100 } };
const streams = new Map([[7, START], [8, SPOKEN]]);
const GOOD = message(KIND.WEIGHTS, 7, 5, 2, 0.5, new Float32Array([0, 1, 2, 3, 4, 5]));
const isProtocolError = (e) => e instanceof FacecastError && e.code === 'protocol';

test('the header: little-endian fields, u32 above 2^31', () => {
  assert.deepEqual(parseHeader(GOOD), { kind: 1, version: 1, stream: 7, first: 5, count: 2, pts: 0.5 });
  const big = parseHeader(message(KIND.AUDIO, 0xfffffff0, 0x80000001, 5, 1e-3, new Int16Array(5)));
  assert.deepEqual([big.stream, big.first], [0xfffffff0, 0x80000001]);
});

test('bad headers are rejected with a clear message', () => {
  const cases = {
    'shorter than the 24-byte header': GOOD.slice(0, 23),
    'unknown kind 9': message(9, 7, 0, 1, 0, new Uint8Array(4)),
    'unknown version 2': message(KIND.JPEG, 7, 0, 1, 0, new Uint8Array(4), { version: 2 }),
    'bad pts NaN': message(KIND.WEIGHTS, 7, 0, 1, NaN, new Float32Array(3)),
    'bad pts -1': message(KIND.WEIGHTS, 7, 0, 1, -1, new Float32Array(3)),
    'expected an ArrayBuffer': 'text',
  };
  for (const [what, data] of Object.entries(cases)) {
    assert.throws(() => parseHeader(data), (e) => isProtocolError(e) && e.message.includes(what), what);
  }
});

test('weights: one WeightsFrame per frame, at pts + k / fps', () => {
  const frames = parseMedia(GOOD, streams);
  assert.deepEqual(frames.map((f) => [f.type, f.id, f.stream, f.index, [...f.values], [...f.weights], f.get('b'), f.get('x'), f.get('none')]), [
    ['weights', 'u1', 7, 5, [0, 1, 2], [0, 1], 1, 2, undefined],
    ['weights', 'u1', 7, 6, [3, 4, 5], [3, 4], 4, 5, undefined],
  ]);
  assert.ok(Math.abs(frames[1].time - (0.5 + 1 / 60)) < 1e-12);
  // A Node Buffer at an odd offset (its float32 values are not aligned) reads the same.
  const odd = Buffer.concat([Buffer.from([0]), Buffer.from(GOOD)]).subarray(1);
  assert.equal(odd.byteOffset % 4, 1);
  assert.deepEqual(parseMedia(odd, streams).map((f) => [...f.values]), [[0, 1, 2], [3, 4, 5]]);
});

test('audio and JPEG items', () => {
  const [chunk] = parseMedia(message(KIND.AUDIO, 8, 100, 3, 0.2, new Int16Array([-32768, 0, 32767])), streams);
  assert.deepEqual([chunk.type, chunk.first, chunk.count, chunk.sampleRate, [...chunk.pcm], chunk.time], ['audio', 100, 3, 22050, [-32768, 0, 32767], 0.2]);
  const [jpeg] = parseMedia(message(KIND.JPEG, 7, 4, 1, 0.1, new Uint8Array([0xff, 0xd8, 0xff])), streams);
  assert.deepEqual([jpeg.type, jpeg.index, [...jpeg.jpeg]], ['jpeg', 4, [0xff, 0xd8, 0xff]]);
});

test('payloads that do not match their header or stream are rejected', () => {
  const cases = {
    'without its stream_start': message(KIND.WEIGHTS, 9, 0, 1, 0, new Float32Array(3)),
    'payload bytes for 2 frames': GOOD.slice(0, -1),
    'payload bytes for 0 frames': message(KIND.WEIGHTS, 7, 0, 0, 0, new Float32Array(0)),
    'payload bytes for 4294967295 frames': message(KIND.WEIGHTS, 7, 0, 0xffffffff, 0, new Float32Array(3)),
    'which announced no audio': message(KIND.AUDIO, 7, 0, 2, 0, new Int16Array(2)),
    'payload bytes for 3 samples': message(KIND.AUDIO, 8, 0, 3, 0, new Int16Array(2)),
    'JPEG message: count 2': message(KIND.JPEG, 7, 0, 2, 0, new Uint8Array(4)),
    'JPEG message: count 1, 0 payload bytes': message(KIND.JPEG, 7, 0, 1, 0, new Uint8Array(0)),
  };
  for (const [what, data] of Object.entries(cases)) {
    assert.throws(() => parseMedia(data, streams), (e) => isProtocolError(e) && e.message.includes(what), what);
  }
});

test('random corruptions give items or a protocol error, nothing else', () => {
  let seed = 35;
  const rand = (n) => ((seed = (seed * 1103515245 + 12345) % 2 ** 31), seed % n);
  let errors = 0;
  for (let i = 0; i < 5000; i++) {
    const data = new Uint8Array(GOOD.slice(0, rand(GOOD.byteLength + 8)));
    for (let k = rand(4); k > 0 && data.length; k--) data[rand(data.length)] = rand(256);
    try {
      const items = parseMedia(data.buffer, streams);
      assert.ok(items.length >= 1);
    } catch (e) {
      assert.ok(isProtocolError(e), String(e));
      errors += 1;
    }
  }
  assert.ok(errors > 1000, `${errors} errors`);
});

test('JSON messages: a type is required, stream_start and stream_end are checked', () => {
  assert.deepEqual(parseText('{"type": "pong", "t": 1}'), { type: 'pong', t: 1 });
  const start = parseText('{"type": "stream_start", "id": "a", "stream": 1, "fps": 30}');
  assert.deepEqual([start.names, start.extra], [[], []]);
  assert.equal(parseText('{"type": "stream_end", "id": "a", "stream": null, "frames": 0}').stream, null);
  for (const text of ['not json', '[]', '{}', '"x"', 'null', '{"type": 3}', '{"type": "stream_start", "stream": "x"}',
    '{"type": "stream_start", "id": "a", "stream": 1, "fps": 0}', '{"type": "stream_start", "id": "a", "stream": 1, "fps": 30, "names": [1]}',
    '{"type": "stream_end", "id": "a", "stream": [], "frames": 1}']) {
    assert.throws(() => parseText(text), isProtocolError, text);
  }
});

test('applyWeights: by name on every mesh that has the target', () => {
  const mesh = (names) => ({ isMesh: true, morphTargetDictionary: Object.fromEntries(names.map((n, i) => [n, i])), morphTargetInfluences: names.map(() => 0) });
  const head = mesh(['jawOpen', 'eyeBlinkLeft', 'smile']);
  const teeth = mesh(['mouthClose', 'jawOpen']);
  const root = { traverse: (fn) => [root, head, { traverse() {} }, teeth].forEach((o) => o !== root && fn(o)) };
  const names = ['jawOpen', 'mouthClose', 'missing'];
  assert.equal(applyWeights(root, names, new Float32Array([0.5, 0.25, 1, 9])), 3);
  assert.deepEqual([head.morphTargetInfluences, teeth.morphTargetInfluences], [[0.5, 0, 0], [0.25, 0.5]]);
  assert.equal(applyWeights([head, teeth], names, [0.75, 0, 0]), 3); // the same names: cached lookups
  assert.deepEqual([head.morphTargetInfluences[0], teeth.morphTargetInfluences[1]], [0.75, 0.75]);
});

test('applyExpressions: VRM 1.0 names, VRM 0.x presets under their 1.0 names, custom names', () => {
  const set = {};
  const manager = { getExpression: (n) => (['aa', 'happy', 'blinkLeft', 'Custom'].includes(n) ? {} : null), setValue: (n, v) => (set[n] = v) };
  const n = applyExpressions({ expressionManager: manager }, ['A', 'joy', 'blinkLeft', 'Custom', 'ih', 'jawOpen'], [0.1, 0.2, 0.3, 0.4, 0.5, 0.6]);
  assert.equal(n, 4);
  assert.deepEqual(set, { aa: 0.1, happy: 0.2, blinkLeft: 0.3, Custom: 0.4 });
  assert.deepEqual([vrm1Name('Blink_L'), vrm1Name('sorrow'), vrm1Name('jawOpen'), vrm0Name('relaxed'), vrm0Name('x')], ['blinkLeft', 'sad', 'jawOpen', 'Fun', 'x']);
});
