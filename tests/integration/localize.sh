#!/usr/bin/env bash
# Localisation in a stored map and extension of it, from outside (`rgbdmap run --map DIR [--frozen-map]`):
#   1. synthetic: a map of the loop (160 frames); the same room and path sampled anew (100 frames, another
#      session) localises in it with --frozen-map: placed within 1 s of its first keyframe, its every-frame
#      poses in the stored map's frame (the first session's ground-truth alignment, `rgbdmap eval
#      --align-on`) within 2 x the first session's ATE, slices sent to it, the robot told it is placed (its
#      link logs the ServerStatus' placement), the map directory byte-identical before and after;
#   2. never placed wrongly: other rooms (loop and sweep scenes of other seeds, 60 frames) against that map and, when
#      ../shared/data has it, against the fr1_xyz map below: not one is placed (each gets slices of its own
#      keyframes meanwhile, and its link logs that it is not placed);
#   3. fr1_xyz (../shared/data, skipped when absent): frames 0-249 map, 250-499 localise (same checks as 1);
#      the same 250-499 extend a copy of the map (no --frozen-map): one map of both sessions whose
#      keyframes' ATE is under EXTEND_BOUND; fr1_rpy (the same desk, the same motion-capture frame) is
#      placed, if at all, within 10 cm of its ground truth in the stored map's frame (its first 150 frames).
# Usage: localize.sh BIN_DIR OUT_DIR DATA_DIR. Exit 0 ok, 1 a check failed.
set -u
bin="$1" out="$2" data="${3:-}"
rm -rf "$out" && mkdir -p "$out"
fail() { echo "FAIL: $*"; exit 1; }
ok() { echo "ok: $*"; }
rg="$bin/rgbdmap"
ate() { "$rg" eval --gt "$1" --est "$2" "${@:3}" | awk '/^ate_rmse_m/ {print $2}'; }
robot() { jq -r ".server.robots[] | select(.robot == \"robot0\") | .$2" "$1/report.json"; }
lt() { awk -v a="$1" -v b="$2" 'BEGIN {exit !(a < b)}'; }
# localise NAME DATASET MAP FIRST_GT FIRST_EST [run options]: a frozen run of DATASET in MAP, checked.
localise() {
  local name=$1 ds=$2 map=$3 gt1=$4 est1=$5; shift 5
  find "$map" -type f | sort | xargs md5sum >"$out/$name.before.md5"
  "$rg" run --dataset "$ds" --map "$map" --frozen-map --out "$out/$name" "$@" >"$out/$name.log" 2>&1 \
    || fail "$name: rgbdmap run: $(tail -n 3 "$out/$name.log")"
  md5sum --quiet -c "$out/$name.before.md5" >"$out/$name.md5.txt" 2>&1 || fail "$name: the map changed: $(cat "$out/$name.md5.txt")"
  [ "$(find "$map" -type f | wc -l)" = "$(wc -l <"$out/$name.before.md5")" ] || fail "$name: a file appeared in the map"
  [ "$(robot "$out/$name" mode)" = localize ] && [ "$(robot "$out/$name" placed)" = true ] || fail "$name: not placed"
  [ "$(jq .server.slices_sent "$out/$name/report.json")" -gt 0 ] || fail "$name: no slice sent to the placed robot"
  grep -q ": placed in the stored map" "$out/$name.log" || fail "$name: the robot was not told (ServerStatus) it is placed"
  local first; first=$(robot "$out/$name" first_placement_s)
  lt "$first" 1.0 || fail "$name: first placement after $first s"
  local one two; one=$(ate "$gt1" "$est1") two=$(ate "$ds/groundtruth.txt" "$out/$name/trajectory_robot0.txt" --align-on "$est1" --align-gt "$gt1")
  lt "$two" "$(awk -v a="$one" 'BEGIN {print 2 * a}')" || fail "$name: ATE $two m in the map's frame, first session $one m"
  ok "$name: placed $first s after its first keyframe, $(robot "$out/$name" keyframes_matched)/$(robot "$out/$name" keyframes_localized) keyframes matched, ATE $two m in the stored map's frame (first session $one m), map unchanged"
}
# unplaced NAME DATASET MAP: a frozen run of another place in MAP is never placed.
unplaced() {
  "$rg" run --dataset "$2" --map "$3" --frozen-map --out "$out/$1" >"$out/$1.log" 2>&1 || fail "$1: rgbdmap run"
  [ "$(robot "$out/$1" placed)" = false ] || fail "$1: placed in a map of another place"
  [ "$(jq .server.slices_sent "$out/$1/report.json")" -gt 0 ] || fail "$1: no slice from its own keyframes"
  grep -q "not placed in the stored map yet" "$out/$1.log" || fail "$1: the robot was not told it is unplaced"
  ! grep -q ": placed in the stored map" "$out/$1.log" || fail "$1: the robot was told it is placed"
  tried=$((tried + 1))
}
tried=0

