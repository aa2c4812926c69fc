#!/usr/bin/env bash
# The main job on its embedded default: builds, then `rgbdmap run` (synthesises a sequence when no
# dataset is given). Extra arguments are passed to `rgbdmap run`, e.g. --dataset DIR --out DIR.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
"$root/deploy/build.sh"
exec "${BUILD_DIR:-$root/build}/bin/rgbdmap" run "$@"
