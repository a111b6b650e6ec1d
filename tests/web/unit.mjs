// Unit tests of the web client's pure parts, in node (no browser, no server): the facecast.v1 binary
// header, the timeline's expression curve, and the player's frame scheduling on the performance
// clock (a stream without audio). The header and the player are the JS client's (clients/js, whose
// own tests are clients/js/tests/).

import { parseHeader, parseMedia, HEADER_BYTES, KIND, StreamPlayer } from '../../clients/js/facecast.js';
import { expressionSegments } from '../../web/timeline.js';

let passed = 0;
let failed = 0;
function check(name, ok, detail = '') {
  if (ok) passed += 1;
  else failed += 1;
  console.log(`${ok ? 'ok  ' : 'FAIL'}  ${name}${detail ? ` — ${detail}` : ''}`);
}
function throws(fn) {
  try {
    fn();
    return false;
  } catch {
    return true;
  }
}

function message(kind, stream, first, count, pts, payload) {
  const buf = new ArrayBuffer(HEADER_BYTES + payload.byteLength);
  const v = new DataView(buf);
  v.setUint8(0, kind);
  v.setUint8(1, 1);
  v.setUint16(2, 0, true);
  v.setUint32(4, stream, true);
  v.setUint32(8, first, true);
  v.setUint32(12, count, true);
  v.setFloat64(16, pts, true);
  new Uint8Array(buf, HEADER_BYTES).set(new Uint8Array(payload.buffer ?? payload, payload.byteOffset ?? 0, payload.byteLength));
  return buf;
}

// ---- Header.
{
  const buf = message(KIND.WEIGHTS, 7, 120, 3, 2.5, new Float32Array(6));
  const h = parseHeader(buf);
  check('header fields (little-endian)', h.kind === 1 && h.version === 1 && h.stream === 7 && h.first === 120 && h.count === 3 && h.pts === 2.5, JSON.stringify(h));
  const big = message(KIND.AUDIO, 0xfffffff0, 0x80000001, 5, 1e-3, new Int16Array(5));
  const hb = parseHeader(big);
  check('u32 fields above 2^31', hb.stream === 0xfffffff0 && hb.first === 0x80000001, JSON.stringify(hb));
  check('a short message is rejected', throws(() => parseHeader(new ArrayBuffer(10))));
  const bad = message(KIND.JPEG, 1, 0, 1, 0, new Uint8Array(4));
  new DataView(bad).setUint8(1, 2);
  check('an unknown version is rejected', throws(() => parseHeader(bad)));
  const badKind = message(9, 1, 0, 1, 0, new Uint8Array(4));
  check('an unknown kind is rejected', throws(() => parseHeader(badKind)));
}

// ---- Expression curve: (name, a, T) reaches a/63 in T seconds and holds until the next tag.
{
  const segs = expressionSegments(
    [
      { name: 'joy', intensity: 63, ramp: 0.5, start: 0 },
      { name: 'surprise', intensity: 0, ramp: 0.2, start: 2 },
    ],
    3,
  );
  check('one segment per tag', segs.length === 2);
  check('the first tag ramps from 0 to its level', segs[0].from === 0 && segs[0].to === 1 && segs[0].end === 2);
  check('the next tag starts from the level reached', Math.abs(segs[1].from - 1) < 1e-9 && segs[1].to === 0 && segs[1].end === 3);
  const cut = expressionSegments(
    [
      { name: 'joy', intensity: 63, ramp: 2, start: 0 },
      { name: 'anger', intensity: 30, ramp: 1, start: 1 },
    ],
    4,
  );
  check('an interrupted ramp hands over its current value', cut[1].from > 0.4 && cut[1].from < 0.6, String(cut[1].from));
  check('unsorted tags are sorted', expressionSegments([{ name: 'b', intensity: 10, ramp: 0, start: 1 }, { name: 'a', intensity: 20, ramp: 0, start: 0 }], 2)[0].name === 'a');
}

