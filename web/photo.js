// An avatar from a photo: a front photo uploaded or taken with the webcam (getUserMedia), scaled
// to at most MAX_SIDE pixels and sent as a JPEG; its 68 landmarks found on the server
// (POST /api/photo/landmarks) and drawn over it; the build (POST /api/photo, a job followed to its
// end); the result previewed with a slider per shape and linked to the speak page.
// window.__photo is the page's state for the browser test (tests/web/photo.mjs).

import { loadGlb, morphMeshes, targetNames } from './avatar.js';
import { showAlert } from './alerts.js';
import { authHeaders, fetchJson, keepTokenInLinks } from './api.js';
import { postJson, resetSliders, runJob, shapeSliders, wireDropZone } from './rig/controls.js';
import { MeshView } from './rig/mesh_view.js';

const MAX_SIDE = 1280; // the server detects on at most 640 px; more only sharpens the texture
const $ = (id) => document.getElementById(id);

const state = { front: null, side: null, landmarks: null, job: null, polling: null, result: null, stream: null };
const resultView = new MeshView($('view-result'));

window.__photo = {
  get landmarks() {
    return state.landmarks;
  },
  get job() {
    return state.job ? { ...state.job } : null;
  },
  get result() {
    return state.result ? { rig: state.result.rig, url: state.result.url, shapes: state.result.names } : null;
  },
  previews: 0, // landmark answers (found or refused) so far
  resultReady: false,
  errors: [],
  /** Whether the result's skin has a texture (baked from the photo). */
  textured() {
    let found = false;
    state.result?.root.traverse((o) => {
      if (o.isMesh) for (const m of [].concat(o.material)) found ||= !!m.map;
    });
    return found;
  },
  /** The photo canvas's colour at (x, y) of the photo, for the landmark drawing check. */
  photoPixel(x, y) {
    return Array.from($('photo-canvas').getContext('2d').getImageData(Math.round(x), Math.round(y), 1, 1).data);
  },
  /** The largest influence of a shape on the result's primitives. */
  influence(name) {
    const v = state.result ? morphMeshes(state.result.root).map((m) => m.morphTargetInfluences[m.morphTargetDictionary[name]] ?? 0) : [];
    return v.length ? Math.max(...v) : null;
  },
};

function error(message, code = 'error') {
  window.__photo.errors.push({ code, message });
  showAlert({ level: 'error', code, message });
}

async function checkServer() {
  try {
    const h = await fetchJson('/healthz');
    $('conn').dataset.state = 'open';
    $('conn-text').textContent = `Server ${h?.version ? `facecast ${h.version}` : 'ok'}`;
  } catch {
    $('conn').dataset.state = 'reconnecting';
    $('conn-text').textContent = 'Server unreachable — retrying';
  }
}

/** A drawable (image or video frame) as a JPEG data URL of at most MAX_SIDE pixels. */
function toPhoto(source, width, height) {
  const k = Math.min(1, MAX_SIDE / Math.max(width, height));
  const c = document.createElement('canvas');
  c.width = Math.round(width * k);
  c.height = Math.round(height * k);
  c.getContext('2d').drawImage(source, 0, 0, c.width, c.height);
  return { url: c.toDataURL('image/jpeg', 0.92), width: c.width, height: c.height, canvas: c };
}

async function readImage(file) {
  const url = URL.createObjectURL(file);
  try {
    const img = new Image();
    img.src = url;
    await img.decode();
    return toPhoto(img, img.naturalWidth, img.naturalHeight);
  } finally {
    URL.revokeObjectURL(url);
  }
}

/** The photo on the page's canvas with the landmarks (if found) as green dots. */
function drawPhoto() {
  const c = $('photo-canvas');
  const p = state.front;
  if (!p) return;
  c.width = p.width;
  c.height = p.height;
  const g = c.getContext('2d');
  g.drawImage(p.canvas, 0, 0);
  const points = state.landmarks?.points || [];
  const r = Math.max(2, p.width / 250);
  g.fillStyle = '#3ddc84';
  for (const [x, y] of points) {
    g.beginPath();
    g.arc(x, y, r, 0, 2 * Math.PI);
    g.fill();
  }
  $('photo-empty').classList.add('hidden');
}

