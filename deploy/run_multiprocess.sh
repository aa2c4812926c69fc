#!/usr/bin/env bash
# One mapping server and N robot processes on this machine over LCM or Cyclone DDS (loopback only), on one
# dataset split into overlapping frame ranges (N=2 on 300 frames: 0:170 and 130:300). Synthesises a loop
# sequence when no --dataset is given. Generates a fresh key per robot, writes the configs, runs
# rgbdmap-server, rgbdmap-monitor and N x rgbdmap-client --fast, stops the server with SIGINT once the
# clients are done, evaluates every trajectory and the server's merged keyframes, and prints a summary.
#
# Usage: bash deploy/run_multiprocess.sh [--transport lcm|dds] [--robots N] [--dataset DIR] [--out DIR]
#          [--frames F] [--check MAX_ATE_M] [--no-netns] [--viewer PORT] [--realtime] [--record-keyframes]
#   --frames F     frames of the synthetic sequence (default 300), or the first F frames of --dataset
#   --check M      exit 1 unless every keyframe was acknowledged, all robots end in one map, the merged
#                  keyframe ATE is below M metres and the monitor printed a status (used by the CI test)
#   --viewer PORT  also run rgbdmap-viewer (http://127.0.0.1:PORT/, Foxglove ws://127.0.0.1:PORT) beside the
#                  monitor, stopped after the server (use --no-netns to reach it from a browser on this
#                  machine); RGBDMAP_VIEWER_PROBE, if set, is a command run in the background once it listens
#   --realtime     the clients read the sequence at its frame rate (30 Hz) instead of --fast
#   --record-keyframes  each client also records what it sent: robots/<R>/keyframes_<R>.rkf (a keyframe
#                  stream for rgbdmap-replay, deploy/bench_fleet.sh)
#   --no-netns     run on the host network (the default re-runs itself inside tests/transport/run_in_netns.sh,
#                  a private namespace with only loopback, when that is permitted)
# RGBDMAP_SERVER_YAML, if set, is appended to the generated server.yaml (other sections, e.g.
# "map:\n  stream_delay_s: 0"; deploy/bench_viewer.sh --stream-delay uses it).
# Outputs in --out (default out/multiprocess_<transport>): keys/, server.yaml, client_<R>.yaml, map/
# (store, keyframes_<R>.txt, server_summary.json), robots/<R>/ (trajectory_<R>.txt, client_<R>.json),
# logs/, eval_<R>.txt, eval_merged.txt, time_*.txt (peak memory, CPU), summary.txt (key=value).
set -euo pipefail
repo="$(cd "$(dirname "$0")/.." && pwd)"
bin="${RGBDMAP_BIN:-$repo/build/bin}"
transport=lcm robots=2 dataset="" out="" frames="" check="" netns=1 viewer= pace=--fast record=0
while [ $# -gt 0 ]; do
  case "$1" in
    --transport) transport="$2"; shift 2 ;;
    --robots) robots="$2"; shift 2 ;;
    --dataset) dataset="$2"; shift 2 ;;
    --out) out="$2"; shift 2 ;;
    --frames) frames="$2"; shift 2 ;;
    --check) check="$2"; shift 2 ;;
    --no-netns) netns=0; shift ;;
    --viewer) viewer="$2"; shift 2 ;;
    --realtime) pace=""; shift ;;
    --record-keyframes) record=1; shift ;;
    -h|--help) awk 'NR > 1 && !/^#/ {exit} NR > 1 {sub(/^# ?/, ""); print}' "$0"; exit 0 ;;
    *) echo "unknown argument: $1 (see --help)" >&2; exit 2 ;;
  esac
done
case "$transport" in lcm|dds) ;; *) echo "--transport must be lcm or dds" >&2; exit 2 ;; esac
[[ "$robots" =~ ^[1-9][0-9]?$ ]] || { echo "--robots must be 1..99" >&2; exit 2; }
[ -z "$frames" ] || { [[ "$frames" =~ ^[0-9]+$ ]] && [ "$frames" -ge $((robots * 20)) ]; } \
  || { echo "--frames must be at least 20 per robot" >&2; exit 2; }
for b in rgbdmap rgbdmap-server rgbdmap-client rgbdmap-monitor; do
  [ -x "$bin/$b" ] || { echo "missing $bin/$b: run deploy/build.sh (or ninja -C build $b)" >&2; exit 1; }
done
out="${out:-out/multiprocess_$transport}"
mkdir -p "$out"
out="$(cd "$out" && pwd)"