"$rg" synth --scene loop --frames 160 --out "$out/loop" >/dev/null 2>&1 || fail synth
"$rg" synth --scene loop --frames 100 --out "$out/loop_again" >/dev/null 2>&1 || fail synth
for s in 2 3; do
  "$rg" synth --scene loop --frames 60 --seed "$s" --out "$out/other_loop_$s" >/dev/null 2>&1 || fail synth
  "$rg" synth --scene sweep --frames 60 --seed "$s" --out "$out/other_sweep_$s" >/dev/null 2>&1 || fail synth
done
"$rg" run --dataset "$out/loop" --out "$out/loop_map" >"$out/loop_map.log" 2>&1 || fail "loop map"
localise loop_again "$out/loop_again" "$out/loop_map/map" "$out/loop/groundtruth.txt" "$out/loop_map/trajectory_robot0.txt"
for d in other_loop_2 other_sweep_2 other_loop_3 other_sweep_3; do unplaced "$d" "$out/$d" "$out/loop_map/map"; done

xyz="$data/tum_fr1_xyz_first500" rpy="$data/tum_fr1_rpy_first250"
if [ -d "$xyz" ]; then
  "$rg" run --dataset "$xyz" --frames 0:250 --out "$out/xyz_map" >"$out/xyz_map.log" 2>&1 || fail "xyz map"
  cp -r "$out/xyz_map/map" "$out/xyz_extend"
  localise xyz_localise "$xyz" "$out/xyz_map/map" "$xyz/groundtruth.txt" "$out/xyz_map/trajectory_robot0.txt" --frames 250:500
  for d in other_loop_2 other_sweep_3; do unplaced "xyz_$d" "$out/$d" "$out/xyz_map/map"; done
  "$rg" run --dataset "$xyz" --frames 250:500 --map "$out/xyz_extend" --out "$out/xyz_ext" >"$out/xyz_ext.log" 2>&1 \
    || fail "xyz extend"
  [ "$(jq .server.maps "$out/xyz_ext/report.json")" = 1 ] || fail "extend: not one map"
  ext=$(ate "$xyz/groundtruth.txt" "$out/xyz_ext/keyframes_robot0.txt")
  lt "$ext" "${EXTEND_BOUND:-0.0125}" || fail "extend: keyframes ATE $ext m"
  ok "extend: one map of $(grep -vc '^#' "$out/xyz_ext/keyframes_robot0.txt") keyframes (both sessions), keyframes ATE $ext m"
  if [ -d "$rpy" ]; then
    "$rg" run --dataset "$rpy" --frames 0:150 --map "$out/xyz_map/map" --frozen-map --out "$out/rpy" >"$out/rpy.log" 2>&1 || fail "rpy run"
    if [ "$(robot "$out/rpy" placed)" = true ]; then
      e=$(ate "$rpy/groundtruth.txt" "$out/rpy/trajectory_robot0.txt" --align-on "$out/xyz_map/trajectory_robot0.txt" --align-gt "$xyz/groundtruth.txt")
      lt "$e" 0.10 || fail "fr1_rpy placed in the fr1_xyz map $e m from its ground truth: a wrong placement"
      ok "fr1_rpy (the same desk) placed in the fr1_xyz map, $e m from its ground truth in the map's frame"
    else
      ok "fr1_rpy not placed in the fr1_xyz map"
    fi
  fi
else
  echo "skip: $xyz absent (the fr1_xyz part)"
fi
ok "never placed wrongly: $tried runs of other places, none placed"
