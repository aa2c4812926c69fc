#!/usr/bin/env bash
# Accuracy of `rgbdmap run` (its defaults, every frame) on every sequence at hand: the real ones in
# ../shared/data (TUM fr1_rpy first 250 frames, fr1_xyz first 500; skipped with a message when absent) and
# the synthetic loop and sweep (exact ground truth). One row per sequence:
#   odometry      ATE of the robot's odometry alone (report.json ate_rmse_odometry_only_m)
#   keyframes     ATE of the optimised keyframes alone (keyframes_robot0.txt)
#   full system   ATE of every frame in the map frame (trajectory_robot0.txt, smoothed); with --runs N > 1
#                 the median and the min-max over the N runs
#   2 robots      the joint ATE of two robots on overlapping halves, one merged map
#   client ms     the robot's odometry per frame, median (report.json client_ms_per_frame_median)
#   ingest / decode CPU ms   the server's ingest worker and decode thread CPU per keyframe, median
# With --loaded each sequence runs once more while another job keeps every core busy (one busy loop per
# core): its full-system ATE and the gap to the idle median. ATE: TUM conventions, `rgbdmap eval`
# (association within 0.02 s, rigid alignment). Every run's output stays in OUT/<sequence>/.
# Usage: bash deploy/bench_accuracy.sh [--runs N] [--loaded] [--out DIR] [--only "xyz rpy loop sweep"]
#          [--robots2 0|1] [--server-config FILE] [--config FILE]
# Needs jq. Exit 0 when every run finished, 1 when one failed.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
bin=${RGBDMAP_BIN:-$root/build/bin}
data=$root/../shared/data
runs=1 loaded=0 out=$root/out/bench_accuracy only="rpy xyz loop sweep" robots2=1
extra=()
while [ $# -gt 0 ]; do
  case $1 in
    --runs) runs=$2; shift 2 ;;
    --loaded) loaded=1; shift ;;
    --out) out=$2; shift 2 ;;
    --only) only=$2; shift 2 ;;
    --robots2) robots2=$2; shift 2 ;;
    --server-config|--config) extra+=("$1" "$(cd "$(dirname "$2")" && pwd)/$(basename "$2")"); shift 2 ;;
    -h|--help) awk 'NR > 1 && !/^#/ {exit} NR > 1 {sub(/^# ?/, ""); print}' "$0"; exit 0 ;;
    *) echo "bench_accuracy: unknown argument $1 (see --help)" >&2; exit 2 ;;
  esac
done
command -v jq >/dev/null || { echo "bench_accuracy: jq is missing (deploy/install_deps.sh)" >&2; exit 2; }
[ -x "$bin/rgbdmap" ] || { echo "bench_accuracy: $bin/rgbdmap missing: run deploy/build.sh first" >&2; exit 2; }
mkdir -p "$out"
out=$(cd "$out" && pwd)
failed=0
load_pids=()
stop_load() { for p in "${load_pids[@]}"; do kill "$p" 2>/dev/null || true; done; load_pids=(); }
trap stop_load EXIT

ate() { "$bin/rgbdmap" eval --gt "$1" --est "$2" --json | jq -r '.ate.rmse_m // empty' 2>/dev/null || true; }
fmt() { [ -n "$1" ] && [ "$1" != null ] && printf '%.4f' "$1" || printf -- '-'; }
median() { sort -g | awk '{a[NR] = $1} END {if (NR == 0) print ""; else if (NR % 2) print a[(NR + 1) / 2];
  else print (a[NR / 2] + a[NR / 2 + 1]) / 2}'; }

# run NAME DIR ARGS...: one `rgbdmap run` into DIR; its log next to it
run() {
  local name=$1 dir=$2; shift 2
  rm -rf "$dir"
  mkdir -p "$(dirname "$dir")"
  if ! "$bin/rgbdmap" run --out "$dir" --log-level warn "${extra[@]}" "$@" >"$dir.log" 2>&1; then
    echo "bench_accuracy: $name failed, see $dir.log" >&2
    tail -n 3 "$dir.log" >&2
    failed=1
    return 1
  fi
}

