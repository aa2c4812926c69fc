#!/usr/bin/env bash
# The ros2: frame source on live ROS 2 topics over Cyclone DDS, in the loopback-only namespace of
# tests/transport/run_in_netns.sh: ros2_test_publisher publishes a synthetic sequence as realsense2_camera
# would (bgr8, 32FC1, camera_info; the ROS 2 DDS type names and wire format); `rgbdmap odometry --source
# ros2:` tracks it with the camera from camera_info; ros2_wire_check compares what those DDS types put on the
# wire with ros2::encodeImage / encodeCameraInfo byte for byte; `rgbdmap-client --source ros2:` sends its keyframes to
# an rgbdmap-server over DDS; no CYCLONEDDS_URI, no publisher and a bad domain exit 1 with one error line.
# Usage: test_ros2_source.sh BIN_DIR   (inside run_in_netns.sh)
set -u
bin="$1"
here="$(cd "$(dirname "$0")" && pwd)"
tmp=$(mktemp -d)
pids=()
trap 'for p in "${pids[@]}"; do kill "$p" 2>/dev/null; done; wait 2>/dev/null; rm -rf "$tmp"' EXIT
fail=0
ok() { echo "ok: $1"; }
bad() { echo "FAIL: $1"; fail=1; }
has() { grep -q -- "$3" "$2" && ok "$1" || { bad "$1 (no '$3' in $2)"; tail -n 5 "$2"; }; }
one_error_line() {  # one_error_line "description" file
  local n; n=$(grep -c 'error\]' "$2")
  [ "$n" -eq 1 ] && ok "$1" || { bad "$1: $n error lines"; sed 's/^/  | /' "$2"; }
}
export CYCLONEDDS_URI="file://$here/../../deploy/dds/cyclonedds-loopback.xml"
timeout 60 "$bin/ros2_wire_check" >"$tmp/wire.log" 2>&1 && ok "wire format: $(grep -c '^ok' "$tmp/wire.log") messages byte for byte" ||
  { bad "wire format"; cat "$tmp/wire.log"; }
"$bin/rgbdmap" synth --out "$tmp/seq" --scene sweep --frames 90 --seed 4 >"$tmp/synth.log" 2>&1 ||
  { cat "$tmp/synth.log"; exit 1; }

# Odometry on the live topics (frames may drop: a live source hands on the newest pair).
"$bin/ros2_test_publisher" "$tmp/seq" --rate 30 --frames 60 --wait-readers 30 >"$tmp/pub.log" 2>&1 &
pids+=($!)
timeout 120 "$bin/rgbdmap" odometry --source ros2: --frames 40 --out "$tmp/odo.txt" >"$tmp/odo.log" 2>&1
code=$?
[ "$code" -eq 0 ] && ok "odometry --source ros2: exits 0" || { bad "odometry exit $code"; tail -5 "$tmp/odo.log"; }
wait "${pids[0]}" && ok "the publisher published every frame" || bad "publisher: $(cat "$tmp/pub.log")"
has "camera from camera_info" "$tmp/odo.log" "camera from ros2:.*fx 525"
poses=$(grep -vc '^#' "$tmp/odo.txt" 2>/dev/null || echo 0)
[ "$poses" -eq 40 ] && ok "40 poses" || bad "$poses poses, expected 40"
ate=$("$bin/rgbdmap" eval --gt "$tmp/seq/groundtruth.txt" --est "$tmp/odo.txt" --json | jq -r '.ate.rmse_m')
awk -v a="$ate" 'BEGIN { exit !(a + 0 < 0.01) }' && ok "ATE $ate m < 0.01" || bad "ATE $ate m"

# A robot on the topics, its keyframes to a server over DDS.
url='dds://?domain=0'
key=$(printf '33%.0s' $(seq 32))
echo "robot0 $key" >"$tmp/keys.txt"
echo "$key" >"$tmp/robot0.key"
chmod 600 "$tmp/keys.txt" "$tmp/robot0.key"
printf 'server:\n  map_dir: %s\n  robots: "robot0"\n  transport: "%s"\n  keys_file: %s\n' \
  "$tmp/map" "$url" "$tmp/keys.txt" >"$tmp/server.yaml"
printf 'robot:\n  id: robot0\n  key_file: %s\ntransport:\n  url: "%s"\nlink:\n  final_wait_s: 10\n' \
  "$tmp/robot0.key" "$url" >"$tmp/client.yaml"
"$bin/rgbdmap-server" --config "$tmp/server.yaml" >"$tmp/server.log" 2>&1 &
server=$!
pids+=($server)
"$bin/ros2_test_publisher" "$tmp/seq" --rate 30 --wait-readers 30 >"$tmp/pub2.log" 2>&1 &
pub2=$!
pids+=($pub2)
timeout 120 "$bin/rgbdmap-client" --config "$tmp/client.yaml" --source ros2: --frames :40 --out "$tmp/client" \
  >"$tmp/client.log" 2>&1
code=$?
[ "$code" -eq 0 ] && ok "rgbdmap-client --source ros2: exits 0" || { bad "client exit $code"; tail -5 "$tmp/client.log"; }
kill -INT "$server"; wait "$server"
kill "$pub2" 2>/dev/null; wait "$pub2" 2>/dev/null  # no publisher left for the cases below
stored=$(jq -r '.keyframes' "$tmp/map/server_summary.json" 2>/dev/null)
[ -n "$stored" ] && [ "$stored" -gt 2 ] && ok "the server stored $stored keyframes of robot0" ||
  { bad "server stored '${stored}' keyframes"; tail -5 "$tmp/server.log"; }

# Mistakes.
env -u CYCLONEDDS_URI timeout 30 "$bin/rgbdmap" odometry --source ros2: --out "$tmp/x.txt" >"$tmp/nouri.log" 2>&1
[ $? -eq 2 ] && ok "no CYCLONEDDS_URI: exit 2 (configuration)" || bad "no CYCLONEDDS_URI: exit $?"
has "no CYCLONEDDS_URI: says so" "$tmp/nouri.log" "CYCLONEDDS_URI is not set"
[ "$(grep -c '^error:' "$tmp/nouri.log")" -eq 1 ] && ok "no CYCLONEDDS_URI: one error line" || { bad "no CYCLONEDDS_URI: error lines"; cat "$tmp/nouri.log"; }
timeout 30 "$bin/rgbdmap" odometry --source 'ros2:?wait=1' --out "$tmp/x.txt" >"$tmp/nopub.log" 2>&1
[ $? -eq 1 ] && ok "no publisher: exit 1" || bad "no publisher: exit $?"
has "no publisher: names the topic" "$tmp/nopub.log" "no depth image on /camera/camera/aligned_depth_to_color/image_raw within 1 s"
one_error_line "no publisher: one line" "$tmp/nopub.log"
timeout 30 "$bin/rgbdmap" odometry --source 'ros2:?domain=999' --out "$tmp/x.txt" >"$tmp/domain.log" 2>&1
[ $? -eq 1 ] && ok "bad domain: exit 1" || bad "bad domain: exit $?"
has "bad domain: says so" "$tmp/domain.log" "domain must be 0..232"
[ "$fail" -eq 0 ] && echo "ros2 source: all checks passed"
exit "$fail"
