// The rest pose in the browser, as the server's renderer draws it (docs/algorithms.md#rest-pose):
// an avatar saved in T- or A-pose stands with its arms down. The upper arms are a VRM's humanoid
// bones, else found by name through HUMANOID (configs/rig/humanoid.json, mirrored here; the web
// test checks they agree); each turns about its joint until the line to its farthest child points
// down and armAngleDeg outward, and the fingers curl (fingerCurlDeg).

import * as THREE from 'three';

export const HUMANOID = {
  prefixes: ['mixamorig', 'jbip', 'bip01', 'bip001', 'ccbase', 'def', 'org', 'armature'],
  leftUpperArm: ['leftupperarm', 'leftarm', 'upperarml', 'upperarm01l', 'lupperarm', 'upperarmleft', 'leftshoulderarm', 'arml'],
  rightUpperArm: ['rightupperarm', 'rightarm', 'upperarmr', 'upperarm01r', 'rupperarm', 'upperarmright', 'rightshoulderarm', 'armr'],
  armAngleDeg: 10,
  minTurnDeg: 15,
  fingerCurlDeg: [15, 25, 15],
};

// "mixamorig:LeftArm" -> "leftarm", "J_Bip_L_UpperArm" -> "lupperarm" (as rest_pose.cpp does).
export function normalizedName(name) {
  let n = (name || '').slice((name || '').lastIndexOf(':') + 1).toLowerCase().replace(/[^a-z0-9]/g, '');
  const p = HUMANOID.prefixes.find((q) => n.length > q.length && n.startsWith(q));
  if (p) n = n.slice(p.length);
  return n;
}

function byName(root, candidates) {
  const bones = [];
  root.traverse((o) => o.isBone && bones.push(o));
  for (const c of candidates) {
    const hit = bones.find((b) => normalizedName(b.name) === c);
    if (hit) return hit;
  }
  return null;
}

// Turns `node` (world rotation r, premultiplied) keeping its parent where it is.
function turnInWorld(node, r) {
  const world = node.getWorldQuaternion(new THREE.Quaternion());
  const parent = node.parent ? node.parent.getWorldQuaternion(new THREE.Quaternion()) : new THREE.Quaternion();
  node.quaternion.copy(parent.invert().multiply(r).multiply(world));
  node.updateMatrixWorld(true);
}

const worldPosition = (o) => o.getWorldPosition(new THREE.Vector3());

// The child of `node` farthest from it, or null.
function farthestChild(node) {
  const origin = worldPosition(node);
  let far = null;
  let best = 0;
  for (const child of node.children) {
    const d = worldPosition(child).distanceTo(origin);
    if (d > best) [far, best] = [child, d];
  }
  return far;
}

// Relaxed hands, as rest_pose.cpp curls them: the fingers of the hand below `arm` (`side` 1: the
// figure's left, at +x) turn toward the palm by fingerCurlDeg per joint, the thumb (the finger that
// points least along the hand) stays. Returns [node, world-axis turn] pairs, found at rest.
function fingerCurls(arm, side) {
  const forearm = farthestChild(arm);
  const hand = forearm && farthestChild(forearm);
  if (!hand) return [];
  const along = worldPosition(hand).sub(worldPosition(forearm)).normalize();
  const fingers = [];
  for (const c of hand.children) {
    const chain = [c];
    for (let n = farthestChild(c); n && chain.length <= 64; n = farthestChild(n)) chain.push(n);
    if (chain.length >= 2) fingers.push(chain);
  }
  if (fingers.length < 3) return [];
  const direction = (f) => worldPosition(f[f.length - 1]).sub(worldPosition(f[0])).normalize();
  let thumb = 0;
  fingers.forEach((f, i) => direction(f).dot(along) < direction(fingers[thumb]).dot(along) && (thumb = i));
  fingers.splice(thumb, 1);
  let across = new THREE.Vector3();
  for (const a of fingers)
    for (const b of fingers) {
      const d = worldPosition(a[0]).sub(worldPosition(b[0]));
      if (d.length() > across.length()) across = d;
    }
  const palm = along.clone().cross(across);
  if (palm.length() < 1e-9) return [];
  palm.normalize();
  const facing = palm.dot(new THREE.Vector3(-side, -1, 0).normalize());
  if (Math.abs(facing) < 0.3) return [];
  if (facing < 0) palm.negate();
  const turns = [];
  for (const f of fingers)
    for (let k = 0; k + 1 < f.length && k < HUMANOID.fingerCurlDeg.length; ++k) {
      const axis = worldPosition(f[k + 1]).sub(worldPosition(f[k])).normalize().cross(palm);
      if (axis.length() < 1e-6 || !HUMANOID.fingerCurlDeg[k]) continue;
      turns.push([f[k], new THREE.Quaternion().setFromAxisAngle(axis.normalize(), THREE.MathUtils.degToRad(HUMANOID.fingerCurlDeg[k]))]);
    }
  return turns;
}

