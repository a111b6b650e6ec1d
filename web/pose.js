// The rest pose in the browser, as the server's renderer draws it (docs/algorithms.md#rest-pose):
// an avatar saved in T- or A-pose stands with its arms down. The upper arms are a VRM's humanoid
// bones, else found by name through HUMANOID (configs/rig/humanoid.json, mirrored here; the web
// test checks they agree); each turns about its joint until the line to its farthest child points
// down and armAngleDeg outward.

import * as THREE from 'three';

export const HUMANOID = {
  prefixes: ['mixamorig', 'jbip', 'bip01', 'bip001', 'ccbase', 'def', 'org', 'armature'],
  leftUpperArm: ['leftupperarm', 'leftarm', 'upperarml', 'upperarm01l', 'lupperarm', 'upperarmleft', 'leftshoulderarm', 'arml'],
  rightUpperArm: ['rightupperarm', 'rightarm', 'upperarmr', 'upperarm01r', 'rupperarm', 'upperarmright', 'rightshoulderarm', 'armr'],
  armAngleDeg: 10,
  minTurnDeg: 15,
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

/**
 * Puts the arms of `root` down (a VRM through its normalized humanoid bones, so three-vrm keeps the
 * pose). Returns what it turned: [{ name, degrees }].
 */
export function restPose(root, vrm = null) {
  root.updateMatrixWorld(true);
  const arms = vrm?.humanoid
    ? [vrm.humanoid.getNormalizedBoneNode('leftUpperArm'), vrm.humanoid.getNormalizedBoneNode('rightUpperArm')]
    : [byName(root, HUMANOID.leftUpperArm), byName(root, HUMANOID.rightUpperArm)];
  const turned = [];
  const a = THREE.MathUtils.degToRad(HUMANOID.armAngleDeg);
  for (const arm of arms) {
    if (!arm) continue;
    const origin = arm.getWorldPosition(new THREE.Vector3());
    let far = null;
    let best = 0;
    for (const child of arm.children) {
      const d = child.getWorldPosition(new THREE.Vector3()).distanceTo(origin);
      if (d > best) [far, best] = [child, d];
    }
    if (!far || best <= 0) continue;
    const d = far.getWorldPosition(new THREE.Vector3()).sub(origin).normalize();
    const down = new THREE.Vector3(d.x >= 0 ? Math.sin(a) : -Math.sin(a), -Math.cos(a), 0);
    const degrees = THREE.MathUtils.radToDeg(Math.acos(THREE.MathUtils.clamp(d.dot(down), -1, 1)));
    if (degrees < HUMANOID.minTurnDeg) continue;
    turnInWorld(arm, new THREE.Quaternion().setFromUnitVectors(d, down));
    turned.push({ name: arm.name, degrees });
  }
  return turned;
}
