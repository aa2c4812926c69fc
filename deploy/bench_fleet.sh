#!/usr/bin/env bash
# A fleet on one server: N light robots (rgbdmap-replay) send a recorded keyframe stream at a set
# keyframe rate for a set time, over LCM or Cyclone DDS on loopback, against one rgbdmap-server. No odometry
# runs during the measurement, so 16 robots fit on 2 cores. Robot i starts the stream at keyframe i*K/N (K
# keyframes in the stream), so the robots are at different places of one scene and the server must join
# them into one map by loop closure; each further pass of a robot starts a new chain.
#
# Prints per robot: keyframes sent / acknowledged, ack latency p50 / p90 / max, the worst minute's p90; per
# minute of the run: the p90 over all robots; and the server's keyframes, maps, CPU and peak memory.
#
# Usage: bash deploy/bench_fleet.sh [--robots N] [--rate HZ] [--minutes M] [--transport lcm|dds]
#          [--stream FILE] [--frames F] [--out DIR] [--check P90_MS] [--server KEY=VALUE ...]
#   --robots N     light robots (default 16)
#   --rate HZ      keyframes per second per robot (default 1)
#   --minutes M    how long each robot sends (default 10; may be fractional)
#   --stream FILE  the keyframe stream to replay; default: recorded first by one rgbdmap-client on a synthetic
#                  loop of F frames (default 300) with deploy/run_multiprocess.sh --record-keyframes
#   --server K=V   one more key of server.yaml's server: section, e.g. --server background_nice=0 (repeatable)
#   --check MS     exit 1 unless every keyframe was acknowledged, every minute's p90 over all robots is at most
#                  MS milliseconds and all robots end in one map
# Outputs in --out (default out/bench_fleet): record/ (the recording run), keys/, server.yaml, map/, logs/,
# replay/replay_<R>.json, time_server.txt, server_threads.txt (CPU s by thread), per_minute.txt, summary.txt
# (key=value). Numbers are printed, never asserted unless --check is given.
set -euo pipefail
repo="$(cd "$(dirname "$0")/.." && pwd)"
bin="${RGBDMAP_BIN:-$repo/build/bin}"
robots=16 rate=1 minutes=10 transport=lcm stream="" frames=300 out="out/bench_fleet" check="" server_keys=()
while [ $# -gt 0 ]; do
  case "$1" in
    --robots) robots="$2"; shift 2 ;;
    --rate) rate="$2"; shift 2 ;;
    --minutes) minutes="$2"; shift 2 ;;
    --transport) transport="$2"; shift 2 ;;
    --stream) stream="$2"; shift 2 ;;
    --frames) frames="$2"; shift 2 ;;
    --out) out="$2"; shift 2 ;;
    --check) check="$2"; shift 2 ;;
    --server) [[ "$2" =~ ^[a-z_]+=[^[:space:]]+$ ]] || { echo "--server takes KEY=VALUE" >&2; exit 2; }
      server_keys+=("$2"); shift 2 ;;
    -h|--help) awk 'NR > 1 && !/^#/ {exit} NR > 1 {sub(/^# ?/, ""); print}' "$0"; exit 0 ;;
    *) echo "unknown argument: $1 (see --help)" >&2; exit 2 ;;
  esac
done
case "$transport" in lcm|dds) ;; *) echo "--transport must be lcm or dds" >&2; exit 2 ;; esac
[[ "$robots" =~ ^[1-9][0-9]?$ ]] || { echo "--robots must be 1..99" >&2; exit 2; }
[[ "$rate" =~ ^[0-9]+([.][0-9]+)?$ ]] && awk -v r="$rate" 'BEGIN {exit !(r > 0 && r <= 100)}' \
  || { echo "--rate must be in (0, 100]" >&2; exit 2; }
[[ "$minutes" =~ ^[0-9]+([.][0-9]+)?$ ]] && awk -v m="$minutes" 'BEGIN {exit !(m > 0 && m <= 1440)}' \
  || { echo "--minutes must be in (0, 1440]" >&2; exit 2; }
for b in rgbdmap rgbdmap-server rgbdmap-client rgbdmap-replay; do
  [ -x "$bin/$b" ] || { echo "missing $bin/$b: run deploy/build.sh" >&2; exit 1; }
done
mkdir -p "$out"
out="$(cd "$out" && pwd)"

# --- the stream (recorded once, outside the measurement) ------------------------------------------------
if [ -z "$stream" ] && [ -z "${RGBDMAP_TRANSPORT_NETNS:-}" ]; then
  stream="$out/record/robots/robot0/keyframes_robot0.rkf"
  if [ ! -s "$stream" ]; then
    echo "== recording a keyframe stream: one rgbdmap-client on a synthetic loop of $frames frames"
    bash "$repo/deploy/run_multiprocess.sh" --transport "$transport" --robots 1 --frames "$frames" \
      --record-keyframes --out "$out/record" >"$out/record.log" 2>&1 \
      || { echo "recording failed; see $out/record.log" >&2; tail -n 5 "$out/record.log" >&2; exit 1; }
  fi
