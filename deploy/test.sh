#!/usr/bin/env bash
# Builds and runs the whole test suite (CTest). Tests needing ../shared/data skip when it is absent.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
"$root/deploy/build.sh"
ctest --test-dir "${BUILD_DIR:-$root/build}" --output-on-failure -j "$(nproc)" "$@"
