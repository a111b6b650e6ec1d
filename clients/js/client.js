// A client of the facecast.v1 WebSocket protocol (docs/protocol.md) for browsers and Node >= 20.
// Every message is an event (the client is an EventTarget; `detail` is the item) and an item of the
// async iterator; requests with an answer (subscribe, produce, ping...) return promises.

import { FacecastError, PROTOCOL, parseMedia, parseText } from './protocol.js';
import { awaitAnswer, collect, itemQueue, unref } from './queue.js';

const TOKEN_CHARS = /^[A-Za-z0-9._~-]+$/; // what a subprotocol may carry
const MAX_STREAMS = 256; // stream_starts remembered (a stream whose end never came is forgotten)
const OPEN = 1; // WebSocket.OPEN

function closeReason(code, reason) {
  if (code === 1008) return `closed by the server: ${reason || 'policy violation (a client that does not keep up)'} (1008)`;
  if (code === 1001) return 'the server is shutting down (1001)';
  if (code === 1006) return 'no connection to the server (1006)';
  return reason ? `${reason} (${code})` : `connection closed (${code})`;
}

export class FacecastClient extends EventTarget {
  /**
   * `key`: an API key or viewer token, or a function returning one (read at every connection).
   * `via`: 'subprotocol' (facecast.token.K), 'message' (a first auth message) or 'auto' (the
   * subprotocol when the key fits one). `WebSocket`: the constructor (default: the global one).
   * `timeout`: seconds to wait for hello and for answers. `reconnect`: reopen with back-off.
   * `pingInterval`: seconds between pings (0: none).
   */
  constructor(url, { key = null, via = 'auto', WebSocket = globalThis.WebSocket, timeout = 30, reconnect = false, pingInterval = 15 } = {}) {
    super();
    if (typeof WebSocket !== 'function') {
      throw new FacecastError('unsupported', 'no WebSocket: pass connect(url, {WebSocket}) (Node 20: node --experimental-websocket)');
    }
    if (!['auto', 'subprotocol', 'message'].includes(via)) throw new TypeError(`via must be auto, subprotocol or message, not ${via}`);
    Object.assign(this, { url, timeout, reconnect, pingInterval, hello: null, attempt: 0 });
    this.state = 'closed'; // 'connecting' | 'open' (hello received) | 'reconnecting' | 'closed'
    Object.assign(this, { _key: key, _via: via, _WebSocket: WebSocket, _ws: null, _wanted: false, _opening: null });
    Object.assign(this, { _streams: new Map(), _waiting: [], _sinks: new Set(), _ids: 0, _timers: {} });
  }

  /** True once the server's hello came on the current socket. */
  get connected() {
    return this.state === 'open' && this._ws?.readyState === OPEN;
  }

  /** Opens the connection; resolves with the server's hello (with `reconnect`, after retries). */
  open() {
    this._wanted = true;
    if (this.connected) return Promise.resolve(this.hello);
    if (!this._opening) {
      let settle;
      const promise = new Promise((resolve, reject) => (settle = { resolve, reject }));
      promise.catch(() => {}); // nobody needs to await it
      this._opening = { promise, ...settle };
      this._dial();
    }
    return this._opening.promise;
  }

  /** Closes for good (no reconnect); resolves when the socket has closed. */
  close(code = 1000, reason = 'bye') {
    this._wanted = false;
    clearTimeout(this._timers.retry);
    const ws = this._ws;
    if (!ws) {
      this._lost(null, code, 'closed by the client');
      return Promise.resolve();
    }
    const closed = new Promise((resolve) => {
      ws.addEventListener?.('close', () => resolve());
      unref(setTimeout(resolve, 3000));
    });
    try {
      ws.close(code, reason);
    } catch {
      // already closing
    }
    this._lost(ws, code, 'closed by the client');
    return closed;
  }

