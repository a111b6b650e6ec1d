// Building: the Build button's readiness, and the job (POST /api/rigs) followed to its result.

import { runJob } from './controls.js';
import { $, error, sameTopology, state } from './page.js';
import { showResult } from './result.js';

export function updateBuild() {
  const running = state.job && (state.job.state === 'queued' || state.job.state === 'running');
  // Another topology without marker pairs: the server finds the facial landmarks itself; pairs given
  // here replace them (then at least 3).
  const pairsOk = sameTopology() || state.pairs.length === 0 || state.pairs.length >= 3;
  const ok = !!state.target && window.__rig.templateReady && pairsOk;
  $('build').disabled = !ok || running;
  if (!running && state.target && !ok) $('job-status').textContent = 'Give at least 3 marker pairs, or none (landmarks are then found automatically).';
  else if (!running && ok && !state.job) $('job-status').textContent = 'Ready to build.';
}

export async function build() {
  const body = {
    name: $('name').value.trim() || 'My head',
    template: state.templateId,
    mesh: { format: state.target.format, data: state.target.data },
    options: { virtual_edges: $('ve').checked ? 'auto' : 'off', lambda: Number($('lambda').value) || 0 },
  };
  if (state.pairs.length) body.markers = { index_base: 0, pairs: state.pairs.map(({ name, template, target }) => ({ name, template, target })) };
  await runJob('/api/rigs', body, state, { what: 'rig build', error, onChange: updateBuild, onDone: showResult });
}
