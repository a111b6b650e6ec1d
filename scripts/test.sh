#!/usr/bin/env bash
# One command from a fresh Debian 12 machine (as root) to a passing test suite: installs
# dependencies, builds (Release), and runs the fast tests under AddressSanitizer +
# UndefinedBehaviorSanitizer (build-asan/, clang), the slow ones and the checks of pace and time (label
# realtime, also run instrumented) in Release; then every server test, slow ones too, under ThreadSanitizer (build-tsan/,
# only the server and what it links; the checks of real-time behaviour are left out there), and
# every libFuzzer target for 30 s from its seed corpus (scripts/fuzz.sh, clang). With
# --no-sanitize, every test in Release.
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
stage() { echo "[$(date +%T)] $*"; }
# The next tree compiles in the background at the lowest CPU priority while this tree's tests run
# (they wait on sockets, subprocesses and real time for much of it): it takes only what they leave
# idle. Its output goes to DIR/build.log, printed if it fails. It runs as a process group of its
# own (job control, set -m), so that an exit stops all of it, but in this session: with the
# scheduler's autogroups a new session would be weighed equally with the tests, whatever its nice.
background=() background_log=
build_behind() {
  mkdir -p "$1"
  background_log=$1/build.log
  shift
  set -m
  nice -n 19 "$@" </dev/null >"$background_log" 2>&1 &
  background=($!)
  set +m
}
await_build() {
  ((${#background[@]})) || return 0
  wait "${background[0]}" || { tail -n 60 "$background_log" >&2; echo "build failed: $background_log" >&2; exit 1; }
  background=()
}
trap '((${#background[@]})) && kill -- "-${background[0]}" 2>/dev/null; true' EXIT

stage install
scripts/install-deps.sh
stage "Release build"
# With the sanitizer passes the Release tree first builds only what its own tests need
# (tests/CMakeLists.txt: release_checks); the rest of it is built behind the TSan tests.
if ((sanitize)); then
  scripts/build.sh build --target=release_checks
else
  scripts/build.sh build
fi
# Release runs the slow tests, which the ASan+UBSan tree leaves out, and the checks of pace and
# time (label realtime), which hold only uninstrumented; without the sanitizers, every test.
labels=() tsan_cases=()
if ((sanitize)); then
  labels=(-L 'slow|realtime')
  ((fast)) && labels=(-L realtime) tsan_cases=("~[slow]")
elif ((fast)); then
  labels=(-LE slow)
fi
# Both sanitizer trees at -O1: the ASan+UBSan tree took 75 minutes of compiler time at -O3 and
# 43 at -O1, for tests that run 21 minutes instead of 13.5 (docs/benchmarks.md#build-time). The
# ASan+UBSan tree is compiled by clang, in about three quarters of GCC's time.
o1=(-DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -g1 -DNDEBUG"
  -DCMAKE_C_FLAGS_RELWITHDEBINFO="-O1 -g1 -DNDEBUG" -DFACECAST_BUILD_BENCH=OFF)
((sanitize)) &&
  build_behind build-asan env CC=clang CXX=clang++ scripts/build.sh build-asan -DFACECAST_SANITIZE=ON "${o1[@]}"
stage "Release tests"
(cd build && ctest --output-on-failure -j2 "${labels[@]}")
if ((sanitize)); then
  stage "ASan+UBSan build (the rest of it)"
  await_build
  # ThreadSanitizer on the multi-threaded part: the server and its tests only (--fast: not the slow).
  build_behind build-tsan scripts/build.sh build-tsan --target=test_server -DFACECAST_TSAN=ON "${o1[@]}"
  export ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
  stage "ASan+UBSan tests"
  (cd build-asan && ctest --output-on-failure -j2 -LE slow)
  stage "TSan build (the rest of it)"
  await_build
  # Behind the TSan tests: the fuzzers, then the rest of the Release tree (benchmarks, other tests).
  build_behind build-fuzz bash -c 'scripts/fuzz.sh --build-only && scripts/build.sh build'
  stage "TSan tests"
  # test_server runs outside ctest here: the shared data comes through the same fixture first.
  (cd build-tsan && ctest -R '^extract_shared_data$' --output-on-failure >/dev/null)
  # One process per core, each half the cases (balanced by the Release and ASan runs' times); a
  # process stops at its first report, and its log (each case's seconds, -d yes) is printed when it fails.
  export TSAN_OPTIONS="halt_on_error=1 second_deadlock_stack=1 suppressions=$PWD/tests/server/tsan.supp"
  rm -rf build-tsan/split
  mkdir -p build-tsan/split
  # Catch's --list-test-names-only exits with the number of cases it listed.
  build-tsan/tests/server/test_server --list-test-names-only "${tsan_cases[@]}" >build-tsan/split/names ||
    true
  [ -s build-tsan/split/names ] || { echo "ThreadSanitizer: test_server listed no cases" >&2; exit 1; }
  python3 scripts/split_cases.py "$(nproc)" build-tsan/split build/Testing/Temporary/CTestCostData.txt \
    build-asan/Testing/Temporary/CTestCostData.txt <build-tsan/split/names
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
  stage "fuzz build and the rest of the Release tree"
  await_build
  stage fuzz
  scripts/fuzz.sh "${FACECAST_FUZZ_SECONDS:-30}"
fi
stage done
