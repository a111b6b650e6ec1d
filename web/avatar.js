// The 3D avatar: a rig's or a user's GLB/VRM in three.js (every mesh, its materials and skin; VRM
// through three-vrm with its MToon materials), weights set by name on every mesh (morphs.js), the
// face framed, standing in the rest pose (pose.js: arms down), the head turned through the neck and
// head bones (or about a pivot below the head), in a Viewport (viewport.js: orbit camera, studio
// lighting); glTF loading and the helpers the rig builder shares (rest box, part colours, morph
// meshes).

import * as THREE from 'three';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';
import { MeshoptDecoder } from 'three/addons/libs/meshopt_decoder.module.js';
import { VRMLoaderPlugin, VRMUtils } from '@pixiv/three-vrm';
import { Viewport } from './viewport.js';
import { MorphBinding, morphMeshes, targetNames } from './morphs.js';
import { bodyJoints, filePose, restPose, setBodyPose } from './pose.js';

export { morphMeshes, targetNames };

/** Loads a GLB or VRM (URL or ArrayBuffer) with GLTFLoader; a VRM's model is gltf.userData.vrm. */
export async function loadGlb(source, headers = {}, onProgress = undefined) {
  const loader = new GLTFLoader();
  loader.register((parser) => new VRMLoaderPlugin(parser));
  loader.setMeshoptDecoder(MeshoptDecoder);  // the shipped template is meshopt-compressed
  loader.setRequestHeader(headers);
  if (source instanceof ArrayBuffer) return loader.parseAsync(source, '');
  return loader.loadAsync(source, onProgress);
}

/**
 * The bounding box of the meshes' rest positions in world space. (Box3.setFromObject would include
 * every morph target's extent: a rig's box grows by its jawOpen and tongueOut.)
 */
export function restBox(root, meshes = null) {
  const box = new THREE.Box3();
  const p = new THREE.Vector3();
  root.updateWorldMatrix(true, true);
  const add = (o) => {
    if (!o.isMesh) return;
    const pos = o.geometry.attributes.position;
    const idx = o.geometry.index;
    // Only the vertices this primitive draws (primitives share one vertex array); a skinned mesh's
    // vertices where its skeleton puts them.
    const n = idx ? idx.count : pos.count;
    for (let i = 0; i < n; i++) {
      const v = idx ? idx.getX(i) : i;
      if (o.isSkinnedMesh) o.applyBoneTransform(v, p.fromBufferAttribute(pos, v));
      else p.fromBufferAttribute(pos, v);
      box.expandByPoint(p.applyMatrix4(o.matrixWorld));
    }
  };
  if (meshes) meshes.forEach(add);
  else root.traverse(add);
  return box;
}

/**
 * The face's box: the morph mesh with the most targets (the head) and the other morph meshes inside
 * it (teeth, eyes, tongue); the whole model when nothing has morph targets.
 */
export function faceBox(root) {
  const meshes = morphMeshes(root);
  if (!meshes.length) return restBox(root);
  const head = meshes.reduce((a, b) => (Object.keys(b.morphTargetDictionary).length > Object.keys(a.morphTargetDictionary).length ? b : a));
  const box = restBox(root, [head]);
  const near = box.clone().expandByScalar(0.25 * box.getSize(new THREE.Vector3()).length());
  for (const m of meshes) {
    if (m === head) continue;
    const b = restBox(root, [m]);
    if (near.containsBox(b)) box.union(b);
  }
  return box;
}

