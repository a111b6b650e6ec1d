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
    --text "Hello, papa. Open wide." --idle off --fps 30 --vmc "127.0.0.1:{port}" --vmc-names "${names%%:*}"
done
expect_error "is not HOST:PORT" "$facecast" animate --text hi --vmc 127.0.0.1
expect_error "no port between 1 and 65535" "$facecast" animate --text hi --vmc 127.0.0.1:70000
expect_error "leave --out, --rig and --fap out" "$facecast" animate --text hi --vmc 127.0.0.1:39539 --out "$tmp/w.json"
expect_error "give --out FILE or --vmc" "$facecast" animate --text hi
