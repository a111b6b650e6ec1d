// The 3D avatar: a rig's GLB in three.js, morph target influences set by name, head rotation about
// the neck, in a Viewport (viewport.js: orbit camera, studio lighting); glTF loading and the
// helpers the rig builder shares (rest box, part colours, morph meshes).
//
// A facecast GLB has one mesh with one primitive per material; GLTFLoader turns it into a Group
// with one Mesh per primitive, each with the same morphTargetDictionary. Weights go to all of them.

import * as THREE from 'three';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';
import { Viewport } from './viewport.js';

/** Loads a GLB (URL or ArrayBuffer) with GLTFLoader. */
export async function loadGlb(source, headers = {}, onProgress = undefined) {
  const loader = new GLTFLoader();
  loader.setRequestHeader(headers);
  if (source instanceof ArrayBuffer) return loader.parseAsync(source, '');
  return loader.loadAsync(source, onProgress);
}

/**
 * The bounding box of the meshes' rest positions in world space. (Box3.setFromObject would include
 * every morph target's extent: a rig's box grows by its jawOpen and tongueOut.)
 */
export function restBox(root) {
  const box = new THREE.Box3();
  const p = new THREE.Vector3();
  root.updateWorldMatrix(true, true);
  root.traverse((o) => {
    if (!o.isMesh) return;
    const pos = o.geometry.attributes.position;
    const idx = o.geometry.index;
    // Only the vertices this primitive draws (primitives share one vertex array).
    const n = idx ? idx.count : pos.count;
    for (let i = 0; i < n; i++) {
      p.fromBufferAttribute(pos, idx ? idx.getX(i) : i).applyMatrix4(o.matrixWorld);
      box.expandByPoint(p);
    }
  });
  return box;
}

// Colours for the material names heads usually have: OBJ uploads carry no .mtl, and a rig built from
// one has its material names with a plain grey.
const PART_COLORS = [
  [/lip/i, 0xd98b84],
  [/sclera|eye_?white/i, 0xf3f1ec],
  [/iris/i, 0x4a7fa0],
  [/pupil/i, 0x111111],
  [/teeth|tooth/i, 0xf1ede4],
  [/tongue/i, 0xcc6f6c],
  [/mouth|interior|cavity/i, 0x5a2a2a],
  [/brow/i, 0x6b4a32],
  [/lash/i, 0x2a2220],
];
const SKIN = 0xe8cbb5;

function partColor(name) {
  const hit = PART_COLORS.find(([re]) => re.test(name || ''));
  return hit ? hit[1] : SKIN;
}

export function partMaterial(name) {
  return new THREE.MeshStandardMaterial({ color: partColor(name), roughness: 0.6, side: THREE.DoubleSide, name: name || '' });
}

/**
 * When every material of a model has the same untextured colour (a rig built from an OBJ without
 * .mtl), colours the parts by their material names instead.
 */
export function colorizePlainMaterials(root) {
  const mats = new Set();
  root.traverse((o) => o.isMesh && [].concat(o.material).forEach((m) => mats.add(m)));
  const list = [...mats];
  if (list.length < 2 || list.some((m) => m.map || !m.color)) return false;
  const c0 = list[0].color;
  if (!list.every((m) => m.color.equals(c0))) return false;
  for (const m of list) {
    m.color.setHex(partColor(m.name), THREE.SRGBColorSpace);
  }
  return true;
}

/** True when WebGL runs in software (no GPU): SwiftShader, llvmpipe, softpipe. */
export function isSoftwareRenderer(renderer) {
  const gl = renderer.getContext();
  const ext = gl.getExtension('WEBGL_debug_renderer_info');
  const name = String(gl.getParameter(ext ? ext.UNMASKED_RENDERER_WEBGL : gl.RENDERER));
  return /swiftshader|llvmpipe|softpipe|software/i.test(name);
}

/** Every mesh under root that has morph targets (one per glTF primitive). */
export function morphMeshes(root) {
  const meshes = [];
  root.traverse((o) => {
    if (o.isMesh && o.morphTargetInfluences && o.morphTargetDictionary) meshes.push(o);
  });
  return meshes;
}

/** The morph target names of a loaded glTF, in target order (extras.targetNames). */
export function targetNames(root) {
  const mesh = morphMeshes(root)[0];
  if (!mesh) return [];
  const dict = mesh.morphTargetDictionary;
  const names = [];
  for (const [name, i] of Object.entries(dict)) names[i] = name;
  return names;
}

