#!/usr/bin/env bash
# The main job: installs what is missing (apt-get), builds, and runs `cofusion run` on the
# built-in synthetic scene. Arguments are passed to `cofusion run` (see `build/app/cofusion run --help`).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
"$root/.ci/install-deps.sh"
"$root/.ci/build.sh"
exec "$root/build/app/cofusion" run --headless "$@"
