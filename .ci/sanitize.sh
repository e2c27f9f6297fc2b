#!/usr/bin/env bash
# AddressSanitizer + UndefinedBehaviorSanitizer: builds cofusion and the host-only test suites in
# ./build-asan (.ci/configure-asan.sh: clang, -O1), runs those suites (no Vulkan: io, eval,
# synthetic, export, segmentation, semantic) and one short pipeline run on lavapipe with validation.
# Leaks of the Vulkan driver and the libraries it loads are suppressed
# (.ci/sanitizer-suppressions/lsan.txt); everything else fails the script.
# Usage: .ci/sanitize.sh   (JOBS=N sets the build's and the tests' parallelism)
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="$root/build-asan"
jobs="${JOBS:-$(nproc)}"
if [ -z "${COFUSION_MODELS:-}" ] && [ -d "$root/build/models" ]; then export COFUSION_MODELS="$root/build/models"; fi
"$root/.ci/configure-asan.sh"
# Only what is run below: the executable and the host-only suites.
cmake --build "$build" --parallel "$jobs" --target cofusion cofusion_io_tests cofusion_eval_tests \
  cofusion_synthetic_tests cofusion_export_tests cofusion_segmentation_tests cofusion_semantic_tests >/dev/null

export ASAN_OPTIONS="detect_leaks=1:abort_on_error=1:detect_odr_violation=0:strict_string_checks=1"
export LSAN_OPTIONS="suppressions=$root/.ci/sanitizer-suppressions/lsan.txt:print_suppressions=0"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1"

# The suites that use no Vulkan device (labels set in tests/CMakeLists.txt); the glTF validator
# tests run node, not our code.
log="$build/sanitize-tests.log"
if ! ctest --test-dir "$build" --output-on-failure --parallel "$jobs" --timeout 900 -E 'Slow|GltfValidator' \
  -L '^(io|eval|synthetic|export|segmentation|semantic)$' >"$log" 2>&1; then
  tail -n 80 "$log"
  echo "sanitize.sh: a host-only test failed under the sanitizers (log: $log)" >&2
  exit 1
fi
grep -E "tests passed" "$log"

out="$(mktemp -d)"
trap 'rm -rf "$out"' EXIT
# The Vulkan loader unloads the driver at vkDestroyInstance, before LeakSanitizer looks: the
# driver's leaks then show as "<unknown module>" and no suppression by name can match them (Mesa
# 22.3.6-1+deb12u2: 128 bytes). Preloaded, lavapipe stays loaded and its leaks are named.
lvp="$(ls /usr/lib/*/libvulkan_lvp.so 2>/dev/null | head -n 1 || true)"
LD_PRELOAD="${lvp}" MESA_SHADER_CACHE_DIR="$build/mesa-shader-cache" "$build/app/cofusion" run --headless --validation \
  --input synthetic:two_objects --max-frames 5 --semantic-source none --output "$out/run" >/dev/null
test -f "$out/run/summary.json"
echo "sanitize.sh: clean"
