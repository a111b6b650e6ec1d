// Marker pairs: picking a vertex on one mesh and then on the other, the list, the marker spheres,
// and loading/saving the pairs as JSON (the format of `facecast rig build --markers`).

import * as THREE from 'three';
import { showAlert } from '../alerts.js';
import { updateBuild } from './build.js';
import { $, error, state, views } from './page.js';

function pairColor(i) {
  return new THREE.Color().setHSL(((i * 137.508) % 360) / 360, 0.75, 0.55);
}

export function pick(side, vertex) {
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

export function renderPairs() {
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

/** A marker of pair `i` dragged to `vertex` on one side. */
export function moveMarker(side, i, vertex) {
  if (!state.pairs[i]) return;
  state.pairs[i][side] = vertex;
  renderPairs();
}

export function redrawMarkers() {
  for (const side of ['template', 'target']) {
    const v = views[side];
    v.clearMarkers();
    if (!v.root) continue;
    state.pairs.forEach((p, i) => {
      if (p[side] < v.vertexCount) v.addMarker(p[side], pairColor(i), { pair: i });
    });
    if (state.pending?.side === side) v.addMarker(state.pending.vertex, 0xffffff, { pending: true });
  }
}

export async function loadMarkers(file) {
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

export function saveMarkers() {
  const body = JSON.stringify({ template: state.templateId, target: state.target?.name || '', index_base: 0, pairs: state.pairs }, null, 1);
  const a = document.createElement('a');
  a.href = URL.createObjectURL(new Blob([body], { type: 'application/json' }));
  a.download = 'markers.json';
  a.click();
  setTimeout(() => URL.revokeObjectURL(a.href), 1000);
}

