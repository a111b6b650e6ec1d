// Automatic landmarks: POST /api/landmarks with the uploaded head finds the 68 facial landmarks on
// rendered views of it (the server's dlib), paired with the template's: they become the marker
// pairs (shown on both meshes; drag one on the head to fix it) and the views picture is shown.

import { fetchJson } from '../api.js';
import { renderPairs } from './markers.js';
import { $, error, sameTopology, state } from './page.js';

export async function findLandmarks() {
  if (!state.target || sameTopology()) return;
  const status = $('landmarks-status');
  window.__rig.landmarks = null;
  $('landmarks-picture').classList.add('hidden');
  status.textContent = 'Finding the facial landmarks…';
  try {
    const res = await fetchJson('/api/landmarks', {
      method: 'POST',
      headers: { 'Content-Type': 'application/json' },
      body: JSON.stringify({ template: state.templateId, mesh: { format: state.target.format, data: state.target.data } }),
    });
    let job;
    for (;;) {
      job = await fetchJson(`/api/jobs/${encodeURIComponent(res.job)}`);
      if (job.state === 'done' || job.state === 'failed') break;
      await new Promise((r) => setTimeout(r, 400));
    }
    if (job.state === 'failed') throw new Error(job.error?.message || job.error || 'the landmark job failed');
    const r = job.result;
    state.pairs = r.markers.pairs.map((p) => ({ name: p.name, template: p.template, target: p.target }));
    state.pending = null;
    renderPairs();
    const img = $('landmarks-picture');
    img.src = r.picture;
    img.classList.remove('hidden');
    status.textContent = `${r.markers.pairs.length} landmarks found in ${r.views_found} views (${r.seconds.toFixed(1)} s). Drag a marker on your head to move it.`;
    window.__rig.landmarks = { pairs: r.markers.pairs.length, views: r.views_found };
  } catch (e) {
    status.textContent = `No landmarks: ${e.message}`;
    error(`The landmarks were not found: ${e.message}`, e.code || 'landmarks');
  }
}
