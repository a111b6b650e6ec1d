// Weights onto an avatar: three.js morph targets by name (morphTargetDictionary ->
// morphTargetInfluences, on every mesh that has the name) and three-vrm expressions
// (expressionManager.setValue) under their VRM 0.x or VRM 1.0 preset names. No three.js import:
// the helpers work on the objects three.js and three-vrm make.

/** (VRM 0.x name, VRM 1.0 name) of every preset both versions have (rig/src/vrm_names.cpp). */
export const VRM_PRESETS = Object.freeze([
  ['Neutral', 'neutral'],
  ['A', 'aa'],
  ['I', 'ih'],
  ['U', 'ou'],
  ['E', 'ee'],
  ['O', 'oh'],
  ['Blink', 'blink'],
  ['Blink_L', 'blinkLeft'],
  ['Blink_R', 'blinkRight'],
  ['Joy', 'happy'],
  ['Angry', 'angry'],
  ['Sorrow', 'sad'],
  ['Fun', 'relaxed'],
  ['Surprised', 'surprised'],
  ['LookUp', 'lookUp'],
  ['LookDown', 'lookDown'],
  ['LookLeft', 'lookLeft'],
  ['LookRight', 'lookRight'],
]);

const TO_VRM1 = new Map(VRM_PRESETS.map(([v0, v1]) => [v0.toLowerCase(), v1]));
const TO_VRM0 = new Map(VRM_PRESETS.map(([v0, v1]) => [v1, v0]));

/** The VRM 1.0 name of a VRM 0.x preset, matched without regard to case ("joy" -> "happy"); else `name`. */
export function vrm1Name(name) {
  return TO_VRM1.get(String(name).toLowerCase()) ?? name;
}

/** The VRM 0.x name of a VRM 1.0 preset ("happy" -> "Joy"); else `name`. */
export function vrm0Name(name) {
  return TO_VRM0.get(name) ?? name;
}

/** Every mesh under `root` (an Object3D, or an array of them) that has morph targets. */
export function morphMeshes(root) {
  const meshes = [];
  for (const r of [].concat(root)) {
    r.traverse((o) => {
      if (o.isMesh && o.morphTargetInfluences && o.morphTargetDictionary) meshes.push(o);
    });
  }
  return meshes;
}

// Per mesh (or expression manager): the last names array and its index map, so that a stream's
// names are looked up once.
const cache = new WeakMap();
function mapped(owner, names, lookup) {
  const hit = cache.get(owner);
  if (hit && hit.names === names) return hit.map;
  const map = names.map(lookup);
  cache.set(owner, { names, map });
  return map;
}

/**
 * Sets morph target influences by name: `names[i]` gets `values[i]` on every mesh of `target` (an
 * Object3D, a mesh, or an array of meshes) whose morphTargetDictionary has it; extra values past
 * the names are ignored. Pass the same `names` array each frame (a frame's or stream's), and
 * morphMeshes(root) once instead of the root, to skip the lookups. Returns the influences set.
 */
export function applyWeights(target, names, values) {
  const meshes = Array.isArray(target) && target.every((m) => m.morphTargetDictionary) ? target : morphMeshes(target);
  let set = 0;
  for (const mesh of meshes) {
    const dict = mesh.morphTargetDictionary;
    const map = mapped(mesh, names, (n) => dict[n] ?? -1);
    const inf = mesh.morphTargetInfluences;
    for (let i = 0; i < map.length && i < values.length; i++) {
      if (map[i] >= 0) {
        inf[map[i]] = values[i];
        set += 1;
      }
    }
  }
  return set;
}

/**
 * Sets three-vrm expressions by name: `vrm` is a VRM (or its expressionManager); a name is taken as
 * it is, else as a VRM 0.x preset under its VRM 1.0 name ("A" -> "aa", "Joy" -> "happy", the names
 * three-vrm uses for both versions). vrm.update(delta) (or expressionManager.update()) then moves
 * the morph targets. Returns the expressions set.
 */
export function applyExpressions(vrm, names, values) {
  const manager = vrm?.expressionManager ?? vrm;
  if (!manager?.setValue) return 0;
  const has = (n) => !!manager.getExpression?.(n);
  const map = mapped(manager, names, (n) => (has(n) ? n : has(vrm1Name(n)) ? vrm1Name(n) : null));
  let set = 0;
  for (let i = 0; i < map.length && i < values.length; i++) {
    if (map[i] !== null) {
      manager.setValue(map[i], values[i]);
      set += 1;
    }
  }
  return set;
}
