#!/usr/bin/env bash
# facecast avatar default/variant and render: deterministic bytes, Khronos validator, one pose.
# Usage: cli_avatar.sh FACECAST SOURCE_DIR
set -euo pipefail
facecast=$1 src=$2
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
"$facecast" avatar default --out "$tmp/a.glb"
"$facecast" avatar default --out "$tmp/b.glb"
cmp "$tmp/a.glb" "$tmp/b.glb"
node "$src/scripts/validate-gltf.mjs" "$tmp/a.glb"
"$facecast" avatar variant --seed 3 --eye-size 1.1 --out "$tmp/v.glb"
node "$src/scripts/validate-gltf.mjs" "$tmp/v.glb"
if cmp -s "$tmp/a.glb" "$tmp/v.glb"; then echo "variant equals the default"; exit 1; fi
"$facecast" render --rig "$tmp/a.glb" --weights jawOpen=0.7,mouthSmileLeft=0.5 --size 160x120 --out "$tmp/face.png"
test -s "$tmp/face.png"
if "$facecast" render --rig "$tmp/a.glb" --weights nope=1 --out "$tmp/bad.png" 2>/dev/null; then exit 1; fi
test ! -e "$tmp/bad.png"
if "$facecast" avatar variant --eye-size 3 --out "$tmp/bad.glb" 2>/dev/null; then exit 1; fi
echo ok