// The head and neck bones: a VRM's humanoid bones, else bones named like a head and a neck.
function headBones(root, vrm) {
  if (vrm?.humanoid) {
    return { head: vrm.humanoid.getNormalizedBoneNode('head'), neck: vrm.humanoid.getNormalizedBoneNode('neck') };
  }
  let head = null;
  let neck = null;
  root.traverse((o) => {
    if (!o.isBone) return;
    if (!head && /(^|[:_.])head$/i.test(o.name)) head = o;
    if (!neck && /(^|[:_.])neck$/i.test(o.name)) neck = o;
  });
  return head ? { head, neck } : null;
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



export class AvatarView extends Viewport {
  constructor(canvas, { background = 0x272a33 } = {}) {
    super(canvas, { fov: 22, near: 0.1, background });
    this.fullPR = this.renderer.getPixelRatio();
    // Lowered by adapt() when frames come too slowly; software WebGL starts at half resolution.
    this.motionPR = this.software ? Math.min(this.fullPR, 0.5) : this.fullPR;
    this.controls.dampingFactor = 0.12;
    this.controls.addEventListener('start', () => (this.userMoved = true));
    this.pivot = new THREE.Group(); // the neck of an avatar without head bones
    this.scene.add(this.pivot);
    this.model = null;
    this.vrm = null;
    this.morphs = null;
    this.pose = { yaw: 0, pitch: 0, roll: 0, breath: 0, lean: 0, shrug: 0 };
    this.clock = new THREE.Clock();
    this.observeSize();
  }

  /** The avatar's weight names: morph targets of every mesh, then a VRM's other expressions. */
  get names() {
    return this.morphs ? this.morphs.names : [];
  }

  resize() {
    super.resize();
    // Keep the head framed while the person has not moved the camera.
    if (this.box && !this.userMoved) this.frame(this.box);
  }

  /** Shows a loaded glTF or VRM (replacing the previous avatar) and frames the camera on its face. */
  setModel(gltf) {
    if (this.model) {
      this.pivot.remove(this.model);
      if (this.vrm) VRMUtils.deepDispose(this.model);
      else
        this.model.traverse((o) => {
          if (o.isMesh) {
            o.geometry.dispose();
            for (const m of [].concat(o.material)) m.dispose();
          }
        });
    }
    const vrm = gltf.userData?.vrm ?? null;
    const model = vrm ? vrm.scene : gltf.scene;
    if (vrm) VRMUtils.rotateVRM0(vrm); // VRM 0.x faces -Z; turn it to the camera like VRM 1.0
    this.vrm = vrm;
    this.bones = headBones(model, vrm);
    const box = faceBox(model);
    // Without bones the head turns about the pivot: the neck, below the face's centre, a little behind.
    const size = box.getSize(new THREE.Vector3());
    const center = box.getCenter(new THREE.Vector3());
    const neck = this.bones ? new THREE.Vector3() : new THREE.Vector3(center.x, box.min.y + 0.12 * size.y, center.z - 0.12 * size.z);
    model.position.sub(neck);
    this.pivot.position.copy(neck);
    this.pivot.rotation.set(0, 0, 0);
    this.pivot.add(model);
    // Standing as the server's frames show it (its pose option, from GET /api/rigs; pose.js).
    const standing = this.standing || { kind: 'rest' };
    if (standing.kind === 'file') this.restTurned = filePose(model, vrm, standing.bones || [], this.bones);
    else this.restTurned = standing.kind === 'bind' ? [] : restPose(model, vrm);
    this.body = this.bones ? bodyJoints(model, vrm, this.bones.head, this.bones.neck) : null;
    colorizePlainMaterials(model);
    for (const m of morphMeshes(model)) {
      for (const mat of [].concat(m.material)) {
        if (!mat.isMeshStandardMaterial) continue;
        mat.envMapIntensity = 1;
        if (/sclera|teeth/i.test(mat.name)) mat.roughness = 0.35;
        if (/iris|pupil/i.test(mat.name)) mat.roughness = 0.2;
      }
    }
    this.model = model;
    const force = new URLSearchParams(window.location.search).get('morph');
    const cpu = force === 'cpu' || (force !== 'gpu' && this.software);
    this.morphs = new MorphBinding(model, vrm, { cpu });
    this.pose = { yaw: 0, pitch: 0, roll: 0, breath: 0, lean: 0, shrug: 0 };
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

  /** Applies weights given for `names` (the stream's order) to the targets and expressions of the same name. */
  setWeights(names, values) {
    if (this.morphs?.setWeights(names, values)) this.dirty = true;
  }

  /** Sets one shape by name (sliders); returns false when the avatar lacks it. */
  setWeight(name, value) {
    if (!this.morphs?.setWeight(name, value)) return false;
    this.dirty ||= this.morphs.dirty;
    return true;
  }

  /** Multiplies every weight by f (a decay to the rest pose). */
  scaleWeights(f) {
    if (this.morphs?.scale(f)) this.dirty = true;
  }

  /** The influence of a target on every morph mesh (for tests): [values...] */
  influences(name) {
    this.morphs?.apply();
    return this.morphs ? this.morphs.influences(name) : [];
  }

  /**
   * The head and body pose of the stream's extra channels: the head's rotation in radians (yaw about
   * +Y, pitch about +X, roll about +Z, in that order: three's Euler order 'ZXY'; the neck takes 40 %
   * of it and the head the rest) and the idle body (breath, lean, shrug), turned as the server's
   * renderer turns the skeleton (pose.js setBodyPose). An avatar without head bones turns whole about
   * the pivot and has no body. Missing channels are 0.
   */
  setPose({ yaw = 0, pitch = 0, roll = 0, breath = 0, lean = 0, shrug = 0 }) {
    const pose = { yaw, pitch, roll, breath, lean, shrug };
    const h = this.pose;
    if (Object.keys(pose).every((k) => h[k] === pose[k])) return;
    this.pose = pose;
    if (this.body) setBodyPose(this.body, pose);
    else this.pivot.rotation.set(pitch, yaw, roll, 'ZXY');
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
    if (this.vrm) this.vrm.update(this.clock.getDelta()); // expressions, look-at, spring bones
    this.morphs?.apply(!!this.vrm);
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
