#!/usr/bin/env bash
# Configures ./build-asan, the one sanitizer build that .ci/sanitize.sh and .ci/fuzz.sh share:
# clang, AddressSanitizer + UndefinedBehaviorSanitizer and libFuzzer's coverage instrumentation on
# every target (COFUSION_FUZZ=ON), -O1 with line tables only (readable stacks; a quarter of the
# compile time of RelWithDebInfo). Both scripts configure it the same way, so neither rebuilds
# what the other built.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="$root/build-asan"
# The detector's models of the normal build (tests needing them skip otherwise), and its glTF
# validator (npm), so this build need not fetch it again.
if [ -z "${COFUSION_MODELS:-}" ] && [ -d "$root/build/models" ]; then export COFUSION_MODELS="$root/build/models"; fi
if [ -d "$root/build/node" ] && [ ! -d "$build/node" ]; then mkdir -p "$build" && cp -r "$root/build/node" "$build/node"; fi
# A build folder configured with another compiler (gcc, before 2026-11-25) starts afresh.
if [ -f "$build/CMakeCache.txt" ] && ! grep -q "CMAKE_CXX_COMPILER:.*clang" "$build/CMakeCache.txt"; then
  rm -rf "$build/CMakeCache.txt" "$build/CMakeFiles"
fi
flags="-O1 -gline-tables-only"
CC=clang CXX=clang++ cmake -S "$root" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  "-DCMAKE_CXX_FLAGS_RELWITHDEBINFO=$flags" "-DCMAKE_C_FLAGS_RELWITHDEBINFO=$flags" \
  -DCOFUSION_FUZZ=ON -DCOFUSION_BUILD_TESTS=ON >/dev/null
