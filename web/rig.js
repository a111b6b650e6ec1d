// The rig builder: upload a neutral head, show it beside the template, pick marker pairs by clicking
// corresponding points (nearest vertex of the picked triangle), choose options, POST /api/rigs,
// follow the job, and preview the built rig with a slider per blendshape and its virtual edges.
//
// window.__rig exposes the page's state for the browser tests.

import * as THREE from 'three';
import { OrbitControls } from 'three/addons/controls/OrbitControls.js';
import { makeRenderer, addStudioLights, loadGlb, morphMeshes, targetNames, restBox, partMaterial, colorizePlainMaterials } from './avatar.js';
import { fetchJson, authHeaders, keepTokenInLinks } from './protocol.js';
import { showAlert } from './alerts.js';

const $ = (id) => document.getElementById(id);

// ---------------------------------------------------------------------------------------------------
// OBJ: vertices in file order (marker indices refer to them), faces fan-triangulated.

export function parseObj(text) {
  const pos = [];
  const idx = [];
  const groups = []; // {start, count, material} over idx, from usemtl
  const lines = text.split('\n');
  for (let ln = 0; ln < lines.length; ln++) {
    const line = lines[ln].trim();
    if (line.startsWith('usemtl')) {
      const last = groups[groups.length - 1];
      if (last) last.count = idx.length - last.start;
      groups.push({ start: idx.length, count: 0, material: line.slice(6).trim() });
    } else if (line.startsWith('v ') || line.startsWith('v\t')) {
      const p = line.split(/\s+/);
      const x = Number(p[1]);
      const y = Number(p[2]);
      const z = Number(p[3]);
      if (![x, y, z].every(Number.isFinite)) throw new Error(`OBJ line ${ln + 1}: bad vertex`);
      pos.push(x, y, z);
    } else if (line.startsWith('f ') || line.startsWith('f\t')) {
      const n = pos.length / 3;
      const f = line
        .split(/\s+/)
        .slice(1)
        .map((t) => {
          const i = parseInt(t, 10);
          return i < 0 ? n + i : i - 1;
        });
      if (f.length < 3 || f.some((i) => !(i >= 0))) throw new Error(`OBJ line ${ln + 1}: bad face`);
      for (let k = 1; k + 1 < f.length; k++) idx.push(f[0], f[k], f[k + 1]);
    }
  }
  if (!pos.length) throw new Error('the OBJ has no vertices');
  const n = pos.length / 3;
  if (idx.some((i) => i >= n)) throw new Error('the OBJ has a face with a vertex index past its vertices');
  const last = groups[groups.length - 1];
  if (last) last.count = idx.length - last.start;
  if (groups.length && groups[0].start > 0) groups.unshift({ start: 0, count: groups[0].start, material: '' });
  return {
    positions: new Float32Array(pos),
    indices: n > 65535 ? new Uint32Array(idx) : new Uint16Array(idx),
    vertexCount: n,
    groups: groups.filter((g) => g.count > 0),
  };
}

function objToObject(parsed) {
  const g = new THREE.BufferGeometry();
  g.setAttribute('position', new THREE.BufferAttribute(parsed.positions, 3));
  g.setIndex(new THREE.BufferAttribute(parsed.indices, 1));
  g.computeVertexNormals();
  let material = partMaterial('');
  if (parsed.groups.length > 1) {
    material = parsed.groups.map((gr, i) => {
      g.addGroup(gr.start, gr.count, i);
      return partMaterial(gr.material);
    });
  }
  const mesh = new THREE.Mesh(g, material);
  mesh.name = 'obj';
  const group = new THREE.Group();
  group.add(mesh);
  return group;
}

function countVertices(root) {
  const attrs = new Set();
  let n = 0;
  root.traverse((o) => {
    if (o.isMesh && !attrs.has(o.geometry.attributes.position)) {
      attrs.add(o.geometry.attributes.position);
      n += o.geometry.attributes.position.count;
    }
  });
  return n;
}

// ---------------------------------------------------------------------------------------------------
// A viewport: its own renderer, orbit camera, lights; click picking; marker spheres.

