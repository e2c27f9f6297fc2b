#!/bin/bash
# Packs the built binaries for a machine without this project's dependencies (a lent GPU machine:
# another Linux, glibc at least Debian 12's): cofusion, the GPU test binaries (and the SLAM tests'), every shared library
# they load except glibc's and the C++ runtime, and the Vulkan validation layer, as one .tar.xz
# (about 57 MB). tools/device-check.sh runs them there.
# Usage: tools/pack-for-device.sh BUILD_DIR OUT_DIR   (writes OUT_DIR/pack.tar.xz)
set -euo pipefail
build=${1:?build folder}; out=${2:?output folder}
work=$(mktemp -d); trap 'rm -rf "$work"' EXIT
mkdir -p "$work/bin" "$work/lib" "$work/layers" "$out"
bins=("$build/app/cofusion" "$build"/tests/cofusion_{kernels,gpu,renderer,slam}_tests)
cp "${bins[@]}" "$work/bin/"
for b in "${bins[@]}"; do ldd "$b"; done | awk '$3 ~ /^\// {print $3}' | sort -u |
  grep -vE '/(libc|libm|libdl|libpthread|librt|ld-linux-x86-64|libstdc\+\+|libgcc_s)\.so' |
  xargs -I{} cp -L {} "$work/lib/"
cp /usr/lib/x86_64-linux-gnu/libVkLayer_khronos_validation.so "$work/lib/"
cp /usr/share/vulkan/explicit_layer.d/VkLayer_khronos_validation.json "$work/layers/"
tar -C "$work" -cf - bin lib layers | xz -6 -T0 > "$out/pack.tar.xz"
echo "wrote $out/pack.tar.xz ($(du -h "$out/pack.tar.xz" | cut -f1))"
