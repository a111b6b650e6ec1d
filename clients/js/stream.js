// One stream in the player (player.js): what its stream_start announced, its weight frames and JPEG
// images in time order, its scheduled audio sources, and what is due at an utterance time.

import { stopSources } from './audio.js';

const KEEP = 240; // frames kept behind the one shown

export class PlayerStream {
  constructor(msg, now) {
    this.id = msg.id;
    this.stream = msg.stream;
    this.output = msg.output || 'weights';
    this.fps = msg.fps || 60;
    this.names = msg.names || [];
    this.extra = msg.extra || [];
    this.nch = this.names.length + this.extra.length;
    this.audio = msg.audio || null;
    this.utterance = msg.utterance || null;
    this.duration = msg.duration || msg.utterance?.duration || 0;
    this.frames = []; // {t, w: Float32Array(nch)}, in order of time
    this.jawIndex = this.names.indexOf('jawOpen');
    this.jawCurve = []; // [t, jawOpen] of every frame received (for a timeline)
    this.jpegs = []; // {t, bitmap}, in order of time
    this.pendingJpegs = 0;
    this.shownJpeg = null;
    this.cursor = 0;
    this.clock = null; // 'audio' | 'perf'
    this.t0 = 0; // clock time of utterance time 0
    this.firstMediaAt = 0;
    this.audioEnd = 0; // utterance time where the scheduled audio ends
    this.sources = [];
    this.ended = false;
    this.cancelled = false;
    this.endInfo = null;
    this.startedAt = now;
    this.lastT = -Infinity;
  }

  /** Adds a frame of nch values at utterance time t (frames arrive in order; a dropped one leaves a gap). */
  addFrame(t, w) {
    if (this.jawIndex >= 0) this.jawCurve.push([t, w[this.jawIndex]]);
    let i = this.frames.length;
    while (i > 0 && this.frames[i - 1].t > t) i--;
    this.frames.splice(i, 0, { t, w });
  }

  addJpeg(t, bitmap) {
    let i = this.jpegs.length;
    while (i > 0 && this.jpegs[i - 1].t > t) i--;
    this.jpegs.splice(i, 0, { t, bitmap });
  }

  /** The utterance time of the last thing received (frame, image or audio sample). */
  endOf() {
    const lastFrame = this.frames.length ? this.frames[this.frames.length - 1].t : 0;
    const lastJpeg = this.jpegs.length ? this.jpegs[this.jpegs.length - 1].t : 0;
    return Math.max(lastFrame, lastJpeg, this.audioEnd);
  }

  /** The weights and extra values at utterance time t, interpolated between the frames around it; null before the first. */
  weightsAt(t) {
    if (!this.frames.length) return null;
    while (this.cursor + 1 < this.frames.length && this.frames[this.cursor + 1].t <= t) this.cursor++;
    const a = this.frames[this.cursor];
    if (a.t > t) return null;
    const b = this.frames[this.cursor + 1];
    const w = new Float32Array(this.nch);
    if (b && b.t > a.t && b.t - a.t < 3 / this.fps) {
      const u = Math.min(1, (t - a.t) / (b.t - a.t));
      for (let i = 0; i < this.nch; i++) w[i] = a.w[i] + (b.w[i] - a.w[i]) * u;
    } else {
      w.set(a.w);
    }
    // Frames before the cursor are no longer needed except one for interpolation.
    if (this.cursor > KEEP) {
      this.frames.splice(0, this.cursor - 1);
      this.cursor = 1;
    }
    return { weights: w.subarray(0, this.names.length), extra: w.subarray(this.names.length) };
  }

  /** The image due at utterance time t when it is not the one shown last, else null. */
  jpegAt(t) {
    let i = -1;
    while (i + 1 < this.jpegs.length && this.jpegs[i + 1].t <= t) i++;
    if (i < 0) return null;
    const due = this.jpegs[i];
    for (let k = 0; k < i; k++) this.jpegs[k].bitmap.close?.();
    this.jpegs.splice(0, i);
    if (due === this.shownJpeg) return null;
    this.shownJpeg = due;
    return due.bitmap;
  }

  stopAudio() {
    stopSources(this.sources);
    this.sources = [];
  }

  /** Stops it for good: audio, frames and images. */
  clear() {
    this.stopAudio();
    this.ended = true;
    this.frames = [];
    for (const j of this.jpegs) j.bitmap.close?.();
    this.jpegs = [];
  }

  /** Frees its images when the player moves on (the one shown stays on screen). */
  release() {
    for (const j of this.jpegs) if (j !== this.shownJpeg) j.bitmap.close?.();
  }
}
