// The speak page: connects to facecast.v1, sends speak/cancel, plays the streams on the 3D avatar
// (weights) or on a canvas (frames), draws the timeline, and shows connection state and errors.
//
// window.__facecast exposes the page's state for the browser tests and for curious people.

import { FacecastClient, fetchJson, authHeaders, keepTokenInLinks } from './protocol.js';
import { StreamPlayer } from './player.js';
import { AvatarView, loadGlb } from './avatar.js';
import { Timeline, expressionColor } from './timeline.js';
import { showAlert, dismissAlert, alerts } from './alerts.js';

// The expression names the server accepts in tags: configs/viseme/expressions.json (a browser test
// checks that this list matches it).
export const EXPRESSIONS = ['joy', 'sadness', 'anger', 'fear', 'disgust', 'surprise', 'neutral', 'smile', 'wink'];

const SAMPLES = [
  ['Launch (中文 + English)', '(joy, 40, 0.5)大家好，欢迎来到 Facecast 的发布会。(surprise, 50, 0.3) Nice to meet you!'],
  ['English', 'Hello there! (smile, 45, 0.4)Today we ship version one, and it speaks.'],
  ['中文', '(sadness, 35, 0.8)今天下雨了，我们明天再见吧。'],
  ['Mood swing', '(anger, 50, 0.3)No, no, no! (anger, 0, 0.6)好吧，算了。(joy, 30, 0.5)Fine.'],
  ['Wink', '(wink, 63, 0.2)你好呀, my friend.'],
];

const MOUTH_SHAPES = ['jawOpen', 'mouthFunnel', 'mouthPucker', 'mouthClose', 'viseme_aa', 'viseme_O', 'viseme_E'];

const $ = (id) => document.getElementById(id);
const els = {
  conn: $('conn'),
  connText: $('conn-text'),
  text: $('text'),
  textCount: $('text-count'),
  textError: $('text-error'),
  tagButtons: $('tag-buttons'),
  tagIntensity: $('tag-intensity'),
  tagIntensityOut: $('tag-intensity-out'),
  tagRamp: $('tag-ramp'),
  lang: $('lang'),
  voice: $('voice'),
  rate: $('rate'),
  rateOut: $('rate-out'),
  rig: $('rig'),
  audio: $('audio'),
  idle: $('idle'),
  speak: $('speak'),
  stop: $('stop'),
  samples: $('samples'),
  queue: $('queue'),
  view3d: $('view3d'),
  frames: $('frames'),
  framesHint: $('frames-hint'),
  loading: $('loading'),
  hudRig: $('hud-rig'),
  hudMode: $('hud-mode'),
  hudTime: $('hud-time'),
  mute: $('mute'),
  timeline: $('timeline'),
  tlInfo: $('tl-info'),
};

const client = new FacecastClient();
const player = new StreamPlayer();
const view = new AvatarView(els.view3d);
const timeline = new Timeline(els.timeline);
const framesCtx = els.frames.getContext('2d');

const state = {
  nextId: 1,
  utterances: new Map(), // id -> {id, text, state, stream, li, dropped}
  rigs: [],
  rigId: null,
  rigLoading: null,
  shownStream: null,
  restDecay: true, // no stream drives the face: settle to rest (and blink now and then)
  lastFrameAt: 0,
  history: [],
  log: [],
};

// ---------------------------------------------------------------------------------------------------
// Debug surface for tests.

