// The "from a photo" page against the real `facecast serve` in headless Chromium: a fake webcam
// (Chromium's file capture) showing astronaut.png (scikit-image, public domain; installed by
// scripts/install-deps.sh) is snapped and its 68 landmarks found and drawn; a photo without a
// face says so in one line and cannot be built; astronaut.png uploaded as a file is built into an
// avatar from the shipped template (progress), previewed textured with jawOpen and a smile, listed,
// and it speaks on the main page.

import { execFileSync } from 'node:child_process';
import { existsSync, mkdtempSync, rmSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { join } from 'node:path';
import { run, startServer, launchBrowser, newPage, screenshot, check, must, waitFor, sleep, log, drawnShare, speaksOnMainPage, SKIP } from './lib.mjs';

const astronaut = ['/usr/lib/python3/dist-packages/skimage/data/astronaut.png', '/opt/facecast-testdata/python3-skimage/usr/lib/python3/dist-packages/skimage/data/astronaut.png'].find(existsSync);
if (!astronaut) {
  console.log('astronaut.png is missing (scripts/install-deps.sh installs it)');
  process.exit(process.env.CI === 'true' ? 1 : SKIP);
}

// The webcam's frames (Y4M, which Chromium's fake capture plays in a loop) and a photo without a
// face (ffmpeg's test pattern), made here in a temporary folder.
const scratch = mkdtempSync(join(tmpdir(), 'facecast-photo-'));
process.on('exit', () => rmSync(scratch, { recursive: true, force: true }));
const camera = join(scratch, 'astronaut.y4m');
const noFace = join(scratch, 'pattern.png');
execFileSync('ffmpeg', ['-v', 'error', '-loop', '1', '-i', astronaut, '-frames:v', '3', '-pix_fmt', 'yuv420p', camera]);
execFileSync('ffmpeg', ['-v', 'error', '-f', 'lavfi', '-i', 'testsrc=size=480x360', '-frames:v', '1', noFace]);

// The next landmark answer after `act` (a photo chosen).
const landmarksOf = async (page, act) => {
  const n = await page.evaluate(() => window.__photo.previews);
  await act();
  await waitFor(page, (k) => window.__photo.previews > k, n, { timeout: 60000, what: 'the landmarks' });
  return page.evaluate(() => window.__photo.landmarks);
};

await run('photo', async () => {
  const server = await startServer();
  const browser = await launchBrowser({ args: ['--use-fake-ui-for-media-stream', '--use-fake-device-for-media-stream', `--use-file-for-fake-video-capture=${camera}`] });
  const page = await newPage(browser, { width: 1400, height: 900 });
  await page.goto(`${server.url}/photo.html`);

  // ---- The webcam: snap a photo, its landmarks are found and drawn.
  await page.click('#camera');
  await waitFor(page, () => document.getElementById('video').videoWidth > 0, null, { timeout: 30000, what: 'the webcam' });
  const cam = await landmarksOf(page, () => page.click('#snap'));
  check('the webcam photo: 68 landmarks', cam.points?.length === 68, JSON.stringify(cam.error ?? cam.points?.length));

  // ---- A photo without a face: one line, no build.
  page.allow(/400 \(Bad Request\)/); // the refused preview's console line
  const none = await landmarksOf(page, () => page.setInputFiles('#file', noFace));
  check('a photo without a face says so in one line', /no face found/.test(none.error) && !none.error.includes('\n'), none.error);
  check('and cannot be built', await page.isDisabled('#build'));

  // ---- astronaut.png as a file: landmarks drawn over it.
  const found = await landmarksOf(page, () => page.setInputFiles('#file', astronaut));
  must('68 landmarks on astronaut.png', found.points?.length === 68 && found.width === 512, found.error ?? `${found.points?.length} points, ${found.width} px wide; ${found.note}`);
  const [x, y] = found.points[30];
  const px = await page.evaluate(([a, b]) => window.__photo.photoPixel(a, b), [x, y]);
  check('the landmarks are drawn on the photo', px[1] > 180 && px[0] < 120 && px[2] < 170, `nose tip pixel ${px}`);
  if (found.faces > 1) check('several faces: the page says the largest is used', (await page.textContent('#landmarks-status')).includes('the largest used'), found.note);
  await screenshot(page, 'photo-01-landmarks');

  // ---- Build: the job's progress, then the avatar.
  must('the build button is enabled', await page.isEnabled('#build'));
  await page.fill('#name', 'Astronaut');
  const errorsBefore = await page.evaluate(() => window.__photo.errors.length);
  const t0 = Date.now();
  await page.click('#build');
  const stages = new Set();
  while (!(await page.evaluate((n) => window.__photo.resultReady || window.__photo.job?.state === 'failed' || window.__photo.errors.length > n, errorsBefore))) {
    const j = await page.evaluate(() => window.__photo.job);
    if (j?.state === 'running' && j.stage) stages.add(j.stage);
    if (Date.now() - t0 > 600000) must('the build ends within 10 minutes', false);
    await sleep(150);
  }
  const job = await page.evaluate(() => window.__photo.job);
  must('the photo job is done', job?.state === 'done', JSON.stringify(job?.error ?? job?.state));
  log(`built in ${((Date.now() - t0) / 1000).toFixed(1)} s; stages seen: ${[...stages].join(', ')}`);
  check('the progress shows the build stages', stages.size >= 2, [...stages].join(', '));
  const result = await page.evaluate(() => window.__photo.result);
  check('the avatar has the template expressions and visemes', result.shapes.includes('jawOpen') && result.shapes.includes('viseme_aa') && result.shapes.length === 74, `${result.shapes.length} shapes`);
  check('no identity modes among its shapes', !result.shapes.some((n) => n.startsWith('identity')));
  check('the avatar is textured from the photo', await page.evaluate(() => window.__photo.textured()));
  const listed = await page.evaluate(async (id) => (await (await fetch('/api/rigs')).json()).rigs.some((r) => r.id === id && r.name === 'Astronaut'), result.rig);
  check('the avatar is listed among the rigs', listed);

  // ---- Preview: jawOpen and a smile drive it.
  for (const name of ['jawOpen', 'mouthSmileLeft', 'mouthSmileRight']) {
    await page.locator(`#shapes input[data-shape="${name}"]`).fill(name === 'jawOpen' ? '0.6' : '1');
    await sleep(150);
  }
  const w = await page.evaluate(() => window.__photo.influence('mouthSmileLeft'));
  check('the smile slider drives its morph target', Math.abs(w - 1) < 1e-6, String(w));
  await sleep(300);
  const share = await drawnShare(page, '#view-result canvas');
  check('the avatar is drawn', share > 0.05, `${(share * 100).toFixed(1)}% of its view`);
  await screenshot(page, 'photo-02-result');
  check('no console errors on the photo page', page.problems.length === 0, page.problems.slice(0, 5).join(' | '));

  // ---- It speaks on the main page.
  await speaksOnMainPage(browser, server, result.rig, 'Hello, I am an astronaut.', 'photo-03-speaking');
});
