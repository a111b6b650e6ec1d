// The web client's avatar view on avatars like users' files, made here with glTF-Transform: a
// multi-mesh skinned GLB (a textured head and teeth that share morph targets by name in different
// orders, a body without any, a Hips/Spine/Neck/Head skeleton) and the same as a VRM 1.0 (humanoid
// bones, expressions aa and blink bound to the head's targets), loaded through three-vrm. Checks:
// weights by name reach every mesh, VRM expressions drive their bound targets (also under a VRM 0.x
// preset name), the JS client's applyWeights / applyExpressions do the same, the camera frames the
// face (not the body), the T-posed arms hang down (web/pose.js, mirroring configs/rig/humanoid.json),
// the head pose turns the head bone, the idle body leans and breathes (web/pose.js, mirroring
// configs/rig/body.json), and the page logs no errors. Both are
// imported through the server (POST /api/rigs) and loaded from what it serves back.

import { readFileSync, writeFileSync } from 'node:fs';
import { createRequire } from 'node:module';
import { join } from 'node:path';
import { deflateSync } from 'node:zlib';
import { run, startServer, launchBrowser, newPage, screenshot, check, must, sourceDir, artifacts } from './lib.mjs';

const require = createRequire(join(sourceDir, 'package.json'));
const { Document, NodeIO } = require('@gltf-transform/core');

// A PNG of w x h RGB pixels from colour(x, y) (zlib from node; CRC-32 by the table-free loop).
function png(w, h, colour) {
  const crc = (buf) => {
    let c = ~0;
    for (const b of buf) {
      c ^= b;
      for (let k = 0; k < 8; k++) c = (c >>> 1) ^ (0xedb88320 & -(c & 1));
    }
    return ~c >>> 0;
  };
  const chunk = (type, data) => {
    const out = Buffer.alloc(12 + data.length);
    out.writeUInt32BE(data.length, 0);
    out.write(type, 4, 'ascii');
    data.copy(out, 8);
    out.writeUInt32BE(crc(out.subarray(4, 8 + data.length)), 8 + data.length);
    return out;
  };
  const raw = Buffer.alloc(h * (1 + 3 * w));
  for (let y = 0; y < h; y++)
    for (let x = 0; x < w; x++) raw.set(colour(x, y), y * (1 + 3 * w) + 1 + 3 * x);
  const ihdr = Buffer.alloc(13);
  ihdr.writeUInt32BE(w, 0);
  ihdr.writeUInt32BE(h, 4);
  ihdr.set([8, 2, 0, 0, 0], 8);
  return Buffer.concat([Buffer.from([0x89, 0x50, 0x4e, 0x47, 13, 10, 26, 10]), chunk('IHDR', ihdr), chunk('IDAT', deflateSync(raw)), chunk('IEND', Buffer.alloc(0))]);
}

// A UV sphere (radius r about c): positions, normals, uvs, indices.
function sphere(c, r, nu = 32, nv = 16) {
  const pos = [], nrm = [], uv = [], idx = [];
  for (let i = 0; i <= nv; i++)
    for (let k = 0; k <= nu; k++) {
      const th = (Math.PI * i) / nv, ph = (2 * Math.PI * k) / nu;
      const n = [Math.sin(th) * Math.sin(ph), Math.cos(th), Math.sin(th) * Math.cos(ph)];
      pos.push(c[0] + r * n[0], c[1] + r * n[1], c[2] + r * n[2]);
      nrm.push(...n);
      uv.push(k / nu, i / nv);
    }
  for (let i = 0; i < nv; i++)
    for (let k = 0; k < nu; k++) {
      const a = i * (nu + 1) + k, b = a + nu + 1;
      idx.push(a, b, a + 1, a + 1, b, b + 1);
    }
  return { pos, nrm, uv, idx };
}

