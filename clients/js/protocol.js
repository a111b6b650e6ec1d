// facecast.v1 messages (docs/protocol.md): the 24-byte little-endian media header, the bounded
// decoder of binary messages (checked against their stream_start), and the checks of JSON messages.

export const PROTOCOL = 'facecast.v1';
export const HEADER_BYTES = 24;
export const KIND = Object.freeze({ WEIGHTS: 1, AUDIO: 2, JPEG: 3 });
const VERSION = 1;
const LITTLE_ENDIAN = new Uint8Array(new Uint16Array([1]).buffer)[0] === 1;

/** Any failure of the client. `code`: the server's error code, or 'protocol', 'closed', 'timeout', 'refused'. */
export class FacecastError extends Error {
  constructor(code, message, { id = null, status = null } = {}) {
    super(message);
    this.name = 'FacecastError';
    this.code = code;
    this.id = id;
    this.status = status;
  }
}

const malformed = (message) => new FacecastError('protocol', message);

/** One weights frame: `values` are the stream's `names` weights, then its `extra` values. */
export class WeightsFrame {
  constructor(start, index, time, values) {
    this.type = 'weights';
    this.id = start.id;
    this.stream = start.stream;
    this.index = index;
    this.time = time; // seconds from the start of the utterance's audio
    this.names = start.names;
    this.extra = start.extra;
    this.values = values;
  }

  /** The blendshape weights alone (a view of `values`). */
  get weights() {
    return this.values.subarray(0, this.names.length);
  }

  /** The value of a blendshape or extra channel by name (undefined when the stream has none). */
  get(name) {
    let i = this.names.indexOf(name);
    if (i < 0 && (i = this.extra.indexOf(name)) >= 0) i += this.names.length;
    return i < 0 ? undefined : this.values[i];
  }
}

/** An ArrayBuffer, typed array or Node Buffer as a Uint8Array (anything else: null). */
function bytesOf(data) {
  if (data instanceof ArrayBuffer) return new Uint8Array(data);
  if (ArrayBuffer.isView(data)) return new Uint8Array(data.buffer, data.byteOffset, data.byteLength);
  return null;
}

/** The header of a binary message: {kind, version, stream, first, count, pts}. Throws FacecastError('protocol'). */
export function parseHeader(data) {
  const bytes = bytesOf(data);
  if (!bytes) throw malformed(`binary message of type ${Object.prototype.toString.call(data)} (expected an ArrayBuffer)`);
  if (bytes.byteLength < HEADER_BYTES) {
    throw malformed(`binary message of ${bytes.byteLength} bytes, shorter than the ${HEADER_BYTES}-byte header`);
  }
  const v = new DataView(bytes.buffer, bytes.byteOffset, HEADER_BYTES);
  const header = {
    kind: v.getUint8(0),
    version: v.getUint8(1),
    stream: v.getUint32(4, true),
    first: v.getUint32(8, true),
    count: v.getUint32(12, true),
    pts: v.getFloat64(16, true),
  };
  if (header.kind < KIND.WEIGHTS || header.kind > KIND.JPEG) throw malformed(`binary message: unknown kind ${header.kind}`);
  if (header.version !== VERSION) throw malformed(`binary message: unknown version ${header.version}`);
  if (!Number.isFinite(header.pts) || header.pts < 0) throw malformed(`binary message: bad pts ${header.pts}`);
  return header;
}

// `count` little-endian values of `bytes` per element from `offset`, as a typed array of its own.
function readArray(Type, bytes, count) {
  const size = Type.BYTES_PER_ELEMENT;
  if (LITTLE_ENDIAN && bytes.byteOffset % size === 0) return new Type(bytes.buffer, bytes.byteOffset, count);
  const out = new Type(count);
  const v = new DataView(bytes.buffer, bytes.byteOffset, count * size);
  for (let i = 0; i < count; i++) out[i] = size === 4 ? v.getFloat32(4 * i, true) : v.getInt16(2 * i, true);
  return out;
}

/**
 * The items of one binary message, checked against its stream's `stream_start` (`streams`: a Map
 * from stream number to the stream_start message): WeightsFrame per frame, or one
 * {type: 'audio', id, stream, first, count, time, sampleRate, pcm: Int16Array}, or one
 * {type: 'jpeg', id, stream, index, time, jpeg: Uint8Array}. Throws FacecastError('protocol').
 */
export function parseMedia(data, streams) {
  const header = parseHeader(data);
  const { kind, stream, first, count, pts } = header;
  const start = streams.get(stream);
  if (!start) throw malformed(`binary message for stream ${stream} without its stream_start`);
  const all = bytesOf(data);
  const payload = all.subarray(HEADER_BYTES);
  if (kind === KIND.WEIGHTS) {
    const width = start.names.length + start.extra.length;
    if (count === 0 || width === 0 || payload.byteLength !== count * width * 4) {
      throw malformed(`weights message: ${payload.byteLength} payload bytes for ${count} frames of ${width} float32 values`);
    }
    const values = readArray(Float32Array, payload, count * width);
    const frames = [];
    for (let k = 0; k < count; k++) frames.push(new WeightsFrame(start, first + k, pts + k / start.fps, values.subarray(k * width, (k + 1) * width)));
    return frames;
  }
  if (kind === KIND.AUDIO) {
    const rate = start.audio?.sample_rate;
    if (!Number.isInteger(rate) || rate <= 0) throw malformed(`audio message for stream ${stream}, which announced no audio`);
    if (payload.byteLength !== count * 2) throw malformed(`audio message: ${payload.byteLength} payload bytes for ${count} samples`);
    const pcm = readArray(Int16Array, payload, count);
    return [{ type: 'audio', id: start.id, stream, first, count, time: pts, sampleRate: rate, pcm }];
  }
  if (count !== 1 || payload.byteLength === 0) throw malformed(`JPEG message: count ${count}, ${payload.byteLength} payload bytes`);
  return [{ type: 'jpeg', id: start.id, stream, index: first, time: pts, jpeg: payload.slice() }];
}

const isStringArray = (a) => Array.isArray(a) && a.every((n) => typeof n === 'string');

/** A JSON text message as an object with a string `type`; stream_start and stream_end are checked. Throws FacecastError('protocol'). */
export function parseText(text) {
  let msg;
  try {
    msg = JSON.parse(text);
  } catch (e) {
    throw malformed(`text message is not JSON: ${e.message}`);
  }
  if (!msg || typeof msg !== 'object' || Array.isArray(msg) || typeof msg.type !== 'string') {
    throw malformed(`text message without a type: ${String(text).slice(0, 80)}`);
  }
  const bad = (why) => malformed(`${msg.type}: ${why}: ${String(text).slice(0, 120)}`);
  if (msg.type === 'stream_start') {
    msg.names ??= [];
    msg.extra ??= [];
    if (!isStringArray(msg.names) || !isStringArray(msg.extra)) throw bad('names and extra must be lists of strings');
    if (typeof msg.id !== 'string' || !Number.isInteger(msg.stream)) throw bad('bad id or stream');
    if (!(typeof msg.fps === 'number' && msg.fps > 0)) throw bad('bad fps');
    if (msg.audio != null && typeof msg.audio !== 'object') throw bad('bad audio');
  } else if (msg.type === 'stream_end') {
    if (typeof msg.id !== 'string' || !(msg.stream === null || Number.isInteger(msg.stream))) throw bad('bad id or stream');
    if (!Number.isInteger(msg.frames)) throw bad('bad frames');
  }
  return msg;
}
