// Types of protocol.js: facecast.v1 messages and the binary decoder.

export declare const PROTOCOL: 'facecast.v1';
export declare const HEADER_BYTES: 24;
export declare const KIND: Readonly<{ WEIGHTS: 1; AUDIO: 2; JPEG: 3 }>;

/** `code`: the server's error code (not_found, invalid_input, ...) or 'protocol', 'closed', 'timeout', 'unsupported'. */
export declare class FacecastError extends Error {
  constructor(code: string, message: string, options?: { id?: string | null; status?: number | null });
  code: string;
  id: string | null;
  status: number | null;
}

export interface MediaHeader {
  kind: 1 | 2 | 3;
  version: number;
  stream: number;
  first: number;
  count: number;
  pts: number;
}

/** Any JSON message from the server. */
export interface ServerMessage {
  type: string;
  [field: string]: unknown;
}

export interface Hello extends ServerMessage {
  type: 'hello';
  protocol: string;
  server: string;
  rigs: string[];
  default_rig: string;
  lead: number;
  limits: Record<string, number>;
}

export interface StreamStart extends ServerMessage {
  type: 'stream_start';
  id: string;
  stream: number;
  output: 'weights' | 'frames';
  fps: number;
  /** null for an open (incremental) stream */
  frames: number | null;
  duration: number | null;
  names: string[];
  extra: string[];
  audio: { format: string; sample_rate: number; channels: number; samples: number | null } | null;
  rig: string;
  lead: number;
  size: [number, number] | null;
  utterance?: Record<string, unknown>;
  open?: boolean;
}

export interface StreamEnd extends ServerMessage {
  type: 'stream_end';
  id: string;
  /** null: cancelled while queued */
  stream: number | null;
  frames: number;
  dropped: number;
  cancelled: boolean;
}

/** A server `error`, or (code 'protocol', id null) a message the client could not read. */
export interface ErrorMessage extends ServerMessage {
  type: 'error';
  id: string | null;
  code: string;
  message: string;
}

export declare class WeightsFrame {
  constructor(start: StreamStart, index: number, time: number, values: Float32Array);
  readonly type: 'weights';
  id: string;
  stream: number;
  /** frame index in the stream */
  index: number;
  /** seconds from the start of the utterance's audio */
  time: number;
  names: string[];
  extra: string[];
  /** the `names` weights, then the `extra` values */
  values: Float32Array;
  /** the blendshape weights alone (a view of `values`) */
  readonly weights: Float32Array;
  /** a blendshape or extra value by name; undefined when the stream has none */
  get(name: string): number | undefined;
}

export interface AudioChunk {
  type: 'audio';
  id: string;
  stream: number;
  /** index of the first sample in the stream */
  first: number;
  count: number;
  time: number;
  sampleRate: number;
  pcm: Int16Array;
}

export interface JpegFrame {
  type: 'jpeg';
  id: string;
  stream: number;
  index: number;
  time: number;
  jpeg: Uint8Array;
}

export type MediaItem = WeightsFrame | AudioChunk | JpegFrame;
export type BinaryData = ArrayBuffer | ArrayBufferView;

/** Throws FacecastError('protocol') for a short message, an unknown kind or version, a bad pts. */
export declare function parseHeader(data: BinaryData): MediaHeader;
/** The items of one binary message, checked against its stream's stream_start. Throws FacecastError('protocol'). */
export declare function parseMedia(data: BinaryData, streams: Map<number, Pick<StreamStart, 'id' | 'stream' | 'fps' | 'names' | 'extra' | 'audio'>>): MediaItem[];
/** A JSON message with a string `type` (stream_start and stream_end checked). Throws FacecastError('protocol'). */
export declare function parseText(text: string): ServerMessage;
