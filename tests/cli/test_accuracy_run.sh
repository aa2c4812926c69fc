#!/usr/bin/env bash
# The full system's accuracy as a user gets it: `rgbdmap run` on the shared fr1_rpy frames, every
# frame of the trajectory it writes (map frame, re-anchored on the optimised keyframes, smoothed) against the ground
# truth; one robot, then two robots on overlapping halves whose maps merge, then one robot on every 4th frame
# (faster motion between frames). Skips (77) without the data.
# Measured (Release, 2 cores, `bash deploy/bench_accuracy.sh --only rpy --runs 3`; docs/results.md): one
# robot 0.0086 m, odometry 0.0288 m, two robots joint 0.0076 m, one frame in 4 0.0097 m. The keyframes carry no features (the
# server extracts them) and the keyframe message takes 57.7 KB mean (lossless depth 30.8 KB, JPEG colour
# 26.4 KB).
set -uo pipefail
bin=$1
data=$(cd "$(dirname "$0")/../../.." && pwd)/shared/data/tum_fr1_rpy_first250
[ -d "$data" ] || { echo "SKIP: $data absent"; exit 77; }
source "$(dirname "$0")/cli_test_lib.sh"

check "rgbdmap run, one robot" 0 "$bin/rgbdmap" run --dataset "$data" --out "$tmp/one" --log-level warn
# A healthy run on real data warns about nothing (expected events are info).
warnings=$(grep -c 'warn\]' "$tmp/err.txt")
[ "$warnings" -eq 0 ] && echo "ok: no warning" || { echo "FAIL: $warnings warnings"; grep 'warn\]' "$tmp/err.txt" | head -5; fail=1; }
json "every frame in the trajectory" "$tmp/one/report.json" '.robots.robot0.frames == 250'
json "full system ATE <= 0.0100 m" "$tmp/one/report.json" '.robots.robot0.ate_rmse_m <= 0.0100'
json "at most 0.5 x odometry" "$tmp/one/report.json" \
  '.robots.robot0.ate_rmse_m <= 0.5 * .robots.robot0.ate_rmse_odometry_only_m'
json "bundle adjustment ran" "$tmp/one/report.json" \
  '.server.bundle_adjustment.local_ba_runs > 0 and .server.bundle_adjustment.global_ba_runs > 0'
json "keyframes <= 60 KB mean, features extracted by the server" "$tmp/one/report.json" \
  '.robots.robot0.keyframe_message_bytes_mean <= 60000 and .robots.robot0.keyframe_part_bytes_mean.features == 0 and .server.keyframes_features_extracted == .server.keyframes'
one=$(jq '.robots.robot0.ate_rmse_m' "$tmp/one/report.json")

check "rgbdmap run, two robots" 0 "$bin/rgbdmap" run --dataset "$data" --robots 2 --out "$tmp/two" \
  --log-level warn
json "one merged map" "$tmp/two/report.json" '.server.merged == true'
json "joint ATE <= 0.0095 m" "$tmp/two/report.json" '.server.joint_ate_rmse_m <= 0.0095'
# Two robots sharing the work map the sequence about as well as one robot doing all of it. 20 % for thread
# timing (which keyframes a batch, a local and a global BA see): in 6 runs on 2 cores one robot
# gave 0.0147-0.0153 m and the joint map 0.0151-0.0172 m (ratio up to 1.12; 1 run in 5 failed at 1.1).
json "joint ATE no worse than one robot on the whole sequence" "$tmp/two/report.json" \
  ".server.joint_ate_rmse_m <= 1.2 * $one"
# Faster motion between frames: every 4th frame (7.5 Hz). Through a blurred turn the odometry relocalises
# against the keyframes before its reference (odometry.relocalization_keyframes): 0.0097 m in one map, none
# lost; with 5 keyframes tried 0.1141 m (11 frames lost, a restart in a second map that never merged).
# Every 2nd frame (15 Hz, not run here for time) gives 0.0085 m; the placing of lost frames that it needs
# (0.0259 m without) is checked by link.RobotRun.LostFramesAreBridgedBetweenTheTrackedFramesAroundThem.
sub="$tmp/every4"
mkdir -p "$sub"
ln -s "$data/rgb" "$sub/rgb"
ln -s "$data/depth" "$sub/depth"
cp "$data/depth.txt" "$data/groundtruth.txt" "$sub/"
awk '/^#/ {print; next} {if ((n++) % 4 == 0) print}' "$data/rgb.txt" >"$sub/rgb.txt"
check "rgbdmap run, one frame in 4" 0 "$bin/rgbdmap" run --dataset "$sub" --out "$sub/out" --log-level warn
json "one frame in 4: one map, ATE <= 0.012 m" "$sub/out/report.json" \
  ".server.maps == 1 and .robots.robot0.ate_rmse_m <= 0.012"
echo "measured: one robot $one m at $(jq '.robots.robot0.keyframe_message_bytes_mean' "$tmp/one/report.json") bytes per keyframe, two robots $(jq -c '[.robots.robot0.ate_rmse_m, .robots.robot1.ate_rmse_m, .server.joint_ate_rmse_m]' "$tmp/two/report.json"), one frame in 4 $(jq '.robots.robot0.ate_rmse_m' "$sub/out/report.json") m"
exit "$fail"
