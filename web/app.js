// The speak page: connects to facecast.v1, sends speak/cancel, plays the streams on the 3D avatar
// (weights) or on a canvas (frames), draws the timeline, and shows connection state and errors.
// The pieces live in speak/: page.js (elements, connection, player, view, state), text_box.js,
// settings.js, queue.js (utterances, speak/stop), connection.js (server messages), rigs.js,
// render_loop.js, debug.js (window.__facecast, the page's state for the browser tests).

import { keepTokenInLinks } from './api.js';
import './speak/debug.js';
import { client, els, player, state, timeline } from './speak/page.js';
import { listen } from './speak/connection.js';
import { speak, stop } from './speak/queue.js';
import { tick } from './speak/render_loop.js';
import { loadRig } from './speak/rigs.js';
import { applyOutputMode, loadSettings, saveSettings, setMuted } from './speak/settings.js';
import { buildTagButtons, clearTextError, updateCount } from './speak/text_box.js';

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
  listen();
  timeline.draw();
  client.open();
  requestAnimationFrame(tick);
}

init();
