// The facecast.v1 WebSocket protocol (docs/protocol.md): a reconnecting client and the binary header.
//
// Events (FacecastClient is an EventTarget; each event's `detail` is the payload):
//   state         {state: 'connecting'|'open'|'reconnecting'|'closed', attempt, delay, reason}
//   hello         the server's hello message
//   stream_start  the stream_start message
//   stream_end    the stream_end message
//   error         the error message ({id, code, message})
//   pong          the pong message, plus rtt (seconds)
//   media         {header, payload: ArrayBuffer (the bytes after the header)}

export const PROTOCOL = 'facecast.v1';
export const HEADER_BYTES = 24;
export const KIND = Object.freeze({ WEIGHTS: 1, AUDIO: 2, JPEG: 3 });

/** Parses the 24-byte little-endian header of a binary message. Throws on a short or unknown message. */
export function parseHeader(buffer) {
  if (!(buffer instanceof ArrayBuffer) || buffer.byteLength < HEADER_BYTES) {
    throw new Error(`binary message of ${buffer?.byteLength ?? 0} bytes is shorter than the header`);
  }
  const v = new DataView(buffer);
  const header = {
    kind: v.getUint8(0),
    version: v.getUint8(1),
    stream: v.getUint32(4, true),
    first: v.getUint32(8, true),
    count: v.getUint32(12, true),
    pts: v.getFloat64(16, true),
  };
  if (header.version !== 1) throw new Error(`binary message version ${header.version} (expected 1)`);
  if (header.kind < 1 || header.kind > 3) throw new Error(`binary message kind ${header.kind} is unknown`);
  return header;
}

/** The WebSocket URL of the page's own server (the key travels in the subprotocol list). */
export function defaultUrl(loc = window.location) {
  const scheme = loc.protocol === 'https:' ? 'wss:' : 'ws:';
  return `${scheme}//${loc.host}/ws`;
}

const KEY_STORE = 'facecast.key';

/** The page's API key or token: ?token= in the address, else the one entered (sessionStorage). */
export function currentKey() {
  const fromUrl = new URLSearchParams(window.location.search).get('token');
  if (fromUrl) return fromUrl;
  try {
    return sessionStorage.getItem(KEY_STORE) || '';
  } catch {
    return '';
  }
}

let asked = false;

/**
 * A server that answered 401: asks the person for a key once per page (kept in sessionStorage for
 * this tab). Returns true when a new key was entered.
 */
export function askForKey() {
  try {
    if (sessionStorage.getItem(KEY_STORE)) sessionStorage.removeItem(KEY_STORE); // it was refused
  } catch {
    return false;
  }
  if (asked || new URLSearchParams(window.location.search).has('token')) return false;
  asked = true;
  const key = (window.prompt('This server needs an API key (facecast keys create). Key:') || '').trim();
  if (!key) return false;
  sessionStorage.setItem(KEY_STORE, key);
  return true;
}

/** WebSocket subprotocols: facecast.v1, plus the key as facecast.token.<key> when there is one. */
export function protocols() {
  const key = currentKey();
  return key && /^[A-Za-z0-9._~-]+$/.test(key) ? [PROTOCOL, `facecast.token.${key}`] : [PROTOCOL];
}

export class FacecastClient extends EventTarget {
  constructor(url = defaultUrl()) {
    super();
    this.url = url;
    this.ws = null;
    this.state = 'closed';
    this.hello = null;
    this.attempt = 0;
    this.wanted = false;
    this.timer = null;
    this.pingTimer = null;
    this.lastPong = 0;
  }

  connect() {
    this.wanted = true;
    clearTimeout(this.timer);
    if (this.ws && this.ws.readyState <= WebSocket.OPEN) return;
    this.setState(this.attempt ? 'reconnecting' : 'connecting', { attempt: this.attempt });
    let ws;
    try {
      ws = new WebSocket(this.url, protocols());
    } catch (e) {
      this.scheduleReconnect(String(e.message || e));
      return;
    }
    ws.binaryType = 'arraybuffer';
    this.ws = ws;
    ws.onopen = () => {
      if (ws.protocol && ws.protocol !== PROTOCOL) {
        this.emit('error', { id: null, code: 'unsupported', message: `server chose subprotocol '${ws.protocol}'` });
      }
      this.attempt = 0;
      this.setState('open');
      this.startPing();
    };
    ws.onmessage = (ev) => this.onMessage(ev.data);
    ws.onclose = (ev) => {
      if (this.ws !== ws) return;
      this.ws = null;
      this.stopPing();
      const reason = closeReason(ev);
      this.emit('closed', { code: ev.code, reason });
      if (this.wanted) this.scheduleReconnect(reason);
      else this.setState('closed', { reason });
    };
    // onerror is always followed by onclose, which handles it.
    ws.onerror = () => {};
  }

