// The speak page's shared pieces: its elements, the connection and the stream player (the JS
// client's, clients/js), the 3D view, the timeline and the page state. The other modules of
// web/speak/ work on these.

import { FacecastClient, StreamPlayer } from 'facecast-client';
import { currentKey, defaultUrl } from '../api.js';
import { AvatarView } from '../avatar.js';
import { Timeline } from '../timeline.js';

const $ = (id) => document.getElementById(id);
export const els = {
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

// The key is read at every connection (the page may ask for one after a 401).
export const client = new FacecastClient(defaultUrl(), { key: currentKey, reconnect: true });
export const player = new StreamPlayer();
player.attach(client); // streams and media go to the player before the page's own handlers
export const view = new AvatarView(els.view3d);
export const timeline = new Timeline(els.timeline);

export const state = {
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