async function setFront(photo) {
  state.front = photo;
  state.landmarks = null;
  stopCamera();
  drawPhoto();
  $('build').disabled = true;
  $('landmarks-status').textContent = 'Finding the landmarks…';
  try {
    const res = await postJson('/api/photo/landmarks', { photo: photo.url });
    if (state.front !== photo) return; // another photo was chosen meanwhile
    state.landmarks = res;
    window.__photo.previews += 1;
    drawPhoto();
    $('landmarks-status').textContent = `${res.points.length} landmarks found (face ${Math.round(res.box)} px wide)${res.note ? ` — ${res.note}` : ''}.`;
    $('build').disabled = false;
    $('job-status').textContent = 'Ready to build.';
  } catch (e) {
    if (state.front !== photo) return;
    state.landmarks = { error: e.message };
    window.__photo.previews += 1;
    $('landmarks-status').textContent = `${e.message}. Try another photo.`;
    error(e.message, e.code);
  }
}

async function startCamera() {
  try {
    state.stream = await navigator.mediaDevices.getUserMedia({ video: { width: 1280, height: 720, facingMode: 'user' } });
  } catch (e) {
    error(`The webcam is not available: ${e.message}`, 'camera');
    return;
  }
  const video = $('video');
  video.srcObject = state.stream;
  video.classList.remove('hidden');
  $('photo-canvas').classList.add('hidden');
  $('photo-empty').classList.add('hidden');
  $('snap').classList.remove('hidden');
}

function stopCamera() {
  if (!state.stream) return;
  for (const t of state.stream.getTracks()) t.stop();
  state.stream = null;
  $('video').classList.add('hidden');
  $('photo-canvas').classList.remove('hidden');
  $('snap').classList.add('hidden');
}

function snap() {
  const video = $('video');
  if (!video.videoWidth) return error('The webcam has not started yet.', 'camera');
  setFront(toPhoto(video, video.videoWidth, video.videoHeight));
}

async function build() {
  const body = { name: $('name').value.trim() || 'My photo avatar', front: state.front.url };
  if (state.side) body.side = state.side.url;
  const onChange = () => ($('build').disabled = state.job?.state === 'queued' || state.job?.state === 'running');
  await runJob('/api/photo', body, state, { what: 'build', error, onChange, onDone: showResult });
}

async function showResult(result) {
  $('views').classList.add('result');
  $('view-result').classList.remove('hidden');
  $('result-panel').classList.remove('hidden');
  try {
    const gltf = await loadGlb(result.url, authHeaders());
    resultView.resize();
    resultView.setObject(gltf.scene);
    state.result = { rig: result.rig, url: result.url, names: targetNames(gltf.scene), root: gltf.scene };
  } catch (e) {
    error(`Could not load the avatar: ${e.message || e}`, 'result');
    return;
  }
  shapeSliders($('shapes'), state.result.names, setShape);
  $('open-speak').href = `/?rig=${encodeURIComponent(result.rig)}`;
  keepTokenInLinks($('result-panel'));
  const r = result.report || {};
  const parts = [];
  if (typeof r.seconds?.total === 'number') parts.push(`built in ${r.seconds.total.toFixed(1)} s`);
  if (typeof r.texture?.coverage === 'number') parts.push(`${Math.round(r.texture.coverage * 100)} % of the skin seen in the photo`);
  parts.push(...(result.notes || []));
  $('report-summary').textContent = parts.join(' · ');
  window.__photo.resultReady = true;
}

function setShape(name, value) {
  for (const m of morphMeshes(state.result.root)) {
    const k = m.morphTargetDictionary[name];
    if (k !== undefined) m.morphTargetInfluences[k] = value;
  }
  resultView.dirty = true;
}

function init() {
  wireDropZone($('drop'), $('file'), async (f) => {
    try {
      await setFront(await readImage(f));
    } catch (e) {
      error(`${f.name}: not an image this browser can read (${e.message})`, 'photo');
    }
  });
  $('side-file').addEventListener('change', async () => {
    const f = $('side-file').files[0];
    state.side = f ? await readImage(f).catch((e) => error(`${f.name}: ${e.message}`, 'photo')) : null;
  });
  $('camera').addEventListener('click', startCamera);
  $('snap').addEventListener('click', snap);
  $('build').addEventListener('click', build);
  $('shapes-reset').addEventListener('click', () => resetSliders($('shapes'), setShape));
  keepTokenInLinks();
  const loop = () => {
    requestAnimationFrame(loop);
    if (!$('view-result').classList.contains('hidden')) resultView.render();
  };
  requestAnimationFrame(loop);
  checkServer();
  setInterval(checkServer, 10000);
}

init();
