#!/usr/bin/env bash
# libFuzzer runs of every reader of outside data (tests/fuzz/README.md). Builds the targets in
# ./build-asan (.ci/configure-asan.sh: clang, ASan, UBSan) and runs each for SECONDS (default 15)
# from the committed seeds (tests/fuzz/corpus/<target>/) and what earlier runs in this build
# folder added (build-asan/corpus/<target>/). A crash, leak, sanitizer report, uncaught
# exception, input slower than 10 s or allocation over 2 GB fails the script; the input is kept
# in build-asan/findings/<target>/ and the log in build-asan/fuzz-logs/<target>.txt.
# Usage: .ci/fuzz.sh [SECONDS] [TARGET...]   (TARGET: klg, ply, ...; JOBS=N runs N at once)
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="$root/build-asan"
seconds="${1:-15}"
shift || true
jobs="${JOBS:-$(nproc)}"

"$root/.ci/configure-asan.sh"
cmake --build "$build" --parallel "$jobs" --target fuzzers >/dev/null

targets=("$@")
if [ ${#targets[@]} -eq 0 ]; then
  for seeds in "$root"/tests/fuzz/corpus/*/; do targets+=("$(basename "$seeds")"); done
fi

run_target() {
  local t="$1"
  mkdir -p "$build/corpus/$t" "$build/findings/$t" "$build/fuzz-logs"
  "$build/tests/fuzz/fuzz_$t" -max_total_time="$seconds" -rss_limit_mb=2048 -malloc_limit_mb=2048 -timeout=10 \
    -print_final_stats=1 -artifact_prefix="$build/findings/$t/" "$build/corpus/$t" "$root/tests/fuzz/corpus/$t" \
    >"$build/fuzz-logs/$t.txt" 2>&1
}

declare -A pid_of
failed=()
for t in "${targets[@]}"; do
  [ -x "$build/tests/fuzz/fuzz_$t" ] || { echo "fuzz.sh: no target fuzz_$t" >&2; exit 2; }
  while [ "$(jobs -rp | wc -l)" -ge "$jobs" ]; do wait -n || true; done
  run_target "$t" &
  pid_of[$t]=$!
done
for t in "${targets[@]}"; do
  log="$build/fuzz-logs/$t.txt"
  status=0
  wait "${pid_of[$t]}" || status=$?
  runs="$(grep -a -o 'stat::number_of_executed_units: *[0-9]*' "$log" | grep -o '[0-9]*$' || echo 0)"
  if [ "$status" -eq 0 ]; then
    echo "fuzz.sh: $t: $runs inputs in ${seconds} s, clean"
  else
    echo "fuzz.sh: $t: FAILED (log: $log, input: $build/findings/$t/)"
    grep -a -E "ERROR|SUMMARY|what\(\)|#[0-9]+ .* in cofusion" "$log" | head -12 || true
    failed+=("$t")
  fi
done
if [ ${#failed[@]} -gt 0 ]; then
  echo "fuzz.sh: ${#failed[@]} target(s) failed: ${failed[*]}" >&2
  exit 1
fi
echo "fuzz.sh: clean"
