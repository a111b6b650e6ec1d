// Plays facecast.v1 streams in a browser: PCM16 audio through Web Audio (audio.js), scheduled back
// to back, and weight or JPEG frames presented at their pts against the audio clock (AudioContext
// time), or against performance.now() when the stream has no audio.
//
// Utterance time t of a stream is clockNow(stream.clock) - stream.t0; a frame with presentation time
// pts is shown when t >= pts. Audio chunks start at t0 + first / sample_rate on the AudioContext.

import { AudioOut } from './audio.js';
import { PlayerStream } from './stream.js';

const LEAD = 0.2; // s of local buffer between a stream's first media and its playback (absorbs a busy main thread)
const AUDIO_WAIT = 0.4; // s to wait for announced audio before the frames run on their own clock
const DONE_AFTER = 0.05; // s past its last frame, image or sample that an ended stream is done

const perfNow = () => performance.now() / 1000;

export class StreamPlayer {
  /** `audioContext`: an AudioContext to play through (default: one made by unlockAudio()). */
  constructor({ audioContext = null } = {}) {
    this.audio = new AudioOut(audioContext);
    this.streams = new Map(); // stream number -> Stream
    this.current = null; // the stream being presented (or the last one)
    this.stats = { audioChunks: 0, audioLate: 0, weightFrames: 0, jpegFrames: 0, jpegDrawn: 0, bad: 0 };
  }

  /** The AudioContext (null before unlockAudio). */
  get ctx() {
    return this.audio.ctx;
  }

  get muted() {
    return this.audio.muted;
  }

  /** Creates or resumes the AudioContext; call it from a user gesture (a button). */
  unlockAudio() {
    return this.audio.unlock();
  }

  setMuted(muted) {
    this.audio.setMuted(muted);
  }

  get audioRunning() {
    return this.audio.running;
  }

  /** The audio clock (s): the AudioContext's time as heard. */
  audioNow() {
    return this.audio.now();
  }

  clockNow(kind) {
    return kind === 'audio' ? this.audio.now() : perfNow();
  }

  /**
   * Feeds the player from a client: its stream_start, stream_end and media events (and stops on
   * close). Returns a function that detaches it.
   */
  attach(client) {
    const on = {
      stream_start: (e) => this.start(e.detail),
      stream_end: (e) => this.end(e.detail),
      weights: (e) => this.media(e.detail),
      audio: (e) => this.media(e.detail),
      jpeg: (e) => this.media(e.detail),
      close: () => this.stopAll(),
    };
    for (const [type, fn] of Object.entries(on)) client.addEventListener(type, fn);
    return () => {
      for (const [type, fn] of Object.entries(on)) client.removeEventListener(type, fn);
    };
  }

  /** stream_start: a new stream, queued behind the ones playing or waiting (update() moves on). */
  start(msg) {
    const s = new PlayerStream(msg, perfNow());
    this.streams.set(msg.stream, s);
    if (!this.current) this.current = s;
    return s;
  }

  /** stream_end: the stream ends once everything it sent has been presented. */
  end(msg) {
    const s = this.streams.get(msg.stream);
    if (!s) return null;
    s.ended = true;
    s.cancelled = !!msg.cancelled;
    s.endInfo = msg;
    // Silenced by a stop, but sent to the end before the cancel reached the server: ended now.
    if (s.silenced && !s.cancelled) this.#skipToEnd(s);
    return s;
  }

  /** Stops everything now (a stop button, or the socket closed). */
  stopAll() {
    for (const s of this.streams.values()) s.clear();
    this.streams.clear();
    this.current = null;
  }

  /**
   * After a cancel (a stop): stops the audio of utterance `id`, and its frames go on from the
   * newest one received, where the server's return to rest follows (the server sends ahead of
   * what is shown). Where the cancel comes too late, the stream ends when its end arrives.
   */
  silence(id) {
    for (const s of this.streams.values()) {
      if (s.id !== id) continue;
      s.silenced = true;
      // The audio that was scheduled ahead no longer keeps the stream alive.
      const t = s.clock ? this.clockNow(s.clock) - s.t0 : 0;
      s.audioEnd = Math.min(s.audioEnd, Math.max(0, t));
      s.stopAudio();
      this.#skipTo(s, this.#newest(s));
    }
  }

