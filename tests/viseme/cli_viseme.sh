#!/usr/bin/env bash
# facecast visemes / tts from the command line: JSON, JSON Lines, TSV, every importer, WAV output,
# and one-line errors with a non-zero exit code.
set -euo pipefail
facecast=$1 fixtures=$2
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }

out=$("$facecast" visemes --text "(joy, 40, 0.5)银行行长来了。" --set zh15)
grep -q '"pinyin": "hang2"' <<<"$out" || fail "pinyin missing: $out"
grep -q '"name": "joy"' <<<"$out" || fail "expression missing"
grep -q '"viseme": "zhchsh"' <<<"$out" || fail "zh15 viseme missing"

# The English lexicon: a word espeak-ng reads otherwise is spoken with the CMU dictionary's phones
# (Bartosik: b 3: t oU s I k); with its file missing, espeak-ng reads it (b A@ t @ s I k).
if [[ -e /usr/share/pocketsphinx/model/en-us/cmudict-en-us.dict ]]; then
  out=$("$facecast" visemes --text "Bartosik" --set oculus)
  grep -q '"phone": "3:"' <<<"$out" || fail "the lexicon's reading missing: $out"
fi
out=$(FACECAST_EN_LEXICON="$tmp/missing.dict" "$facecast" visemes --text "Bartosik" --set oculus)
grep -q '"phone": "A@"' <<<"$out" || fail "espeak-ng's reading without a lexicon: $out"

printf '银行行长\nHello world.\n\n2024年，3.5%%\n' >"$tmp/in.txt"
"$facecast" visemes --input "$tmp/in.txt" --format json >"$tmp/out.jsonl"
[[ $(wc -l <"$tmp/out.jsonl") == 4 ]] || fail "JSON Lines: expected 4 lines"
[[ $(grep -c '^{.*"visemes":' "$tmp/out.jsonl") == 4 ]] || fail "JSON Lines: one object per line"
grep -q '"bai3"' <"$tmp/out.jsonl" || fail "percent not read out"
tsv=$("$facecast" visemes --input - --format tsv <"$tmp/in.txt")
grep -qP '^1\t0\.0000\t' <<<"$tsv" || fail "TSV"

for f in "azure azure_visemes.json" "polly polly_speechmarks.ndjson" "mfa mfa_long.TextGrid" \
         "mfa mfa_short.TextGrid" "mfa mfa_alignment.json" "rhubarb rhubarb.tsv" "rhubarb rhubarb.json" \
         "elevenlabs elevenlabs_alignment.json" "json phones_pinyin.json"; do
  set -- $f
  out=$("$facecast" visemes --from "$1" "$fixtures/$2")
  grep -q '"visemes"' <<<"$out" || fail "--from $f"
done

"$facecast" tts --text "你好，hello" --out "$tmp/speech.wav" --timing-out "$tmp/t.json" 2>/dev/null
[[ $(head -c 4 "$tmp/speech.wav") == RIFF ]] || fail "WAV header"
(( $(stat -c %s "$tmp/speech.wav") > 20000 )) || fail "WAV too short"
grep -q '"sample_rate": 22050' "$tmp/t.json" || fail "timing JSON"

# Errors: one line on stderr, exit code 2, no output file.
set +e
err=$("$facecast" visemes --text "你好(joy, 80, 1)" 2>&1 >/dev/null); rc=$?
set -e
[[ $rc == 2 ]] || fail "tag error exit code $rc"
[[ $(wc -l <<<"$err") == 1 && $err == *"character 8"* && $err == *"0..63"* ]] || fail "tag error: $err"
set +e
err=$("$facecast" visemes --from json "$fixtures/phones_unknown.json" --phoneset arpabet 2>&1 >/dev/null); rc=$?
"$facecast" tts --text "(sad, 1, 1)x" --out "$tmp/bad.wav" 2>/dev/null; rc2=$?
set -e
[[ $rc == 2 && $err == *"'QQ9'"* && $err == *"0.100 s"* ]] || fail "unknown phone: $err"
[[ $rc2 == 2 && ! -e $tmp/bad.wav ]] || fail "tts error left a file"
# --audio: any format (here MP3 via ffmpeg) aligned to --text; bad audio is a one-line error.
"$facecast" tts --text "Hello there, good morning" --out "$tmp/speech.wav" 2>/dev/null
ffmpeg -v error -y -i "$tmp/speech.wav" -ar 44100 -ac 2 "$tmp/speech.mp3"
out=$("$facecast" visemes --audio "$tmp/speech.mp3" --text "Hello there, good morning")
grep -q '"text": "morning"' <<<"$out" || fail "visemes --audio --text: $out"
grep -q '"sample_rate": 16000' <<<"$out" || fail "visemes --audio: audio rate"
echo "not audio" >"$tmp/junk.mp3"
set +e
err=$("$facecast" visemes --audio "$tmp/junk.mp3" --text "hi" 2>&1 >/dev/null); rc=$?
set -e
[[ $rc != 0 && $err == *"junk.mp3: not audio"* && $(wc -l <<<"$err") == 1 ]] || fail "bad audio: $err"
# --audio without --text: audio-only lip-sync; bad audio is a one-line error naming the file.
out=$("$facecast" visemes --audio "$tmp/speech.mp3" --tags "(smile,30,0.2)@0.4")
grep -Eq '"viseme": "(aa|E|I|O|U)"' <<<"$out" || fail "visemes --audio (audio-only): $out"
grep -q '"strength"' <<<"$out" || fail "visemes --audio: no strengths"
grep -q '"name": "smile"' <<<"$out" || fail "visemes --audio --tags: $out"
: >"$tmp/empty.wav"
sox -n -r 16000 -c 1 "$tmp/quiet.wav" trim 0 1
for f in junk.mp3 empty.wav quiet.wav; do
  set +e
  err=$("$facecast" visemes --audio "$tmp/$f" 2>&1 >/dev/null); rc=$?
  set -e
  [[ $rc != 0 && $err == *"$tmp/$f"* && $(wc -l <<<"$err") == 1 ]] || fail "audio-only, $f: $err"
done
echo "cli_viseme: all passed"
