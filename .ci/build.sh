#!/usr/bin/env bash
# Configures and builds cofusion-vk in ./build (Release, Ninja). Used by run.sh and test.sh.
# Extra arguments are passed to cmake's configure step (e.g. -DCOFUSION_WERROR=ON).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cmake -S "$root" -B "$root/build" -G Ninja -DCMAKE_BUILD_TYPE=Release "$@" >/dev/null
cmake --build "$root/build" --parallel "$(nproc)"
