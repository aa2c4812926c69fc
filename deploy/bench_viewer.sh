#!/usr/bin/env bash
# The live map viewer under load: a two-robot run over LCM (deploy/run_multiprocess.sh --viewer,
# separate processes, private loopback-only namespace) with 1 and then 10 Foxglove reference clients
# (tests/viewer/bench_clients.js, Node + npm @foxglove/ws-protocol) subscribed to every channel. Prints, per
# client count: the viewer process's CPU (user + system over the run's wall time), bytes per second to all
# clients and to one, the latency of incremental voxel updates from the server's map update to the client
# ("update"), and the latency from a keyframe's acknowledgement at its robot to the first voxel update that
# holds it at a client ("ack -> client", per keyframe: median, p90, max; the issue's target is < 1 s median).
# Usage: bash deploy/bench_viewer.sh [--frames F] [--realtime] [--stream-delay S]
#   --realtime        the robots read the sequence at 30 Hz (default --fast: as fast as they can)
#   --stream-delay S  the server's map.stream_delay_s (default 0.25; 0 = the map stream only every
#                     map.stream_period_s = 2 s)
set -euo pipefail
repo="$(cd "$(dirname "$0")/.." && pwd)"
bin="${RGBDMAP_BIN:-$repo/build/bin}"
frames=300 pace=() args=("$@")
while [ $# -gt 0 ]; do
  case "$1" in
    --frames) frames="$2"; shift 2 ;;
    --realtime) pace=(--realtime); shift ;;
    --stream-delay) export RGBDMAP_SERVER_YAML="map:\n  stream_delay_s: $2"; shift 2 ;;
    *) echo "unknown argument: $1" >&2; exit 2 ;;
  esac
done
node_dir="${RGBDMAP_NODE_DIR:-/usr/local/lib/rgbdmap-node}"
[ -f "$node_dir/node_modules/@foxglove/ws-protocol/package.json" ] \
  || { echo "needs node and @foxglove/ws-protocol in $node_dir (deploy/install_deps.sh)" >&2; exit 1; }
if [ -z "${RGBDMAP_TRANSPORT_NETNS:-}" ]; then
  exec bash "$repo/tests/transport/run_in_netns.sh" bash "$0" "${args[@]}"
fi
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
port=18770
printf '%-8s %8s %8s %10s %12s %12s %10s %16s %10s %10s\n' clients wall_s cpu_% "KB/s all" "KB/s/client" \
  "update ms" "p90 ms" "ack->client ms" "p90 ms" "max ms"
for n in 1 10; do
  RGBDMAP_VIEWER_PROBE="NODE_PATH=$node_dir/node_modules node $repo/tests/viewer/bench_clients.js 127.0.0.1 $port $n $tmp/n$n/robots" \
    bash "$repo/deploy/run_multiprocess.sh" --transport lcm --robots 2 --frames "$frames" --out "$tmp/n$n" \
    --viewer "$port" "${pace[@]}" >"$tmp/n$n.log" 2>&1 || { cat "$tmp/n$n.log" >&2; exit 1; }
  probe=$(tail -n 1 "$tmp/n$n/logs/viewer_probe.log")
  t="$tmp/n$n/time_viewer.txt"
  cpu=$(awk -F': ' '/User time/ {u=$2} /System time/ {s=$2} /Elapsed \(wall/ {split($2, a, ":"); w = a[1] * 60 + a[2]}
    END {printf "%.1f", 100 * (u + s) / w}' "$t")
  wall=$(echo "$probe" | jq -r '.seconds')
  printf '%-8s %8.1f %8s %10.1f %12.1f %12s %10s %16s %10s %10s\n' "$n" "$wall" "$cpu" \
    "$(echo "$probe" | jq '.bytes_per_s / 1000')" "$(echo "$probe" | jq '.bytes_per_s_per_client / 1000')" \
    "$(echo "$probe" | jq '(.latency_ms_median // -1) | floor')" "$(echo "$probe" | jq '(.latency_ms_p90 // -1) | floor')" \
    "$(echo "$probe" | jq '(.ack_latency_ms_median // -1) | floor')" "$(echo "$probe" | jq '(.ack_latency_ms_p90 // -1) | floor')" \
    "$(echo "$probe" | jq '(.ack_latency_ms_max // -1) | floor')"
  echo "$probe" | jq -r '"         (\(.ack_keyframes) keyframes timed, \(.ack_keyframes_missing) never seen at the client \(.ack_missing | tostring); server -> viewer \(.server_to_viewer_kb) KB; client 0 KB per topic: \(.kb_per_topic_client0 | tostring))"'
done
