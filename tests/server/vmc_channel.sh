#!/usr/bin/env bash
# A channel mirrored to a VMC receiver (channels.<name>.vmc): `facecast serve` with the channel,
# a producer's speak over HTTP, and an independent OSC receiver (tests/support/vmc_receive.mjs)
# that checks the bundles; a bad target in the config refuses to start in one line.
# Usage: vmc_channel.sh FACECAST SOURCE_DIR
set -euo pipefail
facecast=$1 src=$2
if [[ ${1:-} == --drive ]]; then
  # The receiver runs this with its port: serve, speak, wait for the utterance, stop.
  facecast=$2 port=$3 tmp=$4
  cat >"$tmp/server.json" <<JSON
{"channel_idle": 0,
 "channels": {"show": {"producer_token": "producer-secret-1",
                       "vmc": {"targets": ["127.0.0.1:$port"], "names": "perfect-sync"}}}}
JSON
  "$facecast" serve --config "$tmp/server.json" --port 0 --data "$tmp/data" >"$tmp/serve.out" 2>"$tmp/serve.err" &
  pid=$!
  trap 'kill $pid 2>/dev/null || true' EXIT
  for _ in $(seq 600); do grep -q "listening on" "$tmp/serve.out" && break; sleep 0.1; done
  url=$(sed -n 's/^facecast: listening on //p' "$tmp/serve.out")
  [[ -n $url ]] || { echo "serve did not start: $(cat "$tmp/serve.err")"; exit 1; }
  python3 - "$url" <<'PY'
import sys, urllib.request
req = urllib.request.Request(sys.argv[1] + "/api/channels/show/speak", method="POST",
                             data=b'{"id": "v1", "text": "Hello, papa. Open wide."}',
                             headers={"Authorization": "Bearer producer-secret-1",
                                      "Content-Type": "application/json"})
assert urllib.request.urlopen(req, timeout=10).status == 202
PY
  # Until the utterance has been played out (its stream_end in the log; slow under sanitizers),
  # then a moment for the last bundles.
  for _ in $(seq 300); do grep -q "stream_end.*id=v1" "$tmp/serve.err" && break; sleep 0.1; done
  sleep 0.5
  kill -TERM $pid; wait $pid || true
  exit 0
fi
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
cd "$src"
node tests/support/vmc_receive.mjs perfect-sync jawOpen -- bash "$0" --drive "$facecast" "{port}" "$tmp"
# A target that is not HOST:PORT: the server refuses to start, naming the field.
echo '{"channels": {"show": {"producer_token": "producer-secret-1", "vmc": {"targets": ["nowhere"]}}}}' >"$tmp/bad.json"
if "$facecast" serve --config "$tmp/bad.json" --port 0 --data "$tmp/data2" 2>"$tmp/err"; then
  echo "FAIL: serve started with a bad VMC target"; exit 1
fi
grep -q "channels.show.vmc.targets" "$tmp/err" || { echo "FAIL: $(cat "$tmp/err")"; exit 1; }
echo ok
