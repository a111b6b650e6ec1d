#!/usr/bin/env bash
# One command from a fresh Debian 12 machine (as root) to the running product:
# installs dependencies, builds, and starts `facecast serve` on the built-in default avatar at
# http://127.0.0.1:8080 (configs/server.json; extra arguments go to `facecast serve`).
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install-deps.sh --serve
# Only what serving needs: the executable (with the lexicon and lip-sync templates it reads);
# scripts/test.sh builds the tests and benchmarks.
scripts/build.sh build --target=facecast
exec build/app/facecast serve "$@"
