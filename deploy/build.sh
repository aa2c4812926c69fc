#!/usr/bin/env bash
# Installs missing dependencies, configures (once) and builds rgbdmap into build/ (binaries in build/bin/).
# Environment: BUILD_DIR (default build), BUILD_TYPE (default Release), CI=true turns warnings into errors.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
"$root/deploy/install_deps.sh"
build_dir=${BUILD_DIR:-$root/build}
werror=OFF
[ "${CI:-}" = "true" ] && werror=ON
cmake -S "$root" -B "$build_dir" -G Ninja -DCMAKE_BUILD_TYPE="${BUILD_TYPE:-Release}" \
  -DRGBDMAP_WERROR="$werror" ${CMAKE_EXTRA_ARGS:-} >/dev/null
cmake --build "$build_dir" -j "$(nproc)"