window.__facecast = {
  ready: false,
  get connection() {
    return client.state;
  },
  get hello() {
    return client.hello;
  },
  get rig() {
    return state.rigId;
  },
  get morphNames() {
    return view.names;
  },
  /** The influence of a morph target by name, the largest over the rig's primitives. */
  influence(name) {
    const v = view.influences(name).filter((x) => x !== null);
    return v.length ? Math.max(...v) : null;
  },
  influences: (name) => view.influences(name),
  mouth() {
    let m = 0;
    for (const n of MOUTH_SHAPES) {
      const v = window.__facecast.influence(n);
      if (v !== null) m = Math.max(m, v);
    }
    return m;
  },
  audioTime: () => (player.ctx ? player.ctx.currentTime : null),
  audioState: () => (player.ctx ? player.ctx.state : 'none'),
  get stats() {
    return { ...player.stats };
  },
  /** The clock the current stream runs on: 'audio' (AudioContext) or 'perf' (no audio). */
  get clock() {
    return player.current ? player.current.clock : null;
  },
  get utteranceTime() {
    const t = player.current ? player.current.lastT : null;
    return Number.isFinite(t) ? t : null;
  },
  get timeline() {
    return { ...timeline.drawn };
  },
  get utterances() {
    return [...state.utterances.values()].map(({ li, ...u }) => u);
  },
  get lastUtterance() {
    const all = window.__facecast.utterances;
    return all[all.length - 1] || null;
  },
  /** [utterance time, mouth opening] for every frame shown of the current stream. */
  get history() {
    return state.history.slice();
  },
  get renderInfo() {
    return { renders: view.renders || 0, pixelRatio: view.renderer.getPixelRatio(), motionPixelRatio: view.motionPR };
  },
  get alerts() {
    return alerts.map((a) => ({ level: a.level, code: a.code, message: a.message }));
  },
  get textError() {
    return els.textError.classList.contains('hidden') ? null : els.textError.textContent;
  },
  log: state.log,
  expressions: EXPRESSIONS,
  headRotation: () => ({ x: view.pivot.rotation.x, y: view.pivot.rotation.y, z: view.pivot.rotation.z }),
};

// ---------------------------------------------------------------------------------------------------
// Settings that survive a reload.

const SETTINGS = ['lang', 'voice', 'rate', 'rig'];
function loadSettings() {
  try {
    const saved = JSON.parse(localStorage.getItem('facecast.settings') || '{}');
    for (const k of SETTINGS) if (saved[k] !== undefined && els[k]) els[k].value = saved[k];
    if (saved.output) setOutput(saved.output);
    if (saved.audio !== undefined) els.audio.checked = saved.audio;
    if (saved.idle !== undefined) els.idle.checked = saved.idle;
    if (saved.muted) setMuted(true);
    return saved;
  } catch {
    return {};
  }
}
function saveSettings() {
  const s = { output: output(), audio: els.audio.checked, idle: els.idle.checked, muted: player.muted };
  for (const k of SETTINGS) s[k] = els[k].value;
  try {
    localStorage.setItem('facecast.settings', JSON.stringify(s));
  } catch {
    // private mode: settings are not kept
  }
}

function output() {
  return document.querySelector('input[name="output"]:checked').value;
}
function setOutput(v) {
  const r = document.querySelector(`input[name="output"][value="${v}"]`);
  if (r) r.checked = true;
  applyOutputMode();
}
function applyOutputMode() {
  const frames = output() === 'frames';
  els.frames.classList.toggle('hidden', !frames);
  els.framesHint.classList.toggle('hidden', !frames || state.framesShown);
  els.hudMode.textContent = frames ? 'frames (server-rendered)' : 'weights (3D)';
}
function setMuted(m) {
  player.setMuted(m);
  els.mute.classList.toggle('muted', m);
  els.mute.setAttribute('aria-pressed', String(m));
  els.mute.title = m ? 'Unmute the voice' : 'Mute the voice';
}

// ---------------------------------------------------------------------------------------------------
// Text box, tags, samples.

function updateCount() {
  const n = [...els.text.value].length;
  const max = client.hello?.limits?.max_text;
  els.textCount.textContent = max ? `${n} / ${max}` : `${n} characters`;
  els.textCount.style.color = max && n > max ? 'var(--bad)' : '';
}

function insertAtCursor(snippet) {
  const ta = els.text;
  const start = ta.selectionStart ?? ta.value.length;
  const end = ta.selectionEnd ?? start;
  ta.setRangeText(snippet, start, end, 'end');
  ta.focus();
  clearTextError();
  updateCount();
}

