#!/usr/bin/env bash
# The live map viewer under load (issue #13): a two-robot run over LCM (deploy/run_multiprocess.sh --viewer,
# separate processes, private loopback-only namespace) with 1 and then 10 Foxglove reference clients
# (tests/viewer/bench_clients.js, Node + npm @foxglove/ws-protocol) subscribed to every channel. Prints, per
# client count: the viewer process's CPU (user + system over the run's wall time), bytes per second to all
# clients and to one, and the latency of incremental voxel updates from the server's map update to the client.
# Usage: bash deploy/bench_viewer.sh [--frames F]
set -euo pipefail
repo="$(cd "$(dirname "$0")/.." && pwd)"
bin="${RGBDMAP_BIN:-$repo/build/bin}"
frames=300
[ "${1:-}" = "--frames" ] && frames="$2"
node_dir="${RGBDMAP_NODE_DIR:-/usr/local/lib/rgbdmap-node}"
[ -f "$node_dir/node_modules/@foxglove/ws-protocol/package.json" ] \
  || { echo "needs node and @foxglove/ws-protocol in $node_dir (deploy/install_deps.sh)" >&2; exit 1; }
if [ -z "${RGBDMAP_TRANSPORT_NETNS:-}" ]; then
  exec bash "$repo/tests/transport/run_in_netns.sh" bash "$0" "$@"
fi
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
port=18770
printf '%-8s %8s %10s %14s %16s %14s %12s\n' clients wall_s cpu_% "KB/s all" "KB/s per client" "latency med ms" "p90 ms"
for n in 1 10; do
  RGBDMAP_VIEWER_PROBE="NODE_PATH=$node_dir/node_modules node $repo/tests/viewer/bench_clients.js 127.0.0.1 $port $n" \
    bash "$repo/deploy/run_multiprocess.sh" --transport lcm --robots 2 --frames "$frames" --out "$tmp/n$n" \
    --viewer "$port" >"$tmp/n$n.log" 2>&1 || { cat "$tmp/n$n.log" >&2; exit 1; }
  probe=$(tail -n 1 "$tmp/n$n/logs/viewer_probe.log")
  t="$tmp/n$n/time_viewer.txt"
  cpu=$(awk -F': ' '/User time/ {u=$2} /System time/ {s=$2} /Elapsed \(wall/ {split($2, a, ":"); w = a[1] * 60 + a[2]}
    END {printf "%.1f", 100 * (u + s) / w}' "$t")
  wall=$(echo "$probe" | jq -r '.seconds')
  printf '%-8s %8.1f %10s %14.1f %16.1f %14s %12s\n' "$n" "$wall" "$cpu" \
    "$(echo "$probe" | jq '.bytes_per_s / 1000')" "$(echo "$probe" | jq '.bytes_per_s_per_client / 1000')" \
    "$(echo "$probe" | jq '.latency_ms_median')" "$(echo "$probe" | jq '.latency_ms_p90')"
done
