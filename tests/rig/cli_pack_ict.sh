#!/usr/bin/env bash
# facecast rig pack/info/unpack on the ICT FaceKit; the GLB must pass the glTF validator and load in
# three.js with all 57 names. Usage: cli_pack_ict.sh FACECAST TEST_DATA_DIR SOURCE_DIR
set -euo pipefail
facecast=$1 data=$2 src=$3
ict=$data/ict-facekit/FaceXModel
if [ ! -f "$ict/generic_neutral_mesh.obj" ]; then
  if [ "${CI:-}" = true ]; then echo "FAIL: ICT FaceKit missing at $ict"; exit 1; fi
  echo "ICT FaceKit missing at $ict: not run"; exit 0
fi
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT

"$facecast" rig pack --neutral "$ict/generic_neutral_mesh.obj" --shapes "$ict" --out "$tmp/ict.glb"
node "$src/scripts/validate-gltf.mjs" "$tmp/ict.glb"
names=$(node -e 'const j=require(process.argv[1]); console.log(j.expressions.join(","))' "$ict/vertex_indices.json")
node "$src/tests/rig/three_load.mjs" "$tmp/ict.glb" "$names,cheekRaiser_L,PupilDilate_R"

"$facecast" rig info "$tmp/ict.glb" --json > "$tmp/info.json"
node -e '
  const i = require(process.argv[1]);
  const ok = i.vertices === 26719 && i.shapes.length === 57 && i.materials.length === 12 &&
    i.shapes.every(s => s.max_displacement > 0) && i.shapes.some(s => s.name === "jawOpen");
  if (!ok) { console.error("unexpected rig info", JSON.stringify(i).slice(0, 300)); process.exit(1); }
' "$tmp/info.json"
"$facecast" rig info "$tmp/ict.glb" | grep -q '^  jawOpen'

# unpack -> pack round trip gives the same shapes (names, moved vertices, max displacement).
"$facecast" rig unpack "$tmp/ict.glb" --out "$tmp/unpacked"
test "$(ls "$tmp/unpacked" | wc -l)" -eq 58
"$facecast" rig pack --neutral "$tmp/unpacked/neutral.obj" --shapes "$tmp/unpacked" --out "$tmp/again.glb"
"$facecast" rig info "$tmp/again.glb" --json > "$tmp/again.json"
node -e '
  const a = require(process.argv[1]), b = require(process.argv[2]);
  if (a.vertices !== b.vertices || a.triangles !== b.triangles) process.exit(1);
  for (let k = 0; k < a.shapes.length; ++k) {
    const s = a.shapes[k], t = b.shapes[k];
    if (s.name !== t.name || Math.abs(s.max_displacement - t.max_displacement) > 1e-4) {
      console.error("shape differs after round trip:", s, t); process.exit(1);
    }
  }
' "$tmp/info.json" "$tmp/again.json"

# Bad input: a clear one-line error, non-zero exit, no output file.
printf 'v 0 0 0\nv 1 0 0\nf 1 2 3\n' > "$tmp/unpacked/broken.obj"
if "$facecast" rig pack --neutral "$tmp/unpacked/neutral.obj" --shapes "$tmp/unpacked" --out "$tmp/bad.glb" 2>"$tmp/err"; then
  echo "FAIL: mismatched vertex count accepted"; exit 1
fi
grep -q 'broken.obj: 2 vertices, but the neutral has 26719' "$tmp/err"
test ! -e "$tmp/bad.glb"
echo "cli_pack_ict: ok"
