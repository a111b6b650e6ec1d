// Types of client.js: the facecast.v1 client.

import type { AudioChunk, ErrorMessage, Hello, JpegFrame, ServerMessage, StreamEnd, StreamStart, WeightsFrame } from './protocol.js';

export type Item = ServerMessage | WeightsFrame | AudioChunk | JpegFrame;
export type ConnectionState = 'connecting' | 'open' | 'reconnecting' | 'closed';

/** A WebSocket constructor (the browser's, Node's global one, or one of the same shape). */
export type WebSocketConstructor = new (url: string, protocols?: string | string[]) => WebSocket;

export interface ClientOptions {
  /** an API key or viewer token, or a function returning one (read at every connection) */
  key?: string | null | (() => string | null | undefined);
  /** how the key travels; 'auto': the subprotocol list when the key fits one, else a first auth message */
  via?: 'auto' | 'subprotocol' | 'message';
  WebSocket?: WebSocketConstructor;
  /** seconds to wait for hello and for answers (default 30) */
  timeout?: number;
  /** reopen with back-off after a lost connection (default false) */
  reconnect?: boolean;
  /** seconds between pings (default 15; 0: none) */
  pingInterval?: number;
}

export interface SpeakOptions {
  id?: string;
  channel?: string;
  more?: boolean;
  rig?: string;
  fps?: number;
  output?: 'weights' | 'frames';
  audio?: boolean;
  lang?: 'auto' | 'zh' | 'en';
  voice?: string;
  rate?: number;
  idle?: boolean;
  timing?: 'tts' | 'model';
  size?: [number, number];
  timestamps?: { format: string; data: unknown; phoneset?: string; text?: string };
  audio_id?: string;
  vmc?: string;
  [field: string]: unknown;
}

export interface Utterance {
  start: StreamStart | null;
  end: StreamEnd | null;
  frames: WeightsFrame[];
  audio: AudioChunk[];
  images: JpegFrame[];
  /** other messages read meanwhile (segment, presence, ...) */
  others: ServerMessage[];
}

export interface StateDetail {
  state: ConnectionState;
  attempt?: number;
  /** ms until the next attempt */
  delay?: number;
  reason?: string;
  code?: number;
}

export interface ClientEventMap {
  state: CustomEvent<StateDetail>;
  close: CustomEvent<{ code: number; reason: string }>;
  hello: CustomEvent<Hello>;
  stream_start: CustomEvent<StreamStart>;
  stream_end: CustomEvent<StreamEnd>;
  error: CustomEvent<ErrorMessage>;
  weights: CustomEvent<WeightsFrame>;
  audio: CustomEvent<AudioChunk>;
  jpeg: CustomEvent<JpegFrame>;
  /** every item, whatever its type */
  message: CustomEvent<Item>;
  [type: string]: CustomEvent<any>;
}

export declare class FacecastClient extends EventTarget implements AsyncIterable<Item> {
  constructor(url: string, options?: ClientOptions);
  readonly url: string;
  timeout: number;
  reconnect: boolean;
  pingInterval: number;
  /** the last hello from the server */
  hello: Hello | null;
  state: ConnectionState;
  attempt: number;
  /** true once the server's hello came on the current socket */
  readonly connected: boolean;

  addEventListener<K extends keyof ClientEventMap>(type: K, listener: (event: ClientEventMap[K]) => void, options?: boolean | AddEventListenerOptions): void;
  addEventListener(type: string, listener: EventListenerOrEventListenerObject | null, options?: boolean | AddEventListenerOptions): void;

  open(): Promise<Hello>;
  close(code?: number, reason?: string): Promise<void>;
  /** throws FacecastError('closed') when not connected */
  send(message: Record<string, unknown> & { type: string }): void;
  /** returns the utterance's id */
  speak(text?: string, options?: SpeakOptions): string;
  append(id: string, text: string, options?: { channel?: string }): void;
  end(id: string, options?: { channel?: string }): void;
  cancel(id: string, options?: { channel?: string }): void;
  /** one live audio chunk (PCM16 mono); the weights come back as stream "audio-<n>" (collect('audio-')) */
  sendAudio(pcm: Int16Array, sampleRate: number, first: number, options?: { last?: boolean; aligned?: boolean }): void;
  /** more text of the open aligned audio stream, optionally with its time (seconds of the stream) */
  audioText(text: string, options?: { start?: number; end?: number; final?: boolean }): void;
  /** expression tags over the open live audio stream */
  expression(tags: string): void;
  subscribe(channel: string): Promise<ServerMessage & { type: 'subscribed'; channel: string; subscribers: number; playing: string | null }>;
  unsubscribe(channel: string): Promise<ServerMessage & { type: 'unsubscribed'; channel: string }>;
  produce(channel: string, token: string): Promise<ServerMessage & { type: 'producing'; channel: string }>;
  ping(): Promise<ServerMessage & { type: 'pong'; t: number; server_time: number; rtt: number }>;
  /** every item from now on; ends when the client closes */
  messages(options?: { timeout?: number }): AsyncIterableIterator<Item>;
  [Symbol.asyncIterator](): AsyncIterableIterator<Item>;
  /** until the stream_end of `id`; rejects with FacecastError on its error */
  collect(id: string, options?: { timeout?: number }): Promise<Utterance>;
}

export declare function connect(url: string, options?: ClientOptions): Promise<FacecastClient>;