class MeshView {
  constructor(el, { onPick } = {}) {
    this.el = el;
    this.canvas = el.querySelector('canvas');
    this.pendingEl = el.querySelector('.pending');
    this.renderer = makeRenderer(this.canvas);
    this.scene = new THREE.Scene();
    this.scene.background = new THREE.Color(0x272a33);
    this.camera = new THREE.PerspectiveCamera(25, 1, 0.01, 1000);
    this.controls = new OrbitControls(this.camera, this.canvas);
    this.controls.enableDamping = true;
    this.controls.addEventListener('change', () => (this.dirty = true));
    addStudioLights(this.scene, this.renderer);
    this.root = null;
    this.markers = new THREE.Group();
    this.scene.add(this.markers);
    this.offsets = new Map(); // position attribute -> index offset of its first vertex
    this.radius = 1;
    this.dirty = true;
    this.onPick = onPick;
    const down = { x: 0, y: 0, t: 0 };
    this.canvas.addEventListener('pointerdown', (e) => Object.assign(down, { x: e.clientX, y: e.clientY, t: performance.now() }));
    this.canvas.addEventListener('pointerup', (e) => {
      const moved = Math.hypot(e.clientX - down.x, e.clientY - down.y);
      if (moved < 5 && performance.now() - down.t < 600 && this.onPick) this.pickAt(e.clientX, e.clientY);
    });
    new ResizeObserver(() => this.resize()).observe(el);
    this.resize();
  }

  resize() {
    const w = Math.max(1, this.el.clientWidth);
    const h = Math.max(1, this.el.clientHeight);
    this.renderer.setSize(w, h, false);
    this.camera.aspect = w / h;
    this.camera.updateProjectionMatrix();
    this.dirty = true;
  }

  setObject(root) {
    if (this.root) this.scene.remove(this.root);
    this.root = root;
    this.scene.add(root);
    this.offsets = new Map();
    let off = 0;
    root.traverse((o) => {
      if (o.isMesh && !this.offsets.has(o.geometry.attributes.position)) {
        this.offsets.set(o.geometry.attributes.position, off);
        off += o.geometry.attributes.position.count;
      }
    });
    this.vertexCount = off;
    const box = restBox(root);
    const size = box.getSize(new THREE.Vector3());
    const center = box.getCenter(new THREE.Vector3());
    this.radius = 0.5 * size.length();
    const tan = Math.tan(THREE.MathUtils.degToRad(this.camera.fov / 2));
    const dist = 1.15 * Math.max((0.5 * size.y) / tan, (0.5 * size.x) / (tan * this.camera.aspect)) + 0.5 * size.z;
    this.camera.near = dist / 100;
    this.camera.far = dist * 50;
    this.camera.position.set(center.x, center.y, center.z + dist);
    this.camera.updateProjectionMatrix();
    this.controls.target.copy(center);
    this.controls.update();
    this.clearMarkers();
    this.dirty = true;
  }

  /** The world position of vertex index i (over all position attributes, in traversal order). */
  vertexPosition(i, target = new THREE.Vector3()) {
    let found = null;
    this.root?.traverse((o) => {
      if (found || !o.isMesh) return;
      const attr = o.geometry.attributes.position;
      const off = this.offsets.get(attr);
      if (i >= off && i < off + attr.count) found = o;
    });
    if (!found) return null;
    const off = this.offsets.get(found.geometry.attributes.position);
    found.getVertexPosition(i - off, target);
    return found.localToWorld(target);
  }

  pickAt(clientX, clientY) {
    if (!this.root) return;
    const r = this.canvas.getBoundingClientRect();
    const ndc = new THREE.Vector2(((clientX - r.left) / r.width) * 2 - 1, -((clientY - r.top) / r.height) * 2 + 1);
    const ray = new THREE.Raycaster();
    ray.setFromCamera(ndc, this.camera);
    const hits = ray.intersectObject(this.root, true).filter((h) => h.face && h.object.isMesh);
    if (!hits.length) return;
    const h = hits[0];
    const mesh = h.object;
    const off = this.offsets.get(mesh.geometry.attributes.position) || 0;
    let best = -1;
    let bestD = Infinity;
    const p = new THREE.Vector3();
    for (const v of [h.face.a, h.face.b, h.face.c]) {
      mesh.getVertexPosition(v, p);
      mesh.localToWorld(p);
      const d = p.distanceToSquared(h.point);
      if (d < bestD) {
        bestD = d;
        best = v;
      }
    }
    this.onPick(best + off, h.point);
  }