export class AvatarView extends Viewport {
  constructor(canvas, { background = 0x272a33 } = {}) {
    super(canvas, { fov: 22, near: 0.1, background });
    this.fullPR = this.renderer.getPixelRatio();
    this.motionPR = this.fullPR; // lowered by adapt() when frames come too slowly
    this.controls.dampingFactor = 0.12;
    this.controls.addEventListener('start', () => (this.userMoved = true));
    this.pivot = new THREE.Group(); // the neck: head rotation is applied here
    this.scene.add(this.pivot);
    this.model = null;
    this.meshes = [];
    this.names = [];
    this.index = new Map(); // name -> morph index
    this.weights = new Float32Array(0); // current influences, by morph index
    this.observeSize();
  }

  resize() {
    super.resize();
    // Keep the head framed while the person has not moved the camera.
    if (this.box && !this.userMoved) this.frame(this.box);
  }

  /** Shows a loaded glTF scene (replacing the previous rig) and frames the camera on it. */
  setModel(gltf) {
    if (this.model) {
      this.pivot.remove(this.model);
      this.model.traverse((o) => {
        if (o.isMesh) {
          o.geometry.dispose();
          for (const m of [].concat(o.material)) m.dispose();
        }
      });
    }
    const model = gltf.scene;
    // Put the neck at the pivot: below the head's centre, a little behind it.
    const box = restBox(model);
    const size = box.getSize(new THREE.Vector3());
    const center = box.getCenter(new THREE.Vector3());
    const neck = new THREE.Vector3(center.x, box.min.y + 0.12 * size.y, center.z - 0.12 * size.z);
    model.position.sub(neck);
    this.pivot.position.copy(neck);
    this.pivot.rotation.set(0, 0, 0);
    this.pivot.add(model);
    colorizePlainMaterials(model);
    for (const m of morphMeshes(model)) {
      for (const mat of [].concat(m.material)) {
        mat.envMapIntensity = 1;
        if (/sclera|teeth/i.test(mat.name)) mat.roughness = 0.35;
        if (/iris|pupil/i.test(mat.name)) mat.roughness = 0.2;
      }
    }
    this.model = model;
    this.meshes = morphMeshes(model);
    this.names = targetNames(model);
    this.index = new Map(this.names.map((n, i) => [n, i]));
    this.weights = new Float32Array(this.names.length);
    this._mapNames = null;
    this.setupCpuMorph();
    this.box = box;
    this.userMoved = false;
    this.frame(box);
    this.dirty = true;
  }

  frame(box) {
    const size = box.getSize(new THREE.Vector3());
    const center = box.getCenter(new THREE.Vector3());
    const dist = this.fitDistance(size, { margin: 1.12, widthShare: 0.6 });
    this.camera.near = dist / 50;
    this.camera.far = dist * 20;
    this.camera.position.set(center.x + dist * 0.12, center.y + size.y * 0.04, center.z + dist);
    this.camera.updateProjectionMatrix();
    this.controls.target.copy(center);
    this.controls.minDistance = dist * 0.3;
    this.controls.maxDistance = dist * 4;
    this.controls.update();
  }

  /**
   * Applies weights given for `names` (the stream's order) to the morph targets of the same name.
   * A map from stream order to morph index is cached per names array.
   */
  setWeights(names, values) {
    if (this._mapNames !== names) {
      this._mapNames = names;
      this._map = names.map((n) => (this.index.has(n) ? this.index.get(n) : -1));
    }
    const map = this._map;
    let changed = false;
    for (let i = 0; i < map.length && i < values.length; i++) {
      const k = map[i];
      if (k >= 0 && this.weights[k] !== values[i]) {
        this.weights[k] = values[i];
        changed = true;
      }
    }
    if (changed) this.push();
  }

  /** Sets one shape by name (sliders); returns false when the rig lacks it. */
  setWeight(name, value) {
    const k = this.index.get(name);
    if (k === undefined) return false;
    if (this.weights[k] !== value) {
      this.weights[k] = value;
      this.push();
    }
    return true;
  }

  /** Multiplies every weight by f (a decay to the rest pose). */
  scaleWeights(f) {
    let changed = false;
    for (let i = 0; i < this.weights.length; i++) {
      if (this.weights[i] === 0) continue;
      this.weights[i] = Math.abs(this.weights[i]) < 1e-4 ? 0 : this.weights[i] * f;
      changed = true;
    }
    if (changed) this.push();
  }

  push() {
    this.dirty = true;
    for (const m of this.meshes) {
      const inf = m.morphTargetInfluences;
      for (let i = 0; i < inf.length && i < this.weights.length; i++) inf[i] = this.weights[i];
    }
    if (this.cpu) this.cpu.dirty = true;
  }

