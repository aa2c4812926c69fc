#!/usr/bin/env bash
# A long outage: one light robot (rgbdmap-replay with a keyframe spool) sends a recorded keyframe stream at
# RATE keyframes/s while the server is killed (SIGKILL) 30 s in and started again OUTAGE seconds later, with
# the shipped link defaults, in a private loopback-only network namespace. rgbdmap-monitor runs throughout.
# Prints: keyframes sent / acknowledged / stored (the server's map store), keyframes made during the outage,
# the largest spool the monitor saw, the robot's peak RSS, given-up-and-requeued keyframes, ack latency, and
# the time from the server's return until every keyframe was acknowledged. Needs root and jq.
#
# Usage: bash deploy/bench_outage.sh [--outage S (300)] [--rate HZ (1)] [--after S (90)] [--transport lcm|dds]
#          [--stream FILE] [--out DIR (out/bench_outage)]
#   --after S     the robot keeps sending S seconds after the server returned
#   --stream FILE default: recorded first by one rgbdmap-client on a synthetic 300-frame loop
#                 (deploy/run_multiprocess.sh --record-keyframes)
# Exit 0 when every keyframe was acknowledged and stored; 1 otherwise.
set -u
repo="$(cd "$(dirname "$0")/.." && pwd)"
bin="${RGBDMAP_BIN:-$repo/build/bin}"
outage=300 rate=1 after=90 transport=lcm stream="" out="out/bench_outage"
while [ $# -gt 0 ]; do
  case "$1" in
    --outage) outage="$2"; shift 2 ;;
    --rate) rate="$2"; shift 2 ;;
    --after) after="$2"; shift 2 ;;
    --transport) transport="$2"; shift 2 ;;
    --stream) stream="$2"; shift 2 ;;
    --out) out="$2"; shift 2 ;;
    -h|--help) awk 'NR > 1 && !/^#/ {exit} NR > 1 {sub(/^# ?/, ""); print}' "$0"; exit 0 ;;
    *) echo "unknown argument: $1 (see --help)" >&2; exit 2 ;;
  esac
done
command -v jq >/dev/null || { echo "jq is required (deploy/install_deps.sh)" >&2; exit 1; }
mkdir -p "$out"; out="$(cd "$out" && pwd)"
if [ -z "$stream" ] && [ -z "${RGBDMAP_TRANSPORT_NETNS:-}" ]; then
  stream="$out/record/robots/robot0/keyframes_robot0.rkf"
  if [ ! -s "$stream" ]; then
    echo "== recording a keyframe stream: one rgbdmap-client on a synthetic loop of 300 frames"
    bash "$repo/deploy/run_multiprocess.sh" --transport "$transport" --robots 1 --frames 300 \
      --record-keyframes --out "$out/record" >"$out/record.log" 2>&1 \
      || { echo "recording failed; see $out/record.log" >&2; tail -n 5 "$out/record.log" >&2; exit 1; }
  fi
fi
[ -s "$stream" ] || { echo "no keyframe stream: $stream" >&2; exit 1; }
stream="$(cd "$(dirname "$stream")" && pwd)/$(basename "$stream")"
if [ -z "${RGBDMAP_TRANSPORT_NETNS:-}" ]; then
  unshare -n true 2>/dev/null || { echo "'unshare -n' is not permitted here (needs root)" >&2; exit 77; }
  exec bash "$repo/tests/transport/run_in_netns.sh" bash "$0" --outage "$outage" --rate "$rate" --after "$after" \
    --transport "$transport" --stream "$stream" --out "$out"
fi
. "$repo/deploy/lib/local_fleet.sh"
use_loopback_transport "$transport" "$repo"
rm -rf "$out/keys" "$out/map" "$out/replay" "$out/logs" "$out/spool"
mkdir -p "$out/logs" "$out/replay"
write_keys_and_configs "$out" "$url" robot 1
server_pid="" pids=()
cleanup() { kill "$server_pid" "${pids[@]}" 2>/dev/null; }
trap cleanup EXIT
start_server() {
  "$bin/rgbdmap-server" --config "$out/server.yaml" --status-every 0 >>"$out/logs/server.log" 2>&1 &
  server_pid=$!
}
duration=$(( 30 + outage + after ))
echo "== one robot at $rate keyframe/s for $duration s over $transport; the server down from 30 s for $outage s"
start_server; sleep 2
"$bin/rgbdmap-monitor" --transport "$url" --robots robot0 --keys-file "$out/keys/server_keys.txt" --period 1 \
  >"$out/logs/monitor.log" 2>&1 &
monitor=$!; pids+=("$monitor")
t0=$(date +%s.%N)
"$bin/rgbdmap-replay" --config "$out/client_robot0.yaml" --stream "$stream" --rate "$rate" --duration "$duration" \
  --spool "$out/spool" --out "$out/replay" >"$out/logs/replay.log" 2>&1 &
replay=$!; pids+=("$replay")
sleep 30; kill -9 "$server_pid"; wait "$server_pid" 2>/dev/null
echo "   server killed at $(date +%T)"
sleep "$outage"; start_server; t_back=$(date +%s.%N)
echo "   server started again at $(date +%T)"
wait "$replay"; replay_rc=$?
t_end=$(date +%s.%N)
kill -INT "$server_pid"; wait "$server_pid"; server_rc=$?
kill -INT "$monitor"; wait "$monitor" 2>/dev/null
trap - EXIT

j="$out/replay/replay_robot0.json"
stored=$(jq .keyframes "$out/map/server_summary.json" 2>/dev/null)
during=$(jq --argjson a 30 --argjson b $((30 + outage)) '[.keyframes[] | select(.[1] >= $a and .[1] < $b)] | length' "$j" 2>/dev/null \
  || echo "?")
most=$(grep -o 'spool=[0-9]*' "$out/logs/monitor.log" | cut -d= -f2 | sort -n | tail -n 1)
printf '%-28s %s\n' "keyframes sent" "$(jq .keyframes_sent "$j")" "keyframes acknowledged" "$(jq .keyframes_acked "$j")" \
  "keyframes stored" "${stored:-?}" "made during the outage" "$during" "largest spool (monitor)" "${most:-?}" \
  "left spooled at the end" "$(jq .spool_depth "$j")" "given up and requeued" "$(jq .keyframes_requeued "$j")" \
  "retransmissions" "$(jq .retransmissions "$j")" "robot peak RSS (MB)" "$(jq .rss_peak_mb "$j")" \
  "ack p50 / p90 / max (ms)" "$(jq -r '"\(.ack_ms_p50) / \(.ack_ms_p90) / \(.ack_ms_max)"' "$j")" \
  "server back -> robot done (s)" "$(awk -v a="$t_back" -v b="$t_end" 'BEGIN {printf "%.1f", b - a}')" \
  "replay / server exit" "$replay_rc / $server_rc" | tee "$out/summary.txt"
[ "$replay_rc" = 0 ] && [ "$server_rc" = 0 ] && [ "$(jq .keyframes_acked "$j")" = "${stored:-x}" ] \
  && [ "$(jq .all_acked "$j")" = true ]