  clearMarkers() {
    for (const m of [...this.markers.children]) {
      this.markers.remove(m);
      m.geometry.dispose();
      m.material.dispose();
    }
    this.dirty = true;
  }

  addMarker(vertex, color, { pending = false } = {}) {
    const p = this.vertexPosition(vertex);
    if (!p) return;
    const s = new THREE.Mesh(
      new THREE.SphereGeometry(this.radius * (pending ? 0.018 : 0.014), 16, 12),
      new THREE.MeshBasicMaterial({ color, depthTest: false, transparent: true, opacity: pending ? 0.7 : 1 }),
    );
    s.renderOrder = 10;
    s.position.copy(p);
    this.markers.add(s);
    this.dirty = true;
  }

  render() {
    this.controls.update();
    if (!this.dirty) return;
    this.dirty = false;
    this.renderer.render(this.scene, this.camera);
  }
}

// ---------------------------------------------------------------------------------------------------
// Page state.

const state = {
  templateId: 'default',
  templateVertices: 0,
  target: null, // {name, format, data, vertexCount}
  pairs: [], // {name, template, target}
  pending: null, // {side, vertex}
  job: null,
  polling: null,
  result: null, // {rig, url, names, edges}
  rigs: [],
};

const views = {
  template: new MeshView($('view-template'), { onPick: (v) => pick('template', v) }),
  target: new MeshView($('view-target'), { onPick: (v) => pick('target', v) }),
  result: new MeshView($('view-result')),
};

window.__rig = {
  templateReady: false,
  targetReady: false,
  get pairs() {
    return state.pairs.map((p) => ({ ...p }));
  },
  get job() {
    return state.job ? { ...state.job } : null;
  },
  get result() {
    return state.result ? { rig: state.result.rig, url: state.result.url, shapes: state.result.names.length, edges: state.result.edges?.length ?? null } : null;
  },
  resultReady: false,
  edgesShown: false,
  errors: [],
  /** For tests: click the vertex index on one side as if picked with the mouse. */
  pick: (side, vertex) => pick(side, vertex),
  /** The largest influence of a shape on the result's primitives. */
  influence(name) {
    const v = state.result ? morphMeshes(state.result.root).map((m) => m.morphTargetInfluences[m.morphTargetDictionary[name]] ?? 0) : [];
    return v.length ? Math.max(...v) : null;
  },
  vertexCounts: () => ({ template: views.template.vertexCount || 0, target: views.target.vertexCount || 0 }),
};

function error(message, code = 'error') {
  window.__rig.errors.push({ code, message });
  showAlert({ level: 'error', code, message });
}

// ---------------------------------------------------------------------------------------------------
// Server check and template.

async function checkServer() {
  const conn = $('conn');
  try {
    const h = await fetchJson('/healthz');
    conn.dataset.state = 'open';
    $('conn-text').textContent = `Server ${h?.version ? `facecast ${h.version}` : 'ok'}`;
  } catch (e) {
    conn.dataset.state = 'reconnecting';
    $('conn-text').textContent = 'Server unreachable — retrying';
  }
}

async function loadRigList() {
  try {
    const res = await fetchJson('/api/rigs');
    state.rigs = res?.rigs || [];
  } catch (e) {
    error(`Could not list the rigs: ${e.message}`, e.code);
    state.rigs = [{ id: 'default', name: 'Default avatar' }];
  }
  const sel = $('template');
  sel.replaceChildren();
  for (const r of state.rigs) {
    const o = document.createElement('option');
    o.value = r.id;
    o.textContent = `${r.name || r.id}${r.builtin ? ' (built-in)' : ''}`;
    sel.appendChild(o);
  }
  sel.value = state.rigs.find((r) => r.id === state.templateId) ? state.templateId : state.rigs[0]?.id;
}

