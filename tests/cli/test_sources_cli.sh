#!/usr/bin/env bash
# Frame sources on the command line: a synthetic sequence written into ROS 1 bags with the real
# rosbag writer (TUM topics: rgb8 colour, 32FC1 depth in metres, camera_info; and 16UC1 millimetres),
# read back by the official Python rosbag reader, and through `--source bag:` by odometry (the folder's
# trajectory, byte for byte with 32FC1; within a millimetre-rounding bound with 16UC1), convert, run and
# rgbdmap-client --record; bad bags and a missing camera exit 1 with one clear error line.
# Usage: test_sources_cli.sh BIN_DIR
set -u
bin="$1/rgbdmap"
client="$1/rgbdmap-client"
mkbag="$1/make_test_bag"
source "$(dirname "$0")/cli_test_lib.sh"

check "synth writes a sequence" 0 "$bin" synth --out "$tmp/seq" --scene sweep --frames 60 --seed 4
check "a TUM-style bag (rgb8, 32FC1, camera_info, bz2 chunks)" 0 "$mkbag" "$tmp/seq" "$tmp/tum.bag" --compression bz2
check "a 16UC1 bag (millimetres, bgr8)" 0 "$mkbag" "$tmp/seq" "$tmp/mm.bag" --depth 16UC1 --color bgr8
if /usr/bin/python3 -c 'import rosbag' 2>/dev/null; then
  check "the official Python rosbag reader reads the bag" 0 /usr/bin/python3 - "$tmp/tum.bag" <<'PY'
import sys, rosbag
bag = rosbag.Bag(sys.argv[1])
topics = bag.get_type_and_topic_info().topics
assert topics['/camera/rgb/image_color'].msg_type == 'sensor_msgs/Image', topics
assert topics['/camera/rgb/image_color'].message_count == 60
assert topics['/camera/depth/image'].message_count == 60
assert topics['/camera/rgb/camera_info'].msg_type == 'sensor_msgs/CameraInfo'
_, depth, _ = next(bag.read_messages(topics=['/camera/depth/image']))
assert depth.encoding == '32FC1' and (depth.width, depth.height) == (640, 480) and len(depth.data) == 640 * 480 * 4
_, info, _ = next(bag.read_messages(topics=['/camera/rgb/camera_info']))
assert info.K[0] == 525.0 and info.distortion_model == 'plumb_bob', info
PY
else
  echo "skip: python3-rosbag not installed (the cross-check with the official reader)"
fi

check "odometry on the folder" 0 "$bin" odometry --dataset "$tmp/seq" --out "$tmp/folder.txt"
check "odometry on the 32FC1 bag" 0 "$bin" odometry --source "bag:$tmp/tum.bag" --out "$tmp/bag.txt"
contains "camera from camera_info" "$tmp/err.txt" "camera from bag:.*tum.bag.*fx 525"
if cmp -s "$tmp/folder.txt" "$tmp/bag.txt"; then echo "ok: 32FC1 bag: the folder's trajectory, byte for byte"; else echo "FAIL: 32FC1 trajectory differs"; fail=1; fi
check "odometry on the 16UC1 bag" 0 "$bin" odometry --source "bag:$tmp/mm.bag" --out "$tmp/mm.txt"
ate_folder=$(ate "$tmp/seq/groundtruth.txt" "$tmp/folder.txt")
ate_mm=$(ate "$tmp/seq/groundtruth.txt" "$tmp/mm.txt")
echo "  ATE folder $ate_folder m, 16UC1 bag $ate_mm m"
below "folder ATE" "$ate_folder" 0.02
below "16UC1 bag: ATE within 2 mm of the folder's" "$(awk -v a="$ate_mm" -v b="$ate_folder" 'BEGIN { d = a - b; printf "%.6f", (d < 0 ? -d : d) }')" 0.002
below "16UC1 bag: trajectory within 5 mm of the folder's" "$(ate "$tmp/folder.txt" "$tmp/mm.txt")" 0.005

check "convert a bag into a folder" 0 "$bin" convert --source "bag:$tmp/tum.bag" --out "$tmp/conv"
contains "convert says how many" "$tmp/err.txt" "wrote 60 frames"
check "odometry on the converted folder" 0 "$bin" odometry --dataset "$tmp/conv" --out "$tmp/conv.txt"
if cmp -s "$tmp/folder.txt" "$tmp/conv.txt"; then echo "ok: converted folder: the same trajectory"; else echo "FAIL: converted trajectory differs"; fail=1; fi

printf 'robot:\n  id: bagbot\nlink:\n  final_wait_s: 0.2\n' >"$tmp/client.yaml"
check "client on the bag records what it consumed (exit 3: no server)" 3 "$client" --config "$tmp/client.yaml" \
  --source "bag:$tmp/tum.bag" --fast --frames 5:45 --record "$tmp/rec" --out "$tmp/cout"
json "client counts 40 frames, none dropped" "$tmp/cout/client_bagbot.json" '.frames == 40 and .dropped_frames == 0'
check "odometry on the recording" 0 "$bin" odometry --dataset "$tmp/rec" --out "$tmp/rec.txt"
[ "$(grep -vc '^#' "$tmp/rec.txt")" -eq 40 ] && echo "ok: the recording replays 40 frames" || { echo "FAIL: recording frames"; fail=1; }
contains "recording has camera.yaml" "$tmp/rec/camera.yaml" "fx: 525"
check "client on a folder replayed as a live camera, recording" 3 "$client" --config "$tmp/client.yaml" \
  --source "tum:$tmp/seq?live" --frames :30 --record "$tmp/live_rec" --out "$tmp/live"