fi
[ -s "$stream" ] || { echo "no keyframe stream: $stream" >&2; exit 1; }
stream="$(cd "$(dirname "$stream")" && pwd)/$(basename "$stream")"

# Re-run inside a private loopback-only network namespace unless already there.
if [ -z "${RGBDMAP_TRANSPORT_NETNS:-}" ]; then
  if command -v ip >/dev/null 2>&1 && unshare -n true 2>/dev/null; then
    exec bash "$repo/tests/transport/run_in_netns.sh" bash "$0" --robots "$robots" --rate "$rate" \
      --minutes "$minutes" --transport "$transport" --stream "$stream" --out "$out" ${check:+--check "$check"} \
      $(for kv in "${server_keys[@]}"; do printf -- '--server %s ' "$kv"; done)
  fi
  echo "note: 'unshare -n' not permitted; running on the host network (loopback-only settings)" >&2
fi
. "$repo/deploy/lib/local_fleet.sh"
use_loopback_transport "$transport" "$repo"

# --- keys and configs ---------------------------------------------------------------------------------------
rm -rf "$out/keys" "$out/map" "$out/replay" "$out/logs"
mkdir -p "$out/logs" "$out/replay"
write_keys_and_configs "$out" "$url" replay "$robots"
for kv in "${server_keys[@]}"; do printf '  %s: %s\n' "${kv%%=*}" "${kv#*=}" >>"$out/server.yaml"; done
[ -n "${RGBDMAP_SERVER_YAML:-}" ] && printf '%b\n' "$RGBDMAP_SERVER_YAML" >>"$out/server.yaml"

# --- processes ----------------------------------------------------------------------------------------------
pids=()
cleanup() { for p in "${pids[@]}"; do kill "$p" 2>/dev/null || true; done; }
trap cleanup EXIT
seconds=$(awk -v m="$minutes" 'BEGIN {printf "%.0f", m * 60}')
echo "== $robots robots x $rate keyframe/s for $minutes min over $transport, stream $stream, out $out"
if [ -x /usr/bin/time ]; then
  /usr/bin/time -v -o "$out/time_server.txt" "$bin/rgbdmap-server" --config "$out/server.yaml" --status-every 30 \
    >"$out/logs/server.log" 2>&1 &
else
  "$bin/rgbdmap-server" --config "$out/server.yaml" --status-every 30 >"$out/logs/server.log" 2>&1 &
fi
server_wrap=$!; pids+=("$server_wrap")
sleep 1
kill -0 "$server_wrap" 2>/dev/null || { echo "server failed to start:" >&2; cat "$out/logs/server.log" >&2; exit 1; }
server_pid=$(pgrep -P "$server_wrap" | head -1); server_pid=${server_pid:-$server_wrap}
replay_pids=()
for i in $(seq 0 $((robots - 1))); do
  r="${ids[$i]}"
  # Robot i starts at keyframe i*K/N of the stream's K (--phase i/N).
  "$bin/rgbdmap-replay" --config "$out/client_$r.yaml" --stream "$stream" --rate "$rate" --duration "$seconds" \
    --phase "$(awk -v i="$i" -v n="$robots" 'BEGIN {print i / n}')" --out "$out/replay" >"$out/logs/replay_$r.log" 2>&1 &
  replay_pids+=($!); pids+=($!)
done
failed=0
for i in "${!replay_pids[@]}"; do
  wait "${replay_pids[$i]}" || { echo "replay ${ids[$i]} exited with $?" >&2; failed=1; }
done
# The server's CPU by thread (name: seconds), read before it stops.
tick=$(getconf CLK_TCK)
for t in /proc/"$server_pid"/task/*; do
  [ -r "$t/stat" ] || continue
  awk -v tick="$tick" '{sub(/^[0-9]+ \(/, ""); name = $0; sub(/\) .*/, "", name); sub(/^[^)]*\) /, "")
    printf "%s %.2f\n", name, ($12 + $13) / tick}' "$t/stat"
done | awk '{cpu[$1] += $2} END {for (n in cpu) printf "%s %.1f\n", n, cpu[n]}' | sort -k2 -nr >"$out/server_threads.txt"
kill -INT "$server_pid"
wait "$server_wrap" || { echo "server exited with $?" >&2; failed=1; }
trap - EXIT

