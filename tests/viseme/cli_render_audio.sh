#!/usr/bin/env bash
# facecast render --audio speech.mp3 --text: the text aligned to that audio, an MP4 carrying it.
set -euo pipefail
facecast=$1
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }
text="Hello there, good morning"
"$facecast" tts --text "$text" --out "$tmp/speech.wav" 2>/dev/null
# Half a second of leading silence: the mouth must wait for the speech.
ffmpeg -v error -y -f lavfi -i anullsrc=r=22050:cl=mono -t 0.5 "$tmp/lead.wav"
ffmpeg -v error -y -i "$tmp/lead.wav" -i "$tmp/speech.wav" \
  -filter_complex "[0:a][1:a]concat=n=2:v=0:a=1" -ar 44100 "$tmp/speech.mp3"
"$facecast" visemes --audio "$tmp/speech.mp3" --text "$text" >"$tmp/u.json"
first=$(python3 -c "import json,sys; print(json.load(open(sys.argv[1]))['words'][0]['start'])" "$tmp/u.json")
python3 -c "import sys; sys.exit(0 if 0.45 < float(sys.argv[1]) < 0.65 else 1)" "$first" ||
  fail "first word at $first s, speech starts at 0.5 s"
"$facecast" render --audio "$tmp/speech.mp3" --text "$text" --size 160x120 --out "$tmp/out.mp4" 2>/dev/null
streams=$(ffprobe -v error -show_entries stream=codec_type -of csv=p=0 "$tmp/out.mp4" | sort | tr '\n' ' ')
[[ $streams == "audio video " ]] || fail "streams: $streams"
# The audio alone: audio-only lip-sync; the first sounding viseme waits for the speech too.
"$facecast" visemes --audio "$tmp/speech.mp3" >"$tmp/a.json"
first=$(python3 -c "import json,sys; print([v for v in json.load(open(sys.argv[1]))['visemes'] if v['viseme'] != 'sil'][0]['start'])" "$tmp/a.json")
python3 -c "import sys; sys.exit(0 if 0.4 < float(sys.argv[1]) < 0.7 else 1)" "$first" ||
  fail "audio-only: first viseme at $first s, speech starts at 0.5 s"
"$facecast" render --audio "$tmp/speech.mp3" --size 160x120 --out "$tmp/alone.mp4" 2>/dev/null
streams=$(ffprobe -v error -show_entries stream=codec_type -of csv=p=0 "$tmp/alone.mp4" | sort | tr '\n' ' ')
[[ $streams == "audio video " ]] || fail "audio-only streams: $streams"
echo "cli_render_audio: all passed"
