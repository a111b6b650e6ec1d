#!/usr/bin/env bash
# One command from a fresh Debian 12 machine (as root) to the running product:
# installs dependencies, builds, and starts `facecast serve` on the built-in default avatar at
# http://127.0.0.1:8080 (configs/server.json; extra arguments go to `facecast serve`).
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install-deps.sh
scripts/build.sh build
exec build/server/facecast serve "$@"