function buildTagButtons() {
  els.tagIntensity.addEventListener('input', () => (els.tagIntensityOut.textContent = els.tagIntensity.value));
  for (const name of EXPRESSIONS) {
    const b = document.createElement('button');
    b.type = 'button';
    b.className = 'chip';
    b.dataset.expression = name;
    b.innerHTML = `<span class="sw" style="background:${expressionColor(name)}"></span>${name}`;
    b.title = `Insert (${name}, intensity, ramp seconds) at the cursor`;
    b.addEventListener('click', () => {
      const a = Math.max(0, Math.min(63, Math.round(Number(els.tagIntensity.value) || 0)));
      const t = Math.max(0, Number(els.tagRamp.value) || 0);
      insertAtCursor(`(${name}, ${a}, ${Number(t.toFixed(2))})`);
    });
    els.tagButtons.appendChild(b);
  }
  const reset = document.createElement('button');
  reset.type = 'button';
  reset.className = 'chip';
  reset.dataset.expression = 'reset';
  reset.textContent = 'reset ↺';
  reset.title = 'Insert a tag with intensity 0: the expression returns to neutral';
  reset.addEventListener('click', () => insertAtCursor(`(neutral, 0, ${Number((Number(els.tagRamp.value) || 0.5).toFixed(2))})`));
  els.tagButtons.appendChild(reset);
  for (const [label, text] of SAMPLES) {
    const o = document.createElement('option');
    o.value = text;
    o.textContent = label;
    els.samples.appendChild(o);
  }
  els.samples.addEventListener('change', () => {
    if (!els.samples.value) return;
    els.text.value = els.samples.value;
    els.samples.value = '';
    clearTextError();
    updateCount();
  });
}

function clearTextError() {
  els.textError.classList.add('hidden');
  els.text.classList.remove('has-error');
}

/** Shows an error about the text; "offset N" in the message marks that character (code points). */
function showTextError(message, text) {
  const m = /\b(?:offset|character) (\d+)/.exec(message);
  els.textError.replaceChildren();
  const head = document.createElement('div');
  head.textContent = message;
  els.textError.appendChild(head);
  if (m && text !== undefined) {
    const chars = [...text];
    let at = Math.min(Number(m[1]), chars.length);
    // Mark the whole tag when the offset points into one: back to its '(' and on to its ')'.
    let end = at + 1;
    for (let i = at; i >= 0 && at - i < 48; i--) {
      if (chars[i] === ')' || chars[i] === '）') break;
      if (chars[i] === '(' || chars[i] === '（') {
        at = i;
        end = i + 1;
        while (end < chars.length && end - i < 64 && chars[end - 1] !== ')' && chars[end - 1] !== '）') end++;
        break;
      }
    }
    const from = Math.max(0, at - 24);
    const to = Math.min(chars.length, end + 24);
    const snip = document.createElement('span');
    snip.className = 'snippet';
    snip.append((from > 0 ? '…' : '') + chars.slice(from, at).join(''));
    const mark = document.createElement('mark');
    mark.textContent = chars.slice(at, end).join('') || ' ';
    snip.append(mark, chars.slice(end, to).join('') + (to < chars.length ? '…' : ''));
    els.textError.appendChild(snip);
    // Select the spot in the text box too (UTF-16 indices).
    const u16 = chars.slice(0, at).join('').length;
    const u16end = chars.slice(0, end).join('').length;
    if (els.text.value === text) els.text.setSelectionRange(u16, u16end);
  }
  els.textError.classList.remove('hidden');
  els.text.classList.add('has-error');
}

// ---------------------------------------------------------------------------------------------------
// Utterance queue list.

function addUtterance(id, text) {
  const li = document.createElement('li');
  li.innerHTML = '<span class="st"></span><span class="tx"></span>';
  li.querySelector('.tx').textContent = text.replace(/\s+/g, ' ');
  li.title = text;
  els.queue.prepend(li);
  while (els.queue.children.length > 6) els.queue.lastElementChild.remove();
  const u = { id, text, state: 'sent', stream: null, li, dropped: 0, error: null };
  state.utterances.set(id, u);
  setUtteranceState(u, 'sent');
  return u;
}

