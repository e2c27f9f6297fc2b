#!/usr/bin/env bash
# The tests: installs what is missing (apt-get), builds (the same build as run.sh), runs every
# GoogleTest case through ctest with Vulkan validation on, then the sanitizer build's host-only
# suites and a short run of every fuzz target.
# Real-data cases use $COFUSION_DATA (default: ../shared/data beside this checkout) and skip when
# it is absent.
# Quick local loop without the slow real-data cases: ctest --test-dir build -E Slow
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
if [ -z "${COFUSION_DATA:-}" ] && [ -d "$root/../shared/data" ]; then
  export COFUSION_DATA="$(cd "$root/../shared/data" && pwd)"
fi
"$root/.ci/install-deps.sh"
"$root/.ci/fetch-models.sh" || echo "test.sh: no detector models (see above); the semantic detector is unavailable"
"$root/.ci/build.sh"
ctest --test-dir "$root/build" --output-on-failure --parallel 2 --timeout 900
# The same code under AddressSanitizer + UndefinedBehaviorSanitizer (a clang build in build-asan):
# the suites that need no Vulkan device and a 5-frame pipeline run; then every reader of outside
# data under libFuzzer for 10 s (tests/fuzz/README.md) in that build.
"$root/.ci/sanitize.sh"
"$root/.ci/fuzz.sh" 10
