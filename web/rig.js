// The rig builder: upload a neutral head, show it beside the template, find its facial landmarks
// on the server (the marker pairs; drag one to fix it), or pick marker pairs by clicking
// corresponding points (nearest vertex of the picked triangle), choose options, POST /api/rigs,
// follow the job, and preview the built rig with a slider per blendshape and its virtual edges.
// The pieces live in rig/: page.js (state, views, window.__rig for the browser tests), obj.js,
// mesh_view.js, server.js, meshes.js (template and upload), landmarks.js, markers.js, build.js, result.js.

import { keepTokenInLinks } from './api.js';
import { build } from './rig/build.js';
import { resetSliders, wireDropZone } from './rig/controls.js';
import { findLandmarks } from './rig/landmarks.js';
import { loadMarkers, moveMarker, pick, renderPairs, saveMarkers } from './rig/markers.js';
import { loadTemplate, readFile } from './rig/meshes.js';
import { $, state, views } from './rig/page.js';
import { setShape, showEdges } from './rig/result.js';
import { checkServer, loadRigList } from './rig/server.js';

function init() {
  views.template.onPick = (v) => pick('template', v);
  views.target.onPick = (v) => pick('target', v);
  views.template.onDrag = (i, v) => moveMarker('template', i, v);
  views.target.onDrag = (i, v) => moveMarker('target', i, v);
  $('landmarks').addEventListener('click', findLandmarks);
  wireDropZone($('drop'), $('file'), readFile);
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
  $('shapes-reset').addEventListener('click', () => resetSliders($('shapes'), setShape));
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