/**
 * Puts the arms of `root` down and relaxes the hands (a VRM through its normalized humanoid bones,
 * so three-vrm keeps the pose). Returns what it turned: [{ name, degrees }].
 */
export function restPose(root, vrm = null) {
  root.updateMatrixWorld(true);
  const arms = vrm?.humanoid
    ? [vrm.humanoid.getNormalizedBoneNode('leftUpperArm'), vrm.humanoid.getNormalizedBoneNode('rightUpperArm')]
    : [byName(root, HUMANOID.leftUpperArm), byName(root, HUMANOID.rightUpperArm)];
  const turned = [];
  // The fingers first, each about its joint in the world's axes at rest (q = q0 W0^-1 R W0: the arm's
  // turn below then carries them).
  const curls = arms.flatMap((arm, i) => (arm ? fingerCurls(arm, i === 0 ? 1 : -1) : []));
  const rest = curls.map(([node]) => [node.quaternion.clone(), node.getWorldQuaternion(new THREE.Quaternion())]);
  curls.forEach(([node, r], i) => {
    const [q0, w0] = rest[i];
    node.quaternion.copy(q0).multiply(w0.clone().invert().multiply(r).multiply(w0));
    turned.push({ name: node.name, degrees: THREE.MathUtils.radToDeg(2 * Math.acos(Math.min(1, Math.abs(r.w)))) });
  });
  root.updateMatrixWorld(true);
  const a = THREE.MathUtils.degToRad(HUMANOID.armAngleDeg);
  for (const arm of arms) {
    if (!arm) continue;
    const far = farthestChild(arm);
    if (!far) continue;
    const d = worldPosition(far).sub(worldPosition(arm)).normalize();
    const down = new THREE.Vector3(d.x >= 0 ? Math.sin(a) : -Math.sin(a), -Math.cos(a), 0);
    const degrees = THREE.MathUtils.radToDeg(Math.acos(THREE.MathUtils.clamp(d.dot(down), -1, 1)));
    if (degrees < HUMANOID.minTurnDeg) continue;
    turnInWorld(arm, new THREE.Quaternion().setFromUnitVectors(d, down));
    turned.push({ name: arm.name, degrees });
  }
  return turned;
}

/**
 * Turns the bones of a pose file as the server does (rig/src/rest_pose.cpp, docs/cli.md#pose-files):
 * `bones` is [{ bone, rotation: [x, y, z, w] }], each a turn in the figure's axes (it faces +Z)
 * about the bone's joint, carried by the bones above it. A bone is a VRM humanoid bone name (the
 * VRM's normalized bone; without a VRM the head and neck in `head`, the upper arms by HUMANOID) or
 * a joint's own name. Returns what it turned: [{ name, degrees }]; a bone the avatar lacks is left.
 */
export function filePose(root, vrm, bones, head = null) {
  root.updateMatrixWorld(true);
  const own = (name) => {
    const wanted = THREE.PropertyBinding.sanitizeNodeName(name);
    let hit = null;
    root.traverse((o) => (hit ||= o.name === wanted || o.name === name ? o : null));
    return hit;
  };
  const find = (name) =>
    vrm?.humanoid?.getNormalizedBoneNode(name) ??
    (name === 'head' || name === 'neck' ? head?.[name] : null) ??
    (name === 'leftUpperArm' || name === 'rightUpperArm' ? byName(root, HUMANOID[name]) : null) ??
    own(name);
  // Each bone's rest rotations first: the turns compose down the skeleton as on the server.
  const found = bones.map((b) => [find(b.bone), b]).filter(([node]) => node);
  const rest = found.map(([node]) => ({ local: node.quaternion.clone(), world: node.getWorldQuaternion(new THREE.Quaternion()) }));
  const turned = [];
  found.forEach(([node, b], i) => {
    const r = new THREE.Quaternion(...b.rotation).normalize();
    const w = rest[i].world;
    node.quaternion.copy(rest[i].local).multiply(w.clone().invert().multiply(r).multiply(w));
    turned.push({ name: node.name, degrees: THREE.MathUtils.radToDeg(2 * Math.acos(Math.min(1, Math.abs(r.w)))) });
  });
  root.updateMatrixWorld(true);
  return turned;
}

// The idle body, as the server's renderer turns it (rig/src/body.cpp, docs/algorithms.md#idle-body):
// BODY mirrors configs/rig/body.json (the web test checks they agree).
export const BODY = { neckShare: 0.4, breathChestDeg: 1.2, breathShoulderDeg: 1.0, shrugDeg: 6.0, leanCounter: 0.7 };

/**
 * The joints a body pose turns: a VRM's normalized humanoid bones, else found from the head down
 * (the chest carries the neck, the spine runs down to where another limb branches off, a shoulder
 * carries an upper arm). `head` and `neck` are the avatar's head bones. Returns null without a
 * head; each joint with its rest rotations, for setBodyPose.
 */
