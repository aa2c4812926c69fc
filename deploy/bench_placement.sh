#!/usr/bin/env bash
# Placement benchmark: how soon a robot that starts anywhere in a stored map is placed in it. A map is made
# once (fr1_xyz frames 0-249 from ../shared/data; the synthetic loop, entered from another sampling of the
# same path), then the server is started on it
# with --frozen-map for each start: a robot runs 30 frames from that start (`rgbdmap run --frames A:A+30
# --map MAP --frozen-map`). Prints one row per start (placed, seconds from its first keyframe to its first
# placement as the server measured it, keyframes matched / taken) and the median, p90 and max over the
# starts. Starts: every --step frames of the sequence, mapped part and beyond.
#
# Usage: bash deploy/bench_placement.sh [--out DIR] [--step N] [--data DIR]
# Outputs in --out (default out/bench_placement): <sequence>_map/, runs/, table.txt
set -u
repo="$(cd "$(dirname "$0")/.." && pwd)"
bin="${RGBDMAP_BIN:-$repo/build/bin}"
out="out/bench_placement" step=20 data="$repo/../shared/data"
while [ $# -gt 0 ]; do
  case "$1" in
    --out) out="$2"; shift 2 ;;
    --step) step="$2"; shift 2 ;;
    --data) data="$2"; shift 2 ;;
    -h|--help) awk 'NR > 1 && !/^#/ {exit} NR > 1 {sub(/^# ?/, ""); print}' "$0"; exit 0 ;;
    *) echo "unknown argument: $1 (see --help)" >&2; exit 2 ;;
  esac
done
command -v jq >/dev/null || { echo "jq is required (deploy/install_deps.sh)" >&2; exit 1; }
rm -rf "$out" && mkdir -p "$out/runs"
table="$out/table.txt"
: >"$table"
row() { printf '%-10s %6s %7s %10s %9s\n' "$@" | tee -a "$table"; }
stats() {  # stats FILE: median, p90, max of the numbers in FILE
  sort -g "$1" | awk '{v[NR] = $1} END {if (NR == 0) {print "- - -"; exit}
    printf "%.3f %.3f %.3f", v[int((NR + 1) / 2)], v[int(0.9 * (NR - 1)) + 1], v[NR]}'
}
bench() {  # bench NAME MAP_DATASET MAP_FRAMES DATASET TOTAL_FRAMES: starts in DATASET
  local name=$1 map_ds=$2 map_frames=$3 ds=$4 total=$5 a times="$out/${1}_times.txt" placed=0 tried=0
  "$bin/rgbdmap" run --dataset "$map_ds" --frames "0:$map_frames" --out "$out/${name}_map" --log-level warn \
    >"$out/${name}_map.log" 2>&1 || { echo "$name: the map run failed" >&2; return 1; }
  : >"$times"
  row sequence start placed first_s matched
  for ((a = 0; a + 30 <= total; a += step)); do
    local r="$out/runs/${name}_$a"
    "$bin/rgbdmap" run --dataset "$ds" --frames "$a:$((a + 30))" --map "$out/${name}_map/map" --frozen-map \
      --out "$r" --log-level warn >"$r.log" 2>&1 || { echo "$name $a: run failed" >&2; continue; }
    local j; j=$(jq -c '.server.robots[] | select(.robot == "robot0")' "$r/report.json")
    local p s m; p=$(jq -r .placed <<<"$j") s=$(jq -r .first_placement_s <<<"$j")
    m="$(jq -r .keyframes_matched <<<"$j")/$(jq -r .keyframes_localized <<<"$j")"
    tried=$((tried + 1))
    [ "$p" = true ] && { placed=$((placed + 1)); echo "$s" >>"$times"; }
    row "$name" "$a" "$p" "$s" "$m"
  done
  echo "$name: $placed of $tried starts placed; time to first placement median / p90 / max: $(stats "$times") s" \
    | tee -a "$table"
}
xyz="$data/tum_fr1_xyz_first500"
[ -d "$xyz" ] && bench fr1_xyz "$xyz" 250 "$xyz" 494
# The synthetic room mapped from one pass (200 frames) and entered from another sampling of it (150 frames).
"$bin/rgbdmap" synth --scene loop --frames 200 --out "$out/loop" >/dev/null 2>&1
"$bin/rgbdmap" synth --scene loop --frames 150 --out "$out/loop_again" >/dev/null 2>&1
bench loop "$out/loop" 200 "$out/loop_again" 150
