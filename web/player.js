// Plays facecast.v1 streams: PCM16 audio through Web Audio, scheduled back to back, and weight or JPEG
// frames presented at their pts against the audio clock (AudioContext time), or against
// performance.now() when the stream has no audio.
//
// Utterance time t of a stream is clockNow(stream.clock) - stream.t0; a frame with presentation time
// pts is shown when t >= pts. Audio chunks start at t0 + first / sample_rate on the AudioContext.

import { KIND } from './protocol.js';

const LEAD = 0.2; // s of local buffer between a stream's first media and its playback (absorbs a busy main thread)
const AUDIO_WAIT = 0.4; // s to wait for announced audio before the frames run on their own clock

function perfNow() {
  return performance.now() / 1000;
}

export class StreamPlayer {
  constructor() {
    this.ctx = null;
    this.gain = null;
    this.streams = new Map(); // stream number -> Stream
    this.current = null; // the stream being presented (or the last one)
    this.stats = { audioChunks: 0, audioLate: 0, weightFrames: 0, jpegFrames: 0, jpegDrawn: 0, bad: 0 };
    this.muted = false;
  }

  /** Creates or resumes the AudioContext; call it from a user gesture (the speak button). */
  unlockAudio() {
    if (!this.ctx) {
      const AC = window.AudioContext || window.webkitAudioContext;
      if (!AC) return null;
      this.ctx = new AC({ latencyHint: 'interactive' });
      this.gain = this.ctx.createGain();
      this.gain.connect(this.ctx.destination);
    }
    if (this.ctx.state === 'suspended') this.ctx.resume().catch(() => {});
    return this.ctx;
  }

  setMuted(muted) {
    this.muted = muted;
    if (this.gain) this.gain.gain.value = muted ? 0 : 1;
  }

  get audioRunning() {
    return !!this.ctx && this.ctx.state === 'running';
  }

  /** The audio clock, corrected by the output timestamp where the browser gives one. */
  audioNow() {
    if (!this.ctx) return 0;
    let t = this.ctx.currentTime;
    const ts = this.ctx.getOutputTimestamp ? this.ctx.getOutputTimestamp() : null;
    if (ts && ts.contextTime > 0 && ts.performanceTime > 0) {
      // Never run ahead of what the context has rendered.
      t = Math.min(t, ts.contextTime + (performance.now() - ts.performanceTime) / 1000);
    }
    // The two estimates can disagree by the output latency: the clock never goes back.
    this._audioNow = Math.max(this._audioNow || 0, t);
    return this._audioNow;
  }

  clockNow(kind) {
    return kind === 'audio' ? this.audioNow() : perfNow();
  }

  /** stream_start: a new stream, queued behind the one playing. */
  start(msg) {
    const nch = (msg.names?.length || 0) + (msg.extra?.length || 0);
    const s = {
      id: msg.id,
      stream: msg.stream,
      output: msg.output || 'weights',
      fps: msg.fps || 60,
      names: msg.names || [],
      extra: msg.extra || [],
      nch,
      audio: msg.audio || null,
      utterance: msg.utterance || null,
      duration: msg.duration || msg.utterance?.duration || 0,
      frames: [], // {t, w: Float32Array(nch)}, in order of time
      jawIndex: (msg.names || []).indexOf('jawOpen'),
      jawCurve: [], // [t, jawOpen] of every frame received (for the timeline)
      jpegs: [], // {t, bitmap}
      pendingJpegs: 0,
      cursor: 0,
      clock: null, // 'audio' | 'perf'
      t0: 0,
      firstMediaAt: 0,
      audioEnd: 0, // utterance time where the scheduled audio ends
      sources: [],
      ended: false,
      cancelled: false,
      endInfo: null,
      startedAt: perfNow(),
      lastT: -Infinity,
      shownJpeg: null,
    };
    this.streams.set(msg.stream, s);
    if (!this.current || this.done(this.current)) this.current = s;
    return s;
  }

  end(msg) {
    const s = this.streams.get(msg.stream);
    if (!s) return null;
    s.ended = true;
    s.cancelled = !!msg.cancelled;
    s.endInfo = msg;
    return s;
  }

  /** Stops everything now (stop button, or the socket closed). */
  stopAll() {
    for (const s of this.streams.values()) {
      for (const src of s.sources) {
        try {
          src.stop();
        } catch {
          // already stopped
        }
      }
      s.sources = [];
      s.ended = true;
      s.frames = [];
      for (const j of s.jpegs) j.bitmap.close?.();
      s.jpegs = [];
    }
    this.streams.clear();
    this.current = null;
  }