async function loadTemplate(id) {
  state.templateId = id;
  window.__rig.templateReady = false;
  $('template-info').textContent = 'Loading…';
  try {
    const gltf = await loadGlb(`/api/rigs/${encodeURIComponent(id)}.glb`, authHeaders());
    views.template.setObject(gltf.scene);
    state.templateVertices = views.template.vertexCount;
    const names = targetNames(gltf.scene);
    $('template-info').textContent = `${state.templateVertices.toLocaleString()} vertices · ${names.length} blendshapes`;
    window.__rig.templateReady = true;
    redrawMarkers();
    updateTopologyNote();
  } catch (e) {
    $('template-info').textContent = '';
    error(`Could not load the template '${id}': ${e.message || e}`, 'template');
  }
}

// ---------------------------------------------------------------------------------------------------
// Upload.

async function readFile(file) {
  const name = file.name.toLowerCase();
  $('drop-text').textContent = `Reading ${file.name}…`;
  window.__rig.targetReady = false;
  try {
    let object;
    let mesh;
    if (name.endsWith('.obj')) {
      const text = await file.text();
      const parsed = parseObj(text);
      object = objToObject(parsed);
      mesh = { format: 'obj', data: text };
    } else if (name.endsWith('.glb')) {
      const buf = await file.arrayBuffer();
      const gltf = await loadGlb(buf);
      object = gltf.scene;
      colorizePlainMaterials(object);
      // Show the neutral: no morphs on the target.
      for (const m of morphMeshes(object)) m.morphTargetInfluences.fill(0);
      mesh = { format: 'glb', data: await toBase64(file) };
    } else {
      throw new Error('choose an .obj or .glb file');
    }
    views.target.setObject(object);
    const n = countVertices(object);
    state.target = { name: file.name, ...mesh, vertexCount: n };
    $('target-empty').classList.add('hidden');
    $('drop-text').textContent = file.name;
    if (!$('name').value) $('name').value = file.name.replace(/\.[^.]+$/, '');
    window.__rig.targetReady = true;
    redrawMarkers();
    updateTopologyNote();
  } catch (e) {
    $('drop-text').textContent = 'Drop an OBJ or GLB here, or click to choose one';
    error(`Could not read ${file.name}: ${e.message || e}`, 'upload');
  }
  updateBuild();
}

function toBase64(blob) {
  return new Promise((resolve, reject) => {
    const r = new FileReader();
    r.onload = () => resolve(String(r.result).replace(/^data:[^,]*,/, ''));
    r.onerror = () => reject(r.error);
    r.readAsDataURL(blob);
  });
}

function sameTopology() {
  return state.target && state.templateVertices && state.target.vertexCount === state.templateVertices;
}

function updateTopologyNote() {
  const info = $('mesh-info');
  if (!state.target) {
    info.textContent = '';
    return;
  }
  const n = state.target.vertexCount.toLocaleString();
  info.textContent = sameTopology()
    ? `${n} vertices — the template's topology: no markers needed.`
    : `${n} vertices — another topology: pick marker pairs (at least a dozen spread over the face).`;
  updateBuild();
}

// ---------------------------------------------------------------------------------------------------
// Markers.

function pairColor(i) {
  return new THREE.Color().setHSL(((i * 137.508) % 360) / 360, 0.75, 0.55);
}

function pick(side, vertex) {
  if (side === 'template' && !window.__rig.templateReady) return;
  if (side === 'target' && !window.__rig.targetReady) return;
  const other = side === 'template' ? 'target' : 'template';
  if (state.pending && state.pending.side === other) {
    const p = { name: `p${state.pairs.length + 1}`, template: 0, target: 0 };
    p[side] = vertex;
    p[other] = state.pending.vertex;
    state.pairs.push(p);
    state.pending = null;
  } else {
    state.pending = { side, vertex };
  }
  renderPairs();
}

function renderPairs() {
  const ul = $('pairs');
  ul.replaceChildren();
  state.pairs.forEach((p, i) => {
    const li = document.createElement('li');
    const sw = document.createElement('span');
    sw.className = 'sw';
    sw.style.background = `#${pairColor(i).getHexString()}`;
    const nm = document.createElement('span');
    nm.className = 'nm';
    nm.textContent = `${p.name}  T${p.template} → ${p.target}`;
    nm.title = p.name;
    const del = document.createElement('button');
    del.type = 'button';
    del.textContent = '✕';
    del.title = 'Remove this pair';
    del.setAttribute('aria-label', `Remove ${p.name}`);
    del.addEventListener('click', () => {
      state.pairs.splice(i, 1);
      renderPairs();
    });
    li.append(sw, nm, del);
    ul.appendChild(li);
  });
  for (const side of ['template', 'target']) {
    const el = views[side].pendingEl;
    if (el) el.textContent = state.pending?.side === side ? `vertex ${state.pending.vertex} — now click the same point on the other mesh` : '';
  }
  redrawMarkers();
  updateBuild();
}

