#!/usr/bin/env bash
# One command from a fresh Debian 12 machine (as root) to a passing test suite:
# installs dependencies, builds (Release), runs every test through ctest, then builds again with
# AddressSanitizer + UndefinedBehaviorSanitizer and runs the fast tests there, and runs every server
# test, slow ones too, under ThreadSanitizer (build-tsan/, only the server and what it links; the
# checks of real-time behaviour are left out there), and runs every libFuzzer target for 30 s from
# its seed corpus (scripts/fuzz.sh, clang).
# Options: --fast  skip tests labelled slow (CI runs everything)
#          --no-sanitize  skip the sanitizer and fuzzing passes
set -euo pipefail
cd "$(dirname "$0")/.."
fast=0 sanitize=1
for a in "$@"; do
  case $a in
    --fast) fast=1 ;;
    --no-sanitize) sanitize=0 ;;
    *) echo "usage: scripts/test.sh [--fast] [--no-sanitize]" >&2; exit 2 ;;
  esac
done
scripts/install-deps.sh
scripts/build.sh build
labels=() tsan_cases=()
((fast)) && labels=(-LE slow) tsan_cases=("~[slow]")
(cd build && ctest --output-on-failure -j2 "${labels[@]}")
if ((sanitize)); then
  # Both sanitizer trees at -O1: the ASan+UBSan tree took 75 minutes of compiler time at -O3 and
  # 43 at -O1, for tests that run 21 minutes instead of 13.5 (docs/benchmarks.md#build-time).
  o1=(-DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -g1 -DNDEBUG"
    -DCMAKE_C_FLAGS_RELWITHDEBINFO="-O1 -g1 -DNDEBUG" -DFACECAST_BUILD_BENCH=OFF)
  scripts/build.sh build-asan -DFACECAST_SANITIZE=ON "${o1[@]}"
  export ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
  (cd build-asan && ctest --output-on-failure -j2 -LE slow)
  # ThreadSanitizer on the multi-threaded part: the server and its tests only (--fast: not the slow).
  scripts/build.sh build-tsan --target=test_server -DFACECAST_TSAN=ON "${o1[@]}"
  # test_server runs outside ctest here: the shared data comes through the same fixture first.
  (cd build-tsan && ctest -R '^extract_shared_data$' --output-on-failure >/dev/null)
  # One process per core, each half the cases (balanced by the Release run's times); a process
  # stops at its first report, and its log (each case's seconds, -d yes) is printed when it fails.
  export TSAN_OPTIONS="halt_on_error=1 second_deadlock_stack=1 suppressions=$PWD/tests/server/tsan.supp"
  rm -rf build-tsan/split
  mkdir -p build-tsan/split
  # Catch's --list-test-names-only exits with the number of cases it listed.
  build-tsan/tests/server/test_server --list-test-names-only "${tsan_cases[@]}" >build-tsan/split/names ||
    true
  [ -s build-tsan/split/names ] || { echo "ThreadSanitizer: test_server listed no cases" >&2; exit 1; }
  python3 scripts/split_cases.py build/Testing/Temporary/CTestCostData.txt "$(nproc)" build-tsan/split \
    <build-tsan/split/names
  pids=()
  for f in build-tsan/split/cases-*.txt; do
    build-tsan/tests/server/test_server -f "$f" -d yes >"${f%.txt}.log" 2>&1 &
    pids+=($!)
  done
  failed=0
  for i in "${!pids[@]}"; do
    wait "${pids[$i]}" && continue
    failed=1
    tail -n 300 "build-tsan/split/cases-$i.log" >&2
  done
  ((failed == 0)) || { echo "ThreadSanitizer: the server tests failed (build-tsan/split/*.log)" >&2; exit 1; }
  grep -h "test cases" build-tsan/split/cases-*.log || true
  scripts/fuzz.sh "${FACECAST_FUZZ_SECONDS:-30}"
fi
