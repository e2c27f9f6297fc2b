#!/usr/bin/env bash
# AddressSanitizer + UndefinedBehaviorSanitizer: builds the tree with COFUSION_SANITIZE=ON in
# ./build-asan (RelWithDebInfo: readable stacks), runs the host-only test suites (no Vulkan:
# io, eval, synthetic, export, segmentation, semantic) and one short pipeline run on lavapipe.
# Leaks of the Vulkan driver and the libraries it loads are suppressed
# (.ci/sanitizer-suppressions/lsan.txt); everything else fails the script.
# Usage: .ci/sanitize.sh [extra cmake arguments]   (JOBS=N sets the build's parallelism)
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="$root/build-asan"
# The detector's models, when the normal build has fetched them (tests needing them skip otherwise).
if [ -z "${COFUSION_MODELS:-}" ] && [ -d "$root/build/models" ]; then export COFUSION_MODELS="$root/build/models"; fi
# The glTF validator (npm) of the normal build, so this one need not fetch it again.
if [ -d "$root/build/node" ] && [ ! -d "$build/node" ]; then mkdir -p "$build" && cp -r "$root/build/node" "$build/node"; fi
cmake -S "$root" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCOFUSION_SANITIZE=ON -DCOFUSION_WERROR=ON "$@" >/dev/null
# Only what is run below: the executable and the host-only suites.
cmake --build "$build" --parallel "${JOBS:-$(nproc)}" --target cofusion cofusion_io_tests cofusion_eval_tests \
  cofusion_synthetic_tests cofusion_export_tests cofusion_segmentation_tests cofusion_semantic_tests

export ASAN_OPTIONS="detect_leaks=1:abort_on_error=1:detect_odr_violation=0:strict_string_checks=1"
export LSAN_OPTIONS="suppressions=$root/.ci/sanitizer-suppressions/lsan.txt:print_suppressions=0"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1"

# The suites that use no Vulkan device (labels set in tests/CMakeLists.txt); the glTF validator
# tests run node, not our code.
ctest --test-dir "$build" --output-on-failure --parallel "${JOBS:-$(nproc)}" --timeout 900 -E 'Slow|GltfValidator' \
  -L '^(io|eval|synthetic|export|segmentation|semantic)$'

out="$(mktemp -d)"
trap 'rm -rf "$out"' EXIT
MESA_SHADER_CACHE_DIR="$build/mesa-shader-cache" "$build/app/cofusion" run --headless --validation \
  --input synthetic:two_objects --max-frames 5 --semantic-source none --output "$out/run"
test -f "$out/run/summary.json"
echo "sanitize.sh: clean"
