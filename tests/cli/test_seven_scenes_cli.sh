#!/usr/bin/env bash
# A 7-Scenes sequence folder through `rgbdmap run --dataset`: a synthetic loop (exact ground truth, seen by
# 7-Scenes' colour camera) rewritten in the 7-Scenes layout by make_7scenes_fixture (the depth as the
# Kinect's depth camera sees it, 2.6 cm away with focal 585; the depth camera's poses) is converted with its
# depth registered back to the colour camera; its ground truth is the colour camera's again, and the map's
# ATE is close to the same run on the original folder (both global shutter, as the synthetic camera is). A
# frame without depth is skipped and counted.
# Usage: test_seven_scenes_cli.sh BIN_DIR
set -u
bin="$1/rgbdmap"
mkfix="$1/make_7scenes_fixture"
source "$(dirname "$0")/cli_test_lib.sh"

check "synth writes a loop" 0 "$bin" synth --out "$tmp/seq" --scene loop --frames 150 --seed 2
check "the loop in the 7-Scenes layout" 0 "$mkfix" "$tmp/seq" "$tmp/7s"
rm "$tmp/7s/frame-000077.depth.png"
check "run on the original folder" 0 "$bin" run --dataset "$tmp/seq" --out "$tmp/tum" --log-level warn
printf 'camera:\n  readout_s: 0\n' >"$tmp/global_shutter.yaml"  # the synthetic camera's (7-Scenes': 0.025 s)
check "run on the 7-Scenes folder" 0 "$bin" run --dataset "$tmp/7s" --out "$tmp/s7" --log-level warn \
  --config "$tmp/global_shutter.yaml"
contains "the missing depth image is named" "$tmp/err.txt" "frame-000077.depth.png"
contains "the converted camera is 7-Scenes' colour camera" "$tmp/s7/source_0/camera.yaml" "fx: 525"
contains "in millimetres" "$tmp/s7/source_0/camera.yaml" "depth_scale: 1000"
[ "$(grep -vc '^#' "$tmp/s7/source_0/rgb.txt")" -eq 149 ] && echo "ok: 149 frames converted" ||
  { echo "FAIL: frames converted: $(grep -vc '^#' "$tmp/s7/source_0/rgb.txt")"; fail=1; }
awk '/^#/ {next} {$1 = sprintf("%.6f", $1 - 1000); print}' "$tmp/seq/groundtruth.txt" >"$tmp/gt_shifted.txt"
below "the converted ground truth is the colour camera's" "$(ate "$tmp/gt_shifted.txt" "$tmp/s7/source_0/groundtruth.txt")" 0.0001
a_tum=$(jq -r '.robots.robot0.ate_rmse_m' "$tmp/tum/report.json")
a_7s=$(jq -r '.robots.robot0.ate_rmse_m' "$tmp/s7/report.json")
echo "  ATE original folder $a_tum m, 7-Scenes layout $a_7s m"
below "7-Scenes layout: map ATE" "$a_7s" 0.007
below "7-Scenes layout: within 3 mm of the original folder's (millimetre depth, registered twice)" \
  "$(awk -v a="$a_7s" -v b="$a_tum" 'BEGIN { printf "%.6f", a - b }')" 0.003
check "odometry on the 7-Scenes folder (--dataset)" 0 "$bin" odometry --dataset "$tmp/7s" --out "$tmp/odo.txt"
below "its odometry ATE" "$(ate "$tmp/s7/source_0/groundtruth.txt" "$tmp/odo.txt")" 0.02
check "an empty folder is no 7-Scenes sequence (TUM layout expected)" 1 "$bin" run --dataset "$tmp/empty_missing" --out "$tmp/x"
exit $fail
