#!/usr/bin/env bash
# Configures and builds Facecast.
# Usage: scripts/build.sh [BUILD_DIR] [--target=T ...] [extra cmake args...]
# Compiles through ccache when it is installed (install-deps does): the cache is keyed on paths
# relative to this checkout, so a fresh clone anywhere reuses what an earlier build compiled.
set -euo pipefail
cd "$(dirname "$0")/.."
dir=${1:-build}
shift || true
configure=() targets=()
for a in "$@"; do
  case $a in
    --target=*) targets+=(--target "${a#--target=}") ;;
    *) configure+=("$a") ;;
  esac
done
if command -v ccache >/dev/null 2>&1; then
  export CCACHE_BASEDIR=$PWD CCACHE_NOHASHDIR=1
  configure=(-DCMAKE_C_COMPILER_LAUNCHER=ccache -DCMAKE_CXX_COMPILER_LAUNCHER=ccache "${configure[@]}")
fi
cmake -S . -B "$dir" -G Ninja -DCMAKE_BUILD_TYPE=Release "${configure[@]}" >/dev/null
cmake --build "$dir" -j2 "${targets[@]}"