  _dial() {
    clearTimeout(this._timers.retry);
    if (this._ws) return;
    this._setState(this.attempt ? 'reconnecting' : 'connecting', { attempt: this.attempt });
    const key = (typeof this._key === 'function' ? this._key() : this._key) || '';
    const via = this._via === 'auto' ? (TOKEN_CHARS.test(key) ? 'subprotocol' : 'message') : this._via;
    const protocols = key ? [PROTOCOL, via === 'message' ? 'facecast.token' : `facecast.token.${key}`] : [PROTOCOL];
    let ws;
    try {
      ws = new this._WebSocket(this.url, protocols);
    } catch (e) {
      this._lost(null, 1006, String(e?.message || e));
      return;
    }
    this._ws = ws;
    ws.binaryType = 'arraybuffer';
    const fail = (code, reason) => {
      try {
        ws.close(code, reason);
      } catch {
        // not open yet
      }
      this._lost(ws, code, reason);
    };
    this._timers.hello = unref(setTimeout(() => fail(4000, `no hello within ${this.timeout} s`), this.timeout * 1000));
    let opened = false;
    ws.onopen = () => {
      opened = true;
      if (ws.protocol && ws.protocol !== PROTOCOL) {
        this._deliver({ type: 'error', id: null, code: 'protocol', message: `the server chose the subprotocol '${ws.protocol}'` });
      }
      if (key && via === 'message') ws.send(JSON.stringify({ type: 'auth', token: key }));
    };
    ws.onmessage = (ev) => this._receive(ev.data);
    ws.onclose = (ev) => this._lost(ws, ev.code, ev.reason);
    // An error is followed by close, except a failed handshake in some Node versions (undici).
    ws.onerror = () => opened || fail(1006, '');
  }

  // The socket `ws` closed (null: none was made). Reconnects, or ends requests and iterators.
  _lost(ws, code, reason) {
    if (ws !== this._ws) return;
    this._ws = null;
    clearTimeout(this._timers.hello);
    clearInterval(this._timers.ping);
    this._streams.clear();
    const text = reason === 'closed by the client' ? reason : closeReason(code, reason);
    const error = new FacecastError('closed', `${this.url}: ${text}`);
    for (const w of [...this._waiting]) w.settle(null, error);
    if (ws) this._emit('close', { code, reason: text });
    if (this._wanted && this.reconnect) {
      this.attempt += 1;
      // 0.5 s, 1 s, 2 s ... capped at 8 s, with a little jitter so many clients do not return at once.
      const delay = Math.min(8000, 500 * 2 ** Math.min(this.attempt - 1, 4)) * (0.85 + 0.3 * Math.random());
      this._setState('reconnecting', { attempt: this.attempt, delay, reason: text });
      this._timers.retry = setTimeout(() => this._dial(), delay);
      return;
    }
    this._wanted = false;
    this._opening?.reject(error);
    this._opening = null;
    this._setState('closed', { reason: text, code });
    const abnormal = ![1000, 1001].includes(code) && text !== 'closed by the client';
    for (const sink of this._sinks) sink.finish(abnormal ? error : null);
  }

  _receive(data) {
    let items;
    try {
      items = typeof data === 'string' ? [this._text(parseText(data))] : parseMedia(data, this._streams);
    } catch (e) {
      const message = e instanceof FacecastError ? e.message : `cannot decode a message: ${e?.message || e}`;
      items = [{ type: 'error', id: null, code: 'protocol', message }];
    }
    for (const item of items) this._deliver(item);
  }

  _text(msg) {
    if (msg.type === 'hello') {
      this.hello = msg;
      this.attempt = 0;
      clearTimeout(this._timers.hello);
      this._setState('open');
      this._startPing();
      this._opening?.resolve(msg);
      this._opening = null;
    } else if (msg.type === 'stream_start') {
      this._streams.set(msg.stream, msg);
      for (const old of this._streams.keys()) if (this._streams.size > MAX_STREAMS) this._streams.delete(old);
    } else if (msg.type === 'stream_end' && msg.stream !== null) {
      this._streams.delete(msg.stream);
    }
    return msg;
  }

  // Hands an item to a request waiting for it, else to the listeners and iterators.
  _deliver(item) {
    const w = this._waiting.find((r) => r.matches(item) || (item.type === 'error' && item.id == null && item.code !== 'protocol'));
    if (w) return item.type === 'error' ? w.settle(null, new FacecastError(item.code, item.message)) : w.settle(item);
    this._emit(item.type, item);
    this._emit('message', item);
    for (const sink of this._sinks) sink.push(item);
  }

  _emit(type, detail) {
    this.dispatchEvent(new CustomEvent(type, { detail }));
  }

  _setState(state, extra = {}) {
    this.state = state;
    this._emit('state', { state, ...extra });
  }

  _startPing() {
    clearInterval(this._timers.ping);
    if (this.pingInterval > 0) {
      this._timers.ping = unref(setInterval(() => this.connected && this.send({ type: 'ping', t: performance.now() / 1000 }), this.pingInterval * 1000));
    }
  }

  /** Sends one JSON message as it is (fields that are null or undefined are left out). Throws FacecastError('closed') when not connected. */
  send(message) {
    if (!this.connected) throw new FacecastError('closed', `${message.type}: not connected (${this.state})`);
    this._ws.send(JSON.stringify(Object.fromEntries(Object.entries(message).filter(([, v]) => v != null))));
  }

