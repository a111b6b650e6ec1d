// Utterances: the queue list with each one's state, the Speak and Stop buttons, and the speak and
// cancel messages.

import { showAlert } from '../alerts.js';
import { client, els, player, state, view } from './page.js';
import { output } from './settings.js';
import { clearTextError, showTextError } from './text_box.js';

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

export function setUtteranceState(u, s, note) {
  u.state = s;
  u.li.dataset.state = s;
  u.li.querySelector('.st').textContent = note || s;
  updateButtons();
}

function pendingIds() {
  return [...state.utterances.values()].filter((u) => u.state === 'sent' || u.state === 'playing').map((u) => u.id);
}

export function updateButtons() {
  // Frames mode needs no model here: the server renders.
  els.speak.disabled = !client.connected || (!view.model && output() === 'weights');
  els.stop.disabled = !pendingIds().length && !player.current;
}

export function speak() {
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
  if (!client.connected) {
    showAlert({ level: 'error', code: 'offline', message: 'Not connected to the server; the page reconnects by itself.' });
    return;
  }
  if (els.audio.checked) {
    const ctx = player.unlockAudio();
    if (!ctx) showAlert({ level: 'warn', code: 'audio', message: 'This browser has no Web Audio; the face moves without sound.' });
  }
  const id = `u${state.nextId++}`;
  const out = output();
  const fields = {
    lang: els.lang.value,
    rig: state.rigId || 'default',
    output: out,
    audio: els.audio.checked,
    voice: els.voice.value,
    rate: Number(els.rate.value),
    idle: els.idle.checked,
    fps: out === 'frames' ? 30 : 60,
  };
  if (out === 'frames') fields.size = framesSize();
  const u = addUtterance(id, text);
  u.sentText = text;
  try {
    client.speak(text, { id, ...fields });
  } catch {
    setUtteranceState(u, 'error', 'not sent');
  }
  state.log.push({ t: performance.now(), sent: { type: 'speak', id, text, ...fields } });
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

export function stop() {
  for (const id of pendingIds()) {
    if (client.connected) client.cancel(id);
    player.silence(id);
  }
  // Utterances the server has finished sending may still play or wait here: they end too.
  player.stopSent();
  updateButtons();
}
