// Weights by name on every mesh of an avatar. A user's avatar spreads its morph targets over several
// meshes (head, teeth, eyes, tongue), each with its own target order; a VRM also has expressions
// (aa, ih, ou, ee, oh, blink, happy, ...) bound to morph targets of its meshes. A name in the stream
// drives every mesh's target of that name, or the VRM expression of that name (a VRM 0.x preset
// name, A or Joy, under its VRM 1.0 name: the JS client's table).
//
// Software WebGL (SwiftShader, llvmpipe) spends most of a frame looping over every morph target per
// vertex; there the morphs are blended on the CPU (sparse deltas, only the targets in use) into each
// geometry's position buffer and the shaders draw plain meshes. `?morph=cpu|gpu` forces a path.

import * as THREE from 'three';
import { morphMeshes, vrm1Name } from 'facecast-client';

export { morphMeshes };

/** The morph target names of all meshes of a loaded glTF, each once, in first-seen order. */
export function targetNames(root) {
  const names = [];
  const seen = new Set();
  for (const mesh of morphMeshes(root)) {
    const inOrder = [];
    for (const [name, i] of Object.entries(mesh.morphTargetDictionary)) inOrder[i] = name;
    for (const n of inOrder) if (n !== undefined && !seen.has(n)) (seen.add(n), names.push(n));
  }
  return names;
}

// The sparse deltas of one geometry's morph targets, for CPU blending.
function sparseTargets(geometry) {
  return (geometry.morphAttributes.position || []).map((attr) => {
    const a = attr.array;
    const idx = [];
    for (let v = 0; v < attr.count; v++) if (a[3 * v] !== 0 || a[3 * v + 1] !== 0 || a[3 * v + 2] !== 0) idx.push(v);
    const vi = Uint32Array.from(idx);
    const d = new Float32Array(3 * vi.length);
    vi.forEach((v, k) => d.set(a.subarray(3 * v, 3 * v + 3), 3 * k));
    return { vi, d };
  });
}

export class MorphBinding {
  /** `vrm`: three-vrm's VRM of the model, or null. `cpu`: blend on the CPU (see above). */
  constructor(root, vrm, { cpu }) {
    this.meshes = morphMeshes(root);
    this.expressions = vrm?.expressionManager ?? null;
    const morphNames = targetNames(root);
    const expressionNames = this.expressions ? this.expressions.expressions.map((e) => e.expressionName) : [];
    this.names = [...morphNames, ...expressionNames.filter((n) => !morphNames.includes(n))];
    this.index = new Map(this.names.map((n, i) => [n, i]));
    this.weights = new Float32Array(this.names.length);
    // Per mesh: [union index, target index, bound] triples (bound: a VRM expression drives that
    // target too; expressions reset their targets on every update, so a direct weight is added after).
    const bound = new Set();
    for (const e of this.expressions?.expressions || [])
      for (const b of e.binds) for (const m of b.primitives || []) bound.add(`${m.uuid}:${b.index}`);
    this.targets = this.meshes.map((m) =>
      Object.entries(m.morphTargetDictionary).map(([name, k]) => [this.index.get(name), k, bound.has(`${m.uuid}:${k}`)]),
    );
    this.expressionIndex = expressionNames
      .filter((n) => !morphNames.includes(n))
      .map((n) => [n, this.index.get(n)]);
    this.cpu = cpu ? this.setupCpu() : null;
    this.dirty = true;
  }

  // One entry per position buffer: the meshes drawing it, its rest positions and sparse targets.
  setupCpu() {
    const groups = new Map();
    for (const m of this.meshes) {
      const pos = m.geometry.attributes.position;
      // Interleaved vertex data stays on the GPU path (the blend writes packed xyz).
      if (!m.geometry.morphAttributes.position?.length || pos.isInterleavedBufferAttribute) continue;
      if (!groups.has(pos)) groups.set(pos, { pos, base: Float32Array.from(pos.array), targets: sparseTargets(m.geometry), meshes: [] });
      groups.get(pos).meshes.push(m);
    }
    for (const g of groups.values()) {
      for (const m of g.meshes) {
        m.geometry.morphAttributes = {};
        m.frustumCulled = false;
      }
      g.pos.setUsage(THREE.DynamicDrawUsage);
    }
    return [...groups.values()];
  }

  /** Sets the weights given for `names` (a stream's order; cached per names array). */
  setWeights(names, values) {
    if (this._names !== names) {
      this._names = names;
      this._map = names.map((n) => this.index.get(n) ?? this.index.get(vrm1Name(n)) ?? -1);
    }
    for (let i = 0; i < this._map.length && i < values.length; i++) {
      const k = this._map[i];
      if (k >= 0 && this.weights[k] !== values[i]) {
        this.weights[k] = values[i];
        this.dirty = true;
      }
    }
    return this.dirty;
  }

  /** Sets one weight by name; false when the avatar has no target or expression of that name. */
  setWeight(name, value) {
    const k = this.index.get(name);
    if (k === undefined) return false;
    if (this.weights[k] !== value) (this.weights[k] = value), (this.dirty = true);
    return true;
  }

  /** Multiplies every weight by f (a decay to the rest pose). */
  scale(f) {
    for (let i = 0; i < this.weights.length; i++) {
      if (this.weights[i] === 0) continue;
      this.weights[i] = Math.abs(this.weights[i]) < 1e-4 ? 0 : this.weights[i] * f;
      this.dirty = true;
    }
    return this.dirty;
  }

  /**
   * Puts the weights into the meshes and the VRM's expressions (when they changed, or `force`: after
   * the VRM's own update), then blends on the CPU.
   */
  apply(force = false) {
    if (!this.dirty && !force) return;
    this.dirty = false;
    this.meshes.forEach((m, i) => {
      const inf = m.morphTargetInfluences;
      for (const [u, k, bound] of this.targets[i]) if (!bound) inf[k] = this.weights[u];
    });
    if (this.expressions) {
      for (const [name, u] of this.expressionIndex) this.expressions.setValue(name, this.weights[u]);
      this.expressions.update();
      this.meshes.forEach((m, i) => {
        const inf = m.morphTargetInfluences;
        for (const [u, k, bound] of this.targets[i]) if (bound) inf[k] += this.weights[u];
      });
    }
    for (const g of this.cpu || []) {
      const out = g.pos.array;
      out.set(g.base);
      const inf = g.meshes[0].morphTargetInfluences;
      g.targets.forEach(({ vi, d }, k) => {
        const w = inf[k];
        if (!w) return;
        for (let j = 0; j < vi.length; j++) {
          const o = 3 * vi[j];
          out[o] += w * d[3 * j];
          out[o + 1] += w * d[3 * j + 1];
          out[o + 2] += w * d[3 * j + 2];
        }
      });
      g.pos.needsUpdate = true;
    }
  }

  /** The influence of a target on every morph mesh (for tests): null where a mesh lacks it. */
  influences(name) {
    return this.meshes.map((m) => {
      const k = m.morphTargetDictionary[name];
      return k === undefined ? null : m.morphTargetInfluences[k];
    });
  }
}