function setUtteranceState(u, s, note) {
  u.state = s;
  u.li.dataset.state = s;
  u.li.querySelector('.st').textContent = note || s;
  updateButtons();
}

function pendingIds() {
  return [...state.utterances.values()].filter((u) => u.state === 'sent' || u.state === 'playing').map((u) => u.id);
}

function updateButtons() {
  // Frames mode needs no model here: the server renders.
  els.speak.disabled = !client.open || (!view.model && output() === 'weights');
  els.stop.disabled = !pendingIds().length && !player.current;
}

// ---------------------------------------------------------------------------------------------------
// Speak and stop.

function speak() {
  const text = els.text.value.trim();
  clearTextError();
  if (!text) {
    showTextError('Type something for the avatar to say.');
    return;
  }
  const max = client.hello?.limits?.max_text;
  if (max && [...text].length > max) {
    showTextError(`The text has ${[...text].length} characters; the server accepts at most ${max}.`);
    return;
  }
  if (!client.open) {
    showAlert({ level: 'error', code: 'offline', message: 'Not connected to the server; the page reconnects by itself.' });
    return;
  }
  if (els.audio.checked) {
    const ctx = player.unlockAudio();
    if (!ctx) showAlert({ level: 'warn', code: 'audio', message: 'This browser has no Web Audio; the face moves without sound.' });
  }
  const id = `u${state.nextId++}`;
  const out = output();
  const msg = {
    type: 'speak',
    id,
    text,
    lang: els.lang.value,
    rig: state.rigId || 'default',
    output: out,
    audio: els.audio.checked,
    voice: els.voice.value,
    rate: Number(els.rate.value),
    idle: els.idle.checked,
    fps: out === 'frames' ? 30 : 60,
  };
  if (out === 'frames') msg.size = framesSize();
  const u = addUtterance(id, text);
  u.sentText = text;
  if (!client.send(msg)) setUtteranceState(u, 'error', 'not sent');
  state.log.push({ t: performance.now(), sent: msg });
}

function framesSize() {
  const r = els.frames.getBoundingClientRect();
  const aspect = r.width > 0 && r.height > 0 ? r.width / r.height : 4 / 3;
  let w = 640;
  let h = Math.round(w / aspect / 16) * 16;
  if (h > 720) {
    h = 720;
    w = Math.round((h * aspect) / 16) * 16;
  }
  return [Math.max(16, Math.min(1920, w)), Math.max(16, Math.min(1920, h))];
}

function stop() {
  for (const id of pendingIds()) {
    client.send({ type: 'cancel', id });
    player.silence(id);
  }
  updateButtons();
}

// ---------------------------------------------------------------------------------------------------
// Protocol events.

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

client.addEventListener('state', (e) => {
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
});

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
      message: has ? 'The server rejected the token in the address (?token=…).' : 'This server needs a token: open the page as /?token=YOUR_TOKEN.',
      sticky: true,
    });
  }
}

client.addEventListener('closed', () => {
  // Whatever was playing is gone with the connection: stop it and let the face settle.
  for (const u of state.utterances.values()) {
    if (u.state === 'sent' || u.state === 'playing') setUtteranceState(u, 'error', 'lost');
  }
  player.stopAll();
  state.restDecay = true;
});

client.addEventListener('hello', (e) => {
  state.everOpen = true;
  els.connText.textContent = `Connected · ${e.detail.server || 'facecast'}`;
  updateCount();
});

client.addEventListener('stream_start', (e) => {
  const m = e.detail;
  player.start(m);
  const u = state.utterances.get(m.id);
  if (u) {
    u.stream = m.stream;
    u.duration = m.duration;
    setUtteranceState(u, 'playing', `${(m.duration || 0).toFixed(1)} s`);
  }
  state.log.push({ t: performance.now(), stream_start: { id: m.id, stream: m.stream, frames: m.frames, names: m.names?.length } });
});

