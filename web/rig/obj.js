// OBJ uploads in the rig builder: vertices in file order (marker indices refer to them), faces
// fan-triangulated, usemtl groups coloured by their material names.

import * as THREE from 'three';
import { partMaterial } from '../avatar.js';

export function parseObj(text) {
  const pos = [];
  const idx = [];
  const groups = []; // {start, count, material} over idx, from usemtl
  const lines = text.split('\n');
  for (let ln = 0; ln < lines.length; ln++) {
    const line = lines[ln].trim();
    if (line.startsWith('usemtl')) {
      const last = groups[groups.length - 1];
      if (last) last.count = idx.length - last.start;
      groups.push({ start: idx.length, count: 0, material: line.slice(6).trim() });
    } else if (line.startsWith('v ') || line.startsWith('v\t')) {
      const p = line.split(/\s+/);
      const x = Number(p[1]);
      const y = Number(p[2]);
      const z = Number(p[3]);
      if (![x, y, z].every(Number.isFinite)) throw new Error(`OBJ line ${ln + 1}: bad vertex`);
      pos.push(x, y, z);
    } else if (line.startsWith('f ') || line.startsWith('f\t')) {
      const n = pos.length / 3;
      const f = line
        .split(/\s+/)
        .slice(1)
        .map((t) => {
          const i = parseInt(t, 10);
          return i < 0 ? n + i : i - 1;
        });
      if (f.length < 3 || f.some((i) => !(i >= 0))) throw new Error(`OBJ line ${ln + 1}: bad face`);
      for (let k = 1; k + 1 < f.length; k++) idx.push(f[0], f[k], f[k + 1]);
    }
  }
  if (!pos.length) throw new Error('the OBJ has no vertices');
  const n = pos.length / 3;
  if (idx.some((i) => i >= n)) throw new Error('the OBJ has a face with a vertex index past its vertices');
  const last = groups[groups.length - 1];
  if (last) last.count = idx.length - last.start;
  if (groups.length && groups[0].start > 0) groups.unshift({ start: 0, count: groups[0].start, material: '' });
  return {
    positions: new Float32Array(pos),
    indices: n > 65535 ? new Uint32Array(idx) : new Uint16Array(idx),
    vertexCount: n,
    groups: groups.filter((g) => g.count > 0),
  };
}

export function objToObject(parsed) {
  const g = new THREE.BufferGeometry();
  g.setAttribute('position', new THREE.BufferAttribute(parsed.positions, 3));
  g.setIndex(new THREE.BufferAttribute(parsed.indices, 1));
  g.computeVertexNormals();
  let material = partMaterial('');
  if (parsed.groups.length > 1) {
    material = parsed.groups.map((gr, i) => {
      g.addGroup(gr.start, gr.count, i);
      return partMaterial(gr.material);
    });
  }
  const mesh = new THREE.Mesh(g, material);
  mesh.name = 'obj';
  const group = new THREE.Group();
  group.add(mesh);
  return group;
}

export function countVertices(root) {
  const attrs = new Set();
  let n = 0;
  root.traverse((o) => {
    if (o.isMesh && !attrs.has(o.geometry.attributes.position)) {
      attrs.add(o.geometry.attributes.position);
      n += o.geometry.attributes.position.count;
    }
  });
  return n;
}