  /** Stops one stream's audio (on cancel the server still sends the 0.2 s return to rest). */
  silence(id) {
    for (const s of this.streams.values()) {
      if (s.id !== id) continue;
      // The audio that was scheduled ahead no longer keeps the stream alive.
      const t = s.clock ? this.clockNow(s.clock) - s.t0 : 0;
      s.audioEnd = Math.min(s.audioEnd, Math.max(0, t));
      for (const src of s.sources) {
        try {
          src.stop();
        } catch {
          // already stopped
        }
      }
      s.sources = [];
    }
  }

  media(header, payload) {
    const s = this.streams.get(header.stream);
    if (!s) return;
    if (header.kind === KIND.AUDIO) this.onAudio(s, header, payload);
    else if (header.kind === KIND.WEIGHTS) this.onWeights(s, header, payload);
    else if (header.kind === KIND.JPEG) this.onJpeg(s, header, payload);
  }

  /** The earliest start time (in the given clock) a new stream may use: after the previous one. */
  queueFloor(s, kind) {
    let floor = -Infinity;
    for (const o of this.streams.values()) {
      if (o === s || !o.clock || o.stream > s.stream) continue;
      const end = o.t0 + Math.max(o.audioEnd, o.frames.length ? o.frames[o.frames.length - 1].t : 0);
      // Convert the other stream's end into this clock.
      floor = Math.max(floor, o.clock === kind ? end : end - this.clockNow(o.clock) + this.clockNow(kind));
    }
    return floor;
  }

  startClock(s, kind, pts) {
    s.clock = kind;
    s.t0 = Math.max(this.clockNow(kind) + LEAD - pts, this.queueFloor(s, kind));
  }

  onAudio(s, h, payload) {
    this.stats.audioChunks += 1;
    const sr = s.audio?.sample_rate || 22050;
    const n = Math.min(h.count, payload.byteLength >> 1);
    if (!n) return;
    if (!this.ctx || this.ctx.state !== 'running') {
      // No audio output (blocked by the browser): the frames keep their own clock.
      if (!s.clock) this.startClock(s, 'perf', h.pts);
      s.audioEnd = Math.max(s.audioEnd, (h.first + n) / sr);
      return;
    }
    if (!s.clock) this.startClock(s, 'audio', h.pts);
    else if (s.clock === 'perf') {
      // Frames started on their own clock; move the stream onto the audio clock without a jump.
      s.t0 = s.t0 - perfNow() + this.audioNow();
      s.clock = 'audio';
    }
    const pcm = new Int16Array(payload, 0, n);
    const buf = this.ctx.createBuffer(1, n, sr);
    const ch = buf.getChannelData(0);
    for (let i = 0; i < n; i++) ch[i] = pcm[i] / 32768;
    const src = this.ctx.createBufferSource();
    src.buffer = buf;
    src.connect(this.gain);
    const at = s.t0 + h.first / sr;
    const now = this.ctx.currentTime;
    if (at >= now + 0.002) {
      src.start(at);
    } else {
      // Late chunk: skip what should already have been heard to stay in sync.
      this.stats.audioLate += 1;
      const skip = now + 0.002 - at;
      if (skip >= n / sr) return;
      src.start(now + 0.002, skip);
    }
    s.sources.push(src);
    src.onended = () => {
      const i = s.sources.indexOf(src);
      if (i >= 0) s.sources.splice(i, 1);
    };
    s.audioEnd = Math.max(s.audioEnd, (h.first + n) / sr);
  }

  onWeights(s, h, payload) {
    const nch = s.nch;
    const count = Math.min(h.count, Math.floor(payload.byteLength / (4 * nch)));
    if (!nch || !count) {
      this.stats.bad += 1;
      return;
    }
    const all = new Float32Array(payload, 0, count * nch);
    for (let k = 0; k < count; k++) {
      const t = h.pts + k / s.fps;
      const frame = { t, w: all.subarray(k * nch, (k + 1) * nch) };
      if (s.jawIndex >= 0) s.jawCurve.push([t, frame.w[s.jawIndex]]);
      // Frames arrive in order; a dropped message only leaves a gap.
      const last = s.frames[s.frames.length - 1];
      if (!last || t > last.t) s.frames.push(frame);
      else {
        let i = s.frames.length;
        while (i > 0 && s.frames[i - 1].t > t) i--;
        s.frames.splice(i, 0, frame);
      }
    }
    this.stats.weightFrames += count;
    if (!s.firstMediaAt) s.firstMediaAt = perfNow();
    if (!s.clock && !s.audio) this.startClock(s, 'perf', h.pts);
  }