// The avatar: node layout Hips > Spine > Neck > Head and Spine > LeftArm > LeftForeArm (and the
// right), saved in T-pose; meshes Head (sphere at y 1.6), Teeth (small sphere in front of the head's
// lower half), Body (a tall sphere), arms (long ellipsoids), all skinned.
function makeAvatar() {
  const doc = new Document();
  const buffer = doc.createBuffer();
  const acc = (type, array) => doc.createAccessor().setType(type).setArray(array).setBuffer(buffer);
  // Saved in T-pose: the arms straight out from the shoulders.
  const names = ['Hips', 'Spine', 'Neck', 'Head', 'LeftArm', 'LeftForeArm', 'RightArm', 'RightForeArm'];
  const parents = [-1, 0, 1, 2, 1, 4, 1, 6];
  const origins = [[0, 1.0, 0], [0, 1.2, 0], [0, 1.42, 0], [0, 1.5, 0], [0.2, 1.38, 0], [0.45, 1.38, 0], [-0.2, 1.38, 0], [-0.45, 1.38, 0]];
  const joints = names.map((n) => doc.createNode(n));
  joints.forEach((j, i) => j.setTranslation(parents[i] >= 0 ? origins[i].map((v, k) => v - origins[parents[i]][k]) : origins[0]));
  joints.forEach((j, i) => parents[i] >= 0 && joints[parents[i]].addChild(j));
  const ibm = new Float32Array(16 * names.length);
  origins.forEach((o, i) => ibm.set([1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, -o[0], -o[1], -o[2], 1], 16 * i));
  const skin = doc.createSkin().setInverseBindMatrices(acc('MAT4', ibm)).setSkeleton(joints[0]);
  joints.forEach((j) => skin.addJoint(j));
  const texture = doc.createTexture('skin').setMimeType('image/png').setImage(png(16, 16, (x) => (x < 8 ? [230, 40, 40] : [40, 40, 230])));
  const scene = doc.createScene().addChild(joints[0]);
  const part = (name, geo, joint, targets, material) => {
    const n = geo.pos.length / 3;
    const prim = doc
      .createPrimitive()
      .setAttribute('POSITION', acc('VEC3', new Float32Array(geo.pos)))
      .setAttribute('NORMAL', acc('VEC3', new Float32Array(geo.nrm)))
      .setAttribute('TEXCOORD_0', acc('VEC2', new Float32Array(geo.uv)))
      .setAttribute('JOINTS_0', acc('VEC4', new Uint8Array(4 * n).map((_, i) => (i % 4 ? 0 : joint))))
      .setAttribute('WEIGHTS_0', acc('VEC4', new Float32Array(4 * n).map((_, i) => (i % 4 ? 0 : 1))))
      .setIndices(acc('SCALAR', new Uint16Array(geo.idx)))
      .setMaterial(material);
    for (const [target, delta] of targets) {
      const d = new Float32Array(3 * n);
      for (let v = 0; v < n; v++) d.set(delta(geo.pos.slice(3 * v, 3 * v + 3)), 3 * v);
      prim.addTarget(doc.createPrimitiveTarget(target).setAttribute('POSITION', acc('VEC3', d)));
    }
    const mesh = doc.createMesh(name).addPrimitive(prim);
    if (targets.length) mesh.setWeights(targets.map(() => 0)); // glTF-Transform writes extras.targetNames from the targets' names
    const node = doc.createNode(`${name}_mesh`).setMesh(mesh).setSkin(skin);
    scene.addChild(node);
    return node;
  };
  const jaw = ([, y, z]) => (y < 1.58 && z > 0 ? [0, -0.04, 0] : [0, 0, 0]);
  const blink = ([, y, z]) => (y > 1.63 && z > 0.05 ? [0, -0.02, 0] : [0, 0, 0]);
  const skinMat = doc.createMaterial('skin').setBaseColorTexture(texture).setRoughnessFactor(0.6).setMetallicFactor(0);
  part('Head', sphere([0, 1.6, 0], 0.1), 3, [['eyeBlinkLeft', blink], ['jawOpen', jaw]], skinMat);
  part('Teeth', sphere([0, 1.55, 0.06], 0.02, 12, 6), 3, [['jawOpen', jaw]], doc.createMaterial('teeth').setBaseColorFactor([0.95, 0.93, 0.88, 1]));
  const arm = (x) => ({ ...sphere([0, 0, 0], 1, 12, 6), pos: sphere([0, 0, 0], 1, 12, 6).pos.map((v, i) => (i % 3 === 0 ? x + 0.25 * v : i % 3 === 1 ? 1.38 + 0.04 * v : 0.04 * v)) });
  const sleeve = doc.createMaterial('sleeve').setBaseColorFactor([0.2, 0.3, 0.5, 1]);
  part('LeftArm', arm(0.45), 4, [], sleeve);
  part('RightArm', arm(-0.45), 6, [], sleeve);
  part('Body', { ...sphere([0, 1.0, 0], 0.3), pos: sphere([0, 0, 0], 1).pos.map((v, i) => (i % 3 === 1 ? 1.0 + 0.45 * v : 0.25 * v)) }, 1, [], doc.createMaterial('cloth').setBaseColorFactor([0.2, 0.3, 0.5, 1]));
  return doc;
}

