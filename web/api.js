// The pages' access to their server: the WebSocket URL, the API key or token (from ?token= or asked
// for once and kept for the tab), fetch with that key, and links that keep ?token=. The facecast.v1
// protocol itself is the JS client's (clients/js, imported as 'facecast-client').

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