  onJpeg(s, h, payload) {
    this.stats.jpegFrames += 1;
    if (!s.firstMediaAt) s.firstMediaAt = perfNow();
    if (!s.clock && !s.audio) this.startClock(s, 'perf', h.pts);
    s.pendingJpegs += 1;
    createImageBitmap(new Blob([payload], { type: 'image/jpeg' }))
      .then((bitmap) => {
        s.pendingJpegs -= 1;
        if (!this.streams.has(s.stream)) {
          bitmap.close?.();
          return;
        }
        const frame = { t: h.pts, bitmap };
        let i = s.jpegs.length;
        while (i > 0 && s.jpegs[i - 1].t > frame.t) i--;
        s.jpegs.splice(i, 0, frame);
      })
      .catch(() => {
        s.pendingJpegs -= 1;
        this.stats.bad += 1;
      });
  }

  /** The utterance time of the last thing a stream has received (frame, image or audio sample). */
  endOf(s) {
    const lastFrame = s.frames.length ? s.frames[s.frames.length - 1].t : 0;
    const lastJpeg = s.jpegs.length ? s.jpegs[s.jpegs.length - 1].t : 0;
    return Math.max(lastFrame, lastJpeg, s.audioEnd);
  }

  /** True when a stream has ended on the server and everything it sent has been presented. */
  done(s) {
    if (!s.ended) return false;
    if (!s.clock) return true;
    const t = this.clockNow(s.clock) - s.t0;
    return s.pendingJpegs === 0 && t > this.endOf(s) + 0.05;
  }

  /** The utterance time of stream s now, or null before its clock starts. */
  timeOf(s) {
    if (!s) return null;
    if (!s.clock) {
      // Audio was announced but does not come: run the frames on their own clock.
      if (s.audio && s.firstMediaAt && perfNow() - s.firstMediaAt > AUDIO_WAIT) {
        const first = s.frames[0]?.t ?? s.jpegs[0]?.t ?? 0;
        this.startClock(s, 'perf', first);
      } else {
        return null;
      }
    }
    return this.clockNow(s.clock) - s.t0;
  }

  /**
   * Advances presentation. Returns {stream, t, weights, extra, jpeg, done} for the stream being shown:
   * weights/extra are Float32Arrays (interpolated between the two frames around t) or null before the
   * first frame; jpeg is the ImageBitmap due now (only when it changed since the last call).
   */
  update() {
    // Move on to the next stream when the current one has been fully presented.
    if (this.current && this.done(this.current)) {
      const next = [...this.streams.values()].filter((o) => o.stream > this.current.stream).sort((a, b) => a.stream - b.stream)[0];
      if (next) {
        this.release(this.current);
        this.current = next;
      }
    }
    const s = this.current;
    if (!s) return null;
    const t = this.timeOf(s);
    const out = { stream: s, t, weights: null, extra: null, jpeg: null, done: this.done(s) };
    if (t === null) return out;
    if (out.done) out.t = Math.min(t, this.endOf(s) || s.duration);
    // Presentation time never goes back (a clock hand-over or correction waits instead).
    if (s.lastT > out.t) out.t = s.lastT;
    s.lastT = out.t;
    const tt = out.t;
    if (s.frames.length) {
      while (s.cursor + 1 < s.frames.length && s.frames[s.cursor + 1].t <= tt) s.cursor++;
      const a = s.frames[s.cursor];
      if (a.t <= tt) {
        const b = s.frames[s.cursor + 1];
        const nshape = s.names.length;
        const w = new Float32Array(s.nch);
        if (b && b.t > a.t && b.t - a.t < 3 / s.fps) {
          const u = Math.min(1, (tt - a.t) / (b.t - a.t));
          for (let i = 0; i < s.nch; i++) w[i] = a.w[i] + (b.w[i] - a.w[i]) * u;
        } else {
          w.set(a.w);
        }
        out.weights = w.subarray(0, nshape);
        out.extra = w.subarray(nshape);
        // Frames before the cursor are no longer needed except one for interpolation.
        if (s.cursor > 240) {
          s.frames.splice(0, s.cursor - 1);
          s.cursor = 1;
        }
      }
    }
    if (s.jpegs.length) {
      let i = -1;
      while (i + 1 < s.jpegs.length && s.jpegs[i + 1].t <= tt) i++;
      if (i >= 0) {
        const due = s.jpegs[i];
        for (let k = 0; k < i; k++) s.jpegs[k].bitmap.close?.();
        s.jpegs.splice(0, i);
        if (due !== s.shownJpeg) {
          s.shownJpeg = due;
          out.jpeg = due.bitmap;
          this.stats.jpegDrawn += 1;
        }
      }
    }
    return out;
  }

  release(s) {
    for (const j of s.jpegs) if (j !== s.shownJpeg) j.bitmap.close?.();
    this.streams.delete(s.stream);
  }
}
