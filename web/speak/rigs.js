// Rigs: the list in the Rig menu (from the server) and loading the chosen rig's GLB into the view.

import { fetchJson, authHeaders } from '../api.js';
import { loadGlb } from '../avatar.js';
import { showAlert } from '../alerts.js';
import { client, els, state, view } from './page.js';
import { updateButtons } from './queue.js';
import { saveSettings } from './settings.js';

export async function refreshRigs() {
  try {
    const res = await fetchJson('/api/rigs');
    state.rigs = res?.rigs || [];
    if (res?.default) state.serverDefault = res.default;
    if (res?.pose) view.standing = res.pose; // stand avatars as the server's frames do
  } catch (e) {
    if (e.status === 401) state.needsToken = true;
    else showAlert({ level: 'error', code: e.code || 'rigs', message: `Could not list the rigs: ${e.message}` });
    if (!state.rigs.length) state.rigs = (client.hello?.rigs || ['default']).map((id) => ({ id, name: id }));
  }
  const want = new URLSearchParams(location.search).get('rig') || state.rigId || state.savedRig || state.serverDefault || client.hello?.default_rig || 'default';
  els.rig.replaceChildren();
  for (const r of state.rigs) {
    const o = document.createElement('option');
    o.value = r.id;
    o.textContent = `${r.name || r.id}${r.builtin ? ' (built-in)' : ''}`;
    els.rig.appendChild(o);
  }
  const pick = state.rigs.find((r) => r.id === want) ? want : state.rigs[0]?.id || 'default';
  els.rig.value = pick;
  if (pick !== state.rigId) await loadRig(pick);
}

export async function loadRig(id) {
  state.rigLoading = id;
  els.loading.textContent = 'Loading the avatar…';
  els.loading.classList.remove('hidden');
  try {
    const gltf = await loadGlb(`/api/rigs/${encodeURIComponent(id)}.glb`, authHeaders(), (e) => {
      if (e.lengthComputable && e.total) els.loading.textContent = `Loading the avatar… ${Math.round((100 * e.loaded) / e.total)}%`;
    });
    if (state.rigLoading !== id) return;
    view.setModel(gltf);
    state.rigId = id;
    const r = state.rigs.find((x) => x.id === id);
    els.hudRig.textContent = r?.name || id;
    els.loading.classList.add('hidden');
    window.__facecast.ready = true;
    saveSettings();
  } catch (e) {
    els.loading.textContent = `Could not load rig '${id}'.`;
    showAlert({ level: 'error', code: 'rig', message: `Could not load rig '${id}': ${e.message || e}` });
  } finally {
    updateButtons();
  }
}