  /** The pts of the newest frame or image stream s has received (-Infinity: none yet). */
  #newest(s) {
    return Math.max(s.frames.at(-1)?.t ?? -Infinity, s.jpegs.at(-1)?.t ?? -Infinity);
  }

  /**
   * Ends now the streams the server has finished sending (a cancel no longer reaches them) that
   * still play or wait here, but a cancelled one's return to rest: with cancel and silence for
   * the ones still being sent, a stop button stops everything. Returns how many it ended.
   */
  stopSent() {
    let stopped = 0;
    for (const s of this.streams.values()) {
      if (!s.ended || s.cancelled || this.done(s)) continue;
      s.stopAudio();
      s.audioEnd = 0;
      this.#skipToEnd(s);
      stopped += 1;
    }
    return stopped;
  }

  /** Moves stream s's clock past its end: it is done. */
  #skipToEnd(s) {
    this.#skipTo(s, s.endOf() + 2 * DONE_AFTER);
  }

  /** Moves stream s's clock on so that its time is `t` now (it never goes back). */
  #skipTo(s, t) {
    if (!s.clock) return;
    const now = this.clockNow(s.clock) - s.t0;
    if (t > now) s.t0 -= t - now;
  }

  /** A media item of the client: a WeightsFrame, an audio chunk or a JPEG frame. */
  media(item) {
    const s = this.streams.get(item.stream);
    if (!s) return;
    if (item.type === 'audio') this.onAudio(s, item);
    else if (item.type === 'weights') this.onWeights(s, item);
    else if (item.type === 'jpeg') this.onJpeg(s, item);
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
    // A stream silenced before its media came starts at once.
    if (s.silenced) s.t0 = this.clockNow(kind) - pts;
    else s.t0 = Math.max(this.clockNow(kind) + LEAD - pts, this.queueFloor(s, kind));
  }

  onAudio(s, chunk) {
    this.stats.audioChunks += 1;
    if (s.silenced) return; // sent before the cancel reached the server
    const sr = s.audio?.sample_rate || chunk.sampleRate || 22050;
    const n = chunk.pcm.length;
    if (!n) return;
    if (!this.audio.running) {
      // No audio output (blocked by the browser): the frames keep their own clock.
      if (!s.clock) this.startClock(s, 'perf', chunk.time);
      s.audioEnd = Math.max(s.audioEnd, (chunk.first + n) / sr);
      return;
    }
    if (!s.clock) this.startClock(s, 'audio', chunk.time);
    else if (s.clock === 'perf') {
      // Frames started on their own clock; move the stream onto the audio clock without a jump.
      s.t0 = s.t0 - perfNow() + this.audio.now();
      s.clock = 'audio';
    }
    const { source, late } = this.audio.play(chunk.pcm, sr, s.t0 + chunk.first / sr);
    if (late) this.stats.audioLate += 1;
    if (!source) return;
    s.sources.push(source);
    source.onended = () => {
      const i = s.sources.indexOf(source);
      if (i >= 0) s.sources.splice(i, 1);
    };
    s.audioEnd = Math.max(s.audioEnd, (chunk.first + n) / sr);
  }

  onWeights(s, item) {
    if (!s.nch || item.values.length !== s.nch) {
      this.stats.bad += 1;
      return;
    }
    s.addFrame(item.time, item.values);
    this.stats.weightFrames += 1;
    if (!s.firstMediaAt) s.firstMediaAt = perfNow();
    if (!s.clock && (!s.audio || s.silenced)) this.startClock(s, 'perf', item.time);
    if (s.silenced) this.#skipTo(s, this.#newest(s)); // after a stop, what comes is shown at once
  }

  onJpeg(s, item) {
    this.stats.jpegFrames += 1;
    if (!s.firstMediaAt) s.firstMediaAt = perfNow();
    if (!s.clock && (!s.audio || s.silenced)) this.startClock(s, 'perf', item.time);
    s.pendingJpegs += 1;
    createImageBitmap(new Blob([item.jpeg], { type: 'image/jpeg' }))
      .then((bitmap) => {
        s.pendingJpegs -= 1;
        if (!this.streams.has(s.stream)) return bitmap.close?.();
        s.addJpeg(item.time, bitmap);
        if (s.silenced) this.#skipTo(s, this.#newest(s));
      })
      .catch(() => {
        s.pendingJpegs -= 1;
        this.stats.bad += 1;
      });
  }

  /** True when a stream has ended on the server and everything it sent has been presented. */
  done(s) {
    if (!s.ended) return false;
    if (!s.clock) return true;
    return s.pendingJpegs === 0 && this.clockNow(s.clock) - s.t0 > s.endOf() + DONE_AFTER;
  }

  /** The utterance time of stream s now (its playback clock), or null before its clock starts. */
  timeOf(s) {
    if (!s) return null;
    if (!s.clock) {
      // Audio was announced but does not come: run the frames on their own clock.
      if (!(s.audio && s.firstMediaAt && perfNow() - s.firstMediaAt > AUDIO_WAIT)) return null;
      this.startClock(s, 'perf', s.frames[0]?.t ?? s.jpegs[0]?.t ?? 0);
    }
    return this.clockNow(s.clock) - s.t0;
  }

  /**
   * Advances presentation (call it every animation frame). Returns {stream, t, weights, extra, jpeg,
   * done} for the stream being shown: weights/extra are Float32Arrays (interpolated between the two
   * frames around t) or null before the first frame; jpeg is the ImageBitmap due now (only when it
   * changed since the last call).
   */
  update() {
    // Move on to the next stream when the current one has been fully presented.
    if (this.current && this.done(this.current)) {
      const later = [...this.streams.values()].filter((o) => o.stream > this.current.stream);
      const next = later.sort((a, b) => a.stream - b.stream)[0];
      if (next) {
        this.current.release();
        this.streams.delete(this.current.stream);
        this.current = next;
      }
    }
    const s = this.current;
    if (!s) return null;
    const t = this.timeOf(s);
    const out = { stream: s, t, weights: null, extra: null, jpeg: null, done: this.done(s) };
    if (t === null) return out;
    if (out.done) out.t = Math.min(t, s.endOf() || s.duration);
    // Presentation time never goes back (a clock hand-over or correction waits instead).
    if (s.lastT > out.t) out.t = s.lastT;
    s.lastT = out.t;
    Object.assign(out, s.weightsAt(out.t));
    out.jpeg = s.jpegAt(out.t);
    if (out.jpeg) this.stats.jpegDrawn += 1;
    return out;
  }
}
