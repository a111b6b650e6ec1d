#!/usr/bin/env bash
# A clone without ../shared/data builds a rig from a head of its own topology on the shipped
# template (rigbuild/data/ict_facekit.glb): `facecast rig build --target head.obj --out me.glb`.
# Usage: cli_rig_build_shipped.sh FACECAST
set -euo pipefail
facecast=$1
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
fail() { echo "FAIL: $*"; exit 1; }
export FACECAST_SHARED_DATA=$tmp/no-shared-data

"$facecast" avatar variant --seed 11 --out "$tmp/user.glb" 2>/dev/null
"$facecast" rig unpack "$tmp/user.glb" --out "$tmp/user" 2>/dev/null
cp "$tmp/user/neutral.obj" "$tmp/head.obj"
"$facecast" rig build --target "$tmp/head.obj" --out "$tmp/me.glb" 2>"$tmp/log" || fail "rig build: $(tail -n 3 "$tmp/log")"
"$facecast" rig info "$tmp/me.glb" >"$tmp/info" 2>&1
grep -q "jawOpen" "$tmp/info" || fail "no jawOpen in the built rig: $(cat "$tmp/info")"
grep -q "viseme_aa" "$tmp/info" || fail "no Oculus visemes in the built rig: $(cat "$tmp/info")"
echo "ok: $(grep -c . "$tmp/info") lines of rig info"
