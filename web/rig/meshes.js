// The two meshes: the template rig (GLB from the server) and the uploaded head (OBJ or GLB), shown
// side by side, with a note on whether their topologies match.

import { loadGlb, targetNames, morphMeshes, colorizePlainMaterials } from '../avatar.js';
import { authHeaders } from '../api.js';
import { updateBuild } from './build.js';
import { findLandmarks } from './landmarks.js';
import { redrawMarkers } from './markers.js';
import { countVertices, objToObject, parseObj } from './obj.js';
import { $, error, sameTopology, state, views } from './page.js';

export async function loadTemplate(id) {
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
    state.pairs = []; // pairs name the template's vertices: found again for this one
    redrawMarkers();
    updateTopologyNote();
    findLandmarks();
  } catch (e) {
    $('template-info').textContent = '';
    error(`Could not load the template '${id}': ${e.message || e}`, 'template');
  }
}

// ---------------------------------------------------------------------------------------------------
// Upload.

export async function readFile(file) {
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
    } else if (name.endsWith('.glb') || name.endsWith('.vrm')) {
      const buf = await file.arrayBuffer();
      const gltf = await loadGlb(buf);
      object = gltf.scene;
      colorizePlainMaterials(object);
      // Show the neutral: no morphs on the target.
      for (const m of morphMeshes(object)) m.morphTargetInfluences.fill(0);
      mesh = { format: name.endsWith('.vrm') ? 'vrm' : 'glb', data: await toBase64(file) };
    } else {
      throw new Error('choose an .obj, .glb or .vrm file');
    }
    views.target.setObject(object);
    const n = countVertices(object);
    state.target = { name: file.name, ...mesh, vertexCount: n };
    $('target-empty').classList.add('hidden');
    $('drop-text').textContent = file.name;
    if (!$('name').value) $('name').value = file.name.replace(/\.[^.]+$/, '');
    window.__rig.targetReady = true;
    state.pairs = [];
    redrawMarkers();
    updateTopologyNote();
    findLandmarks();
  } catch (e) {
    $('drop-text').textContent = 'Drop an OBJ, GLB or VRM here, or click to choose one';
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

function updateTopologyNote() {
  const info = $('mesh-info');
  if (!state.target) {
    info.textContent = '';
    return;
  }
  const n = state.target.vertexCount.toLocaleString();
  info.textContent = sameTopology()
    ? `${n} vertices — the template's topology: no markers needed.`
    : `${n} vertices — another topology: the facial landmarks are found automatically, or pick marker pairs (at least a dozen spread over the face).`;
  updateBuild();
}

