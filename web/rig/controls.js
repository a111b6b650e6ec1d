// Controls the rig builder and the photo page share: a file drop zone, a slider per shape, and
// following a job (GET /api/jobs/{id}) to its end.

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

/**
 * The job's record, or null when the server did not answer (`onLost(error)` is told, and the
 * caller polls again later).
 */
export async function fetchJob(id, onLost) {
  try {
    return await fetchJson(`/api/jobs/${encodeURIComponent(id)}`);
  } catch (e) {
    onLost(e);
    return null;
  }
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
