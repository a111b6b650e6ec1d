#!/usr/bin/env bash
# facecast animate --vmc: an independent OSC receiver (tests/support/vmc_receive.mjs, npm `osc`) gets
# one bundle per frame in real time with Perfect Sync and VRM 0.x names; bad targets are one-line
# errors.
# Usage: cli_vmc.sh FACECAST SOURCE_DIR
set -euo pipefail
facecast=$1 src=$2
source "$(dirname "$0")/../support/cli.sh"
cd "$src"
for names in perfect-sync:jawOpen vrm0:A; do
  node tests/support/vmc_receive.mjs "${names%%:*}" "${names#*:}" -- "$facecast" animate \
    --text "Hello, papa. Open wide." --fps 30 --vmc "127.0.0.1:{port}" --vmc-names "${names%%:*}"
done
expect_error "is not HOST:PORT" "$facecast" animate --text hi --vmc 127.0.0.1
expect_error "no port between 1 and 65535" "$facecast" animate --text hi --vmc 127.0.0.1:70000
expect_error "leave --out, --rig and --fap out" "$facecast" animate --text hi --vmc 127.0.0.1:39539 --out "$tmp/w.json"
expect_error "give --out FILE or --vmc" "$facecast" animate --text hi
# The sound beside the bundles: --play (ffplay; SDL's dummy output here) and --wav, which starts at
# frame 0 and lasts the speech.
SDL_AUDIODRIVER=dummy VMC_IDLE=off node tests/support/vmc_receive.mjs perfect-sync jawOpen -- "$facecast" animate \
  --text "Hello, papa. Open wide." --idle off --fps 30 --vmc "127.0.0.1:{port}" --play --wav "$tmp/s.wav"
seconds=$(ffprobe -v error -show_entries format=duration -of csv=p=0 "$tmp/s.wav")
python3 -c "import sys; d = float(sys.argv[1]); assert 1.5 < d < 2.5, d" "$seconds" ||
  fail "--wav: $seconds s of speech"
expect_error "there is no speech audio" "$facecast" animate \
  --timestamps tests/viseme/fixtures/rhubarb.tsv --vmc 127.0.0.1:39539 --play
expect_error "--play plays beside --vmc" "$facecast" animate --text hi --play --out "$tmp/w.json"