# gt_of DIR: the ground truth of the current sequence's run in DIR (a dataset's, or the synthesised one's)
gt_of() {
  if [ "${args[0]}" = --dataset ]; then echo "${args[1]}/groundtruth.txt"; else echo "$1/synthetic_$seq/groundtruth.txt"; fi
}

rows=()
for seq in $only; do
  case $seq in
    rpy) args=(--dataset "$data/tum_fr1_rpy_first250"); label="TUM fr1_rpy, 250 frames" ;;
    xyz) args=(--dataset "$data/tum_fr1_xyz_first500"); label="TUM fr1_xyz, 500 frames" ;;
    loop) args=(--scene loop); label="synthetic loop, 300 frames" ;;
    sweep) args=(--scene sweep); label="synthetic sweep, 300 frames" ;;
    *) echo "bench_accuracy: unknown sequence $seq (rpy xyz loop sweep)" >&2; exit 2 ;;
  esac
  if [ "${args[0]}" = --dataset ] && [ ! -d "${args[1]}" ]; then
    echo "bench_accuracy: ${args[1]} absent: $seq skipped" >&2
    continue
  fi
  full=() odo="" kf="" client="" ingest="" decode=""
  for i in $(seq 1 "$runs"); do
    dir=$out/$seq/run$i
    run "$seq run $i" "$dir" "${args[@]}" || continue
    r=$dir/report.json
    full+=("$(jq -r '.robots.robot0.ate_rmse_m' "$r")")
    if [ "$i" = 1 ]; then
      odo=$(jq -r '.robots.robot0.ate_rmse_odometry_only_m' "$r")
      kf=$(ate "$(gt_of "$dir")" "$dir/keyframes_robot0.txt")
      client=$(jq -r '.robots.robot0.client_ms_per_frame_median' "$r")
      ingest=$(jq -r '.server.ingest_cpu_ms_median' "$r")
      decode=$(jq -r '.server.decode_cpu_ms_median' "$r")
    fi
  done
  med=$(printf '%s\n' "${full[@]}" | grep -v '^$' | median)
  spread=""
  if [ "${#full[@]}" -gt 1 ]; then
    lo=$(printf '%s\n' "${full[@]}" | sort -g | head -1)
    hi=$(printf '%s\n' "${full[@]}" | sort -g | tail -1)
    spread=" ($(fmt "$lo")-$(fmt "$hi"), ${#full[@]} runs)"
  fi
  joint=""
  if [ "$robots2" = 1 ] && run "$seq 2 robots" "$out/$seq/robots2" "${args[@]}" --robots 2; then
    joint=$(jq -r '.server.joint_ate_rmse_m' "$out/$seq/robots2/report.json")
  fi
  busy=""
  if [ "$loaded" = 1 ]; then
    for _ in $(seq 1 "$(nproc)"); do
      sh -c 'while :; do :; done' &
      load_pids+=($!)
    done
    if run "$seq loaded" "$out/$seq/loaded" "${args[@]}"; then
      l=$(jq -r '.robots.robot0.ate_rmse_m' "$out/$seq/loaded/report.json")
      busy=" | $(fmt "$l") ($(awk -v l="$l" -v m="$med" 'BEGIN {printf "%+.1f %%", 100 * (l - m) / m}'))"
    fi
    stop_load
  fi
  rows+=("| $label | $(fmt "$odo") | $(fmt "$kf") | $(fmt "$med")$spread | $(fmt "$joint") | $(printf '%.1f' "$client") | $(printf '%.1f / %.1f' "$ingest" "$decode")$busy |")
done

echo "ATE RMSE in metres (rgbdmap run defaults, every frame); outputs in $out"
header="| sequence | odometry | keyframes | full system | 2 robots merged | client ms/frame | server CPU ms/kf ingest / decode |"
rule="|---|---|---|---|---|---|---|"
[ "$loaded" = 1 ] && header="$header full system, cores busy |" && rule="$rule---|"
echo "$header"
echo "$rule"
printf '%s\n' "${rows[@]}"
exit $failed