  close() {
    this.wanted = false;
    clearTimeout(this.timer);
    this.stopPing();
    if (this.ws) this.ws.close(1000, 'bye');
    this.ws = null;
    this.setState('closed', { reason: 'closed by the page' });
  }

  get open() {
    return !!this.ws && this.ws.readyState === WebSocket.OPEN;
  }

  /** Sends a control message; returns false when the socket is not open. */
  send(msg) {
    if (!this.open) return false;
    this.ws.send(JSON.stringify(msg));
    return true;
  }

  scheduleReconnect(reason) {
    this.attempt += 1;
    // 0.5 s, 1 s, 2 s ... capped at 8 s, with a little jitter so many tabs do not return at once.
    const delay = Math.min(8000, 500 * 2 ** Math.min(this.attempt - 1, 4)) * (0.85 + 0.3 * Math.random());
    this.setState('reconnecting', { attempt: this.attempt, delay, reason });
    this.timer = setTimeout(() => this.connect(), delay);
  }

  startPing() {
    this.stopPing();
    this.pingTimer = setInterval(() => this.send({ type: 'ping', t: performance.now() / 1000 }), 15000);
  }

  stopPing() {
    clearInterval(this.pingTimer);
    this.pingTimer = null;
  }

  onMessage(data) {
    if (typeof data === 'string') {
      let msg;
      try {
        msg = JSON.parse(data);
      } catch {
        this.emit('error', { id: null, code: 'internal', message: 'the server sent text that is not JSON' });
        return;
      }
      if (msg.type === 'hello') this.hello = msg;
      if (msg.type === 'pong') msg.rtt = performance.now() / 1000 - msg.t;
      if (['hello', 'stream_start', 'stream_end', 'error', 'pong'].includes(msg.type)) this.emit(msg.type, msg);
      return;
    }
    let header;
    try {
      header = parseHeader(data);
    } catch (e) {
      this.emit('error', { id: null, code: 'internal', message: e.message });
      return;
    }
    this.emit('media', { header, payload: data.slice(HEADER_BYTES) });
  }

  setState(state, extra = {}) {
    this.state = state;
    this.emit('state', { state, ...extra });
  }

  emit(type, detail) {
    this.dispatchEvent(new CustomEvent(type, { detail }));
  }
}

function closeReason(ev) {
  if (ev.code === 1008) return 'closed by the server: the page could not keep up (policy violation)';
  if (ev.code === 1001) return 'the server is shutting down';
  if (ev.code === 1006) return 'no connection to the server';
  return ev.reason ? `${ev.reason} (${ev.code})` : `connection closed (${ev.code})`;
}

/**
 * fetch() that returns parsed JSON and throws an Error with the server's {error: {code, message}}.
 * A 401 asks for a key (once per page) and tries again with it.
 */
export async function fetchJson(url, options = {}) {
  const send = () => {
    const headers = { ...(options.headers || {}), ...authHeaders() };
    // JSON bodies say so (the server answers other types with 415).
    if (typeof options.body === 'string' && !Object.keys(headers).some((h) => h.toLowerCase() === 'content-type')) {
      headers['Content-Type'] = 'application/json';
    }
    return fetch(url, { ...options, headers });
  };
  let res;
  try {
    res = await send();
    if (res.status === 401 && askForKey()) res = await send();
  } catch (e) {
    const err = new Error(`cannot reach the server (${e.message})`);
    err.code = 'unreachable';
    throw err;
  }
  const text = await res.text();
  let body = null;
  try {
    body = text ? JSON.parse(text) : null;
  } catch {
    body = null;
  }
  if (!res.ok) {
    const e = body?.error;
    const err = new Error(e?.message || `${res.status} ${res.statusText}`);
    err.code = e?.code || String(res.status);
    err.status = res.status;
    throw err;
  }
  return body;
}

/** The headers fetch needs for a protected server (GLTFLoader's requestHeader). */
export function authHeaders() {
  const key = currentKey();
  return key ? { Authorization: `Bearer ${key}` } : {};
}

/** Carries the page's ?token= over to the other pages' links (a protected server needs it). */
export function keepTokenInLinks(root = document) {
  const token = new URLSearchParams(window.location.search).get('token');
  if (!token) return;
  for (const a of root.querySelectorAll('a[href]')) {
    const url = new URL(a.getAttribute('href'), window.location.href);
    if (url.origin !== window.location.origin) continue;
    url.searchParams.set('token', token);
    a.setAttribute('href', url.pathname + url.search + url.hash);
  }
}
