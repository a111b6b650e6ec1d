// The server as the rig builder sees it: its health in the top bar and the list of rigs (the
// template menu).

import { fetchJson } from '../api.js';
import { $, error, state } from './page.js';

export async function checkServer() {
  const conn = $('conn');
  try {
    const h = await fetchJson('/healthz');
    conn.dataset.state = 'open';
    $('conn-text').textContent = `Server ${h?.version ? `facecast ${h.version}` : 'ok'}`;
  } catch (e) {
    conn.dataset.state = 'reconnecting';
    $('conn-text').textContent = 'Server unreachable — retrying';
  }
}

export async function loadRigList() {
  try {
    const res = await fetchJson('/api/rigs');
    state.rigs = res?.rigs || [];
  } catch (e) {
    error(`Could not list the rigs: ${e.message}`, e.code);
    state.rigs = [{ id: 'default', name: 'Default avatar' }];
  }
  const sel = $('template');
  sel.replaceChildren();
  for (const r of state.rigs) {
    const o = document.createElement('option');
    o.value = r.id;
    o.textContent = `${r.name || r.id}${r.builtin ? ' (built-in)' : ''}`;
    sel.appendChild(o);
  }
  sel.value = state.rigs.find((r) => r.id === state.templateId) ? state.templateId : state.rigs[0]?.id;
}
