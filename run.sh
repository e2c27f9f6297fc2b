#!/usr/bin/env bash
# The main job: installs what is missing (apt-get), builds, and runs `cofusion run` on the
# built-in synthetic scene. Arguments are passed to `cofusion run` (see `build/app/cofusion run --help`).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
"$root/.ci/install-deps.sh"
"$root/.ci/fetch-models.sh" || echo "run.sh: no detector models (see above); the semantic detector is unavailable"
"$root/.ci/build.sh"
exec "$root/build/app/cofusion" run --headless "$@"