json "live run counts frames and drops" "$tmp/live/client_bagbot.json" '.frames + .dropped_frames == 30'
check "odometry on the live recording" 0 "$bin" odometry --dataset "$tmp/live_rec" --out "$tmp/live_rec.txt"
# The client's live trajectory is in the map frame: without a server, its odometry on the camera mount
# (T_base_camera * T_odom_cam), one fixed rigid transform away from `rgbdmap odometry`'s: the same frames,
# and the same poses after a rigid alignment (trajectory_bagbot.txt is the same, smoothed).
if diff <(awk '!/^#/ {print $1}' "$tmp/live/trajectory_bagbot.txt") <(awk '!/^#/ {print $1}' "$tmp/live_rec.txt") >/dev/null; then
  echo "ok: the recording replays the live session's frames"
else
  echo "FAIL: replay of the live recording has other frames than the live trajectory"; fail=1
fi
below "replay of the live recording: the live trajectory up to the camera mount" \
  "$(ate "$tmp/live/trajectory_bagbot_live.txt" "$tmp/live_rec.txt")" 0.000001
check "run on a bag" 0 "$bin" run --source "bag:$tmp/tum.bag" --frames 40 --out "$tmp/run"
[ "$(grep -vc '^#' "$tmp/run/trajectory_robot0.txt")" -eq 40 ] && echo "ok: run: 40 poses" || { echo "FAIL: run poses"; fail=1; }

# Bad bags: exit 1, one error line saying what is wrong; no crash.
check "a bag that is not there" 1 "$bin" odometry --source "bag:$tmp/nodepth.bag" --out "$tmp/x.txt"
contains "missing file named" "$tmp/err.txt" "nodepth.bag"
"$mkbag" "$tmp/seq" "$tmp/nodepth.bag" --no-depth --frames 5 2>/dev/null
check "bag without the depth topic" 1 "$bin" odometry --source "bag:$tmp/nodepth.bag" --out "$tmp/x.txt"
contains "names the missing topic and the topics there are" "$tmp/err.txt" "no topic /camera/depth/image (choose another with ?depth=TOPIC; the bag has: /camera/rgb/camera_info"
one_error_line "missing topic: one line" "$tmp/err.txt"
"$mkbag" "$tmp/seq" "$tmp/enc.bag" --depth 8UC1 --frames 5 2>/dev/null
check "unsupported depth encoding" 1 "$bin" odometry --source "bag:$tmp/enc.bag" --out "$tmp/x.txt"
contains "names the encoding" "$tmp/err.txt" "unsupported depth encoding '8UC1' (32FC1 metres, 16UC1 millimetres)"
one_error_line "encoding: one line" "$tmp/err.txt"
head -c $(($(stat -c %s "$tmp/tum.bag") / 2)) "$tmp/tum.bag" >"$tmp/cut.bag"
check "truncated bag" 1 "$bin" odometry --source "bag:$tmp/cut.bag" --out "$tmp/x.txt"
contains "says it cannot read the bag and how to repair it" "$tmp/err.txt" "bag .*cut.bag: cannot read.*rosbag reindex"
one_error_line "truncated: one line" "$tmp/err.txt"
check "truncated bag, client" 1 "$client" --config "$tmp/client.yaml" --source "bag:$tmp/cut.bag" --out "$tmp/x"
check "truncated bag, convert" 1 "$bin" convert --source "bag:$tmp/cut.bag" --out "$tmp/x"
if [ -x /usr/bin/rosbag ] && /usr/bin/python3 -c 'import rosbag' 2>/dev/null; then
  check "rosbag reindex repairs the truncated bag, as the error says" 0 /usr/bin/python3 /usr/bin/rosbag reindex "$tmp/cut.bag"
  check "the repaired bag reads up to the cut" 0 "$bin" odometry --source "bag:$tmp/cut.bag" --out "$tmp/cut.txt"
  n=$(grep -vc '^#' "$tmp/cut.txt")
  [ "$n" -ge 20 ] && [ "$n" -lt 60 ] && echo "ok: $n of 60 frames before the cut" || { echo "FAIL: $n frames after reindex"; fail=1; }
fi

# No camera attached (the CI machines): one line naming what was tried, exit 1.
check "openni2 without a device" 1 "$bin" odometry --source openni2: --out "$tmp/x.txt"
contains "names OpenNI2 and its drivers" "$tmp/err.txt" "openni2: no RGB-D camera found by OpenNI2 .* (PS1080"
one_error_line "openni2: one line" "$tmp/err.txt"
check "openni2 without a device, client" 1 "$client" --config "$tmp/client.yaml" --source openni2: --out "$tmp/x"
one_error_line "openni2 client: one line" "$tmp/err.txt"

check "--dataset and --source together" 2 "$bin" odometry --dataset "$tmp/seq" --source "bag:$tmp/tum.bag" --out "$tmp/x.txt"
check "unknown source kind" 2 "$bin" odometry --source "realsense:0" --out "$tmp/x.txt"
contains "names it" "$tmp/err.txt" "unknown kind 'realsense'"
check "unknown bag option" 2 "$client" --source "bag:$tmp/tum.bag?colour=/x"
exit $fail
