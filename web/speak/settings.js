// The speak page's settings that survive a reload (localStorage), the output mode and muting.

import { els, player, state } from './page.js';

const SETTINGS = ['lang', 'voice', 'rate', 'rig'];
export function loadSettings() {
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
export function saveSettings() {
  const s = { output: output(), audio: els.audio.checked, idle: els.idle.checked, muted: player.muted };
  for (const k of SETTINGS) s[k] = els[k].value;
  try {
    localStorage.setItem('facecast.settings', JSON.stringify(s));
  } catch {
    // private mode: settings are not kept
  }
}

export function output() {
  return document.querySelector('input[name="output"]:checked').value;
}
function setOutput(v) {
  const r = document.querySelector(`input[name="output"][value="${v}"]`);
  if (r) r.checked = true;
  applyOutputMode();
}
export function applyOutputMode() {
  const frames = output() === 'frames';
  els.frames.classList.toggle('hidden', !frames);
  els.framesHint.classList.toggle('hidden', !frames || state.framesShown);
  els.hudMode.textContent = frames ? 'frames (server-rendered)' : 'weights (3D)';
}
export function setMuted(m) {
  player.setMuted(m);
  els.mute.classList.toggle('muted', m);
  els.mute.setAttribute('aria-pressed', String(m));
  els.mute.title = m ? 'Unmute the voice' : 'Mute the voice';
}