function redrawMarkers() {
  for (const side of ['template', 'target']) {
    const v = views[side];
    v.clearMarkers();
    if (!v.root) continue;
    state.pairs.forEach((p, i) => {
      if (p[side] < v.vertexCount) v.addMarker(p[side], pairColor(i));
    });
    if (state.pending?.side === side) v.addMarker(state.pending.vertex, 0xffffff, { pending: true });
  }
}

async function loadMarkers(file) {
  try {
    const j = JSON.parse(await file.text());
    const base = Number(j.index_base || 0);
    if (!Array.isArray(j.pairs)) throw new Error('no "pairs" array');
    const pairs = j.pairs.map((p, i) => {
      const t = Number(p.template) - base;
      const g = Number(p.target) - base;
      if (!Number.isInteger(t) || !Number.isInteger(g) || t < 0 || g < 0) throw new Error(`pair ${i + 1}: template and target must be vertex indices`);
      return { name: String(p.name || `p${i + 1}`), template: t, target: g };
    });
    const tv = views.template.vertexCount || Infinity;
    const gv = views.target.vertexCount || Infinity;
    const out = pairs.filter((p) => p.template >= tv || p.target >= gv);
    if (out.length) showAlert({ level: 'warn', code: 'markers', message: `${out.length} pair(s) point past the meshes' vertices (e.g. ${out[0].name}).` });
    state.pairs = pairs;
    state.pending = null;
    renderPairs();
  } catch (e) {
    error(`Could not read the marker file: ${e.message}`, 'markers');
  }
}

function saveMarkers() {
  const body = JSON.stringify({ template: state.templateId, target: state.target?.name || '', index_base: 0, pairs: state.pairs }, null, 1);
  const a = document.createElement('a');
  a.href = URL.createObjectURL(new Blob([body], { type: 'application/json' }));
  a.download = 'markers.json';
  a.click();
  setTimeout(() => URL.revokeObjectURL(a.href), 1000);
}

// ---------------------------------------------------------------------------------------------------
// Build and job progress.

function updateBuild() {
  const running = state.job && (state.job.state === 'queued' || state.job.state === 'running');
  const ok = !!state.target && window.__rig.templateReady && (sameTopology() || state.pairs.length >= 3);
  $('build').disabled = !ok || running;
  if (!running && state.target && !ok) $('job-status').textContent = 'Another topology needs at least 3 marker pairs (more is better).';
  else if (!running && ok && !state.job) $('job-status').textContent = 'Ready to build.';
}

async function build() {
  const body = {
    name: $('name').value.trim() || 'My head',
    template: state.templateId,
    mesh: { format: state.target.format, data: state.target.data },
    options: { virtual_edges: $('ve').checked ? 'auto' : 'off', lambda: Number($('lambda').value) || 0 },
  };
  if (state.pairs.length) body.markers = { index_base: 0, pairs: state.pairs.map(({ name, template, target }) => ({ name, template, target })) };
  setProgress(0, 'Uploading…');
  $('build').disabled = true;
  try {
    const res = await fetchJson('/api/rigs', { method: 'POST', headers: { 'Content-Type': 'application/json' }, body: JSON.stringify(body) });
    state.job = { id: res.job, state: 'queued', progress: 0 };
    $('job-id').textContent = `job ${res.job}`;
    poll();
  } catch (e) {
    setProgress(0, `The build did not start: ${e.message}`);
    error(`The build did not start: ${e.message}`, e.code);
    state.job = null;
    updateBuild();
  }
}

function setProgress(p, text) {
  $('progress-bar').style.width = `${Math.round(Math.max(0, Math.min(1, p)) * 100)}%`;
  if (text !== undefined) $('job-status').textContent = text;
}

