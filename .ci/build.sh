#!/usr/bin/env bash
# Configures and builds cofusion-vk in ./build (Release, Ninja, warnings as errors). run.sh and
# test.sh both call it without arguments, so they share one configuration and one build: whichever
# runs second builds only what changed. Extra arguments are passed to cmake's configure step
# (they change the configuration for every later build in ./build too).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cmake -S "$root" -B "$root/build" -G Ninja -DCMAKE_BUILD_TYPE=Release -DCOFUSION_WERROR=ON "$@" >/dev/null
cmake --build "$root/build" --parallel "$(nproc)"