client.addEventListener('stream_end', (e) => {
  const m = e.detail;
  player.end(m);
  const u = state.utterances.get(m.id);
  if (u) {
    u.dropped = m.dropped || 0;
    u.frames = m.frames;
    setUtteranceState(u, m.cancelled ? 'cancelled' : 'done', m.cancelled ? 'stopped' : m.dropped ? `${m.dropped} dropped` : 'done');
  }
  state.log.push({ t: performance.now(), stream_end: m });
});

client.addEventListener('error', (e) => {
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
});

client.addEventListener('media', (e) => player.media(e.detail.header, e.detail.payload));

// ---------------------------------------------------------------------------------------------------
// Rigs.

async function refreshRigs() {
  try {
    const res = await fetchJson('/api/rigs');
    state.rigs = res?.rigs || [];
    if (res?.default) state.serverDefault = res.default;
  } catch (e) {
    if (e.status === 401) state.needsToken = true;
    else showAlert({ level: 'error', code: e.code || 'rigs', message: `Could not list the rigs: ${e.message}` });
    if (!state.rigs.length) state.rigs = (client.hello?.rigs || ['default']).map((id) => ({ id, name: id }));
  }
  const want = new URLSearchParams(location.search).get('rig') || state.rigId || state.savedRig || state.serverDefault || client.hello?.default_rig || 'default';
  els.rig.replaceChildren();
  for (const r of state.rigs) {
    const o = document.createElement('option');
    o.value = r.id;
    o.textContent = `${r.name || r.id}${r.builtin ? ' (built-in)' : ''}`;
    els.rig.appendChild(o);
  }
  const pick = state.rigs.find((r) => r.id === want) ? want : state.rigs[0]?.id || 'default';
  els.rig.value = pick;
  if (pick !== state.rigId) await loadRig(pick);
}

async function loadRig(id) {
  state.rigLoading = id;
  els.loading.textContent = 'Loading the avatar…';
  els.loading.classList.remove('hidden');
  try {
    const gltf = await loadGlb(`/api/rigs/${encodeURIComponent(id)}.glb`, authHeaders(), (e) => {
      if (e.lengthComputable && e.total) els.loading.textContent = `Loading the avatar… ${Math.round((100 * e.loaded) / e.total)}%`;
    });
    if (state.rigLoading !== id) return;
    view.setModel(gltf);
    state.rigId = id;
    const r = state.rigs.find((x) => x.id === id);
    els.hudRig.textContent = r?.name || id;
    els.loading.classList.add('hidden');
    window.__facecast.ready = true;
    saveSettings();
  } catch (e) {
    els.loading.textContent = `Could not load rig '${id}'.`;
    showAlert({ level: 'error', code: 'rig', message: `Could not load rig '${id}': ${e.message || e}` });
  } finally {
    updateButtons();
  }
}

// ---------------------------------------------------------------------------------------------------
// The render loop: present the due frame, draw the timeline, render the avatar.

