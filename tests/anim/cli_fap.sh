#!/usr/bin/env bash
# MPEG-4 FAP files on the command line: animate --out anim.fap writes the FBA ASCII file; animate
# --fap reads one back (the jaw follows the original), hand-written files drive a rig, render
# --fap makes a video; malformed files are one-line errors naming the line.
# Usage: cli_fap.sh FACECAST SOURCE_DIR
set -euo pipefail
facecast=$1 src=$2
source "$(dirname "$0")/../support/cli.sh"
cd "$src"
data=tests/anim/data
text="Papa made a big apple pie, maybe more. Open wide and say ah."

"$facecast" animate --text "$text" --fps 25 --idle off --out "$tmp/speech.fap"
"$facecast" animate --text "$text" --fps 25 --idle off --out "$tmp/speech.json"
"$facecast" animate --fap "$tmp/speech.fap" --fps 25 --out "$tmp/back.json"
python3 - "$tmp" <<'PY'
import json, sys
tmp = sys.argv[1]
lines = [l for l in open(f"{tmp}/speech.fap") if not l.startswith("#")]
version, name, fps, frames = lines[0].split()
assert (version, name, float(fps)) == ("2.1", "speech", 25.0), lines[0]
assert len(lines) == 1 + 2 * int(frames), (len(lines), frames)
mask = lines[1].split()
assert len(mask) == 68 and mask[0] == "1" and mask[1] == "1" and mask[2] == "1", mask
a, b = json.load(open(f"{tmp}/speech.json")), json.load(open(f"{tmp}/back.json"))
assert a["frames"] == b["frames"] == int(frames), (a["frames"], b["frames"], frames)
def column(t, name):
    i = t["shapes"].index(name)
    return [row[i] for row in t["weights"]]
def corr(x, y):
    n = len(x); mx, my = sum(x) / n, sum(y) / n
    sxy = sum((p - mx) * (q - my) for p, q in zip(x, y))
    sxx = sum((p - mx) ** 2 for p in x); syy = sum((q - my) ** 2 for q in y)
    return sxy / (sxx * syy) ** 0.5
r = corr(column(a, "jawOpen"), column(b, "jawOpen"))
print(f"anim.fap round trip: jawOpen correlation {r:.3f} over {a['frames']} frames")
assert r >= 0.9, r
PY

# Hand-written files (tests/anim/data, from the standard's description) drive the shipped
# template and the built-in avatar.
rig=rigbuild/data/ict_facekit.glb
"$facecast" animate --fap $data/jaw_and_blink.fap --rig $rig --fps 25 --out "$tmp/jaw.json"
"$facecast" animate --fap $data/visemes.fap --fps 25 --out "$tmp/visemes.json"
"$facecast" animate --fap $data/joy.fap --fps 10 --out "$tmp/joy.csv"
python3 - "$tmp" <<'PY'
import csv, json, sys
tmp = sys.argv[1]
jaw = json.load(open(f"{tmp}/jaw.json"))
j = jaw["shapes"].index("jawOpen")
opening = [row[j] for row in jaw["weights"][:5]]
assert opening[0] < 0.05 and opening[4] > opening[2] > opening[1] > opening[0], opening
blink = jaw["shapes"].index("eyeBlinkLeft")
assert jaw["weights"][7][blink] > 0.6, jaw["weights"][7][blink]
assert abs(jaw["head"][11][1] - 0.05) < 1e-3, jaw["head"][11]  # pitch 5000 AU
v = json.load(open(f"{tmp}/visemes.json"))
j = v["shapes"].index("jawOpen")
assert v["weights"][3][j] > v["weights"][0][j] + 0.2, (v["weights"][0][j], v["weights"][3][j])
rows = list(csv.reader(open(f"{tmp}/joy.csv")))
smile = rows[0].index("MouthSmileLeft")
assert float(rows[-1][smile]) > float(rows[1][smile]) + 0.2, (rows[1][smile], rows[-1][smile])
print("hand-written FAP files drive the rigs")
PY

"$facecast" render --fap $data/visemes.fap --rig $rig --size 160x120 --fps 25 --out "$tmp/fap.mp4"
frames=$(ffprobe -v error -count_frames -select_streams v:0 -show_entries stream=nb_read_frames \
  -of csv=p=0 "$tmp/fap.mp4")
[[ $frames -eq 12 ]] || fail "render --fap: $frames frames, expected 12"

printf '2.1 x 25 2\n1 0 2\n' >"$tmp/short.fap"
expect_error "short.fap:2: the mask: expected a whole number" "$facecast" animate --fap "$tmp/short.fap" --out "$tmp/x.json"
printf '2.1 x 25 2\n%s\n0 1e300\n' "$(printf '0 0 1 %.0s' ; printf '0 %.0s' {1..65})" >"$tmp/huge.fap"
expect_error "huge.fap:3: FAP 3: beyond" "$facecast" animate --fap "$tmp/huge.fap" --out "$tmp/x.json"
expect_error "leave --text and --timestamps out" "$facecast" animate --fap $data/joy.fap --text hi --out "$tmp/x.json"
expect_error "must end in .json, .bin, .csv or .fap" "$facecast" animate --text hi --out "$tmp/x.txt"
expect_error "leave --out, --rig and --fap out" "$facecast" animate --fap $data/joy.fap --vmc 127.0.0.1:39539
echo "cli_fap: ok"