  // Sends and waits for the answer of type `reply` (or an error without id).
  _request(message, reply, matches) {
    const { promise, settle } = awaitAnswer(this._waiting, (m) => m.type === reply && matches(m), this.timeout, message.type);
    try {
      this.send(message);
    } catch (e) {
      settle(null, e);
    }
    return promise;
  }

  /** Queues an utterance; returns its id. `fields`: any speak field (rig, fps, audio, lang, voice, rate, idle, timing, output, size, timestamps, audio_id, vmc). */
  speak(text, { id, channel, more, ...fields } = {}) {
    id ??= `u${++this._ids}`;
    this.send({ type: 'speak', id, text, channel, more, ...fields });
    return id;
  }

  /** Adds text to an open utterance (speak with more: true). */
  append(id, text, { channel } = {}) {
    this.send({ type: 'append', id, text, channel });
  }

  /** Closes an open utterance: the rest of its text is spoken, then its stream ends. */
  end(id, { channel } = {}) {
    this.send({ type: 'end', id, channel });
  }

  /** Stops an utterance (it fades to rest; stream_end has cancelled: true) or drops it from the queue. */
  cancel(id, { channel } = {}) {
    this.send({ type: 'cancel', id, channel });
  }

  /**
   * One live audio chunk (docs/protocol.md, "Live audio in"): `pcm` (Int16Array, mono) at
   * `sampleRate`, `first` the index of its first sample in the stream (0 opens a stream; `aligned`:
   * its text comes by audioText); `last` ends it. The weights come back as a stream with id
   * "audio-<stream>" (collect('audio-')).
   */
  sendAudio(pcm, sampleRate, first, { last = false, aligned = false } = {}) {
    if (!this.connected) throw new FacecastError('closed', `audio: not connected (${this.state})`);
    const out = new ArrayBuffer(24 + 2 * pcm.length);
    const v = new DataView(out);
    v.setUint8(0, 4);
    v.setUint8(1, 1);
    v.setUint16(2, (last ? 1 : 0) | (aligned ? 2 : 0), true);
    v.setUint32(4, sampleRate, true);
    v.setUint32(8, first, true);
    v.setUint32(12, pcm.length, true);
    for (let i = 0; i < pcm.length; ++i) v.setInt16(24 + 2 * i, pcm[i], true);
    this._ws.send(out);
  }

  /** More text of the open aligned audio stream: as it comes (English), or with its time in the stream ({start, end}: seconds; any language). */
  audioText(text, { start, end, final } = {}) {
    this.send({ type: 'audio_text', text, start, end, final });
  }

  /** Expression tags over the open live audio stream ("(smile,40,0.5)"). */
  expression(tags) {
    this.send({ type: 'expression', tags });
  }

  /** Watches a channel; resolves with the `subscribed` answer (subscribers, playing). */
  subscribe(channel) {
    return this._request({ type: 'subscribe', channel }, 'subscribed', (m) => m.channel === channel);
  }

  unsubscribe(channel) {
    return this._request({ type: 'unsubscribe', channel }, 'unsubscribed', (m) => m.channel === channel);
  }

  /** Becomes a producer of a channel (then speak(text, {channel}) plays on it). */
  produce(channel, token) {
    return this._request({ type: 'produce', channel, token }, 'producing', (m) => m.channel === channel);
  }

  /** Resolves with the pong (plus `rtt`, seconds). */
  async ping() {
    const t = performance.now() / 1000;
    const pong = await this._request({ type: 'ping', t }, 'pong', (m) => m.t === t);
    return { ...pong, rtt: performance.now() / 1000 - t };
  }

  /**
   * An async iterator of every item from now on (media as WeightsFrame / audio / jpeg items, JSON
   * messages as they are, errors as {type: 'error'} items). It ends when the client closes (throws
   * FacecastError('closed') after an abnormal close); `timeout` (s): throw when nothing comes.
   */
  messages({ timeout = 0 } = {}) {
    const ended = !this._wanted && !this._ws;
    return itemQueue(this._sinks, { timeout, ended });
  }

  [Symbol.asyncIterator]() {
    return this.messages();
  }

  /**
   * Gathers utterance `id` until its stream_end: {start, end, frames, audio, images, others}.
   * Rejects with FacecastError (the server's code) on an error for `id`. Call it right after speak.
   */
  collect(id, { timeout = this.timeout } = {}) {
    return collect(this.messages({ timeout }), id, this.url);
  }
}

/** Connects and waits for the server's hello (client.hello). Options as FacecastClient's. */
export async function connect(url, options = {}) {
  const client = new FacecastClient(url, options);
  await client.open();
  return client;
}
