// The rig builder's shared pieces: the page state, the three views, errors, and window.__rig (the
// page's state for the browser tests, tests/web/rig_builder.mjs; the other modules set its flags).

import { morphMeshes } from '../avatar.js';
import { showAlert } from '../alerts.js';
import { MeshView } from './mesh_view.js';

export const $ = (id) => document.getElementById(id);

export const state = {
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

export const views = {
  template: new MeshView($('view-template')), // onPick: set by rig.js (markers.js pick)
  target: new MeshView($('view-target')),
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
  pick: (side, vertex) => views[side].onPick(vertex),
  /** The largest influence of a shape on the result's primitives. */
  influence(name) {
    const v = state.result ? morphMeshes(state.result.root).map((m) => m.morphTargetInfluences[m.morphTargetDictionary[name]] ?? 0) : [];
    return v.length ? Math.max(...v) : null;
  },
  landmarks: null, // {pairs, views} once the server found them (landmarks.js)
  /** For tests: the client position of a vertex in a view. */
  screenOf: (side, vertex) => views[side].screenOf(vertex),
  vertexCounts: () => ({ template: views.template.vertexCount || 0, target: views.target.vertexCount || 0 }),
};

export function error(message, code = 'error') {
  window.__rig.errors.push({ code, message });
  showAlert({ level: 'error', code, message });
}

/** Whether the uploaded head has the template's vertex count (then no markers are needed). */
export function sameTopology() {
  return state.target && state.templateVertices && state.target.vertexCount === state.templateVertices;
}
