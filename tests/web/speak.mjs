// The speak page against the real `facecast serve` in headless Chromium:
// a mixed Chinese/English sentence with a tag moves the mouth morphs over time and returns them to
// rest, the audio clock advances, the timeline draws the utterance, Stop cancels, frames mode draws
// server JPEGs on the canvas, a bad tag shows its error with the offset, the connection state follows
// the server going away and coming back, and the page logs no console errors.

import { run, startServer, launchBrowser, newPage, screenshot, check, must, waitFor, sleep, log, readJson, drawnShare } from './lib.mjs';

const SENTENCE = '大家好，我是 Facecast。(joy, 40, 0.5)Nice to meet you, 很高兴认识你！';

async function canvasHash(page, selector) {
  return page.evaluate((sel) => {
    const c = document.querySelector(sel);
    if (!c.width || !c.height) return null;
    const g = c.getContext('2d');
    const d = g.getImageData(0, 0, c.width, c.height).data;
    let h = 2166136261;
    for (let i = 0; i < d.length; i += 4 * 7) h = Math.imul(h ^ (d[i] + 3 * d[i + 1] + 7 * d[i + 2]), 16777619) >>> 0;
    return h;
  }, selector);
}

await run('speak', async () => {
  const server = await startServer();
  const browser = await launchBrowser();
  const page = await newPage(browser);

  // ---- The page loads, connects and shows the default avatar.
  await page.goto(`${server.url}/`);
  await waitFor(page, () => window.__facecast?.ready && window.__facecast.connection === 'open', null, {
    timeout: 90000,
    what: 'the avatar to load and the socket to open',
  });
  const info = await page.evaluate(() => ({ names: window.__facecast.morphNames, hello: window.__facecast.hello, expressions: window.__facecast.expressions }));
  must('the rig has mouth morph targets', info.names.includes('jawOpen'), `${info.names.length} morph targets`);
  check('hello names the protocol', info.hello?.protocol === 'facecast.v1', JSON.stringify(info.hello?.protocol));
  const configured = readJson('configs/viseme/expressions.json').expressions;
  check('the tag buttons are the configured expressions', JSON.stringify(info.expressions) === JSON.stringify(configured), info.expressions.join(','));
  check('connection state shows connected', (await page.textContent('#conn-text')).startsWith('Connected'));
  await sleep(700); // the full-resolution frame once still
  const share = await drawnShare(page, '#view3d');
  check('the 3D view draws the avatar (WebGL works)', share > 0.15, `${(share * 100).toFixed(1)}% of the view`);
  await screenshot(page, 'speak-01-loaded');

  // ---- The tag buttons insert a tag at the cursor.
  await page.fill('#text', 'Hello 你好');
  await page.evaluate(() => document.getElementById('text').setSelectionRange(6, 6));
  await page.click('#tag-buttons [data-expression="surprise"]');
  const withTag = await page.inputValue('#text');
  check('a tag button inserts (surprise, 40, 0.5) at the cursor', withTag === 'Hello (surprise, 40, 0.5)你好', withTag);

  // ---- Speak a mixed sentence with a tag.
  await page.fill('#text', SENTENCE);
  const audioBefore = await page.evaluate(() => window.__facecast.audioTime());
  const wall0 = Date.now();
  await page.click('#speak');
  await waitFor(page, () => window.__facecast.utterances.some((u) => u.state === 'playing' || u.state === 'done'), null, {
    timeout: 30000,
    what: 'stream_start',
  });
  let shot = false;
  const samples = [];
  const t0 = Date.now();
  // Sample until the stream has ended and the face has had time to settle.
  while (Date.now() - t0 < 40000) {
    const s = await page.evaluate(() => {
      const f = window.__facecast;
      const h = f.headRotation();
      return { jaw: f.influence('jawOpen'), mouth: f.mouth(), audio: f.audioTime(), t: f.utteranceTime, state: f.lastUtterance?.state, head: Math.max(Math.abs(h.x), Math.abs(h.y), Math.abs(h.z)) };
    });
    samples.push(s);
    if (!shot && s.mouth > 0.15) {
      await screenshot(page, 'speak-02-speaking');
      shot = true;
    }
    if (s.state === 'done' || s.state === 'error' || s.state === 'cancelled') {
      if (!samples.doneAt) samples.doneAt = Date.now();
      if (Date.now() - samples.doneAt > 1500) break;
    }
    await sleep(50);
  }
  const u1 = await page.evaluate(() => window.__facecast.lastUtterance);
  must('the utterance played to the end', u1.state === 'done', JSON.stringify(u1));
  const mouths = samples.map((s) => s.mouth);
  log(`mouth over time: ${mouths.map((m) => m.toFixed(2)).join(' ')}`);
  const peak = Math.max(...mouths);
  const distinct = new Set(mouths.map((m) => m.toFixed(3))).size;
  check('mouth shapes open while speaking', peak > 0.15, `peak ${peak.toFixed(3)}`);
  check('mouth influences change over time', distinct >= 8, `${distinct} distinct values in ${samples.length} samples`);
  // Opening and closing, on every frame the page showed: openings above half the peak separated by
  // dips below a quarter of it.
  const shown = await page.evaluate(() => window.__facecast.history);
  const render = await page.evaluate(() => window.__facecast.renderInfo);
  const shownPeak = Math.max(...shown.map(([, m]) => m));
  let swings = 0;
  let high = false;
  for (const [, m] of shown) {
    if (!high && m > 0.5 * shownPeak) {
      high = true;
      swings += 1;
    } else if (high && m < 0.25 * shownPeak) high = false;
  }
  const span = shown.length ? shown[shown.length - 1][0] - shown[0][0] : 0;
  log(`${shown.length} frames shown over ${span.toFixed(2)} s (${(shown.length / Math.max(span, 1e-3)).toFixed(1)} fps), pixel ratio in motion ${render.motionPixelRatio}`);
  check('the mouth opens, closes and opens again (syllables)', swings >= 2, `${swings} openings in ${shown.length} shown frames`);
  const headPeak = Math.max(...samples.map((s) => s.head));
  check('the head moves with the streamed headYaw/headPitch/headRoll', headPeak > 1e-3, `peak ${headPeak.toFixed(4)} rad`);
  const rest = await page.evaluate(() => window.__facecast.mouth());
  check('mouth shapes return to rest after the utterance', rest < 0.02, `mouth ${rest.toFixed(4)} at the end`);
  const audioAfter = samples[samples.length - 1].audio;
  const wall = (Date.now() - wall0) / 1000;
  check('audio time advances', audioAfter - (audioBefore ?? 0) > Math.min(1.5, 0.5 * (u1.duration || 2)), `AudioContext ${audioBefore} -> ${audioAfter?.toFixed(2)} s over ${wall.toFixed(1)} s`);
  const ts = samples.map((s) => s.t).filter((t) => t !== null);
  const monotonic = ts.every((t, i) => i === 0 || t >= ts[i - 1] - 1e-6);
  if (!monotonic) log(`utterance time: ${ts.map((t) => t.toFixed(3)).join(' ')}`);
  check('utterance time runs forward to the end', monotonic && ts[ts.length - 1] >= 0.9 * (u1.duration || 1), `last ${ts[ts.length - 1]?.toFixed(2)} of ${u1.duration?.toFixed(2)} s`);
  check('the frames ran on the audio clock', (await page.evaluate(() => window.__facecast.clock)) === 'audio');
  const stats = await page.evaluate(() => window.__facecast.stats);
  check('audio chunks and weight frames arrived', stats.audioChunks > 0 && stats.weightFrames > 30, JSON.stringify(stats));

  // ---- The timeline drew this utterance.
  const tl = await page.evaluate(() => window.__facecast.timeline);
  check('the timeline shows the utterance', tl.id === u1.id && tl.visemes >= 10 && tl.words >= 3, JSON.stringify(tl));
  check('the timeline shows the expression tag', tl.expressions >= 1);
  check('the timeline playhead moved to the end', tl.playhead !== null && tl.playhead >= 0.9 * (u1.duration || 1), `${tl.playhead}`);
  const tlPixels = await page.evaluate(() => {
    const c = document.getElementById('timeline');
    const d = c.getContext('2d').getImageData(0, 0, c.width, c.height).data;
    let colorful = 0;
    for (let i = 0; i < d.length; i += 4) if (Math.max(d[i], d[i + 1], d[i + 2]) - Math.min(d[i], d[i + 1], d[i + 2]) > 60) colorful += 1;
    return colorful / (d.length / 4);
  });
  check('the timeline canvas has coloured viseme and expression blocks', tlPixels > 0.05, `${(tlPixels * 100).toFixed(1)}% coloured pixels`);
  await screenshot(page, 'speak-03-done');

  // ---- Without audio the frames run on performance.now().
  await page.uncheck('#audio');
  await page.fill('#text', '(smile, 40, 0.2)Hello, 你好！');
  await page.click('#speak');
  await waitFor(page, () => window.__facecast.lastUtterance?.state === 'playing', null, { timeout: 30000, what: 'the silent utterance' });
  const silentPeak = await page
    .waitForFunction(() => window.__facecast.mouth() > 0.08 && window.__facecast.mouth(), null, { timeout: 15000, polling: 30 })
    .then((h) => h.jsonValue())
    .catch(() => 0);
  check('without audio the mouth moves on the performance clock', silentPeak > 0.08 && (await page.evaluate(() => window.__facecast.clock)) === 'perf', `peak ${Number(silentPeak).toFixed(3)}`);
  await waitFor(page, () => window.__facecast.lastUtterance?.state === 'done', null, { timeout: 30000, what: 'the silent utterance to end' });
  await page.check('#audio');

  // ---- Two utterances in a row queue and play in order.
  await page.fill('#text', '第一句。');
  await page.click('#speak');
  await page.fill('#text', 'The second one.');
  await page.click('#speak');
  const pair = await page.evaluate(() => window.__facecast.utterances.slice(-2).map((u) => u.id));
  await waitFor(page, (ids) => ids.every((id) => window.__facecast.utterances.find((u) => u.id === id)?.state === 'done'), pair, {
    timeout: 40000,
    what: 'both queued utterances to finish',
  });
  const order = await page.evaluate((ids) => {
    const ev = window.__facecast.log.filter((e) => (e.stream_start || e.stream_end) && ids.includes((e.stream_start || e.stream_end).id));
    return ev.map((e) => (e.stream_start ? `start:${e.stream_start.id}` : `end:${e.stream_end.id}`));
  }, pair);
  check('queued utterances play one after the other', order.join(' ') === `start:${pair[0]} end:${pair[0]} start:${pair[1]} end:${pair[1]}`, order.join(' '));
  const tl2 = await page.evaluate(() => window.__facecast.timeline);
  check('the timeline moves on to the second utterance', tl2.id === pair[1], JSON.stringify(tl2.id));

  // ---- Stop cancels a playing utterance; the face returns to rest.
  await page.fill('#text', 'This is a long sentence that the stop button interrupts before it ends, 这句话很长，会被打断。');
  await page.click('#speak');
  await waitFor(page, () => window.__facecast.lastUtterance?.state === 'playing' && window.__facecast.mouth() > 0.05, null, {
    timeout: 30000,
    what: 'the second utterance to play',
  });
  await sleep(600);
  await page.click('#stop');
  const stopped = await waitFor(page, () => {
    const u = window.__facecast.lastUtterance;
    return u.state === 'cancelled' || u.state === 'done' ? u.state : null;
  }, null, { timeout: 10000, what: 'stream_end after cancel' });
  check('Stop cancels the utterance (stream_end cancelled)', stopped === 'cancelled', stopped);
  const restAfterStop = await page
    .waitForFunction(() => window.__facecast.mouth() < 0.02, null, { timeout: 5000, polling: 50 })
    .then(() => page.evaluate(() => window.__facecast.mouth()))
    .catch(() => page.evaluate(() => window.__facecast.mouth()));
  check('the face returns to rest after Stop', restAfterStop < 0.02, restAfterStop.toFixed(4));

  // ---- A bad tag shows the server's error with its offset.
  const bad = 'Hello 你好 (happy, 40, 0.5) world';
  await page.fill('#text', bad);
  await page.click('#speak');
  const errText = await waitFor(page, () => window.__facecast.textError, null, { timeout: 15000, what: 'the tag error' });
  const m = /(?:offset|character) (\d+)/.exec(errText);
  const tagStart = [...bad].indexOf('(');
  check('the error names the unknown expression', /happy/.test(errText), errText);
  check('the error gives the character offset of the tag', !!m && Number(m[1]) >= tagStart && Number(m[1]) <= tagStart + 6, `offset ${m?.[1]}, tag at ${tagStart}`);
  const marked = await page.textContent('#text-error mark');
  check('the offending part of the text is marked', !!marked && bad.includes(marked.trim()) && /\(|happy|h/.test(marked), JSON.stringify(marked));
  const alertShown = await page.locator('.alert[data-code="invalid_input"]').count();
  check('an error alert with the code is shown', alertShown > 0);
  await screenshot(page, 'speak-04-bad-tag');

  // ---- Frames mode: server-rendered JPEGs drawn on the canvas at their pts.
  await page.check('input[name="output"][value="frames"]');
  // Long enough (about 4 s) that a loaded machine, whose frames arrive late and in bursts and so
  // are skipped to the one due, still draws several: the check is that the path works, not its rate.
  await page.fill('#text', '(smile, 50, 0.3)你好, hello! The server renders my face, frame by frame, and sends each one.');
  await page.click('#speak');
  await waitFor(page, () => (window.__facecast.framesDrawn || 0) > 0, null, { timeout: 30000, what: 'the first JPEG frame' });
  const hashes = new Set();
  let frameShot = false;
  const f0 = Date.now();
  while (Date.now() - f0 < 20000) {
    hashes.add(await canvasHash(page, '#frames'));
    const st = await page.evaluate(() => window.__facecast.lastUtterance?.state);
    if (!frameShot && hashes.size >= 3) {
      await screenshot(page, 'speak-05-frames');
      frameShot = true;
    }
    if (st !== 'playing' && st !== 'sent') break;
    await sleep(80);
  }
  const fstats = await page.evaluate(() => ({ drawn: window.__facecast.framesDrawn, stats: window.__facecast.stats, visible: !document.getElementById('frames').classList.contains('hidden') }));
  check('frames mode shows the frames canvas', fstats.visible);
  check('frames mode draws JPEG frames', fstats.drawn >= 5 && fstats.stats.jpegFrames >= 5, JSON.stringify(fstats));
  check('the frames canvas changes over time', hashes.size >= 3, `${hashes.size} distinct canvas images`);
  if (!frameShot) await screenshot(page, 'speak-05-frames');
  await page.check('input[name="output"][value="weights"]');

  // ---- Rate limit: a burst of speaks past the server's allowance shows a rate-limit message.
  const limits = await page.evaluate(() => window.__facecast.hello?.limits);
  await page.fill('#text', 'Hi.');
  const burst = 25;
  for (let i = 0; i < burst; i++) await page.click('#speak');
  const limited = await page
    .waitForFunction(() => document.querySelector('.alert[data-code="rate_limited"], .alert[data-code="limit"]')?.textContent, null, { timeout: 10000, polling: 50 })
    .then((h) => h.jsonValue())
    .catch(() => null);
  check('a burst of speaks shows the rate-limit message', !!limited, `${limited} (limits ${JSON.stringify(limits)})`);
  await screenshot(page, 'speak-06-rate-limited');
  await page.click('#stop');
  await waitFor(page, () => !window.__facecast.utterances.some((u) => u.state === 'sent' || u.state === 'playing'), null, {
    timeout: 30000,
    what: 'every queued utterance to be cancelled',
  });
  check('Stop cancels every queued utterance', true);
  const restAfterBurst = await page
    .waitForFunction(() => window.__facecast.mouth() < 0.02, null, { timeout: 5000, polling: 50 })
    .then(() => page.evaluate(() => window.__facecast.mouth()))
    .catch(() => page.evaluate(() => window.__facecast.mouth()));
  // ... and stays there: what the server had finished sending (queued here behind a busy page)
  // stops with the rest (it once played on after the face had closed between two utterances).
  let loudest = restAfterBurst;
  for (let i = 0; i < 20 && loudest < 0.02; i++) {
    await sleep(50);
    loudest = Math.max(loudest, await page.evaluate(() => window.__facecast.mouth()));
  }
  const playerState = loudest < 0.02 ? '' : ` ${JSON.stringify(await page.evaluate(() => window.__facecast.player))}`;
  check('the face is at rest after stopping the queue, and stays there for a second', loudest < 0.02, `${restAfterBurst.toFixed(4)}, then at most ${loudest.toFixed(4)}${playerState}`);

  // ---- No console errors while the server was up.
  check('no console errors', page.problems.length === 0, page.problems.slice(0, 5).join(' | '));

  // ---- The server goes away: the page says so, then reconnects when it is back.
  page.allow(/WebSocket connection to .* failed|ERR_CONNECTION_REFUSED|Failed to load resource/);
  const port = server.port;
  await server.stop();
  await waitFor(page, () => window.__facecast.connection === 'reconnecting' && document.querySelector('.alert[data-code="connection"]'), null, {
    timeout: 15000,
    what: 'the page to notice the server is gone',
  });
  check('the page shows that the server is unreachable', /unreachable/i.test(await page.textContent('#conn-text')), await page.textContent('#conn-text'));
  await screenshot(page, 'speak-07-server-down');
  const again = await startServer({ port, data: server.data });
  await waitFor(page, () => window.__facecast.connection === 'open', null, { timeout: 20000, what: 'the page to reconnect' });
  check('the page reconnects when the server is back', true, again.url);
  check('the connection alert is gone after reconnecting', (await page.locator('.alert[data-code="connection"]').count()) === 0);
  log(`problems while the server was down (allowed): ${page.problems.length}`);
  check('no unexpected console errors overall', page.problems.length === 0, page.problems.slice(0, 5).join(' | '));
});
