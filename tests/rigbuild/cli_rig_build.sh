#!/usr/bin/env bash
# facecast rig build / rig check on the built-in avatar and a variant of it (same topology, no
# shared data): the rig, the report with contacts and intersections, the virtual-edge files and
# picture; one-line errors with a non-zero exit and no file left behind.
# Usage: cli_rig_build.sh FACECAST
set -euo pipefail
facecast=$1
source "$(dirname "$0")/../support/cli.sh"

"$facecast" avatar default --out "$tmp/default.glb" 2>/dev/null
"$facecast" avatar variant --seed 7 --out "$tmp/user.glb" 2>/dev/null
"$facecast" rig build --template "$tmp/default.glb" --target "$tmp/user.glb" --out "$tmp/me.glb" \
  --report "$tmp/report.json" --ve-out "$tmp/edges.obj" --ve-png "$tmp/edges.png" \
  --crossings-png "$tmp/crossings" 2>"$tmp/log"
grep -q "contacts" "$tmp/log" || fail "no stage timings: $(cat "$tmp/log")"
test -s "$tmp/edges.png" && test -s "$tmp/edges.json" && grep -q "^l " "$tmp/edges.obj"
node -e '
const r = JSON.parse(require("fs").readFileSync(process.argv[1]));
if (r.shapes.length !== 52) throw "shapes: " + r.shapes.length;
if (!(r.virtual_edges.count > 100)) throw "virtual edges: " + r.virtual_edges.count;
if (!(r.contacts.watched_pairs > 0) || r.contacts.crossings_left > r.contacts.crossings ||
    r.contacts.copy_crossings_left > r.contacts.copy_crossings) throw "contacts";
for (const k of ["correspondence", "virtual_edges", "factor", "solve", "contacts", "total", "intersections"])
  if (typeof r.timings_s[k] !== "number") throw "timing " + k;
const s = r.shapes.find(x => x.name === "jawOpen");
if (!(s.max_displacement > 0.5) || typeof s.intersections.new !== "number") throw "jawOpen entry";
// New pairs by the parts they join (the avatar has one material per part) add up to the count.
for (const x of r.shapes) {
  const by = Object.values(x.intersections.new_by_parts).reduce((a, b) => a + b, 0);
  if (by !== x.intersections.new) throw "new_by_parts of " + x.name;
}
if (typeof r.intersections.new_by_parts !== "object") throw "new_by_parts";
// One picture per shape with new pairs, named after it.
const fs = require("fs");
const with_new = r.shapes.filter(x => x.intersections.new > 0).map(x => x.name + ".png").sort();
if (with_new.length === 0) throw "no shape with new pairs to draw";
if (JSON.stringify(fs.readdirSync(process.argv[2]).sort()) !== JSON.stringify(with_new))
  throw "crossing pictures: " + fs.readdirSync(process.argv[2]);
' "$tmp/report.json" "$tmp/crossings"
"$facecast" rig info "$tmp/me.glb" | grep -q "shapes      52" || fail "rig info"
"$facecast" rig check "$tmp/me.glb" --template "$tmp/default.glb" >/dev/null

printf 'v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n' >"$tmp/triangle.obj"
expect_error_line "give --markers" "$facecast" rig build --template "$tmp/default.glb" \
  --target "$tmp/triangle.obj" --out "$tmp/x.glb"
# Another topology without --markers: automatic landmarks, and a triangle has no face.
expect_error_line "no face found" "$facecast" rig build --template "$tmp/default.glb" \
  --target "$tmp/triangle.obj" --out "$tmp/x.glb" --markers-out "$tmp/m.json"
test ! -e "$tmp/m.json" || fail "a failed build left its markers"
test ! -e "$tmp/x.glb" || fail "a failed build left its output"
if "$facecast" rig build --template "$tmp/default.glb" --target "$tmp/user.glb" \
  --out "$tmp/x.glb" --contacts maybe 2>"$tmp/err"; then fail "--contacts maybe accepted"; fi
grep -q -- "--contacts" "$tmp/err" || fail "usage error lacks --contacts: $(cat "$tmp/err")"
echo "cli_rig_build: ok"