  /**
   * Software WebGL (SwiftShader, llvmpipe) spends most of a frame looping over every morph target
   * per vertex. There the morphs are blended on the CPU instead (sparse deltas, only the shapes in
   * use) into the shared position buffer, and the shaders draw a plain mesh. The influences stay in
   * morphTargetInfluences either way. `?morph=cpu|gpu` forces a path.
   */
  setupCpuMorph() {
    this.cpu = null;
    const force = new URLSearchParams(window.location.search).get('morph');
    if (force === 'gpu' || (force !== 'cpu' && !isSoftwareRenderer(this.renderer))) return;
    const first = this.meshes[0];
    const pos = first?.geometry.attributes.position;
    const deltas = first?.geometry.morphAttributes.position;
    if (!pos || !deltas?.length || !this.meshes.every((m) => m.geometry.attributes.position === pos)) return;
    const shapes = deltas.map((attr) => {
      const a = attr.array;
      const idx = [];
      for (let v = 0; v < attr.count; v++) if (a[3 * v] !== 0 || a[3 * v + 1] !== 0 || a[3 * v + 2] !== 0) idx.push(v);
      const vi = Uint32Array.from(idx);
      const d = new Float32Array(3 * vi.length);
      vi.forEach((v, k) => d.set(a.subarray(3 * v, 3 * v + 3), 3 * k));
      return { vi, d };
    });
    for (const m of this.meshes) {
      m.geometry.morphAttributes = {};
      m.frustumCulled = false;
    }
    pos.setUsage(THREE.DynamicDrawUsage);
    this.cpu = { pos, base: Float32Array.from(pos.array), shapes, dirty: true };
  }

  blendOnCpu() {
    const c = this.cpu;
    if (!c || !c.dirty) return;
    c.dirty = false;
    const out = c.pos.array;
    out.set(c.base);
    for (let k = 0; k < c.shapes.length && k < this.weights.length; k++) {
      const w = this.weights[k];
      if (w === 0) continue;
      const { vi, d } = c.shapes[k];
      for (let j = 0; j < vi.length; j++) {
        const o = 3 * vi[j];
        out[o] += w * d[3 * j];
        out[o + 1] += w * d[3 * j + 1];
        out[o + 2] += w * d[3 * j + 2];
      }
    }
    c.pos.needsUpdate = true;
  }

  /** The influence of a shape on every primitive (for tests): [values...] */
  influences(name) {
    return this.meshes.map((m) => {
      const k = m.morphTargetDictionary[name];
      return k === undefined ? null : m.morphTargetInfluences[k];
    });
  }

  /**
   * Head rotation in radians about the neck: yaw about +Y, pitch about +X, roll about +Z, applied in
   * that order (the matrix Rz * Rx * Ry, three's Euler order 'ZXY').
   */
  setHead(yaw, pitch, roll) {
    const r = this.pivot.rotation;
    if (r.x === pitch && r.y === yaw && r.z === roll) return;
    r.set(pitch, yaw, roll, 'ZXY');
    this.dirty = true;
  }

  /** Renders when anything changed (weights, head, camera, size) or when forced. */
  render(force = false) {
    this.controls.update();
    const now = performance.now();
    if (!this.dirty && !force) {
      this._streak = 0;
      // Reduced resolution is for motion: once still for a moment, draw one frame at full resolution.
      if (this.motionPR < this.fullPR && !this.refined && now - (this._lastDirty || 0) > 400) {
        this.refined = true;
        this.setPR(this.fullPR);
        this.blendOnCpu();
        this.renderer.render(this.scene, this.camera);
      }
      return false;
    }
    this.dirty = false;
    this._lastDirty = now;
    if (this.refined) {
      this.refined = false;
      this.setPR(this.motionPR);
    }
    this.blendOnCpu();
    this.renderer.render(this.scene, this.camera);
    this.renders = (this.renders || 0) + 1;
    this.adapt();
    return true;
  }

  setPR(pr) {
    if (this.renderer.getPixelRatio() === pr) return;
    this.renderer.setPixelRatio(pr);
    this.renderer.setSize(Math.max(1, this.canvas.clientWidth), Math.max(1, this.canvas.clientHeight), false);
  }

  /**
   * Adaptive resolution: when renders on consecutive animation frames come slower than ~20 per
   * second (software WebGL, a weak GPU), lower the pixel ratio step by step (down to 0.4) so the
   * animation stays fluid.
   */
  adapt() {
    const now = performance.now();
    const gap = now - (this._lastRender || 0);
    this._lastRender = now;
    this._streak = (this._streak || 0) + 1;
    if (this._streak === 1) {
      this._sum = 0;
      this._n = 0;
      return;
    }
    this._sum += gap;
    this._n += 1;
    if (this._n < 8) return;
    const avg = this._sum / this._n;
    this._sum = 0;
    this._n = 0;
    const pr = this.motionPR;
    if (avg > 50 && pr > 0.4) {
      this.motionPR = Math.max(0.4, pr * 0.7);
      this.setPR(this.motionPR);
    }
  }
}
