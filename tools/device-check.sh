#!/bin/bash
# Runs on the lent GPU machine, from the repository's root: unpacks PACK (tools/pack-for-device.sh),
# runs the GPU tests (validation on) and `cofusion bench` on the built-in scenes with the device's
# default queues and with 8, writing each report under OUT_DIR. The Vulkan loader must be there
# (on this project's lent machines: Debian's libvulkan1 and glvnd packages unpacked into /).
# Usage: tools/device-check.sh PACK OUT_DIR
set -uo pipefail
pack=${1:?pack.tar.xz}; out=${2:?output folder}
d=$(mktemp -d); tar -C "$d" -xJf "$pack"; mkdir -p "$out"
export LD_LIBRARY_PATH=$d/lib VK_LAYER_PATH=$d/layers COFUSION_SOURCE_DIR=$PWD
c=$d/bin/cofusion
$c bench --list-devices
for t in kernels gpu renderer; do
  echo "== $t tests"; "$d/bin/cofusion_${t}_tests" --gtest_brief=1 2>&1 | grep -E "PASSED|FAILED|Failure|first mismatch"
done
# Of the SLAM tests those that compare GPU paths: tracking (lockstep included), the motion
# kernels, a whole scene's runs mapped and through staging buffers, which must be identical, and
# the host work beside the GPU against in line.
echo "== slam tests (GPU paths)"
"$d/bin/cofusion_slam_tests" --gtest_brief=1 \
  --gtest_filter='Tracking.*:MotionKernels*:CoFusionScenes.RunsOfOneSceneAreBitIdentical*:CoFusionScenes.HostWorkBeside*' 2>&1 |
  grep -E "PASSED|FAILED|Failure"
$c bench --no-semantic --json "$out/bench.json" > "$out/bench.txt" 2>&1; echo "bench: exit $?"
grep -E "^device|active model|whole frame|frames per second" "$out/bench.txt"
$c bench --no-kernels --no-pipeline --no-semantic --queues 8 --json "$out/bench_q8.json" > "$out/bench_q8.txt" 2>&1
echo "bench --queues 8: exit $?"; grep -E "^device|active model" "$out/bench_q8.txt"
