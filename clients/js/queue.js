// The client's waiting: async iterators (each one a queue of the items that came since it was
// made), collecting an utterance, and requests waiting for their answer.

import { FacecastError } from './protocol.js';

/** Node: a timer that does not keep the process alive. */
export function unref(timer) {
  timer?.unref?.();
  return timer;
}

/**
 * An async iterator fed through a sink added to `sinks` (sink.push(item), sink.finish(error)); it
 * leaves `sinks` when it ends. `timeout` (s, 0: none): next() throws when nothing comes in time.
 */
export function itemQueue(sinks, { timeout = 0, ended = false } = {}) {
  const queue = [];
  let waiter = null;
  let end = ended ? { error: null } : null;
  const done = () => {
    sinks.delete(sink);
    end = { error: null };
    return { value: undefined, done: true };
  };
  const sink = {
    push(item) {
      if (waiter) waiter.settle({ value: item, done: false });
      else queue.push(item);
    },
    finish(error) {
      end = { error };
      waiter?.settle(null, error);
    },
  };
  sinks.add(sink);
  return {
    next() {
      if (queue.length) return Promise.resolve({ value: queue.shift(), done: false });
      if (end) {
        const error = end.error;
        return error ? (done(), Promise.reject(error)) : Promise.resolve(done());
      }
      return new Promise((resolve, reject) => {
        const expire = () => waiter?.settle(null, new FacecastError('timeout', `no message within ${timeout} s`));
        const timer = timeout > 0 ? unref(setTimeout(expire, timeout * 1000)) : null;
        waiter = {
          settle(result, error) {
            clearTimeout(timer);
            waiter = null;
            if (result) resolve(result);
            else if (error) reject((done(), error));
            else resolve(done());
          },
        };
      });
    },
    return() {
      waiter?.settle(null, null);
      return Promise.resolve(done());
    },
    [Symbol.asyncIterator]() {
      return this;
    },
  };
}

/**
 * Reads `items` until the stream_end of utterance `id`: {start, end, frames, audio, images, others}.
 * id 'audio-' collects the next live audio stream (its id is "audio-<stream>").
 */
export async function collect(items, id, url) {
  const result = { start: null, end: null, frames: [], audio: [], images: [], others: [] };
  let stream = null;
  for await (const item of items) {
    if (item.type === 'error') {
      if (item.id === id) throw new FacecastError(item.code, item.message, { id });
    } else if (item.type === 'stream_start' && stream === null && (item.id === id || (id === 'audio-' && item.id.startsWith('audio-')))) {
      id = item.id;
      result.start = item;
      stream = item.stream;
    } else if (item.type === 'stream_end' && item.id === id) {
      result.end = item;
      return result;
    } else if (item.type === 'weights' || item.type === 'audio' || item.type === 'jpeg') {
      if (item.stream === stream) ({ weights: result.frames, audio: result.audio, jpeg: result.images })[item.type].push(item);
    } else {
      result.others.push(item);
    }
  }
  throw new FacecastError('closed', `${url}: closed before the end of utterance ${id}`);
}

/**
 * A request in `waiting` until settle(answer) or settle(null, error) (the client calls it with the
 * item `matches` accepts), or `timeout` s: {promise, settle}.
 */
export function awaitAnswer(waiting, matches, timeout, what) {
  const w = { matches };
  const promise = new Promise((resolve, reject) => {
    w.settle = (answer, error) => {
      clearTimeout(w.timer);
      const i = waiting.indexOf(w);
      if (i >= 0) waiting.splice(i, 1);
      if (error) reject(error);
      else resolve(answer);
    };
  });
  w.timer = unref(setTimeout(() => w.settle(null, new FacecastError('timeout', `${what}: no answer within ${timeout} s`)), timeout * 1000));
  waiting.push(w);
  return { promise, settle: w.settle };
}
