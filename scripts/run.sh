#!/usr/bin/env bash
# One command from a fresh Debian 12 machine (as root) to the running product:
# installs dependencies, builds, and starts `facecast serve` on the built-in default avatar.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install-deps.sh
scripts/build.sh build
if build/server/facecast serve --help >/dev/null 2>&1; then
  exec build/server/facecast serve "$@"
fi
# Until the server lands, show what the binary can do.
exec build/server/facecast --help
