// The rig builder's one-click path against the real `facecast serve` in headless Chromium: with the
// shipped ICT FaceKit template chosen, a head of another topology (the MediaPipe canonical face,
// ../shared/data) is uploaded; the server finds its facial landmarks (POST /api/landmarks), the page
// shows them as marker pairs on both meshes with the views picture; one marker is dragged to another
// vertex; the build uses those markers; every shape gets a slider and drives the result; it speaks.

import { existsSync } from 'node:fs';
import { join } from 'node:path';
import { run, sourceDir, startServer, launchBrowser, newPage, screenshot, check, must, waitFor, sleep, log, drawnShare, speaksOnMainPage, SKIP } from './lib.mjs';

const data = process.env.FACECAST_SHARED_DATA || join(sourceDir, '..', 'shared', 'data');
const head = join(data, 'mediapipe', 'canonical_face_model.obj');
if (!existsSync(head)) {
  console.log(`${head} is missing`);
  process.exit(process.env.CI === 'true' ? 1 : SKIP);
}

await run('rig_landmarks', async () => {
  const server = await startServer();
  const browser = await launchBrowser();
  const page = await newPage(browser, { width: 1400, height: 900 });
  await page.goto(`${server.url}/rig.html`);
  await waitFor(page, () => window.__rig?.templateReady, null, { timeout: 90000, what: 'the default template' });
  await page.selectOption('#template', 'ict-facekit');
  await waitFor(page, () => window.__rig.templateReady && window.__rig.vertexCounts().template > 20000, null, {
    timeout: 120000,
    what: 'the shipped ICT FaceKit template (meshopt-compressed GLB)',
  });

  // ---- Upload: the landmarks are found on the server and become the marker pairs.
  await page.setInputFiles('#file', head);
  await waitFor(page, () => window.__rig.landmarks || window.__rig.errors.length, null, { timeout: 240000, what: 'the landmarks' });
  const found = await page.evaluate(() => ({ lm: window.__rig.landmarks, pairs: window.__rig.pairs, errors: window.__rig.errors }));
  must('the landmarks are found', found.lm && found.pairs.length >= 30, JSON.stringify(found.errors.length ? found.errors : found.lm));
  check('every pair names the template and the head', found.pairs.every((p) => /^dlib_\d\d$/.test(p.name) && p.template >= 0 && p.target >= 0 && p.target < 468), `${found.pairs.length} pairs`);
  const pictureWidth = await page.evaluate(() => document.getElementById('landmarks-picture').naturalWidth);
  check('the views picture is shown', pictureWidth > 400, `${pictureWidth} px wide`);
  await screenshot(page, 'rig-landmarks-01-found');

  // ---- Drag the nose tip's marker (dlib_30) on the head a little: the pair follows the pointer.
  const i = found.pairs.findIndex((p) => p.name === 'dlib_30');
  must('the nose tip is among the pairs', i >= 0);
  const before = found.pairs[i].target;
  const at = await page.evaluate((v) => window.__rig.screenOf('target', v), before);
  await page.mouse.move(at.x, at.y);
  await page.mouse.down();
  for (let k = 1; k <= 5; k++) await page.mouse.move(at.x + 4 * k, at.y + 5 * k);
  await page.mouse.up();
  await sleep(300);
  const after = await page.evaluate((n) => window.__rig.pairs[n], i);
  check('dragging a marker moves its pair to another vertex', after.name === 'dlib_30' && after.target !== before, `${before} -> ${after.target}`);
  await screenshot(page, 'rig-landmarks-02-dragged');

  // ---- Build with those markers.
  must('the build button is enabled', await page.isEnabled('#build'));
  const t0 = Date.now();
  await page.click('#build');
  await waitFor(page, () => window.__rig.resultReady || window.__rig.job?.state === 'failed' || window.__rig.errors.length, null, { timeout: 400000, what: 'the build' });
  const job = await page.evaluate(() => window.__rig.job);
  must('the build job is done', job?.state === 'done', JSON.stringify(job?.error ?? job?.state));
  log(`built in ${((Date.now() - t0) / 1000).toFixed(1)} s`);
  const result = await page.evaluate(() => window.__rig.result);
  check('the built rig has the template shapes (ARKit names and visemes)', result.shapes === 74, JSON.stringify(result));

  // ---- Preview every shape: a slider each; jawOpen and a viseme drive the result.
  check('a slider per shape', (await page.locator('#shapes input[type="range"]').count()) === 74);
  for (const name of ['jawOpen', 'viseme_aa', 'eyeBlinkLeft']) {
    await page.locator(`#shapes input[data-shape="${name}"]`).fill('1');
    await sleep(200);
    const w = await page.evaluate((n) => window.__rig.influence(n), name);
    check(`the ${name} slider drives its morph target`, Math.abs(w - 1) < 1e-6, String(w));
  }
  const share = await drawnShare(page, '#view-result canvas');
  check('the built rig is drawn', share > 0.05, `${(share * 100).toFixed(1)}% of its view`);
  await screenshot(page, 'rig-landmarks-03-result');
  check('no console errors on the rig builder', page.problems.length === 0, page.problems.slice(0, 5).join(' | '));

  // ---- It speaks on the main page.
  await speaksOnMainPage(browser, server, result.rig, 'Hello there!', 'rig-landmarks-04-speaking');
});