# Re-run inside a private loopback-only network namespace unless already there (or told not to).
if [ "$netns" = 1 ] && [ -z "${RGBDMAP_TRANSPORT_NETNS:-}" ]; then
  if command -v ip >/dev/null 2>&1 && unshare -n true 2>/dev/null; then
    args=(--transport "$transport" --robots "$robots" --out "$out")
    [ -n "$frames" ] && args+=(--frames "$frames")
    [ -n "$dataset" ] && args+=(--dataset "$(cd "$dataset" && pwd)")
    [ -n "$check" ] && args+=(--check "$check")
    [ -n "$viewer" ] && args+=(--viewer "$viewer")
    [ -z "$pace" ] && args+=(--realtime)
    [ "$record" = 1 ] && args+=(--record-keyframes)
    exec bash "$repo/tests/transport/run_in_netns.sh" bash "$0" "${args[@]}"
  fi
  echo "note: 'unshare -n' not permitted; running on the host network (loopback-only settings)" >&2
fi

. "$repo/deploy/lib/local_fleet.sh"
use_loopback_transport "$transport" "$repo"

# --- data -------------------------------------------------------------------------------------------------
if [ -z "$dataset" ]; then
  dataset="$out/synthetic_loop_${frames:-300}"
  if [ ! -s "$dataset/groundtruth.txt" ]; then
    "$bin/rgbdmap" synth --scene loop --frames "${frames:-300}" --out "$dataset" >"$out/synth.log" 2>&1 \
      || { cat "$out/synth.log" >&2; exit 1; }
  fi
fi
total=$(grep -vc '^#' "$dataset/rgb.txt")
[ -n "$frames" ] && [ "$frames" -lt "$total" ] && total=$frames
gt="$dataset/groundtruth.txt"

# --- keys and configs ---------------------------------------------------------------------------------------
mkdir -p "$out/logs" "$out/robots"
rm -rf "$out/map" "$out/maps_monitor"
write_keys_and_configs "$out" "$url" robot "$robots"
[ -n "${RGBDMAP_SERVER_YAML:-}" ] && printf '%b\n' "$RGBDMAP_SERVER_YAML" >>"$out/server.yaml"

# Overlapping ranges: chunk = total/N, extended by 2/15 of a chunk (at least 10 frames) on each side.
chunk=$((total / robots)); overlap=$((chunk * 2 / 15)); [ "$overlap" -lt 10 ] && overlap=10
range() { local a=$(($1 * chunk - overlap)) b=$((($1 + 1) * chunk + overlap))
  [ "$a" -lt 0 ] && a=0; { [ "$b" -gt "$total" ] || [ "$1" -eq $((robots - 1)) ]; } && b=$total; echo "$a:$b"; }

# --- processes ----------------------------------------------------------------------------------------------
timed() {  # timed NAME cmd... : runs in the background under /usr/bin/time -v when present
  if [ -x /usr/bin/time ]; then /usr/bin/time -v -o "$out/time_$1.txt" "${@:2}" & else "${@:2}" & fi
}
child_of() {  # the real process behind a /usr/bin/time wrapper
  if [ -x /usr/bin/time ]; then pgrep -P "$1" | head -1; else echo "$1"; fi
}
pids=()
cleanup() { for p in "${pids[@]}"; do kill "$p" 2>/dev/null || true; done; }
trap cleanup EXIT

echo "== $robots robot(s) over $transport ($url), dataset $dataset ($total frames), out $out"
start_ns=$(date +%s%N)
timed server "$bin/rgbdmap-server" --config "$out/server.yaml" --status-every 5 >"$out/logs/server.log" 2>&1
server_wrap=$!; pids+=("$server_wrap")
sleep 1
kill -0 "$server_wrap" 2>/dev/null || { echo "server failed to start:" >&2; cat "$out/logs/server.log" >&2; exit 1; }
server_pid=$(child_of "$server_wrap")
"$bin/rgbdmap-monitor" --transport "$url" --robots "$robot_list" --keys-file "$out/keys/server_keys.txt" \
  --period 2 --save-map "$out/maps_monitor" >"$out/logs/monitor.log" 2>"$out/logs/monitor.err" &
monitor_pid=$!; pids+=("$monitor_pid")
viewer_wrap=""
if [ -n "$viewer" ]; then
  timed viewer "$bin/rgbdmap-viewer" --transport "$url" --robots "$robot_list" \
    --keys-file "$out/keys/server_keys.txt" --port "$viewer" >"$out/logs/viewer.log" 2>&1
  viewer_wrap=$!; pids+=("$viewer_wrap")
  for _ in $(seq 1 50); do grep -q "serving http" "$out/logs/viewer.log" && break; sleep 0.1; done
  echo "   viewer: http://127.0.0.1:$viewer/ (Foxglove: ws://127.0.0.1:$viewer)"
  [ -n "${RGBDMAP_VIEWER_PROBE:-}" ] && { bash -c "$RGBDMAP_VIEWER_PROBE" >"$out/logs/viewer_probe.log" 2>&1 & }
