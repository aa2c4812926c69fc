#!/usr/bin/env bash
# Transport benchmark (memq://, udpm://, dds://) inside a private, loopback-only network namespace so no
# multicast or DDS discovery leaves the machine. Needs root (unshare -n). Builds bench_transport if missing.
# Usage: bash deploy/bench_transport.sh [--only memq|udpm|dds] [--keyframes N]
set -euo pipefail
repo="$(cd "$(dirname "$0")/.." && pwd)"
bin="$repo/build/bin/bench_transport"
if [ ! -x "$bin" ]; then
  cmake -S "$repo" -B "$repo/build" -G Ninja -DCMAKE_BUILD_TYPE=Release -DRGBDMAP_BUILD_BENCHMARKS=ON >/dev/null
  ninja -C "$repo/build" -j2 bench_transport
fi
export CYCLONEDDS_URI="file://$repo/deploy/dds/cyclonedds-loopback.xml"
exec bash "$repo/tests/transport/run_in_netns.sh" "$bin" "$@"
