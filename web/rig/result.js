// The built rig: loaded beside the inputs, a slider per blendshape, the report summary, and its
// virtual edges drawn as lines between the (morphed) vertices.

import * as THREE from 'three';
import { loadGlb, targetNames, morphMeshes, colorizePlainMaterials } from '../avatar.js';
import { fetchJson, authHeaders, keepTokenInLinks } from '../api.js';
import { shapeSliders } from './controls.js';
import { $, error, state, views } from './page.js';
import { loadRigList } from './server.js';

export async function showResult(result) {
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
    // A rig without virtual edges (none found, or off) stores none: nothing to fetch.
    const ve = result.report?.virtual_edges?.count === 0 || result.report?.virtual_edges?.mode === 'off' ? { edges: [] } : await fetchJson(`/api/rigs/${encodeURIComponent(id)}/virtual_edges.json`);
    state.result.edges = ve?.edges || [];
    $('ve-info').textContent = state.result.edges.length ? `${state.result.edges.length} edges` : 'none for this rig';
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
  shapeSliders($('shapes'), names, setShape);
}

export function setShape(name, value) {
  if (!state.result) return;
  for (const m of morphMeshes(state.result.root)) {
    const k = m.morphTargetDictionary[name];
    if (k !== undefined) m.morphTargetInfluences[k] = value;
  }
  if (state.result.lines) updateEdgeLines();
  views.result.dirty = true;
}

/** Virtual edges as line segments between the (morphed) target vertices. */
export function showEdges(on) {
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

