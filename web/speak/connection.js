// The connection: its state in the top bar and alerts (with a probe for a missing token), and
// the server's messages: hello, stream_start / stream_end (the utterance list) and errors.

import { fetchJson } from '../api.js';
import { dismissAlert, showAlert } from '../alerts.js';
import { client, els, state, view } from './page.js';
import { setUtteranceState, updateButtons } from './queue.js';
import { refreshRigs } from './rigs.js';
import { showTextError, updateCount } from './text_box.js';

function describeState(d) {
  switch (d.state) {
    case 'connecting':
      return 'Connecting…';
    case 'open':
      return `Connected · ${client.hello?.server || 'facecast'}`;
    case 'reconnecting':
      return d.delay ? `Server unreachable — retrying in ${Math.ceil(d.delay / 1000)} s` : 'Reconnecting…';
    default:
      return 'Disconnected';
  }
}

function onState(e) {
  const d = e.detail;
  els.conn.dataset.state = d.state;
  els.connText.textContent = describeState(d);
  if (d.state === 'open') {
    dismissAlert('connection');
    if (state.wasDown) showAlert({ level: 'info', code: 'connected', message: 'Reconnected to the server.', timeout: 3000 });
    state.wasDown = false;
    refreshRigs();
  } else if (d.state === 'reconnecting') {
    // A browser does not tell why a WebSocket handshake failed: ask the API whether it wants a token.
    if (d.attempt === 1 || d.attempt % 4 === 0) probeAuth();
    if (state.needsToken) {
      els.connText.textContent = 'Token required';
    } else if (d.attempt >= 2 || state.everOpen) {
      showAlert({
        key: 'connection',
        level: 'error',
        code: 'connection',
        message: `The server is not reachable (${d.reason || 'connection lost'}). Reconnecting automatically (attempt ${d.attempt}).`,
        sticky: true,
      });
    }
    state.wasDown = true;
  }
  updateButtons();
}

async function probeAuth() {
  try {
    await fetchJson('/api/rigs');
    state.needsToken = false;
  } catch (e) {
    if (e.status !== 401) return;
    state.needsToken = true;
    els.connText.textContent = 'Token required';
    if (!view.model) els.loading.textContent = 'The avatar loads once the page has the server’s token.';
    const has = new URLSearchParams(location.search).has('token');
    showAlert({
      key: 'connection',
      level: 'error',
      code: 'unauthorized',
      message: has
        ? 'The server rejected the token in the address (?token=…).'
        : 'This server needs an API key or token: reload the page and enter it, or open the page as /?token=YOUR_KEY.',
      sticky: true,
    });
  }
}

function onClosed() {
  // Whatever was playing is gone with the connection (the player stops it): let the face settle.
  for (const u of state.utterances.values()) {
    if (u.state === 'sent' || u.state === 'playing') setUtteranceState(u, 'error', 'lost');
  }
  state.restDecay = true;
}

function onHello(e) {
  state.everOpen = true;
  els.connText.textContent = `Connected · ${e.detail.server || 'facecast'}`;
  updateCount();
}

function onStreamStart(e) {
  const m = e.detail;
  const u = state.utterances.get(m.id);
  if (u) {
    u.stream = m.stream;
    u.duration = m.duration;
    setUtteranceState(u, 'playing', `${(m.duration || 0).toFixed(1)} s`);
  }
  state.log.push({ t: performance.now(), stream_start: { id: m.id, stream: m.stream, frames: m.frames, names: m.names?.length } });
}

function onStreamEnd(e) {
  const m = e.detail;
  const u = state.utterances.get(m.id);
  if (u) {
    u.dropped = m.dropped || 0;
    u.frames = m.frames;
    setUtteranceState(u, m.cancelled ? 'cancelled' : 'done', m.cancelled ? 'stopped' : m.dropped ? `${m.dropped} dropped` : 'done');
  }
  state.log.push({ t: performance.now(), stream_end: m });
}

function onError(e) {
  const m = e.detail;
  // Stop raced with the end of the utterance: nothing to tell the person.
  if (m.code === 'not_found' && /^cancel\b/.test(m.message || '')) return;
  const u = m.id ? state.utterances.get(m.id) : null;
  if (u && (u.state === 'sent' || u.state === 'playing')) {
    u.error = m;
    setUtteranceState(u, 'error', m.code || 'error');
  }
  state.log.push({ t: performance.now(), error: m });
  if (m.code === 'rate_limited') {
    const per = client.hello?.limits?.speak_per_minute;
    showAlert({
      level: 'warn',
      code: 'rate_limited',
      message: `Slow down: ${per ? `the server takes at most ${per} utterances a minute` : 'too many requests'}. Try again in a moment. (${m.message})`,
    });
    return;
  }
  // Errors about the text name the character: "text: offset N: ..." (docs/protocol.md) or
  // "character N: ..." (the viseme engine's wording).
  if (u && /^text\b|\b(?:offset|character) \d+/.test(m.message || '')) {
    showTextError(m.message, u.sentText);
  }
  showAlert({ level: 'error', code: m.code || 'error', message: m.message || 'the server reported an error' });
}

/** Registers the handlers of the connection's events (before it connects). */
export function listen() {
  client.addEventListener('state', onState);
  client.addEventListener('close', onClosed);
  client.addEventListener('hello', onHello);
  client.addEventListener('stream_start', onStreamStart);
  client.addEventListener('stream_end', onStreamEnd);
  client.addEventListener('error', onError);
}
