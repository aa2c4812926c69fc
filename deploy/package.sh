#!/usr/bin/env bash
# Builds the Debian package: bash deploy/package.sh  ->  build/rgbdmap_<version>_<arch>.deb
# Release build under the prefix /usr (configuration in /etc/rgbdmap, see cmake/RgbdmapInstall.cmake), then
# CPack; runtime library dependencies come from dpkg-shlibdeps (dpkg-dev, installed by deploy/install_deps.sh).
# BUILD_DIR (default build) and JOBS (default 2) may be set; an existing build folder keeps its other options.
# Check: dpkg-deb -I build/rgbdmap_*.deb (Depends), dpkg-deb -c build/rgbdmap_*.deb (files).
set -euo pipefail
cd "$(dirname "$0")/.."
build="${BUILD_DIR:-build}"
command -v dpkg-shlibdeps >/dev/null || { echo "dpkg-shlibdeps missing: sudo apt-get install dpkg-dev" >&2; exit 1; }
launcher=()
command -v ccache >/dev/null && launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache -DCMAKE_C_COMPILER_LAUNCHER=ccache)
cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release -DCMAKE_INSTALL_PREFIX=/usr "${launcher[@]}"
nice -n 10 cmake --build "$build" -j"${JOBS:-2}"
(cd "$build" && cpack -G DEB)
ls -l "$build"/rgbdmap_*.deb