async function poll() {
  clearTimeout(state.polling);
  if (!state.job) return;
  let j;
  try {
    j = await fetchJson(`/api/jobs/${encodeURIComponent(state.job.id)}`);
  } catch (e) {
    $('job-status').textContent = `Lost track of the job (${e.message}); retrying…`;
    state.polling = setTimeout(poll, 1500);
    return;
  }
  state.job = j;
  const pct = Math.round((j.progress || 0) * 100);
  if (j.state === 'queued') setProgress(0, 'Queued…');
  else if (j.state === 'running') setProgress(j.progress || 0, `Building: ${j.stage || '…'} (${pct}%)`);
  else if (j.state === 'failed') {
    setProgress(0, `Failed: ${j.error?.message || j.error || 'unknown error'}`);
    error(`The rig build failed: ${j.error?.message || j.error || 'unknown error'}`, j.error?.code || 'build');
    updateBuild();
    return;
  } else if (j.state === 'done') {
    setProgress(1, `Done: rig ${j.result?.rig}`);
    updateBuild();
    await showResult(j.result);
    return;
  }
  updateBuild();
  state.polling = setTimeout(poll, 400);
}

// ---------------------------------------------------------------------------------------------------
// Result preview.

async function showResult(result) {
  const id = result?.rig;
  if (!id) {
    error('The job finished without a rig id.', 'build');
    return;
  }
  $('views').classList.add('result');
  $('view-result').classList.remove('hidden');
  $('result-panel').classList.remove('hidden');
  try {
    const gltf = await loadGlb(result.url || `/api/rigs/${encodeURIComponent(id)}.glb`, authHeaders());
    const root = gltf.scene;
    colorizePlainMaterials(root);
    views.result.resize();
    views.result.setObject(root);
    const names = targetNames(root);
    state.result = { rig: id, url: result.url, names, root, edges: null, lines: null };
    buildSliders(names);
    $('open-speak').href = `/?rig=${encodeURIComponent(id)}`;
    keepTokenInLinks($('result-panel'));
    $('report').textContent = result.report ? JSON.stringify(result.report, null, 1) : 'no report';
    $('report-summary').textContent = summarize(result.report);
    loadRigList();
  } catch (e) {
    error(`Could not load the built rig: ${e.message || e}`, 'result');
    return;
  }
  try {
    const ve = await fetchJson(`/api/rigs/${encodeURIComponent(id)}/virtual_edges.json`);
    state.result.edges = ve?.edges || [];
    $('ve-info').textContent = `${state.result.edges.length} edges`;
    $('show-ve').disabled = !state.result.edges.length;
  } catch (e) {
    state.result.edges = [];
    $('show-ve').disabled = true;
    $('ve-info').textContent = e.status === 404 ? 'none for this rig' : `unavailable (${e.message})`;
  }
  window.__rig.resultReady = true;
}

/** One line from the build report: time, virtual edges, the shape whose gap changed most. */
function summarize(report) {
  if (!report || typeof report !== 'object') return '';
  const parts = [];
  const total = report.timings_s?.total;
  if (typeof total === 'number') parts.push(`built in ${total.toFixed(1)} s`);
  const ve = report.virtual_edges;
  if (ve && typeof ve.count === 'number') parts.push(ve.mode === 'off' ? 'no virtual edges' : `${ve.count} virtual edges (λ ${ve.lambda})`);
  const shapes = Array.isArray(report.shapes) ? report.shapes : [];
  const worst = shapes.filter((x) => typeof x.gap_change === 'number').sort((a, b) => b.gap_change - a.gap_change)[0];
  if (worst) parts.push(`largest gap change ${worst.gap_change.toFixed(2)} (${worst.name}; neutral gap = 10)`);
  return parts.join(' · ');
}

function buildSliders(names) {
  const box = $('shapes');
  box.replaceChildren();
  for (const name of names) {
    const label = document.createElement('label');
    const span = document.createElement('span');
    span.textContent = name;
    span.title = name;
    const input = document.createElement('input');
    input.type = 'range';
    input.min = '0';
    input.max = '1';
    input.step = '0.01';
    input.value = '0';
    input.dataset.shape = name;
    const out = document.createElement('output');
    out.textContent = '0';
    input.addEventListener('input', () => {
      out.textContent = Number(input.value).toFixed(2);
      setShape(name, Number(input.value));
    });
    label.append(span, input, out);
    box.appendChild(label);
  }
}

