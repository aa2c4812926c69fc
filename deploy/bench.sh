#!/usr/bin/env bash
# End-to-end benchmark with real processes (deploy/run_multiprocess.sh, inside a private loopback-only
# network namespace when permitted). Prints two tables:
#  1. one dataset (default: synthetic 300-frame loop, 2 robots): per robot client FPS, keyframes, KB per
#     keyframe, Mbit/s, ATE, peak RSS; server ms per keyframe (wall and CPU), loops, merged ATE, peak RSS;
#  2. scaling: 1, 2, 4, 8 robots on one server, each robot PER_ROBOT frames of one synthetic loop (--fast):
#     server ingest latency (median, p90), server CPU per keyframe and per robot, client FPS.
# Usage: bash deploy/bench.sh [--dataset DIR] [--frames F] [--robots N] [--transport lcm|dds]
#                             [--per-robot FRAMES] [--scaling "1 2 4 8"] [--no-scaling] [--out DIR]
# Timings depend on the machine's load; the numbers are printed, never asserted.
set -euo pipefail
repo="$(cd "$(dirname "$0")/.." && pwd)"
dataset="" frames="" robots=2 transport=lcm per_robot=60 scaling="1 2 4 8" out="out/bench"
while [ $# -gt 0 ]; do
  case "$1" in
    --dataset) dataset="$2"; shift 2 ;;
    --frames) frames="$2"; shift 2 ;;
    --robots) robots="$2"; shift 2 ;;
    --transport) transport="$2"; shift 2 ;;
    --per-robot) per_robot="$2"; shift 2 ;;
    --scaling) scaling="$2"; shift 2 ;;
    --no-scaling) scaling=""; shift ;;
    --out) out="$2"; shift 2 ;;
    -h|--help) awk 'NR > 1 && !/^#/ {exit} NR > 1 {sub(/^# ?/, ""); print}' "$0"; exit 0 ;;
    *) echo "unknown argument: $1 (see --help)" >&2; exit 2 ;;
  esac
done
mkdir -p "$out"
out="$(cd "$out" && pwd)"
for b in rgbdmap rgbdmap-server rgbdmap-client rgbdmap-monitor; do
  [ -x "${RGBDMAP_BIN:-$repo/build/bin}/$b" ] || { echo "missing $b: run deploy/build.sh first" >&2; exit 1; }
done
get() { awk -F= -v k="$2" '$1 == k {print $2}' "$1"; }
run() {  # run OUTDIR ARGS...: one multi-process run, its log kept in OUTDIR.log
  local dir="$1"; shift
  if ! bash "$repo/deploy/run_multiprocess.sh" --out "$dir" "$@" >"$dir.log" 2>&1; then
    echo "run failed ($*); see $dir.log" >&2; tail -n 5 "$dir.log" >&2; return 1
  fi
}

# --- 1. one dataset -----------------------------------------------------------------------------------------
args=(--transport "$transport" --robots "$robots")
[ -n "$dataset" ] && args+=(--dataset "$dataset")
[ -n "$frames" ] && args+=(--frames "$frames")
echo "== dataset run: ${dataset:-synthetic loop} (${frames:-all} frames), $robots robot(s), $transport"
run "$out/dataset" "${args[@]}" || true
s="$out/dataset/summary.txt"
if [ -s "$s" ]; then
  sed -n '/^robot /,/^$/p' "$out/dataset.log"
  printf '%-28s %s\n' "server ms/keyframe (wall)" "$(get "$s" ingest_ms_median) (median)" \
    "server ms/keyframe (CPU)" "$(get "$s" ingest_cpu_ms_median) (median, ingest worker)" \
    "keyframes / loops / maps" "$(get "$s" server_keyframes) / $(get "$s" loops) / $(get "$s" maps)" \
    "merged maps" "$(get "$s" merged_maps)" \
    "merged keyframe ATE (m)" "$(get "$s" merged_ate_m)" \
    "server CPU (s) / peak RSS" "$(get "$s" server_cpu_s) / $(get "$s" server_peak_mb) MB" \
    "map .bt (monitor)" "$(get "$s" map_bt_kb) KB" \
    "all keyframes acked" "$(get "$s" all_acked)" \
    "wall (s)" "$(get "$s" wall_s)"
fi

# --- 2. scaling ---------------------------------------------------------------------------------------------
[ -n "$scaling" ] || exit 0
max=0; for n in $scaling; do [ "$n" -gt "$max" ] && max=$n; done
seq_frames=$((max * per_robot))
syn="$out/synthetic_loop_$seq_frames"
if [ ! -s "$syn/groundtruth.txt" ]; then
  echo "== synthesising $seq_frames frames for the scaling run"
  "${RGBDMAP_BIN:-$repo/build/bin}/rgbdmap" synth --scene loop --frames "$seq_frames" --out "$syn" >"$out/synth.log" 2>&1
fi
echo
echo "== scaling: $per_robot frames per robot (first N x $per_robot frames of one loop), $transport, --fast, $(nproc) cores"
printf '%6s %8s %8s %11s %10s %12s %14s %10s %8s %9s %9s\n' robots frames kf ingest_ms ingest_p90 \
  srv_cpu_ms/kf srv_cpu_s/robot client_fps loops merged_ATE srv_MB
for n in $scaling; do
  d="$out/scale_$n"
  run "$d" --transport "$transport" --robots "$n" --dataset "$syn" --frames $((n * per_robot)) || continue
  s="$d/summary.txt"
  kf=$(get "$s" server_keyframes); cpu=$(get "$s" server_cpu_s)
  p90=$(jq .ingest_ms_p90 "$d/map/server_summary.json")
  fps=$(grep -o '^robot[0-9]*_fps=.*' "$s" | cut -d= -f2 | awk '{t += $1} END {printf "%.1f", t / NR}')
  printf '%6s %8s %8s %11.1f %10.1f %12.1f %14.2f %10s %8s %9.4f %9s\n' "$n" "$(get "$s" frames)" "$kf" \
    "$(get "$s" ingest_ms_median)" "$p90" "$(awk -v c="$cpu" -v k="$kf" 'BEGIN {print (k > 0 ? 1000 * c / k : 0)}')" \
    "$(awk -v c="$cpu" -v n="$n" 'BEGIN {print c / n}')" "$fps" "$(get "$s" loops)" "$(get "$s" merged_ate_m)" \
    "$(get "$s" server_peak_mb)"
done
echo "(ingest_ms: per keyframe from dequeue to graph update, wall; srv_cpu: whole server process CPU"
echo " from /usr/bin/time; client_fps: mean over robots, all processes share the same cores)"
