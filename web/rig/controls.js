// Controls the rig builder and the photo page share: a file drop zone, a slider per shape, and
// a build job started and followed (GET /api/jobs/{id}) to its end.

import { fetchJson } from '../api.js';

/** Calls `onFile(file)` for a file chosen in `input` or dropped on `drop` (Enter/Space open it). */
export function wireDropZone(drop, input, onFile) {
  input.addEventListener('change', () => input.files[0] && onFile(input.files[0]));
  drop.addEventListener('keydown', (e) => (e.key === 'Enter' || e.key === ' ') && input.click());
  drop.addEventListener('dragover', (e) => {
    e.preventDefault();
    drop.classList.add('over');
  });
  drop.addEventListener('dragleave', () => drop.classList.remove('over'));
  drop.addEventListener('drop', (e) => {
    e.preventDefault();
    drop.classList.remove('over');
    if (e.dataTransfer.files[0]) onFile(e.dataTransfer.files[0]);
  });
}

/** A labelled 0..1 range input per name in `box` (input.dataset.shape = name); `onChange(name, value)`. */
export function shapeSliders(box, names, onChange) {
  box.replaceChildren();
  for (const name of names) {
    const label = document.createElement('label');
    const span = document.createElement('span');
    span.textContent = name;
    span.title = name;
    const input = document.createElement('input');
    Object.assign(input, { type: 'range', min: '0', max: '1', step: '0.01', value: '0' });
    input.dataset.shape = name;
    const out = document.createElement('output');
    out.textContent = '0';
    input.addEventListener('input', () => {
      out.textContent = Number(input.value).toFixed(2);
      onChange(name, Number(input.value));
    });
    label.append(span, input, out);
    box.appendChild(label);
  }
}

function setProgress(p, text) {
  document.getElementById('progress-bar').style.width = `${Math.round(Math.max(0, Math.min(1, p)) * 100)}%`;
  if (text !== undefined) document.getElementById('job-status').textContent = text;
}

/**
 * Starts a build job (POST `url` with `body`) and follows it (GET /api/jobs/{id}) to its end on the
 * page's progress bar and status (#progress-bar, #job-status, #job-id). `state.job` holds the job's
 * last record (null when it did not start), `state.polling` the poll's timer. `what` names the build
 * in messages; `error(message, code)` shows an error; `onChange()` follows every change of the job
 * (the Build button's state); `onDone(result)` runs once it is done.
 */
export async function runJob(url, body, state, { what, error, onChange, onDone }) {
  setProgress(0, 'Uploading…');
  document.getElementById('build').disabled = true;
  try {
    const res = await postJson(url, body);
    state.job = { id: res.job, state: 'queued', progress: 0 };
    document.getElementById('job-id').textContent = `job ${res.job}`;
  } catch (e) {
    setProgress(0, `The build did not start: ${e.message}`);
    error(`The build did not start: ${e.message}`, e.code);
    state.job = null;
    onChange();
    return;
  }
  const lost = (e) => (document.getElementById('job-status').textContent = `Lost track of the job (${e.message}); retrying…`);
  const poll = async () => {
    clearTimeout(state.polling);
    if (!state.job) return;
    let j;
    try {
      j = await fetchJson(`/api/jobs/${encodeURIComponent(state.job.id)}`);
    } catch (e) {
      lost(e);
      state.polling = setTimeout(poll, 1500);
      return;
    }
    state.job = j;
    const progress = j.progress || 0;
    if (j.state === 'failed') {
      const message = j.error?.message || j.error || 'unknown error';
      setProgress(0, `Failed: ${message}`);
      error(`The ${what} failed: ${message}`, j.error?.code || 'build');
    } else if (j.state === 'done') setProgress(1, `Done: rig ${j.result?.rig}`);
    else if (j.state === 'running') setProgress(progress, `Building: ${j.stage || '…'} (${Math.round(progress * 100)}%)`);
    else setProgress(0, 'Queued…');
    onChange();
    if (j.state === 'done') await onDone(j.result);
    else if (j.state !== 'failed') state.polling = setTimeout(poll, 400);
  };
  poll();
}

/** Sets every slider of shapeSliders in `box` back to 0 (`onChange(name, 0)` for each). */
export function resetSliders(box, onChange) {
  for (const input of box.querySelectorAll('input')) {
    input.value = '0';
    input.nextElementSibling.textContent = '0';
    onChange(input.dataset.shape, 0);
  }
}

/** POSTs a JSON body and returns the parsed answer (fetchJson's errors). */
export function postJson(url, body) {
  return fetchJson(url, { method: 'POST', headers: { 'Content-Type': 'application/json' }, body: JSON.stringify(body) });
}