let lastTick = performance.now();
function tick() {
  requestAnimationFrame(tick);
  const now = performance.now();
  const dt = Math.min(0.1, (now - lastTick) / 1000);
  lastTick = now;
  const r = player.update();
  if (r) {
    const s = r.stream;
    if (state.shownStream !== s) {
      state.shownStream = s;
      state.history = [];
      timeline.set(s.id, s.utterance, s.duration, s.jawCurve);
      const u = s.utterance;
      els.tlInfo.textContent = u
        ? `${s.id} · ${(s.duration || 0).toFixed(2)} s · ${u.set || ''} · ${u.visemes?.length || 0} visemes · ${u.expressions?.length || 0} expression tags`
        : `${s.id}`;
    }
    if (r.weights && !r.done) {
      view.setWeights(s.names, r.weights);
      if (r.extra && s.extra.length) {
        const e = (n) => {
          const i = s.extra.indexOf(n);
          return i >= 0 ? r.extra[i] : 0;
        };
        view.setHead(e('headYaw'), e('headPitch'), e('headRoll'));
      }
      state.history.push([r.t, window.__facecast.mouth()]);
      if (state.history.length > 5000) state.history.splice(0, 1000);
      state.restDecay = false;
    }
    if (r.jpeg) drawJpeg(r.jpeg);
    if (r.t !== null) {
      timeline.setTime(r.t);
      els.hudTime.textContent = `${Math.max(0, r.t).toFixed(2)} / ${(s.duration || 0).toFixed(2)} s`;
    }
    if (r.done && !state.restDecay) state.restDecay = true;
  }
  // After a stream (or when one was cut off), settle anything left to the rest pose.
  if (state.restDecay && view.model) {
    view.scaleWeights(Math.exp(-dt / 0.08));
    const k = Math.exp(-dt / 0.2);
    const r = view.pivot.rotation;
    const small = (v) => (Math.abs(v * k) < 1e-5 ? 0 : v * k);
    view.setHead(small(r.y), small(r.x), small(r.z));
    idleBlink(now);
  }
  if (view.model && output() === 'weights') view.render();
  else if (view.model && !els.frames.classList.contains('hidden')) view.controls.update();
  updateButtons();
}

// Between utterances the avatar still blinks now and then (the server's idle life covers the
// streams themselves).
const blink = { next: performance.now() + 2500, start: 0 };
function idleBlink(now) {
  if (!els.idle.checked) return;
  if (!blink.start && now >= blink.next) blink.start = now;
  if (!blink.start) return;
  const u = (now - blink.start) / 1000;
  // 70 ms to close, 30 ms closed, 160 ms to open (as the server's idle blinks).
  const v = u < 0.07 ? u / 0.07 : u < 0.1 ? 1 : u < 0.26 ? 1 - (u - 0.1) / 0.16 : 0;
  if (u >= 0.26) {
    blink.start = 0;
    blink.next = now + 2000 + Math.random() * 3500;
  }
  view.setWeight('eyeBlinkLeft', v);
  view.setWeight('eyeBlinkRight', v);
}

function drawJpeg(bitmap) {
  const c = els.frames;
  if (c.width !== bitmap.width || c.height !== bitmap.height) {
    c.width = bitmap.width;
    c.height = bitmap.height;
  }
  framesCtx.drawImage(bitmap, 0, 0);
  state.framesShown = true;
  els.framesHint.classList.add('hidden');
  window.__facecast.framesDrawn = (window.__facecast.framesDrawn || 0) + 1;
}

// ---------------------------------------------------------------------------------------------------
// Wiring.

function init() {
  buildTagButtons();
  const saved = loadSettings();
  state.savedRig = saved.rig;
  els.rateOut.textContent = els.rate.value;
  els.rate.addEventListener('input', () => {
    els.rateOut.textContent = els.rate.value;
    saveSettings();
  });
  for (const k of ['lang', 'voice']) els[k].addEventListener('change', saveSettings);
  els.audio.addEventListener('change', saveSettings);
  els.idle.addEventListener('change', saveSettings);
  for (const r of document.querySelectorAll('input[name="output"]')) {
    r.addEventListener('change', () => {
      applyOutputMode();
      saveSettings();
    });
  }
  els.rig.addEventListener('change', () => loadRig(els.rig.value));
  els.mute.addEventListener('click', () => {
    setMuted(!player.muted);
    saveSettings();
  });
  els.text.addEventListener('input', () => {
    clearTextError();
    updateCount();
  });
  els.speak.addEventListener('click', speak);
  els.stop.addEventListener('click', stop);
  document.addEventListener('keydown', (e) => {
    if (e.key === 'Enter' && (e.ctrlKey || e.metaKey)) {
      e.preventDefault();
      if (!els.speak.disabled) speak();
    } else if (e.key === 'Escape') {
      stop();
    }
  });
  applyOutputMode();
  updateCount();
  keepTokenInLinks();
  timeline.draw();
  client.connect();
  requestAnimationFrame(tick);
}

init();
