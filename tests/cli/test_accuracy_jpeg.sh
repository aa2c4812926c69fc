#!/usr/bin/env bash
# Compressed colour: the shared fr1_xyz frames (colour JPEG 95, as good as lossless for the odometry) against
# the same frames re-encoded as JPEG 90 by make_jpeg_dataset, as a compressed image stream or an MJPEG
# camera mode delivers them. `rgbdmap run` defaults on both: the odometry and the full system (every frame)
# on JPEG 90 are within 10 % of the JPEG 95 run. Skips (77) without the data.
set -uo pipefail
bin=$1
data=$(cd "$(dirname "$0")/../../.." && pwd)/shared/data/tum_fr1_xyz_first500
[ -d "$data" ] || { echo "SKIP: $data absent"; exit 77; }
source "$(dirname "$0")/cli_test_lib.sh"

check "make_jpeg_dataset 90" 0 "$bin/make_jpeg_dataset" "$data" "$tmp/jpeg90" 90
check "rgbdmap run, JPEG 95 (as shared)" 0 "$bin/rgbdmap" run --dataset "$data" --out "$tmp/q95" --log-level warn
check "rgbdmap run, JPEG 90" 0 "$bin/rgbdmap" run --dataset "$tmp/jpeg90" --out "$tmp/q90" --log-level warn
a=$tmp/q95/report.json b=$tmp/q90/report.json
json "JPEG 90: every associated frame" "$b" '.robots.robot0.frames >= 490'
if [ -f "$a" ] && [ -f "$b" ]; then
  jq -s '{odometry: [.[0].robots.robot0.ate_rmse_odometry_only_m, .[1].robots.robot0.ate_rmse_odometry_only_m],
          full: [.[0].robots.robot0.ate_rmse_m, .[1].robots.robot0.ate_rmse_m]}' "$a" "$b" >"$tmp/pair.json"
  json "odometry on JPEG 90 within 10 % of JPEG 95" "$tmp/pair.json" '.odometry[1] <= 1.10 * .odometry[0]'
  json "full system on JPEG 90 within 10 % of JPEG 95" "$tmp/pair.json" '.full[1] <= 1.10 * .full[0]'
  echo "measured (JPEG 95, JPEG 90): $(jq -c . "$tmp/pair.json")"
fi
exit "$fail"
