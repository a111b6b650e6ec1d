#!/usr/bin/env bash
# facecast animate --vmc: an independent OSC receiver (tests/support/vmc_receive.mjs, npm `osc`) gets
# one bundle per frame in real time with Perfect Sync and VRM 0.x names; bad targets are one-line
# errors.
# Usage: cli_vmc.sh FACECAST SOURCE_DIR
set -euo pipefail
facecast=$1 src=$2
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
fail() { echo "FAIL: $*"; exit 1; }
expect_error() {  # expect_error PATTERN COMMAND...: non-zero exit, one line naming PATTERN
  local pattern=$1; shift
  if "$@" 2>"$tmp/err"; then fail "succeeded: $*"; fi
  grep -q -- "$pattern" "$tmp/err" || fail "message lacks '$pattern': $(cat "$tmp/err")"
  [[ $(wc -l <"$tmp/err") -eq 1 ]] || fail "more than one line: $(cat "$tmp/err")"
}
cd "$src"
for names in perfect-sync:jawOpen vrm0:A; do
  node tests/support/vmc_receive.mjs "${names%%:*}" "${names#*:}" -- "$facecast" animate \
    --text "Hello, papa. Open wide." --idle off --fps 30 --vmc "127.0.0.1:{port}" --vmc-names "${names%%:*}"
done
expect_error "is not HOST:PORT" "$facecast" animate --text hi --vmc 127.0.0.1
expect_error "no port between 1 and 65535" "$facecast" animate --text hi --vmc 127.0.0.1:70000
expect_error "leave --out and --rig out" "$facecast" animate --text hi --vmc 127.0.0.1:39539 --out "$tmp/w.json"
expect_error "give --out FILE or --vmc" "$facecast" animate --text hi
