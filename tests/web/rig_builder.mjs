// The rig-builder page against the real `facecast serve` in headless Chromium: a test head made by
// `facecast avatar variant` (the template's topology) is uploaded as GLB and as OBJ and shown beside
// the template; marker pairs are picked by clicking both meshes, removed, and loaded from JSON; the
// build runs through POST /api/rigs and GET /api/jobs/{id} with visible progress; the result is
// previewed with shape sliders and its virtual edges; the new rig then speaks on the main page.

import { execFileSync } from 'node:child_process';
import { mkdtempSync, writeFileSync, rmSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { join } from 'node:path';
import { run, binary, startServer, launchBrowser, newPage, screenshot, check, must, waitFor, sleep, log, drawnShare, speaksOnMainPage } from './lib.mjs';

await run('rig_builder', async () => {
  const work = mkdtempSync(join(tmpdir(), 'facecast-web-rig-'));
  try {
    await body(work);
  } finally {
    rmSync(work, { recursive: true, force: true });
  }
});

async function body(work) {
  // A "user" head with the default avatar's topology, as GLB and as a neutral OBJ.
  const glb = join(work, 'head7.glb');
  execFileSync(binary, ['avatar', 'variant', '--seed', '7', '--out', glb], { stdio: 'inherit' });
  execFileSync(binary, ['rig', 'unpack', glb, '--out', join(work, 'head7')], { stdio: 'inherit' });
  const obj = join(work, 'head7', 'neutral.obj');

  const server = await startServer();
  const browser = await launchBrowser();
  const page = await newPage(browser, { width: 1400, height: 900 });

  await page.goto(`${server.url}/rig.html`);
  await waitFor(page, () => window.__rig?.templateReady, null, { timeout: 90000, what: 'the template to load' });
  check('the server state is shown', /Server/.test(await page.textContent('#conn-text')), await page.textContent('#conn-text'));

  // ---- Upload the GLB: shown beside the template, same vertex count.
  await page.setInputFiles('#file', glb);
  await waitFor(page, () => window.__rig.targetReady, null, { timeout: 90000, what: 'the GLB head to load' });
  let counts = await page.evaluate(() => window.__rig.vertexCounts());
  check('a GLB head loads with the template topology', counts.target === counts.template && counts.target > 1000, JSON.stringify(counts));

  // ---- Upload the OBJ (the neutral the build will use).
  await page.setInputFiles('#file', obj);
  await waitFor(page, () => window.__rig.targetReady && document.getElementById('drop-text').textContent === 'neutral.obj', null, {
    timeout: 90000,
    what: 'the OBJ head to load',
  });
  counts = await page.evaluate(() => window.__rig.vertexCounts());
  check('an OBJ head loads with the template topology', counts.target === counts.template, JSON.stringify(counts));
  check('the page says no markers are needed', /no markers needed/.test(await page.textContent('#mesh-info')), await page.textContent('#mesh-info'));
  await page.fill('#name', 'Seven');

  // ---- Pick a marker pair by clicking the same spot on both meshes (nearest vertex), then remove it.
  const click = async (sel, fx, fy) => {
    const b = await page.locator(sel).boundingBox();
    await page.mouse.click(b.x + b.width * fx, b.y + b.height * fy);
  };
  await click('#view-template canvas', 0.5, 0.5);
  await click('#view-target canvas', 0.5, 0.5);
  await sleep(300);
  let pairs = await page.evaluate(() => window.__rig.pairs);
  check('clicking both meshes makes a marker pair', pairs.length === 1 && pairs[0].template >= 0 && pairs[0].template < counts.template && pairs[0].target >= 0 && pairs[0].target < counts.target, JSON.stringify(pairs));
  await click('#view-template canvas', 0.45, 0.62);
  await click('#view-target canvas', 0.45, 0.62);
  await sleep(300);
  pairs = await page.evaluate(() => window.__rig.pairs);
  check('a second pair', pairs.length === 2, JSON.stringify(pairs));
  await screenshot(page, 'rig-01-markers');
  await page.click('#pairs li:first-child button');
  pairs = await page.evaluate(() => window.__rig.pairs);
  check('removing a pair', pairs.length === 1, JSON.stringify(pairs));

  // ---- Load a marker JSON (the ../shared/data/markers format).
  const markers = join(work, 'markers.json');
  writeFileSync(markers, JSON.stringify({ index_base: 0, pairs: [0, 70, 595, 805, 3675, 5705].map((v, i) => ({ name: `m${i}`, template: v, target: v })) }));
  await page.setInputFiles('#marker-file', markers);
  await waitFor(page, () => window.__rig.pairs.length === 6, null, { timeout: 5000, what: 'the marker file to load' });
  check('a marker JSON loads its pairs', true);
  // Same topology: build without markers (the fast path).
  await page.click('#marker-clear');
  check('clearing the pairs', (await page.evaluate(() => window.__rig.pairs.length)) === 0);

  // ---- Build with virtual edges, follow the job.
  await page.check('#ve');
  await page.fill('#lambda', '4');
  must('the build button is enabled', await page.isEnabled('#build'));
  const t0 = Date.now();
  await page.click('#build');
  const seen = new Set();
  const progress = [];
  let shot = false;
  for (;;) {
    const s = await page.evaluate(() => ({ job: window.__rig.job, ready: window.__rig.resultReady, status: document.getElementById('job-status').textContent, errors: window.__rig.errors }));
    if (s.job) {
      seen.add(s.job.state);
      if (s.job.state === 'running') progress.push(s.job.progress);
      if (!shot && s.job.state === 'running' && s.job.progress > 0) {
        await screenshot(page, 'rig-02-building');
        shot = true;
      }
    }
    if (s.ready || s.job?.state === 'failed' || s.errors.length) {
      log(`job ${s.job?.id}: ${s.job?.state}, stage ${s.job?.stage}, ${s.job?.seconds ?? '?'} s — ${s.status}`);
      break;
    }
    if (Date.now() - t0 > 400000) throw new Error('the build did not finish in 400 s');
    await sleep(200);
  }
  const job = await page.evaluate(() => window.__rig.job);
  const pageErrors = await page.evaluate(() => window.__rig.errors);
  must('the build job is done', job?.state === 'done', JSON.stringify(job?.error ?? job?.state ?? pageErrors));
  log(`built in ${((Date.now() - t0) / 1000).toFixed(1)} s; states seen ${[...seen].join(',')}; ${progress.length} progress readings`);
  check('progress was shown while building', progress.length > 0 || seen.has('queued') || seen.has('running'), `${progress.length} readings, last ${progress[progress.length - 1]}`);
  check('the progress bar is full', (await page.getAttribute('#progress-bar', 'style')).includes('100%'));
  await waitFor(page, () => window.__rig.resultReady, null, { timeout: 60000, what: 'the built rig to load' });
  const result = await page.evaluate(() => window.__rig.result);
  check('the built rig has the template blendshapes', result.shapes === 52, JSON.stringify(result));
  const rigs = await (await fetch(`${server.url}/api/rigs`)).json();
  check('the new rig is listed by GET /api/rigs', rigs.rigs.some((r) => r.id === result.rig), rigs.rigs.map((r) => r.id).join(','));

  // ---- Preview: a slider per blendshape, and the virtual edges.
  check('a slider per blendshape', (await page.locator('#shapes input[type="range"]').count()) === 52);
  await page.locator('#shapes input[data-shape="jawOpen"]').fill('1');
  await page.locator('#shapes input[data-shape="mouthSmileLeft"]').fill('0.7');
  await sleep(300);
  const jaw = await page.evaluate(() => window.__rig.influence('jawOpen'));
  check('the jawOpen slider drives the morph target', Math.abs(jaw - 1) < 1e-6, String(jaw));
  for (const [name, sel] of [['template', '#view-template canvas'], ['uploaded head', '#view-target canvas'], ['built rig', '#view-result canvas']]) {
    const share = await drawnShare(page, sel);
    check(`the ${name} is drawn`, share > 0.08, `${(share * 100).toFixed(1)}% of its view`);
  }
  await screenshot(page, 'rig-03-result');
  const edges = result.edges;
  if (edges > 0) {
    await page.check('#show-ve');
    await waitFor(page, () => window.__rig.edgesShown, null, { timeout: 5000, what: 'the virtual edges' });
    check('the virtual edges are drawn', true, `${edges} edges`);
  } else {
    check('the built rig has virtual edges', false, `edges: ${edges}`);
  }
  await screenshot(page, 'rig-04-virtual-edges');
  check('no console errors on the rig builder', page.problems.length === 0, page.problems.slice(0, 5).join(' | '));

  // ---- The new rig speaks on the main page.
  await speaksOnMainPage(browser, server, result.rig, '你好, hello!', 'rig-05-speaking');
}
