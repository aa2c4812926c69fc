#!/usr/bin/env bash
# `rgbdmap run --ros2` with two robots over LCM (the bridge on a transport instance of its own, as a separate
# rgbdmap-ros2 would be) in the loopback-only namespace of tests/transport/run_in_netns.sh. After the run,
# while the topics stay up, ros2_capture subscribes as a late-joining ROS 2 node (reliable; transient local
# for the latched topics) and keeps each topic's newest sample as CDR; ros2_topics_check.js decodes them
# with the reference ROS 2 CDR reader and compares them with map_<id>.pgm, map.bt and keyframes_<robot>.txt;
# `rgbdmap view-map` reads the /octomap_binary octree back. Then rgbdmap-ros2's mistakes: no CYCLONEDDS_URI,
# a bad mount and a mount for an unknown robot: exit 2, each named.
# Skips (77) without Node or the npm packages (deploy/install_deps.sh installs them).
# Usage: test_ros2_topics.sh BIN_DIR   (inside run_in_netns.sh)
set -u
here="$(cd "$(dirname "$0")" && pwd)"
bin="$1"
node_dir="${RGBDMAP_NODE_DIR:-/usr/local/lib/rgbdmap-node}"
if ! command -v node >/dev/null 2>&1 ||
  [ ! -f "$node_dir/node_modules/@foxglove/rosmsg2-serialization/package.json" ] ||
  [ ! -f "$node_dir/node_modules/@foxglove/rosmsg-msgs-common/package.json" ] ||
  [ ! -f "$node_dir/node_modules/@foxglove/rosmsg/package.json" ]; then
  echo "SKIP: node or @foxglove/rosmsg2-serialization, rosmsg-msgs-common, rosmsg in $node_dir missing (bash deploy/install_deps.sh installs them)"
  exit 77
fi
source "$here/../cli/cli_test_lib.sh"  # $tmp, $fail
source "$here/../cli/map_test_lib.sh"  # wait_for_line, occupied_voxels, largest_grid
pid=""
cleanup() { [ -n "$pid" ] && kill -INT "$pid" 2>/dev/null; wait 2>/dev/null; rm -rf "$tmp"; }
trap cleanup EXIT
ok() { echo "ok: $1"; }
bad() { echo "FAIL: $1"; fail=1; }
export CYCLONEDDS_URI="file://$here/../../deploy/dds/cyclonedds-loopback.xml"
"$bin/rgbdmap" run --robots 2 --frames 200 --transport lcm --out "$tmp/out" --ros2 >"$tmp/run.log" 2>&1 &
pid=$!
wait_for_line "$tmp/run.log" "the map stays on the ROS 2 topics" "$pid" ||
  { echo "FAIL: the run did not finish with the ROS 2 topics up"; tail -20 "$tmp/run.log"; exit 1; }
maps=$(jq -c '.server.merged_maps' "$tmp/out/report.json")
[ "$maps" = '[["robot0","robot1"]]' ] || { echo "FAIL: expected one merged map, report says $maps"; exit 1; }

# What the run wrote: the occupied voxels of map.bt, the largest map_<id>.pgm, the robots' keyframes.
voxels=$(occupied_voxels "$tmp/out/map.bt")
resolution=$("$bin/rgbdmap" view-map "$tmp/out/map.bt" | awk '/^resolution_m/ {print $2}')
read -r grid_w grid_h < <(largest_grid "$tmp/out")
{
  printf '{"resolution": %s, "voxels": %s, "grid": {"width": %s, "height": %s}, "robots": {' \
    "$resolution" "$voxels" "$grid_w" "$grid_h"
  sep=""
  for r in robot0 robot1; do
    printf '%s"%s": {"keyframes": [' "$sep" "$r"
    awk '!/^#/ {printf "%s[%s,%s,%s]", (n++ ? "," : ""), $2, $3, $4}' "$tmp/out/keyframes_$r.txt"
    printf ']}'
    sep=","
  done
  echo '}}'
} >"$tmp/expected.json"
echo "run: map.bt $voxels occupied voxels at $resolution m; 2-D map ${grid_w} x ${grid_h}"

