#!/usr/bin/env bash
# The main job: installs what is missing (apt-get), builds, and runs `cofusion run --headless`.
# Without --input it runs the built-in dynamic scene table_placement (a box, a can and a ball
# carried in from outside the view and put down on a table, as in the paper's demonstration) and
# ends with a table of the models it made and the camera's error against the scene's ground truth.
# Arguments are passed to `cofusion run` (see `build/app/cofusion run --help`), e.g.
#   ./run.sh --input tum:PATH/rgbd_dataset_freiburg3_walking_xyz
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
"$root/.ci/install-deps.sh"
"$root/.ci/fetch-models.sh" || echo "run.sh: no detector models (see above); the semantic detector is unavailable"
"$root/.ci/build.sh"
input=(--input synthetic:table_placement)
for arg in "$@"; do
  case "$arg" in --input | --input=*) input=() ;; esac
done
exec "$root/build/app/cofusion" run --headless "${input[@]}" "$@"
