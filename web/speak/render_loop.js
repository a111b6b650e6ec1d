// The render loop: each animation frame presents the stream's due frame (weights on the 3D avatar,
// or a server-rendered JPEG), moves the timeline, and between streams settles the face to rest
// with an occasional blink.

import { els, player, state, timeline, view } from './page.js';
import { mouth } from './debug.js';
import { updateButtons } from './queue.js';
import { output } from './settings.js';

const framesCtx = els.frames.getContext('2d');

let lastTick = performance.now();
export function tick() {
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
        view.setPose({ yaw: e('headYaw'), pitch: e('headPitch'), roll: e('headRoll'), breath: e('breath'), lean: e('lean'), shrug: e('shrug') });
      }
      state.history.push([r.t, mouth()]);
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
    const small = (v) => (Math.abs(v * k) < 1e-5 ? 0 : v * k);
    view.setPose(Object.fromEntries(Object.entries(view.pose).map(([name, v]) => [name, small(v)])));
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