mkdir -p "$tmp/capture"
topics=(/map:OccupancyGrid:latched /octomap_binary:Octomap:latched /map_cloud:PointCloud2:latched
  /tf_static:TFMessage:latched /tf:TFMessage:volatile)
for r in robot0 robot1; do
  topics+=("/$r/pose:PoseStamped:latched" "/$r/path:Path:latched" "/$r/local_map:OccupancyGrid:latched")
done
timeout 60 "$bin/ros2_capture" "$tmp/capture" 30 1 "${topics[@]}" >"$tmp/capture.log" 2>&1 &&
  ok "a late ROS 2 subscriber got all ${#topics[@]} topics" || { bad "capture"; cat "$tmp/capture.log"; }
NODE_PATH="$node_dir/node_modules" timeout 60 node "$here/ros2_topics_check.js" "$tmp/capture" \
  "$tmp/expected.json" "$tmp/octomap.bt" || fail=1
bt_voxels=$(occupied_voxels "$tmp/octomap.bt" 2>"$tmp/bt.log")
[ "$bt_voxels" = "$voxels" ] && ok "/octomap_binary read back by rgbdmap view-map: $bt_voxels occupied voxels, as map.bt" ||
  { bad "/octomap_binary as .bt: '$bt_voxels' occupied voxels, map.bt $voxels"; cat "$tmp/bt.log"; }

kill -INT "$pid"
wait "$pid"
run_status=$?
pid=""
[ "$run_status" -eq 0 ] && ok "rgbdmap run exits 0 after Ctrl-C" || bad "rgbdmap run exited $run_status after Ctrl-C"
grep -q "ros2: closing ([0-9]* samples published, 0 errors" "$tmp/run.log" && ok "$(grep -o 'ros2: closing.*' "$tmp/run.log")" ||
  { bad "no clean ros2 close logged"; tail -5 "$tmp/run.log"; }

# rgbdmap-ros2's mistakes.
env -u CYCLONEDDS_URI timeout 20 "$bin/rgbdmap-ros2" --transport 'udpm://239.255.76.67:7667?ttl=0' --robots robot0 \
  --open --timeout 1 >"$tmp/no_uri.log" 2>&1
code=$?
[ "$code" -eq 2 ] && ok "no CYCLONEDDS_URI: exit 2 (configuration)" || bad "no CYCLONEDDS_URI: exit $code"
[ "$(grep -c '^error:' "$tmp/no_uri.log")" -eq 1 ] && ok "no CYCLONEDDS_URI: one error line" || { bad "no CYCLONEDDS_URI: error lines"; cat "$tmp/no_uri.log"; }
grep -q "CYCLONEDDS_URI is not set" "$tmp/no_uri.log" && ok "no CYCLONEDDS_URI: named" || bad "no CYCLONEDDS_URI: not named"
timeout 20 "$bin/rgbdmap-ros2" --transport 'udpm://239.255.76.67:7667?ttl=0' --robots robot0 --open \
  --mounts 'robot0=0,0,0.4,0,10' >"$tmp/bad_mount.log" 2>&1
code=$?
[ "$code" -eq 2 ] && grep -q "mounts 'robot0=0,0,0.4,0,10'" "$tmp/bad_mount.log" && ok "a mount of 5 numbers: exit 2, named" ||
  { bad "bad mount: exit $code"; cat "$tmp/bad_mount.log"; }
timeout 20 "$bin/rgbdmap-ros2" --transport 'udpm://239.255.76.67:7667?ttl=0' --robots robot0 --open \
  --mounts 'robot9=0,0,0.4,0,10,0' >"$tmp/unknown_mount.log" 2>&1
code=$?
[ "$code" -eq 2 ] && grep -q "'robot9' is not one of --robots" "$tmp/unknown_mount.log" && ok "a mount for an unknown robot: exit 2, named" ||
  { bad "unknown robot's mount: exit $code"; cat "$tmp/unknown_mount.log"; }
[ "$fail" -eq 0 ] && echo "ros2.topics: all checks passed"
exit "$fail"