# --- report -------------------------------------------------------------------------------------------------
summary="$out/summary.txt"
{ echo "robots=$robots"; echo "rate_hz=$rate"; echo "minutes=$minutes"; echo "transport=$transport"; } >"$summary"
printf '\n%-9s %6s %6s %8s %8s %8s %14s\n' robot sent acked p50_ms p90_ms max_ms worst_min_p90
all_acked=1
for r in "${ids[@]}"; do
  j="$out/replay/replay_$r.json"
  if [ ! -s "$j" ]; then echo "$r: no replay_$r.json" >&2; all_acked=0; failed=1; continue; fi
  [ "$(jq -r .all_acked "$j")" = true ] || all_acked=0
  printf '%-9s %6s %6s %8s %8s %8s %14s\n' "$r" "$(jq .keyframes_sent "$j")" "$(jq .keyframes_acked "$j")" \
    "$(jq .ack_ms_p50 "$j")" "$(jq .ack_ms_p90 "$j")" "$(jq .ack_ms_max "$j")" \
    "$(jq '[.per_minute[].ack_ms_p90] | max' "$j")"
done
# Per minute over all robots: p90 of every acknowledged keyframe sent in that minute (nearest rank).
jq -s -r '[.[].keyframes[] | select(.[2] >= 0) | {m: (.[1] / 60 | floor), a: .[2]}] | group_by(.m)[]
  | (map(.a) | sort) as $s | "\(.[0].m) \($s | length) \($s[(($s | length) * 0.5 | ceil) - 1]) \($s[(($s | length) * 0.9 | ceil) - 1])"' \
  "$out"/replay/replay_*.json >"$out/per_minute.txt" || true
echo
echo "minute  keyframes  p50_ms  p90_ms   (all robots)"
awk '{printf "%6d %10d %7.0f %7.0f\n", $1, $2, $3, $4}' "$out/per_minute.txt"
worst_p90=$(awk 'BEGIN {m = 0} $4 > m {m = $4} END {print m}' "$out/per_minute.txt")
sj="$out/map/server_summary.json"
skf=$(jq .keyframes "$sj"); maps=$(jq .maps "$sj"); loops=$(jq .loops_accepted "$sj"); groups=$(jq -c .merged_maps "$sj")
one_map=0; [ "$(jq '.merged_maps | length' "$sj")" -eq 1 ] && one_map=1
[ "$robots" -eq 1 ] && one_map=1
srv_cpu=n/a srv_mb=n/a
if [ -s "$out/time_server.txt" ]; then
  srv_cpu=$(awk -F': ' '/User time/ {u=$2} /System time/ {s=$2} END {printf "%.1f", u + s}' "$out/time_server.txt")
  srv_mb=$(awk -F': ' '/Maximum resident/ {printf "%.0f", $2 / 1024}' "$out/time_server.txt")
fi
echo
deferred_max=$(jq '.keyframes_deferred_max // 0' "$sj")
dup_queued=$(jq '.keyframes_duplicates_queued // 0' "$sj"); queue_full=$(jq '.keyframes_queue_full // 0' "$sj")
echo "server: keyframes $skf, loops $loops, maps $maps, merged $groups, CPU $srv_cpu s, peak $srv_mb MB," \
  "ingest median $(jq .ingest_ms_median "$sj") ms (CPU $(jq .ingest_cpu_ms_median "$sj") ms)"
echo "server: at most $deferred_max stored keyframes waiting for loop detection at once (the map's lag)," \
  "$queue_full keyframes refused for a full queue, $dup_queued resends of queued keyframes dropped"
echo "server CPU by thread (s): $(awk '{printf "%s%s %s", (NR > 1 ? ", " : ""), $1, $2}' "$out/server_threads.txt")"
echo "all acknowledged: $all_acked; worst minute's p90 over all robots: $worst_p90 ms"
{ echo "server_keyframes=$skf"; echo "loops=$loops"; echo "maps=$maps"; echo "one_map=$one_map"
  echo "server_cpu_s=$srv_cpu"; echo "server_peak_mb=$srv_mb"; echo "all_acked=$all_acked"
  echo "worst_minute_p90_ms=$worst_p90"; echo "keyframes_deferred_max=$deferred_max"
  echo "keyframes_queue_full=$queue_full"; echo "keyframes_duplicates_queued=$dup_queued"; } >>"$summary"
if [ -n "$check" ]; then
  ok=1
  [ "$failed" = 0 ] || { echo "CHECK FAILED: a process exited with an error"; ok=0; }
  [ "$all_acked" = 1 ] || { echo "CHECK FAILED: not every keyframe was acknowledged"; ok=0; }
  awk -v w="$worst_p90" -v c="$check" 'BEGIN {exit !(w <= c)}' \
    || { echo "CHECK FAILED: a minute's p90 ack latency $worst_p90 ms is above $check ms"; ok=0; }
  [ "$one_map" = 1 ] || { echo "CHECK FAILED: robots not in one merged map: $groups"; ok=0; }
  [ "$ok" = 1 ] && echo "CHECK PASSED ($robots robots x $rate Hz for $minutes min)" || exit 1
fi
exit "$failed"
