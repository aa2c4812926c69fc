#!/usr/bin/env bash
# Command-line contract of `rgbdmap`: outputs of synth -> odometry -> eval -> run, and clear errors with
# the documented exit codes (2 = usage, 1 = bad data; unreadable images are skipped and counted).
# Usage: test_cli.sh BIN_DIR
set -u
bin="$1/rgbdmap"
source "$(dirname "$0")/cli_test_lib.sh"

check "synth writes a sequence" 0 "$bin" synth --out "$tmp/seq" --scene sweep --frames 45 --seed 3
for f in rgb.txt depth.txt groundtruth.txt camera.yaml; do contains "synth wrote $f" "$tmp/seq/$f" "."; done
check "odometry runs" 0 "$bin" odometry --dataset "$tmp/seq" --out "$tmp/traj.txt"
contains "odometry summary" "$tmp/err.txt" "frames 45, keyframes"
[ "$(grep -vc '^#' "$tmp/traj.txt")" -eq 45 ] && echo "ok: one pose per frame" || { echo "FAIL: pose count"; fail=1; }
contains "keyframe list beside the trajectory" "$tmp/traj.keyframes.txt" "keyframe poses"
check "eval --json" 0 "$bin" eval --gt "$tmp/seq/groundtruth.txt" --est "$tmp/traj.txt" --json
json "eval prints ATE" "$tmp/out.txt" '.ate | type == "object"'
check "run on a dataset" 0 "$bin" run --dataset "$tmp/seq" --out "$tmp/run"
json "report has ATE" "$tmp/run/report.json" '.robots.robot0.ate_rmse_m | type == "number" and . < 0.1'
json "report has timing" "$tmp/run/report.json" '.robots.robot0 | has("client_ms_per_frame_median")'
[ -s "$tmp/run/trajectory_robot0.txt" ] && [ -s "$tmp/run/keyframes_robot0.txt" ] && echo "ok: run outputs" || { echo "FAIL: run outputs"; fail=1; }
json "report says the server ran" "$tmp/run/report.json" '.server | has("ingest_ms_median")'
# report.json's "server" has the key set of rgbdmap-server's server_summary.json
# (tests/integration/run_multiprocess_netns.sh checks that one against the same schema).
repo="$(cd "$(dirname "$0")/../.." && pwd)"
python3 "$repo/deploy/check_json_schema.py" "$repo/deploy/schemas/server_stats.schema.json" "$tmp/run/report.json" \
  --pointer /server && echo "ok: report.json's server matches the schema" \
  || { echo "FAIL: report.json's server does not match deploy/schemas/server_stats.schema.json"; fail=1; }
check "run with two robots on one dataset (--async)" 0 "$bin" run --dataset "$tmp/seq" --robots 2 --async --out "$tmp/run2"
json "--async: the robots did not wait for the server" "$tmp/run2/report.json" '.robots.robot0.waited_for_server == false'
json "robot1 in the report" "$tmp/run2/report.json" '.robots | has("robot1")'
json "robot1 frame range overlaps robot0's" "$tmp/run2/report.json" '.robots.robot1.frame_range == [20, 45]'
[ "$(grep -vc '^#' "$tmp/run2/trajectory_robot1.txt")" -eq 25 ] && echo "ok: robot1 one pose per frame of its segment" || { echo "FAIL: robot1 pose count"; fail=1; }
check "several datasets need matching --robots" 2 "$bin" run --dataset "$tmp/seq,$tmp/seq" --robots 3 --out "$tmp/run3"
# An unreadable image (corrupt, missing, wrong size) is skipped with a warning and counted; exit 1 only when
# no frame at all could be read. Malformed list lines stay errors (below).
cp -r "$tmp/seq" "$tmp/bad"
img="$tmp/bad/$(grep -v '^#' "$tmp/bad/rgb.txt" | awk 'NR == 10 {print $2}')"  # frame 9's colour image
head -c 100 "$img" >"$tmp/cut.png" && mv "$tmp/cut.png" "$img"  # a truncated PNG
check "odometry skips a corrupt image" 0 "$bin" odometry --dataset "$tmp/bad" --out "$tmp/bad.txt"
contains "the skipped frame is a warning naming the image" "$tmp/err.txt" "skipping frame 9: .*rgb/.*cannot read"
contains "odometry summary counts it" "$tmp/err.txt" "frames 44, .*unreadable 1"
check "run skips a corrupt image" 0 "$bin" run --dataset "$tmp/bad" --frames 20 --out "$tmp/runbad"
contains "run summary counts it" "$tmp/err.txt" "robot0 frames 0-20 (1 unreadable)"
json "report counts it" "$tmp/runbad/report.json" '.robots.robot0 | .unreadable_frames == 1 and .frames == 19'
rm -r "$tmp/bad/depth"
check "odometry with no readable frame is a data error" 1 "$bin" odometry --dataset "$tmp/bad" --out "$tmp/bad.txt"
contains "no readable frame is named" "$tmp/err.txt" "none of the 45 frames could be read"
check "run with no readable frame is a data error" 1 "$bin" run --dataset "$tmp/bad" --frames 20 --out "$tmp/runbad"
json "report still written" "$tmp/runbad/report.json" '.robots.robot0 | .unreadable_frames == 20 and .frames == 0'