// Writes the document as GLB; for a VRM adds VRMC_vrm (the extension glTF-Transform does not know)
// to the JSON chunk.
async function glb({ vrm }) {
  const doc = makeAvatar();
  const io = new NodeIO();
  const bytes = Buffer.from(await io.writeBinary(doc));
  if (!vrm) return bytes;
  const jsonLength = bytes.readUInt32LE(12);
  const json = JSON.parse(bytes.subarray(20, 20 + jsonLength).toString('utf8'));
  const node = (name) => json.nodes.findIndex((n) => n.name === name);
  const humanBones = { hips: 'Hips', spine: 'Spine', neck: 'Neck', head: 'Head' };
  const bones = Object.fromEntries(Object.entries(humanBones).map(([b, n]) => [b, { node: node(n) }]));
  Object.assign(bones, { leftUpperArm: { node: node('LeftArm') }, leftLowerArm: { node: node('LeftForeArm') }, rightUpperArm: { node: node('RightArm') }, rightLowerArm: { node: node('RightForeArm') } });
  // VRM requires the legs and hands too: empty nodes stand in for them.
  for (const [limb, parent] of [['leftUpperLeg', 'Spine'], ['leftLowerLeg', 'Spine'], ['leftFoot', 'Spine'], ['rightUpperLeg', 'Spine'], ['rightLowerLeg', 'Spine'], ['rightFoot', 'Spine'], ['leftHand', 'LeftForeArm'], ['rightHand', 'RightForeArm']]) {
    json.nodes.push({ name: limb, translation: limb.endsWith('Hand') ? [limb.startsWith('left') ? 0.25 : -0.25, 0, 0] : [0, 0, 0] });
    json.nodes[node(parent)].children = [...(json.nodes[node(parent)].children || []), json.nodes.length - 1];
    bones[limb] = { node: json.nodes.length - 1 };
  }
  const bind = (target) => ({ morphTargetBinds: [{ node: node('Head_mesh'), index: json.meshes[json.nodes[node('Head_mesh')].mesh].extras.targetNames.indexOf(target), weight: 1 }] });
  json.extensionsUsed = [...(json.extensionsUsed || []), 'VRMC_vrm'];
  json.extensions = {
    ...(json.extensions || {}),
    VRMC_vrm: {
      specVersion: '1.0',
      meta: { name: 'test', authors: ['facecast'], licenseUrl: 'https://vrm.dev/licenses/1.0/' },
      humanoid: { humanBones: bones },
      expressions: { preset: { aa: bind('jawOpen'), blink: bind('eyeBlinkLeft') } },
    },
  };
  let text = Buffer.from(JSON.stringify(json), 'utf8');
  text = Buffer.concat([text, Buffer.alloc((4 - (text.length % 4)) % 4, 0x20)]);
  const bin = bytes.subarray(20 + jsonLength);
  const header = Buffer.alloc(20);
  header.writeUInt32LE(0x46546c67, 0);
  header.writeUInt32LE(2, 4);
  header.writeUInt32LE(20 + text.length + bin.length, 8);
  header.writeUInt32LE(text.length, 12);
  header.writeUInt32LE(0x4e4f534a, 16);
  return Buffer.concat([header, text, bin]);
}