function setShape(name, value) {
  if (!state.result) return;
  for (const m of morphMeshes(state.result.root)) {
    const k = m.morphTargetDictionary[name];
    if (k !== undefined) m.morphTargetInfluences[k] = value;
  }
  if (state.result.lines) updateEdgeLines();
  views.result.dirty = true;
}

/** Virtual edges as line segments between the (morphed) target vertices. */
function showEdges(on) {
  const r = state.result;
  if (!r) return;
  window.__rig.edgesShown = false;
  for (const m of morphMeshes(r.root)) {
    for (const mat of [].concat(m.material)) {
      mat.transparent = on;
      mat.opacity = on ? 0.35 : 1;
      mat.depthWrite = !on;
      mat.needsUpdate = true;
    }
  }
  if (r.lines) {
    r.lines.parent.remove(r.lines);
    r.lines.geometry.dispose();
    r.lines = null;
  }
  if (on && r.edges?.length) {
    const mesh = morphMeshes(r.root)[0];
    const g = new THREE.BufferGeometry();
    g.setAttribute('position', new THREE.BufferAttribute(new Float32Array(r.edges.length * 6), 3));
    r.lines = new THREE.LineSegments(g, new THREE.LineBasicMaterial({ color: 0xff8a3d, depthTest: false, transparent: true }));
    r.lines.renderOrder = 5;
    r.lines.frustumCulled = false;
    mesh.add(r.lines);
    updateEdgeLines();
    window.__rig.edgesShown = true;
  }
  views.result.dirty = true;
}

function updateEdgeLines() {
  const r = state.result;
  const mesh = r.lines.parent;
  const attr = r.lines.geometry.attributes.position;
  const p = new THREE.Vector3();
  const n = mesh.geometry.attributes.position.count;
  r.edges.forEach(([a, b], i) => {
    for (const [k, v] of [[0, a], [1, b]]) {
      if (v >= 0 && v < n) mesh.getVertexPosition(v, p);
      else p.set(0, 0, 0);
      attr.setXYZ(2 * i + k, p.x, p.y, p.z);
    }
  });
  attr.needsUpdate = true;
  r.lines.geometry.computeBoundingSphere();
}

// ---------------------------------------------------------------------------------------------------
// Wiring.

function init() {
  const drop = $('drop');
  const file = $('file');
  file.addEventListener('change', () => file.files[0] && readFile(file.files[0]));
  drop.addEventListener('keydown', (e) => (e.key === 'Enter' || e.key === ' ') && file.click());
  drop.addEventListener('dragover', (e) => {
    e.preventDefault();
    drop.classList.add('over');
  });
  drop.addEventListener('dragleave', () => drop.classList.remove('over'));
  drop.addEventListener('drop', (e) => {
    e.preventDefault();
    drop.classList.remove('over');
    if (e.dataTransfer.files[0]) readFile(e.dataTransfer.files[0]);
  });
  const mf = $('marker-file');
  mf.addEventListener('change', () => mf.files[0] && loadMarkers(mf.files[0]));
  $('marker-save').addEventListener('click', saveMarkers);
  $('marker-clear').addEventListener('click', () => {
    state.pairs = [];
    state.pending = null;
    renderPairs();
  });
  $('template').addEventListener('change', () => loadTemplate($('template').value));
  $('build').addEventListener('click', build);
  $('show-ve').addEventListener('change', () => showEdges($('show-ve').checked));
  $('shapes-reset').addEventListener('click', () => {
    for (const input of $('shapes').querySelectorAll('input')) {
      input.value = '0';
      input.nextElementSibling.textContent = '0';
      setShape(input.dataset.shape, 0);
    }
  });
  keepTokenInLinks();
  const loop = () => {
    requestAnimationFrame(loop);
    for (const v of Object.values(views)) if (!v.el.classList.contains('hidden')) v.render();
  };
  requestAnimationFrame(loop);
  checkServer();
  setInterval(checkServer, 10000);
  loadRigList().then(() => loadTemplate($('template').value || 'default'));
}

init();