fi
client_wraps=()
for i in $(seq 0 $((robots - 1))); do
  r="${ids[$i]}"; rng=$(range "$i")
  echo "   $r: frames $rng"
  rec=(); [ "$record" = 1 ] && rec=(--record-keyframes "$out/robots/$r/keyframes_$r.rkf")
  timed "client_$r" "$bin/rgbdmap-client" --config "$out/client_$r.yaml" --dataset "$dataset" $pace \
    --frames "$rng" --out "$out/robots/$r" "${rec[@]}" >"$out/logs/client_$r.log" 2>&1
  client_wraps+=($!); pids+=($!)
done
# A second monitor that exits after the first status it sees (what the CI test checks).
"$bin/rgbdmap-monitor" --transport "$url" --robots "$robot_list" --keys-file "$out/keys/server_keys.txt" \
  --once --timeout 60 >"$out/logs/monitor_once.txt" 2>&1 || echo "monitor --once: no status (see logs/monitor_once.txt)" >&2
failed=0
for i in "${!client_wraps[@]}"; do
  wait "${client_wraps[$i]}" || { echo "client ${ids[$i]} exited with $?" >&2; failed=1; }
done
elapsed_ns=$(( $(date +%s%N) - start_ns ))
clients_s=$(printf '%d.%09d' $((elapsed_ns / 1000000000)) $((elapsed_ns % 1000000000)))
kill -INT "$server_pid"
wait "$server_wrap" || { echo "server exited with $?" >&2; failed=1; }
kill -INT "$monitor_pid" 2>/dev/null || true
wait "$monitor_pid" || true
if [ -n "$viewer_wrap" ]; then
  kill -INT "$(child_of "$viewer_wrap")" 2>/dev/null || true
  wait "$viewer_wrap" || { echo "viewer exited with $?" >&2; failed=1; }
  tail -n 1 "$out/logs/viewer.log"
fi
wait  # the viewer probe, if any
trap - EXIT

# --- evaluation -------------------------------------------------------------------------------------------
num() { jq -r --arg k "$2" 'if has($k) then .[$k] else error("no \"\($k)\"") end' "$1"; }  # top-level field
val() { awk -v k="$2" '$1 == k {print $2}' "$1"; }
peak_mb() { [ -s "$1" ] && awk -F': ' '/Maximum resident/ {printf "%.0f", $2 / 1024}' "$1" || echo n/a; }
cpu_s() { [ -s "$1" ] && awk -F': ' '/User time/ {u=$2} /System time/ {s=$2} END {printf "%.1f", u + s}' "$1" || echo n/a; }
summary="$out/summary.txt"
{ echo "transport=$transport"; echo "robots=$robots"; echo "frames=$total"; echo "wall_s=$clients_s"; } >"$summary"
printf '\n%-8s %-9s %6s %5s %6s %9s %10s %11s %9s %8s\n' robot frames fps kf acked ms/frame KB/kf Mbit/s ATE_m peak_MB
all_acked=1
for i in $(seq 0 $((robots - 1))); do
  r="${ids[$i]}"; j="$out/robots/$r/client_$r.json"
  if [ ! -s "$j" ]; then echo "$r: no client_$r.json" >&2; all_acked=0; failed=1; continue; fi
  "$bin/rgbdmap" eval --gt "$gt" --est "$out/robots/$r/trajectory_$r.txt" >"$out/eval_$r.txt" 2>&1 || true
  fr=$(num "$j" frames); kf=$(num "$j" keyframes); ack=$(num "$j" keyframes_acked); ms=$(num "$j" ms_per_frame_median)
  wall=$(num "$j" wall_s); bytes=$(num "$j" bytes_sent); ate=$(val "$out/eval_$r.txt" ate_rmse_m)
  [ "$(num "$j" all_acked)" = true ] || all_acked=0
  fps=$(awk -v f="$fr" -v w="$wall" 'BEGIN {printf "%.1f", (w > 0 ? f / w : 0)}')
  kbkf=$(awk -v b="$bytes" -v k="$kf" 'BEGIN {printf "%.1f", (k > 0 ? b / k / 1000 : 0)}')
  mbps=$(awk -v b="$bytes" -v w="$wall" 'BEGIN {printf "%.2f", (w > 0 ? 8e-6 * b / w : 0)}')
  printf '%-8s %-9s %6s %5s %6s %9s %10s %11s %9.4f %8s\n' "$r" "$(range "$i")" "$fps" "$kf" "$ack" "$ms" "$kbkf" \
    "$mbps" "${ate:-nan}" "$(peak_mb "$out/time_client_$r.txt")"
  { echo "${r}_fps=$fps"; echo "${r}_keyframes=$kf"; echo "${r}_acked=$ack"; echo "${r}_kb_per_kf=$kbkf"
    echo "${r}_mbps=$mbps"; echo "${r}_ate_m=${ate:-nan}"; echo "${r}_peak_mb=$(peak_mb "$out/time_client_$r.txt")"; } >>"$summary"
