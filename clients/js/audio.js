// Web Audio output for the player: one AudioContext (made on a user gesture), a gain for muting,
// PCM16 chunks scheduled at a context time, and the audio clock the frames are presented against.

export class AudioOut {
  /** `context`: an AudioContext to play through (default: one made by unlock()). */
  constructor(context = null) {
    this.ctx = null;
    this.gain = null;
    this.muted = false;
    this._now = 0;
    if (context) this._use(context);
  }

  _use(ctx) {
    this.ctx = ctx;
    this.gain = ctx.createGain();
    this.gain.gain.value = this.muted ? 0 : 1;
    this.gain.connect(ctx.destination);
  }

  /** Creates or resumes the AudioContext; call it from a user gesture. Null without Web Audio. */
  unlock() {
    if (!this.ctx) {
      const AC = globalThis.AudioContext || globalThis.webkitAudioContext;
      if (!AC) return null;
      this._use(new AC({ latencyHint: 'interactive' }));
    }
    if (this.ctx.state === 'suspended') this.ctx.resume().catch(() => {});
    return this.ctx;
  }

  setMuted(muted) {
    this.muted = muted;
    if (this.gain) this.gain.gain.value = muted ? 0 : 1;
  }

  get running() {
    return !!this.ctx && this.ctx.state === 'running';
  }

  /** The audio clock (s), corrected by the output timestamp where the browser gives one; never goes back. */
  now() {
    if (!this.ctx) return 0;
    let t = this.ctx.currentTime;
    const ts = this.ctx.getOutputTimestamp ? this.ctx.getOutputTimestamp() : null;
    if (ts && ts.contextTime > 0 && ts.performanceTime > 0) {
      // Never run ahead of what the context has rendered.
      t = Math.min(t, ts.contextTime + (performance.now() - ts.performanceTime) / 1000);
    }
    // The two estimates can disagree by the output latency: the clock never goes back.
    this._now = Math.max(this._now, t);
    return this._now;
  }

  /**
   * Plays PCM16 samples at context time `at`; a late chunk skips what should already have been
   * heard. Returns {source, late} (source null when all of it is past).
   */
  play(pcm, sampleRate, at) {
    const n = pcm.length;
    const buf = this.ctx.createBuffer(1, n, sampleRate);
    const ch = buf.getChannelData(0);
    for (let i = 0; i < n; i++) ch[i] = pcm[i] / 32768;
    const now = this.ctx.currentTime;
    const late = at < now + 0.002;
    const skip = late ? now + 0.002 - at : 0;
    if (skip >= n / sampleRate) return { source: null, late };
    const src = this.ctx.createBufferSource();
    src.buffer = buf;
    src.connect(this.gain);
    if (late) src.start(now + 0.002, skip);
    else src.start(at);
    return { source: src, late };
  }
}

/** Stops audio sources (already stopped ones are fine). */
export function stopSources(sources) {
  for (const src of sources) {
    try {
      src.stop();
    } catch {
      // already stopped
    }
  }
}
