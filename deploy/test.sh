#!/usr/bin/env bash
# Builds and runs the whole test suite (CTest), then the GoogleTest suites again under AddressSanitizer +
# UBSan (build-asan/). Tests needing ../shared/data skip when it is absent.
# The multi-process integration test runs in the first pass only (timing-sensitive under ASan on 2 cores).
# Environment: RGBDMAP_SKIP_SANITIZERS=1 skips the sanitizer pass (quicker local runs).
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
"$root/deploy/build.sh"
ctest --test-dir "${BUILD_DIR:-$root/build}" --output-on-failure -j "$(nproc)" "$@"
if [ "${RGBDMAP_SKIP_SANITIZERS:-0}" != "1" ]; then
  echo "== sanitizer pass (ASan + UBSan)"
  BUILD_DIR="$root/build-asan" BUILD_TYPE=RelWithDebInfo \
    CMAKE_EXTRA_ARGS="-DRGBDMAP_SANITIZE=ON -DRGBDMAP_BUILD_BENCHMARKS=OFF" "$root/deploy/build.sh"
  UBSAN_OPTIONS=halt_on_error=1:print_stacktrace=1 ASAN_OPTIONS=detect_leaks=1 \
    ctest --test-dir "$root/build-asan" --output-on-failure -j "$(nproc)" -E '^(cli|integration)\.' "$@"
fi
