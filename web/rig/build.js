// Building: the Build button's readiness, POST /api/rigs, and following the job to its result.

import { fetchJob, postJson } from './controls.js';
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
  setProgress(0, 'Uploading…');
  $('build').disabled = true;
  try {
    const res = await postJson('/api/rigs', body);
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
  const j = await fetchJob(state.job.id, (e) => ($('job-status').textContent = `Lost track of the job (${e.message}); retrying…`));
  if (!j) {
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

