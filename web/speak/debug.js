// window.__facecast: the speak page's state for the browser tests (tests/web/speak.mjs) and for
// curious people.

import { alerts } from '../alerts.js';
import { client, els, player, state, timeline, view } from './page.js';
import { EXPRESSIONS } from './text_box.js';

const MOUTH_SHAPES = ['jawOpen', 'mouthFunnel', 'mouthPucker', 'mouthClose', 'viseme_aa', 'viseme_O', 'viseme_E'];

/** The influence of a morph target by name, the largest over the rig's primitives. */
function influence(name) {
  const v = view.influences(name).filter((x) => x !== null);
  return v.length ? Math.max(...v) : null;
}

/** How open the mouth is: the largest influence of the mouth shapes. */
export function mouth() {
  let m = 0;
  for (const n of MOUTH_SHAPES) {
    const v = influence(n);
    if (v !== null) m = Math.max(m, v);
  }
  return m;
}

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
  influence,
  influences: (name) => view.influences(name),
  mouth,
  audioTime: () => (player.ctx ? player.ctx.currentTime : null),
  audioState: () => (player.ctx ? player.ctx.state : 'none'),
  get stats() {
    return { ...player.stats };
  },
  /** The clock the current stream runs on: 'audio' (AudioContext) or 'perf' (no audio). */
  get clock() {
    return player.current ? player.current.clock : null;
  },
  /** The player's state, for a test's failure message: the stream shown and why it is not over. */
  get player() {
    const s = player.current;
    return {
      streams: [...player.streams.keys()],
      restDecay: state.restDecay,
      current: s && {
        id: s.id,
        stream: s.stream,
        ended: s.ended,
        clock: s.clock,
        pendingJpegs: s.pendingJpegs,
        end: s.endOf(),
        t: s.clock ? player.clockNow(s.clock) - s.t0 : null,
        done: player.done(s),
      },
    };
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
  headRotation: () => ({ x: view.pose.pitch, y: view.pose.yaw, z: view.pose.roll }),
};
