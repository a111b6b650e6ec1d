#!/usr/bin/env bash
# Builds the libFuzzer targets with clang (build-fuzz/, ASan + UBSan + coverage) and runs each for a
# while from its committed seed corpus (tests/fuzz/corpus/<target>/), then replays the regression
# inputs (tests/fuzz/regressions/<target>/: inputs that once found a bug). Any crash, sanitizer
# report, leak, timeout or out-of-memory fails the run and leaves the input in build-fuzz/findings/.
# Targets run side by side, one per core.
# Usage: scripts/fuzz.sh [SECONDS_PER_TARGET (default 30) | --build-only] [TARGET ...]
set -euo pipefail
cd "$(dirname "$0")/.."
seconds=${1:-30}
shift || true
build_only=0
[ "$seconds" = --build-only ] && build_only=1
targets=("$@")
((${#targets[@]})) || targets=(fuzz_protocol fuzz_import fuzz_text fuzz_glb fuzz_gltf fuzz_obj fuzz_fap
  fuzz_image)

build_args=()
for t in "${targets[@]}"; do build_args+=(--target="$t"); done
# At -O1 with line tables, as the other sanitizer trees (scripts/test.sh): less compiler time than
# RelWithDebInfo's -O2 -g (docs/benchmarks.md#build-time); each target runs for a fixed time.
CC=clang CXX=clang++ scripts/build.sh build-fuzz "${build_args[@]}" -DFACECAST_FUZZ=ON \
  -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -g1 -DNDEBUG" \
  -DCMAKE_C_FLAGS_RELWITHDEBINFO="-O1 -g1 -DNDEBUG" -DFACECAST_BUILD_BENCH=OFF \
  -DFACECAST_BUILD_TESTS=OFF
((build_only)) && exit 0

export ASAN_OPTIONS=detect_leaks=1:allocator_may_return_null=1
export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
findings=build-fuzz/findings
mkdir -p "$findings"
# One target: its regression inputs, then `seconds` of fuzzing; non-zero on any finding.
run_target() {
  local t=$1 exe seeds work regressions log rc=0
  exe=$(find build-fuzz -type f -name "$t" -perm -u+x | head -n1)
  [ -n "$exe" ] || { echo "fuzz: $t was not built" >&2; return 1; }
  seeds=tests/fuzz/corpus/$t
  work=build-fuzz/corpus/$t
  mkdir -p "$work"
  regressions=tests/fuzz/regressions/$t
  if [ -d "$regressions" ] && [ -n "$(ls -A "$regressions")" ]; then
    echo "fuzz: $t replays $(ls "$regressions" | wc -l) regression inputs"
    "$exe" -rss_limit_mb=2048 -timeout=20 "$regressions"/* >"build-fuzz/$t.regressions.log" 2>&1 ||
      { tail -n 40 "build-fuzz/$t.regressions.log" >&2; echo "fuzz: $t failed a regression input" >&2; return 1; }
  fi
  echo "fuzz: $t for ${seconds}s"
  log=build-fuzz/$t.log
  "$exe" -max_total_time="$seconds" -rss_limit_mb=2048 -timeout=20 -max_len=65536 \
    -artifact_prefix="$findings/$t-" -print_final_stats=1 "$work" "$seeds" >"$log" 2>&1 || rc=$?
  grep -E '^(#[0-9]+ *DONE|stat::number_of_executed_units|stat::peak_rss_mb)' "$log" | sed "s/^/$t: /" || true
  if ((rc)) || compgen -G "$findings/$t-*" >/dev/null; then
    tail -n 40 "$log" >&2
    echo "fuzz: $t failed (exit $rc): $(ls "$findings/$t-"* 2>/dev/null)" >&2
    return 1
  fi
}

# As many targets at once as there are cores; after a failure no other target starts.
rm -f build-fuzz/failed-*
for t in "${targets[@]}"; do
  while (($(jobs -rp | wc -l) >= $(nproc))); do wait -n || true; done
  compgen -G "build-fuzz/failed-*" >/dev/null && break
  { run_target "$t" || touch "build-fuzz/failed-$t"; } &
done
wait
if compgen -G "build-fuzz/failed-*" >/dev/null; then
  echo "fuzz: failed: $(cd build-fuzz && ls failed-* | sed 's/^failed-//' | tr '\n' ' ')" >&2
  exit 1
fi
echo "fuzz: no findings"
