#!/usr/bin/env bash
# facecast animate and facecast render of speech: JSON and binary weights, timestamps in, a short
# MP4 and a frame sequence, the timeline plot, one-line errors with a non-zero exit and no file left behind.
# Usage: cli_animate.sh FACECAST SOURCE_DIR ARTIFACTS_DIR
set -euo pipefail
facecast=$1 src=$2 artifacts=$3
source "$(dirname "$0")/../support/cli.sh"

"$facecast" animate --text "(joy, 40, 0.5)你好，Facecast! Hello." --fps 30 --idle off --out "$tmp/w.json"
node -e '
const j = JSON.parse(require("fs").readFileSync(process.argv[1]));
if (j.fps !== 30 || j.frames !== j.weights.length || j.shapes.length !== 52) throw "shape of the JSON";
const jaw = j.shapes.indexOf("jawOpen");
const peak = Math.max(...j.weights.map(r => r[jaw]));
if (!(peak > 0.2)) throw "the jaw never opens: " + peak;
if (j.weights[j.frames - 1].some(v => v > 0.02)) throw "not at rest at the end";
' "$tmp/w.json"
# The timeline picture (kept in the test artifacts for people to look at).
"$facecast" animate --text "(joy, 60, 0.3)Hello, world. Papa bought a map." --out "$tmp/p.json" --plot "$tmp/timeline.png"
[[ $(head -c 4 "$tmp/timeline.png" | tail -c 3) == PNG ]] || fail "timeline PNG"
(( $(stat -c %s "$tmp/timeline.png") > 10000 )) || fail "timeline PNG too small to hold the lanes"
mkdir -p "$artifacts/anim" && cp "$tmp/timeline.png" "$artifacts/anim/speech_timeline.png"
# A Live Link Face take, read back with Python's csv module: the app's 63 columns, one row per frame.
"$facecast" animate --text "Hello, papa. Open wide." --fps 30 --idle off --out "$tmp/take.csv" 2>/dev/null
python3 - "$tmp/take.csv" <<'PY'
import csv, sys
rows = list(csv.reader(open(sys.argv[1])))
want = ("Timecode,BlendShapeCount,EyeBlinkLeft,EyeLookDownLeft,EyeLookInLeft,EyeLookOutLeft,"
        "EyeLookUpLeft,EyeSquintLeft,EyeWideLeft,EyeBlinkRight,EyeLookDownRight,EyeLookInRight,"
        "EyeLookOutRight,EyeLookUpRight,EyeSquintRight,EyeWideRight,JawForward,JawRight,JawLeft,"
        "JawOpen,MouthClose,MouthFunnel,MouthPucker,MouthRight,MouthLeft,MouthSmileLeft,"
        "MouthSmileRight,MouthFrownLeft,MouthFrownRight,MouthDimpleLeft,MouthDimpleRight,"
        "MouthStretchLeft,MouthStretchRight,MouthRollLower,MouthRollUpper,MouthShrugLower,"
        "MouthShrugUpper,MouthPressLeft,MouthPressRight,MouthLowerDownLeft,MouthLowerDownRight,"
        "MouthUpperUpLeft,MouthUpperUpRight,BrowDownLeft,BrowDownRight,BrowInnerUp,BrowOuterUpLeft,"
        "BrowOuterUpRight,CheekPuff,CheekSquintLeft,CheekSquintRight,NoseSneerLeft,NoseSneerRight,"
        "TongueOut,HeadYaw,HeadPitch,HeadRoll,LeftEyeYaw,LeftEyePitch,LeftEyeRoll,RightEyeYaw,"
        "RightEyePitch,RightEyeRoll").split(",")
assert rows[0] == want, rows[0]
assert len(rows) > 30 and all(len(r) == 63 and r[1] == "61" for r in rows[1:]), "row shape"
assert rows[1][0] == "00:00:00:00.000" and rows[31][0] == "00:00:01:00.000", (rows[1][0], rows[31][0])
jaw = [float(r[want.index("JawOpen")]) for r in rows[1:]]
assert max(jaw) > 0.2 and jaw[-1] < 0.02, (max(jaw), jaw[-1])
PY
expect_error "leave --rig out" "$facecast" animate --text hi --rig "$src/configs" --out "$tmp/t.csv"
"$facecast" animate --timestamps "$src/tests/viseme/fixtures/rhubarb.tsv" --out "$tmp/w.bin"
[[ $(head -c 4 "$tmp/w.bin") == FCWT ]] || fail "binary magic"
"$facecast" animate --timestamps "$src/tests/viseme/fixtures/azure_visemes.json" --out "$tmp/a.json"

"$facecast" render --text "Hello." --size 160x120 --fps 15 --out "$tmp/hello.mp4" 2>/dev/null
ffprobe -v error -show_entries stream=codec_name -of csv=p=0 "$tmp/hello.mp4" | tr '\n' ' ' |
  grep -q "h264 aac" || fail "hello.mp4 streams"
"$facecast" render --timestamps "$src/tests/viseme/fixtures/rhubarb.json" --size 96x64 --fps 10 \
  --out "$tmp/frames/%03d.png" 2>/dev/null
test -s "$tmp/frames/000.png"
test ! -e "$tmp/frames/audio.wav"  # timestamps bring no audio

expect_error "--out" "$facecast" animate --text hi --out "$tmp/w.txt"
expect_error "exactly one of --text or --timestamps" "$facecast" animate --out "$tmp/x.json"
expect_error "character 6" "$facecast" animate --text "(joy, 99, 1)hi" --out "$tmp/x.json"
expect_error "x.gif" "$facecast" render --text hi --out "$tmp/x.gif"
expect_error "README.md: not audio" "$facecast" render --text hi --audio "$src/README.md" --out "$tmp/x.mp4"
test ! -e "$tmp/x.json" && test ! -e "$tmp/x.mp4" || fail "a file was left behind"
echo ok