export function bodyJoints(root, vrm, head, neck) {
  if (!head) return null;
  root.updateMatrixWorld(true);
  const h = vrm?.humanoid;
  const bone = (name) => h?.getNormalizedBoneNode(name) ?? null;
  const normalized = new Set();
  if (h) for (const name of Object.keys(h.humanBones)) bone(name) && normalized.add(bone(name));
  const isJoint = (o) => !!o && (o.isBone || normalized.has(o));
  const top = neck || head;
  let chest = (h && (bone('upperChest') || bone('chest'))) || null;
  if (!chest || chest === top) chest = isJoint(top.parent) ? top.parent : null;
  if (chest && !isJoint(chest.parent)) chest = null; // a root chest would turn the legs too
  const spine = [];
  const arms = h ? [bone('leftUpperArm'), bone('rightUpperArm')] : [byName(root, HUMANOID.leftUpperArm), byName(root, HUMANOID.rightUpperArm)];
  const shoulders = [null, null];
  if (chest) {
    const hips = bone('hips');
    for (let from = chest, j = chest.parent; isJoint(j) && isJoint(j.parent) && j !== hips; from = j, j = j.parent) {
      const limb = !hips && j.children.some((c) => c !== from && isJoint(c) && c.children.some(isJoint));
      if (limb) break;
      spine.unshift(j);
    }
    const named = h ? [bone('leftShoulder'), bone('rightShoulder')] : [null, null];
    for (const side of [0, 1]) {
      const s = named[side] || (isJoint(arms[side]?.parent) ? arms[side].parent : null);
      if (s && s !== chest && !spine.includes(s)) shoulders[side] = s;
    }
  }
  const joints = { head, neck, chest, spine, shoulders, arms: chest ? arms : [null, null] };
  const all = [head, neck, chest, ...spine, ...shoulders, ...joints.arms].filter(Boolean);
  joints.rest = new Map(all.map((o) => [o, { local: o.quaternion.clone(), world: o.getWorldQuaternion(new THREE.Quaternion()), origin: o.getWorldPosition(new THREE.Vector3()) }]));
  return joints;
}

/**
 * Turns the joints for a body pose {yaw, pitch, roll, breath, lean, shrug} (the stream's extra
 * channels), each about its joint in the world's axes at rest (the figure faces +Z), as
 * rig::body_turns does: a turn R in world axes is the local rotation q0 * W0^-1 * R * W0.
 */
export function setBodyPose(joints, pose) {
  const deg = THREE.MathUtils.degToRad;
  const { yaw = 0, pitch = 0, roll = 0, breath = 0, lean = 0, shrug = 0 } = pose;
  const turns = new Map();
  const add = (o, q) => o && turns.set(o, (turns.get(o) || new THREE.Quaternion()).multiply(q));
  const about = (x, y, z, a) => new THREE.Quaternion().setFromAxisAngle(new THREE.Vector3(x, y, z), a);
  const headTurn = (share) => new THREE.Quaternion().setFromEuler(new THREE.Euler(share * pitch, share * yaw, share * roll, 'ZXY'));
  const { head, neck, chest, spine, shoulders, arms } = joints;
  if (neck) {
    add(neck, headTurn(BODY.neckShare));
    add(head, headTurn(1 - BODY.neckShare));
  } else add(head, headTurn(1));
  if (chest) {
    const top = neck || head;
    const c = breath * deg(BODY.breathChestDeg);
    add(chest, about(1, 0, 0, -c));
    add(top, about(1, 0, 0, c));
    if (spine.length) {
      for (const j of spine) add(j, about(0, 0, 1, -lean / spine.length));
      add(chest, about(0, 0, 1, BODY.leanCounter * lean));
    } else {
      add(chest, about(0, 0, 1, -lean));
      add(top, about(0, 0, 1, BODY.leanCounter * lean));
    }
    const raise = breath * deg(BODY.breathShoulderDeg) + shrug * deg(BODY.shrugDeg);
    const centre = joints.rest.get(chest).origin;
    for (const side of [0, 1]) {
      const s = shoulders[side];
      if (!s || raise === 0) continue;
      const tip = arms[side] || s;
      const dx = joints.rest.get(tip).origin.x - centre.x;
      const sign = dx !== 0 ? Math.sign(dx) : side === 0 ? 1 : -1;
      add(s, about(0, 0, 1, sign * raise));
      add(arms[side], about(0, 0, 1, -sign * raise));
    }
  }
  for (const [o, rest] of joints.rest) {
    const r = turns.get(o);
    if (!r) {
      o.quaternion.copy(rest.local);
      continue;
    }
    const w0 = rest.world;
    o.quaternion.copy(rest.local).multiply(w0.clone().invert().multiply(r).multiply(w0));
  }
}