check "unknown option is a usage error" 2 "$bin" odometry --dataset "$tmp/seq" --out "$tmp/x.txt" --bogus 1
contains "unknown option named" "$tmp/err.txt" "unknown option --bogus"
check "missing --out and bad --frames together" 2 "$bin" odometry --dataset "$tmp/seq" --frames -3
contains "both errors reported" "$tmp/err.txt" "--out is required"
check "missing dataset is a data error" 1 "$bin" odometry --dataset "$tmp/nope" --out "$tmp/x.txt"
printf 'odometry:\n  orb:\n    n_features: -1\n' >"$tmp/bad.yaml"
check "out-of-range config value" 2 "$bin" odometry --dataset "$tmp/seq" --out "$tmp/x.txt" --config "$tmp/bad.yaml"
contains "config error names the key" "$tmp/err.txt" "odometry.orb.n_features"
check "bad intrinsics override" 2 "$bin" odometry --dataset "$tmp/seq" --out "$tmp/x.txt" --intrinsics 1,2,3
echo "garbage" >"$tmp/seq/rgb.txt"
check "malformed rgb.txt is a data error" 1 "$bin" odometry --dataset "$tmp/seq" --out "$tmp/x.txt"
contains "malformed line named" "$tmp/err.txt" "rgb.txt:1"
# view-map: a hand-made .bt (root with 8 occupied leaf children), a corrupt one, a missing argument.
printf '# Octomap OcTree binary file\nid OcTree\nsize 9\nres 0.1\ndata\n\xaa\xaa' >"$tmp/tiny.bt"
check "view-map reads a .bt" 0 "$bin" view-map "$tmp/tiny.bt"
contains "view-map counts leaves" "$tmp/out.txt" "occupied_leaves 8"
contains "view-map prints the resolution" "$tmp/out.txt" "resolution_m 0.1"
printf '# Octomap OcTree binary file\nid OcTree\nsize 9\nres 0.1\ndata\n\xff' >"$tmp/cut.bt"
check "view-map rejects a truncated .bt" 1 "$bin" view-map "$tmp/cut.bt"
contains "view-map names the problem" "$tmp/err.txt" "truncated or corrupt"
check "view-map needs a file" 2 "$bin" view-map
check "unknown command" 2 "$bin" frobnicate
# Programs find their data files wherever they are: a viewer copied without share/rgbdmap beside it says
# at start what is missing and where it looked; pointed at the files by RGBDMAP_DATA_DIR it serves.
mkdir -p "$tmp/moved/bin" && cp "$1/rgbdmap-viewer" "$tmp/moved/bin/"
RGBDMAP_DATA_DIR="$tmp/nowhere" check "a moved viewer without its page is a configuration error" 2 \
  "$tmp/moved/bin/rgbdmap-viewer" --open --robots robot0 --transport memq://moved --port 0 --timeout 1
contains "the missing page is named with the places looked in" "$tmp/err.txt" \
  "viewer/index.html not found (looked in $tmp/nowhere/viewer/index.html, $tmp/moved/share/rgbdmap/viewer/index.html"
RGBDMAP_DATA_DIR="$1/../share/rgbdmap" check "RGBDMAP_DATA_DIR points a moved viewer at its page" 0 \
  "$tmp/moved/bin/rgbdmap-viewer" --open --robots robot0 --transport memq://moved --port 0 --timeout 1
contains "the moved viewer serves" "$tmp/err.txt" "rgbdmap-viewer: serving http://127.0.0.1:"
if [ "$fail" -eq 0 ]; then echo "cli: all checks passed"; fi
exit "$fail"