// ---- Player: frames without audio run on performance.now(), interpolated, in order.
// A binary message through the client's parser to the player (streams: the player's stream_starts).
function feed(p, buf) {
  for (const item of parseMedia(buf, p.streams)) p.media(item);
}
{
  let now = 1000; // ms
  const realNow = performance.now.bind(performance);
  performance.now = () => now;
  try {
    const p = new StreamPlayer();
    const s = p.start({ id: 'u1', stream: 3, fps: 10, names: ['jawOpen', 'mouthClose'], extra: ['headYaw'], audio: null, duration: 0.5 });
    const frames = new Float32Array([0, 0, 0, 0.5, 0.1, 0.01, 1, 0.2, 0.02]); // 3 frames x 3 channels
    feed(p, message(KIND.WEIGHTS, 3, 0, 3, 0, frames));
    let r = p.update();
    check('before the lead nothing is shown', r.t < 0 && r.weights === null, `t=${r.t}`);
    now += 200 + 50; // past the lead, half-way between frame 0 (t=0) and frame 1 (t=0.1)
    r = p.update();
    check('frames interpolate between their pts', r.weights && Math.abs(r.weights[0] - 0.25) < 1e-6, `t=${r.t?.toFixed(3)} jaw=${r.weights?.[0]}`);
    check('extra channels follow the weights', r.extra && Math.abs(r.extra[0] - 0.005) < 1e-6, String(r.extra?.[0]));
    now += 100;
    r = p.update();
    check('later frames follow', Math.abs(r.weights[0] - 0.75) < 1e-6, String(r.weights[0]));
    // A frame that arrives out of order is placed by its time.
    const late = new Float32Array([0.9, 0, 0]);
    feed(p, message(KIND.WEIGHTS, 3, 4, 1, 0.4, late));
    const mid = new Float32Array([0.3, 0, 0]);
    feed(p, message(KIND.WEIGHTS, 3, 3, 1, 0.3, mid));
    check('frames are kept in pts order', s.frames.map((f) => f.t).join(',') === '0,0.1,0.2,0.3,0.4', s.frames.map((f) => f.t).join(','));
    p.end({ id: 'u1', stream: 3, frames: 5, dropped: 0, cancelled: false });
    check('an ended stream is not done before its last frame', !p.done(s));
    now += 1000;
    r = p.update();
    check('the last frame holds at the end', Math.abs(r.weights[0] - 0.9) < 1e-6 && r.done, `${r.weights[0]} done=${r.done}`);
    check('the shown time stops at the end', r.t <= 0.5 + 1e-9, String(r.t));
    // A second stream queues behind the first and starts on its own clock.
    p.start({ id: 'u2', stream: 4, fps: 10, names: ['jawOpen'], extra: [], audio: null, duration: 0.2 });
    const one = new Float32Array([0.6]);
    feed(p, message(KIND.WEIGHTS, 4, 0, 1, 0, one));
    now += 250;
    r = p.update();
    check('the next stream follows the finished one', r.stream.id === 'u2' && r.weights && Math.abs(r.weights[0] - 0.6) < 1e-6, `${r.stream.id} ${r.weights?.[0]}`);
  } finally {
    performance.now = realNow;
  }
}

{
  // Streams play in their order; a stop ends at once the streams the server has finished sending
  // (a cancel no longer reaches them), and a cancelled one goes on from its newest frame, where
  // the server's return to rest follows (a stop button, web/speak/queue.js).
  let now = 1000; // ms
  const realNow = performance.now.bind(performance);
  performance.now = () => now;
  const p = new StreamPlayer();
  const utterance = (n, frames = 3) => {
    const s = p.start({ id: `u${n}`, stream: n, fps: 10, names: ['jawOpen'], extra: [], audio: null, duration: frames / 10 });
    feed(p, message(KIND.WEIGHTS, n, 0, frames, 0, new Float32Array(frames).fill(n / 10)));
    return s;
  };
  const ended = (n, cancelled = false) => p.end({ id: `u${n}`, stream: n, frames: 3, dropped: 0, cancelled });
  try {
    utterance(1);
    ended(1);
    utterance(2);
    ended(2);
    now += 2000; // u1 and u2 have played out; no animation frame came meanwhile (a busy page)
    utterance(3);
    let r = p.update();
    check('a stream that starts after a busy spell queues behind the earlier one', r.stream.id === 'u2', r.stream.id);
    const s4 = utterance(4);
    ended(4);
    const s5 = utterance(5, 8); // still being sent: a stop cancels it on the server
    now += 300;
    r = p.update();
    check('the queue plays on', r.stream.id === 'u3' && !r.done, `${r.stream.id} done=${r.done}`);
    ended(3);
    p.silence('u5');
    check("a silenced stream goes on from its newest frame", Math.abs(p.timeOf(s5) - 0.7) < 1e-9, String(p.timeOf(s5)));
    const stopped = p.stopSent();
    check('a stop ends the streams sent to the end', stopped === 2 && p.done(p.streams.get(3)) && p.done(s4), `${stopped} ended`);
    for (let i = 0; i < 3; i++) r = p.update();
    check('the silenced stream is shown next, at once', r.stream.id === 'u5' && !r.done && Math.abs(r.t - 0.7) < 1e-9, `${r.stream.id} t=${r.t}`);
    ended(5, true);
    check('a cancelled stream is not ended by a second stop', p.stopSent() === 0 && !p.done(s5));
    // A cancel that reaches the server after it sent the whole stream: the stream ends uncancelled.
    now += 1000;
    const s6 = utterance(6);
    now += 300;
    p.update();
    p.silence('u6');
    check('a silenced stream is not over before its end arrives', !p.done(s6));
    ended(6);
    check('a silenced stream that ends uncancelled is done when it ends', p.done(s6));
    // Silenced before its media came: what comes is shown at once, up to its newest frame, and
    // audio the server sent before the cancel is not played.
    const s7 = p.start({ id: 'u7', stream: 7, fps: 10, names: ['jawOpen'], extra: [], audio: { sample_rate: 16000 }, duration: 0.5 });
    p.silence('u7');
    feed(p, message(KIND.AUDIO, 7, 0, 1600, 0, new Int16Array(1600)));
    feed(p, message(KIND.WEIGHTS, 7, 0, 5, 0, new Float32Array(5).fill(0.7)));
    check("a silenced stream's late audio is not played", s7.audioEnd === 0 && s7.sources.length === 0, String(s7.audioEnd));
    check('a stream silenced before its media is shown at its newest frame', Math.abs(p.timeOf(s7) - 0.4) < 1e-9, String(p.timeOf(s7)));
  } finally {
    performance.now = realNow;
  }
}

console.log(`web.unit: ${passed} passed, ${failed} failed`);
process.exit(failed ? 1 : 0);