await run('avatar', async () => {
  const server = await startServer();
  const browser = await launchBrowser();
  const page = await newPage(browser, { width: 640, height: 480 });
  const files = { 'multi.glb': await glb({ vrm: false }), 'avatar.vrm': await glb({ vrm: true }) };
  for (const [name, bytes] of Object.entries(files)) writeFileSync(join(artifacts, name), bytes);
  // The files reach the page as users' files do: imported as they are (POST /api/rigs with their
  // content type) and served back by GET /api/rigs/{id}.glb, byte for byte.
  const urls = {};
  for (const [name, bytes] of Object.entries(files)) {
    const type = name.endsWith('.vrm') ? 'model/vrm' : 'model/gltf-binary';
    const r = await fetch(`${server.url}/api/rigs?name=${encodeURIComponent(name)}`, { method: 'POST', headers: { 'Content-Type': type }, body: bytes });
    const body = await r.json();
    must(`${name}: imported (201)`, r.status === 201 && body.id, `${r.status} ${JSON.stringify(body)}`);
    urls[name] = `/api/rigs/${body.id}.glb`;
    const back = Buffer.from(await (await fetch(`${server.url}${urls[name]}`)).arrayBuffer());
    check(`${name}: served back unchanged`, back.equals(bytes), `${back.length} vs ${bytes.length} bytes`);
  }
  // A page of its own with the web client's import map (read from index.html) and one canvas.
  const importMap = readFileSync(join(sourceDir, 'web/index.html'), 'utf8').match(/<script type="importmap">[\s\S]*?<\/script>/)[0];
  const html = `<!doctype html><html><head>${importMap}</head><body style="margin:0"><canvas id="test-view" style="width:640px;height:480px;display:block"></canvas></body></html>`;
  await page.route('**/test-avatars/index.html', (route) => route.fulfill({ status: 200, contentType: 'text/html', body: html }));
  await page.goto(`${server.url}/test-avatars/index.html`);
  for (const [file, isVrm] of [['multi.glb', false], ['avatar.vrm', true]]) {
    const result = await page.evaluate(
      async ({ url }) => {
        const { AvatarView, loadGlb } = await import('/avatar.js');
        const view = (window.__view ||= new AvatarView(document.getElementById('test-view')));
        view.setModel(await loadGlb(url));
        view.render(true);
        const target = view.controls.target.clone();
        view.setWeights(['jawOpen', 'eyeBlinkLeft', 'aa'], [0.5, 0.25, 0]);
        const byName = view.influences('jawOpen');
        view.setWeights(['jawOpen', 'eyeBlinkLeft', 'aa'], [0, 0, 1]);
        const byExpression = view.influences('jawOpen');
        view.setWeights(['jawOpen', 'eyeBlinkLeft', 'A'], [0, 0, 1]); // a VRM 0.x preset name
        const byVrm0Name = view.influences('jawOpen');
        // The JS client's helpers on the same three.js and three-vrm objects.
        const fc = await import('facecast-client');
        const meshes = fc.morphMeshes(view.model);
        fc.applyWeights(meshes, ['eyeBlinkLeft', 'jawOpen'], [0, 0.75]);
        const helper = meshes.map((m) => m.morphTargetInfluences[m.morphTargetDictionary.jawOpen] ?? null);
        const helperExpression = view.vrm && fc.applyExpressions(view.vrm, ['A'], [0.5]) === 1 ? view.vrm.expressionManager.getValue('aa') : null;
        // The rest pose: each upper arm's line to its forearm points down, 10 degrees outward.
        const THREE = await import('three');
        view.vrm?.update(0);
        view.model.updateMatrixWorld(true);
        const at = (name) => view.model.getObjectByName(name).getWorldPosition(new THREE.Vector3());
        const armAngles = ['Left', 'Right'].map((side) => {
          const d = at(`${side}ForeArm`).sub(at(`${side}Arm`)).normalize();
          return THREE.MathUtils.radToDeg(Math.atan2(Math.abs(d.x), -d.y));
        });
        const { HUMANOID, BODY } = await import('/pose.js');
        const headRest = view.bones.head.quaternion.clone();
        const headAt = at('Head');
        view.setPose({ yaw: 0.3 });
        view.render(true);
        const headTurned = view.bones.head.quaternion.angleTo(headRest);
        // The idle body: leaning to the figure's left (+X) carries the head that way; a breath turns
        // the chest (the Spine, which carries the neck).
        view.setPose({ lean: 0.1, breath: 1 });
        view.vrm?.update(0);
        view.model.updateMatrixWorld(true);
        const leanX = at('Head').x - headAt.x;
        const chestTurned = view.body?.chest ? view.body.chest.quaternion.angleTo(view.body.rest.get(view.body.chest).local) : 0;
        view.setPose({});
        view.vrm?.update(0);
        view.model.updateMatrixWorld(true);
        const back = at('Head').distanceTo(headAt);
        return { armAngles, turned: view.restTurned.length, humanoid: HUMANOID, body: BODY, names: view.names, byName, byExpression, byVrm0Name, helper, helperExpression, vrm: !!view.vrm, targetY: target.y, headTurned, leanX, chestTurned, back };
      },
      { url: urls[file] },
    );
    const tag = isVrm ? 'VRM' : 'GLB';
    must(`${tag}: loads`, result.names.includes('jawOpen'), result.names.join(','));
    check(`${tag}: jawOpen by name reaches the head and the teeth (different target orders)`, result.byName.filter((v) => v === 0.5).length === 2, JSON.stringify(result.byName));
    check(`${tag}: the camera frames the face (y 1.5-1.7), not the body`, result.targetY > 1.5 && result.targetY < 1.7, result.targetY.toFixed(3));
    check(`${tag}: the T-posed arms hang down, 10 degrees outward (the rest pose)`, result.turned === 2 && result.armAngles.every((a) => Math.abs(a - 10) < 1), `${result.turned} turned, ${JSON.stringify(result.armAngles)}`);
    if (!isVrm) {
      const table = JSON.parse(readFileSync(join(sourceDir, 'configs/rig/humanoid.json'), 'utf8'));
      const mirrored = { prefixes: table.prefixes, leftUpperArm: table.left_upper_arm, rightUpperArm: table.right_upper_arm, armAngleDeg: table.arm_angle_deg, minTurnDeg: table.min_turn_deg, fingerCurlDeg: table.finger_curl_deg };
      check('web/pose.js mirrors configs/rig/humanoid.json', JSON.stringify(result.humanoid) === JSON.stringify(mirrored), JSON.stringify(result.humanoid));
      const body = JSON.parse(readFileSync(join(sourceDir, 'configs/rig/body.json'), 'utf8'));
      const bodyMirrored = { neckShare: body.neck_share, breathChestDeg: body.breath_chest_deg, breathShoulderDeg: body.breath_shoulder_deg, shrugDeg: body.shrug_deg, leanCounter: body.lean_counter };
      check('web/pose.js mirrors configs/rig/body.json', JSON.stringify(result.body) === JSON.stringify(bodyMirrored), JSON.stringify(result.body));
    }
    check(`${tag}: a lean to the figure's left carries the head to +X`, result.leanX > 0.005, result.leanX.toFixed(4));
    check(`${tag}: the breath and the lean turn the chest`, result.chestTurned > 0.01, result.chestTurned.toFixed(4));
    check(`${tag}: the pose at zero puts the head back`, result.back < 1e-4, result.back.toExponential(2));
    check(`${tag}: the head pose turns the head bone`, result.headTurned > 0.1, String(result.headTurned));
    check(`${tag}: facecast-client's applyWeights sets jawOpen on every mesh`, result.helper.filter((v) => v === 0.75).length === 2, JSON.stringify(result.helper));
    if (isVrm) {
      check('VRM: three-vrm loaded it', result.vrm);
      check('VRM: the expression names are weight names', result.names.includes('aa') && result.names.includes('blink'), result.names.join(','));
      check('VRM: expression aa drives its bound target on the head', result.byExpression[0] === 1, JSON.stringify(result.byExpression));
      check('VRM: the VRM 0.x name A drives expression aa', result.byVrm0Name[0] === 1, JSON.stringify(result.byVrm0Name));
      check("VRM: facecast-client's applyExpressions sets aa for A", result.helperExpression === 0.5, String(result.helperExpression));
    }
    await screenshot(page, `avatar-${isVrm ? 'vrm' : 'glb'}`);
  }
  // Relaxed hands on a skeleton made here as the C++ test makes it (tests/rig/test_rest_pose.cpp):
  // a T-posed left arm, four fingers along +x spread in z, a thumb pointing forward.
  const hands = await page.evaluate(async () => {
    const THREE = await import('three');
    const { restPose } = await import('/pose.js');
    const bone = (name, parent, [x, y, z]) => {
      const b = new THREE.Bone();
      b.name = name;
      b.position.set(x, y, z);
      parent?.add(b);
      return b;
    };
    const hips = bone('Hips', null, [0, 1, 0]);
    const arm = bone('LeftArm', hips, [0.2, 0.45, 0]);
    const forearm = bone('LeftForeArm', arm, [0.3, 0, 0]);
    const hand = bone('LeftHand', forearm, [0.25, 0, 0]);
    const chain = (name, at, step, n) => {
      let parent = hand;
      const out = [];
      for (let k = 0; k < n; ++k) out.push((parent = bone(`${name}${k + 1}`, parent, k === 0 ? at : step)));
      return out;
    };
    const index = chain('LeftHandIndex', [0.05, 0, 0.03], [0.03, 0, 0], 4);
    for (const z of [0.01, -0.01, -0.03]) chain('LeftHandFinger', [0.05, 0, z], [0.03, 0, 0], 4);
    const thumb = chain('LeftHandThumb', [0.02, 0, 0.05], [0.01, 0, 0.03], 3);
    const root = new THREE.Group();
    root.add(hips);
    const at = (o) => o.getWorldPosition(new THREE.Vector3());
    const angle = (a, b) => THREE.MathUtils.radToDeg(a.angleTo(b));
    root.updateMatrixWorld(true);
    const thumbBefore = angle(at(thumb[2]).sub(at(thumb[0])), at(hand).sub(at(forearm)));
    const turned = restPose(root).length;
    root.updateMatrixWorld(true);
    const along = at(hand).sub(at(forearm));
    const palm = along.clone().cross(new THREE.Vector3(0, 0, 1)).normalize();
    return {
      turned,
      curls: [0, 1, 2].map((k) => angle(at(index[k + 1]).sub(at(index[k])), along)),
      toward: at(index[3]).sub(at(index[0])).dot(palm),
      thumb: angle(at(thumb[2]).sub(at(thumb[0])), along) - thumbBefore,
    };
  });
  check('relaxed hands: the fingers curl 15, 40, 55 degrees from the hand, toward the palm, the thumb stays (as rest_pose.cpp)', hands.turned === 13 && [15, 40, 55].every((a, k) => Math.abs(hands.curls[k] - a) < 0.5) && hands.toward > 0.02 && Math.abs(hands.thumb) < 0.5, JSON.stringify(hands));

  const rest = await (await fetch(`${server.url}/api/rigs`)).json();
  check('GET /api/rigs says the avatars stand at rest', rest.pose?.kind === 'rest', JSON.stringify(rest.pose));

  // A server configured with a pose file: the page stands the avatar by it, as the server's frames
  // do -- the right upper arm turned 60 degrees down from the T-pose (30 from straight down), the
  // left one as saved (no rest pose under a pose file).
  const poseFile = join(artifacts, 'wave.json');
  writeFileSync(poseFile, JSON.stringify({ rightUpperArm: { euler_deg: [0, 0, 60] } }));
  const config = join(artifacts, 'posed-server.json');
  writeFileSync(config, JSON.stringify({ ...JSON.parse(readFileSync(join(sourceDir, 'configs/server.json'), 'utf8')), pose: poseFile }));
  const posed = await startServer({ extraArgs: ['--config', config] });
  const listed = await (await fetch(`${posed.url}/api/rigs`)).json();
  must('GET /api/rigs carries the pose file', listed.pose?.kind === 'file' && listed.pose.bones?.[0]?.bone === 'rightUpperArm', JSON.stringify(listed.pose));
  const angles = await page.evaluate(
    async ({ url, pose }) => {
      const THREE = await import('three');
      const view = window.__view;
      view.standing = pose;
      view.setModel(await (await import('/avatar.js')).loadGlb(url));
      view.model.updateMatrixWorld(true);
      const at = (name) => view.model.getObjectByName(name).getWorldPosition(new THREE.Vector3());
      return ['Left', 'Right'].map((side) => {
        const d = at(`${side}ForeArm`).sub(at(`${side}Arm`)).normalize();
        return THREE.MathUtils.radToDeg(Math.atan2(Math.abs(d.x), -d.y));
      });
    },
    { url: urls['multi.glb'], pose: listed.pose },
  );
  check('a pose file stands the page\'s avatar as the server does', Math.abs(angles[0] - 90) < 1 && Math.abs(angles[1] - 30) < 1, JSON.stringify(angles));
  await posed.stop();
  check('no console errors', page.problems.length === 0, page.problems.join(' | '));
});
