#!/usr/bin/env bash
# Builds rgbdmap and runs its tests through CTest. Every test carries tier labels (tests/CMakeLists.txt;
# a GoogleTest case's next to it in its source, tests/test_tier.hpp):
#   unit   fast, no I/O beyond temporary files, no network
#   e2e    end-to-end runs on synthetic or real data (odometry, loop closure, the server, the programs)
#   slow   more than ~20 s in Release (always e2e too)
#   netns  network tests in a private loopback-only namespace (skipped without root)
#   cli    the programs driven by shell scripts (cli.*, run.transports.netns, integration.*, faults.*,
#          viewer.*)
#   accuracy  e2e tests of accuracy bounds on whole sequences (odometry, full system on fr1_rpy)
#   sanitize  the tests run under AddressSanitizer + UBSan: every GoogleTest unit test, the e2e tests that
#          feed forged, malformed or corrupt input (decoders, forged messages, chunk reassembly, bad images,
#          a full disk, refused configurations) and the short network tests (transport.netns,
#          server.chunked.netns)
# Usage:
#   bash deploy/test.sh           the full suite (CI), each test once: the Release build (unity), every test
#                                 but the sanitize tier in Release (build/), then the sanitize tier under
#                                 ASan + UBSan (build-asan/, RelWithDebInfo at -O1, the orchestrating
#                                 libraries and the tests' own code at -O0 (cmake/RgbdmapWarnings.cmake):
#                                 only the GoogleTest executables and the relay they start are built, unity,
#                                 and each executable runs its cases in a few processes, not one per case
#                                 (tests/cmake/test_suite.cmake); the long server runs, the cli tier's
#                                 multi-process runs and the accuracy tests run in Release only: under ASan
#                                 they take 1-2 min each and repeat code paths the sanitize tier covers). Its
#                                 time on a fresh Debian 12 root with 2 cores is in docs/results.md
#   bash deploy/test.sh --quick   the unit tier only, Release, no sanitizers (about a minute after the build)
#   Further arguments go to both ctest runs, e.g. `bash deploy/test.sh -L e2e` or `-R '^server\.'` (the
#   sanitizer tree names its tests by executable: test_map_server.unit.1of2, test_map_server.e2e).
# Tests needing ../shared/data skip when it is absent. By hand: `ctest --test-dir build -j 4 -L unit` (or
# e2e, slow, netns, cli, accuracy, faults, sanitize; -LE to exclude; -j: two slots per core, as below).
# Environment: BUILD_DIR (Release tree, default build), RGBDMAP_SKIP_SANITIZERS=1 skips the sanitizer pass
# and runs the sanitize tier in Release instead.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
quick=0
if [ "${1:-}" = "--quick" ]; then
  quick=1
  shift
fi
"$root/deploy/build.sh"
build_dir=$(cd "${BUILD_DIR:-$root/build}" && pwd)
# Two process slots per core: a test takes two, one that mostly waits takes one (tests/CMakeLists.txt).
slots=$((2 * $(nproc)))
if [ "$quick" = 1 ]; then
  exec ctest --test-dir "$build_dir" --output-on-failure -j "$slots" -L '^unit$' "$@"
fi
if [ "${RGBDMAP_SKIP_SANITIZERS:-0}" = "1" ]; then
  exec ctest --test-dir "$build_dir" --output-on-failure -j "$slots" "$@"
fi
# The sanitize tier runs under the sanitizers below, the rest here (`ctest --test-dir build` runs all).
ctest --test-dir "$build_dir" --output-on-failure -j "$slots" -LE '^sanitize$' "$@"
echo "== sanitizer pass (ASan + UBSan): the sanitize tier"
# The server tests' recorded keyframe stream is copied from the Release tree (byte-identical). Only the
# GoogleTest executables (rgbdmap_test_executables), unity (16 sources per compiler run), the libraries at
# -O1 -g1 and the tests' own code at -O0 (tests/cmake/test_suite.cmake). Not built in the background during the
# Release tests: that load would slow every test of the Release pass.
BUILD_DIR="$root/build-asan" BUILD_TYPE=RelWithDebInfo BUILD_TARGETS=rgbdmap_test_executables \
CMAKE_EXTRA_ARGS="-DRGBDMAP_SANITIZE=ON -DRGBDMAP_BUILD_BENCHMARKS=OFF \
-DRGBDMAP_KEYFRAME_FIXTURE_FROM=$build_dir/tests/fixtures" \
  "$root/deploy/build.sh"
export UBSAN_OPTIONS=halt_on_error=1:print_stacktrace=1 ASAN_OPTIONS=detect_leaks=1
log="$root/build-asan/sanitizer_tests.log"
if ! ctest --test-dir "$root/build-asan" --output-on-failure -j "$slots" -L '^sanitize$' "$@" 2>&1 | tee "$log"; then
  # LeakSanitizer's own tracer sometimes crashes at exit after a test passed ("Tracer caught signal 11",
  # google/sanitizers#1353): not a leak, not our failure. Then, and only then, the failed tests run again.
  grep -q "LeakSanitizer has encountered a fatal error" "$log" || exit 1
  echo "== LeakSanitizer's tracer crashed (google/sanitizers#1353): the failed tests once more"
  ctest --test-dir "$root/build-asan" --output-on-failure --rerun-failed
fi