done
# The server's optimised keyframes of all robots together, aligned once: one map or not.
cat "$out"/map/keyframes_robot*.txt 2>/dev/null | grep -v '^#' | sort -n >"$out/keyframes_merged.txt" || true
"$bin/rgbdmap" eval --gt "$gt" --est "$out/keyframes_merged.txt" >"$out/eval_merged.txt" 2>&1 || true
merged_ate=$(val "$out/eval_merged.txt" ate_rmse_m); merged_ate=${merged_ate:-nan}
sj="$out/map/server_summary.json"
skf=$(num "$sj" keyframes); loops=$(num "$sj" loops_accepted); maps=$(num "$sj" maps); ingest=$(num "$sj" ingest_ms_median)
ingest_cpu=$(num "$sj" ingest_cpu_ms_median)
groups=$(jq -c .merged_maps "$sj")
one_map=0; [ "$(jq '.merged_maps | length' "$sj")" -eq 1 ] && one_map=1  # [[...]] = one group
[ "$robots" -eq 1 ] && one_map=1
bt_kb=n/a  # the map stream as rgbdmap-monitor --save-map recorded it (needs a server that publishes maps)
ls "$out"/maps_monitor/*.bt >/dev/null 2>&1 && bt_kb=$(du -ck "$out"/maps_monitor/*.bt | awk 'END {print $1}')
srv_cpu=$(cpu_s "$out/time_server.txt"); srv_mb=$(peak_mb "$out/time_server.txt")
fixed() { awk -v v="$1" -v d="$2" 'BEGIN {if (v ~ /^-?[0-9.]+([eE][-+]?[0-9]+)?$/) printf "%.*f", d, v; else printf "%s", v}'; }
echo
echo "server: keyframes $skf, loops $loops, maps $maps, merged $groups, ingest median $(fixed "$ingest" 1) ms" \
  "(CPU $(fixed "$ingest_cpu" 1) ms), CPU ${srv_cpu} s, peak ${srv_mb} MB; map .bt ${bt_kb} KB;" \
  "merged keyframe ATE $(fixed "$merged_ate" 4) m; wall $(fixed "$clients_s" 1) s"
status_ok=0; grep -q 'state=running' "$out/logs/monitor_once.txt" && status_ok=1
echo "monitor (rgbdmap-monitor --once):"
head -n 8 "$out/logs/monitor_once.txt" | sed 's/^/  /'
{ echo "server_keyframes=$skf"; echo "loops=$loops"; echo "maps=$maps"; echo "merged_maps=$groups"
  echo "one_map=$one_map"; echo "ingest_ms_median=$ingest"; echo "ingest_cpu_ms_median=$ingest_cpu"
  echo "server_cpu_s=$srv_cpu"; echo "map_bt_kb=$bt_kb"; echo "server_peak_mb=$srv_mb"; echo "merged_ate_m=$merged_ate"
  echo "all_acked=$all_acked"; echo "monitor_status=$status_ok"; } >>"$summary"

if [ -n "$check" ]; then
  ok=1
  [ "$failed" = 0 ] || { echo "CHECK FAILED: a process exited with an error"; ok=0; }
  [ "$all_acked" = 1 ] || { echo "CHECK FAILED: not every keyframe was acknowledged"; ok=0; }
  [ "$one_map" = 1 ] || { echo "CHECK FAILED: robots not in one merged map: $groups"; ok=0; }
  awk -v a="$merged_ate" -v m="$check" 'BEGIN {exit !(a == a + 0 && a < m)}' \
    || { echo "CHECK FAILED: merged ATE $merged_ate m not below $check m"; ok=0; }
  [ "$status_ok" = 1 ] || { echo "CHECK FAILED: rgbdmap-monitor --once printed no status"; ok=0; }
  [ "$ok" = 1 ] && echo "CHECK PASSED ($transport, $robots robots)" || exit 1
fi
exit "$failed"
