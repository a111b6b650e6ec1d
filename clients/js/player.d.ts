// Types of player.js: the browser stream player (Web Audio clock).

import type { FacecastClient } from './client.js';
import type { MediaItem, StreamEnd, StreamStart } from './protocol.js';

/** One stream as the player keeps it. */
export interface PlayerStream {
  id: string;
  stream: number;
  output: 'weights' | 'frames';
  fps: number;
  names: string[];
  extra: string[];
  audio: StreamStart['audio'];
  utterance: Record<string, unknown> | null;
  duration: number;
  /** [time, jawOpen] of every frame received */
  jawCurve: Array<[number, number]>;
  /** the clock it runs on once started */
  clock: 'audio' | 'perf' | null;
  /** clock time of utterance time 0 */
  t0: number;
  ended: boolean;
  cancelled: boolean;
  endInfo: StreamEnd | null;
  /** the last presented utterance time */
  lastT: number;
  [field: string]: unknown;
}

export interface Presentation {
  stream: PlayerStream;
  /** utterance time now (s), null before the stream's clock starts */
  t: number | null;
  /** interpolated weights for stream.names, null before the first frame */
  weights: Float32Array | null;
  /** interpolated extra values (stream.extra: headYaw, headPitch, headRoll, breath, lean, shrug) */
  extra: Float32Array | null;
  /** the JPEG frame due now, when it changed */
  jpeg: ImageBitmap | null;
  /** the stream has ended and everything was presented */
  done: boolean;
}

export declare class StreamPlayer {
  constructor(options?: { audioContext?: AudioContext | null });
  readonly ctx: AudioContext | null;
  readonly muted: boolean;
  readonly audioRunning: boolean;
  streams: Map<number, PlayerStream>;
  current: PlayerStream | null;
  stats: { audioChunks: number; audioLate: number; weightFrames: number; jpegFrames: number; jpegDrawn: number; bad: number };
  /** creates or resumes the AudioContext: call it from a user gesture */
  unlockAudio(): AudioContext | null;
  setMuted(muted: boolean): void;
  /** the audio clock (s) */
  audioNow(): number;
  clockNow(kind: 'audio' | 'perf'): number;
  /** listens to a client's streams and media; returns a function that detaches it */
  attach(client: FacecastClient): () => void;
  start(msg: StreamStart): PlayerStream;
  end(msg: StreamEnd): PlayerStream | null;
  media(item: MediaItem): void;
  stopAll(): void;
  /** ends now the streams sent to the end that still play or wait here (not a cancel's return to rest); returns how many */
  stopSent(): number;
  /** after a cancel: stops utterance `id`'s audio, its frames go on from the newest received (the server's return to rest follows); where the cancel came too late, it ends when its end arrives */
  silence(id: string): void;
  /** the utterance time of a stream now, on its playback clock */
  timeOf(stream: PlayerStream | null): number | null;
  done(stream: PlayerStream): boolean;
  /** advances presentation: call it every animation frame */
  update(): Presentation | null;
}
