// Loads a GLB with three.js's GLTFLoader (as the web client does) and checks that the mesh's
// morphTargetDictionary holds every expected name. Usage: node three_load.mjs rig.glb name1,name2,...
import { readFile } from 'node:fs/promises';
import { GLTFLoader } from 'three/examples/jsm/loaders/GLTFLoader.js';

const [file, names] = process.argv.slice(2);
const buf = await readFile(file);
const ab = buf.buffer.slice(buf.byteOffset, buf.byteOffset + buf.byteLength);
const gltf = await new GLTFLoader().parseAsync(ab, '');
const meshes = [];
gltf.scene.traverse((o) => o.isMesh && meshes.push(o));
if (!meshes.length) throw new Error('no mesh in the scene');
const expected = names ? names.split(',') : [];
for (const mesh of meshes) {
  const dict = mesh.morphTargetDictionary ?? {};
  const missing = expected.filter((n) => !(n in dict));
  if (missing.length) throw new Error(`${mesh.name}: morphTargetDictionary lacks ${missing.join(', ')}`);
  if (mesh.morphTargetInfluences.some((w) => w !== 0)) throw new Error('default weights must be 0');
}
console.log(`${file}: ${meshes.length} primitives, ${Object.keys(meshes[0].morphTargetDictionary).length} morph targets`);
