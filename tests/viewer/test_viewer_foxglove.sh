#!/usr/bin/env bash
# rgbdmap run --viewer with two robots over LCM (the viewer on a transport instance of its own, as a separate
# rgbdmap-viewer would be) in the private loopback-only namespace; after the run, while the viewer stays
# open, the Foxglove WebSocket reference client (npm @foxglove/ws-protocol under Node, foxglove_check.js)
# subscribes to every channel and checks the voxel count against map.bt's occupied voxels and each robot's
# trajectory against keyframes_<robot>.txt. The viewer records its topics (--record); after Ctrl-C the MCAP
# reference reader (npm @mcap/core, mcap_check.js) reads the recording and checks its last messages against
# the same files. Skips (77) without Node or the npm packages
# (deploy/install_deps.sh installs them into RGBDMAP_NODE_DIR, default /usr/local/lib/rgbdmap-node).
# Usage: test_viewer_foxglove.sh BIN_DIR   (run inside tests/transport/run_in_netns.sh)
set -u
here="$(cd "$(dirname "$0")" && pwd)"
bin="$1"
node_dir="${RGBDMAP_NODE_DIR:-/usr/local/lib/rgbdmap-node}"
if ! command -v node >/dev/null 2>&1 || ! command -v zstd >/dev/null 2>&1 ||
  [ ! -f "$node_dir/node_modules/@foxglove/ws-protocol/package.json" ] ||
  [ ! -f "$node_dir/node_modules/@mcap/core/package.json" ]; then
  echo "SKIP: node, zstd, @foxglove/ws-protocol or @mcap/core in $node_dir missing (bash deploy/install_deps.sh installs them)"
  exit 77
fi
source "$here/../cli/map_test_lib.sh"
tmp=$(mktemp -d)
pid=""
cleanup() { [ -n "$pid" ] && kill -INT "$pid" 2>/dev/null; wait 2>/dev/null; rm -rf "$tmp"; }
trap cleanup EXIT
port=18765
"$bin/rgbdmap" run --robots 2 --frames 200 --transport lcm --out "$tmp/out" --viewer "$port" \
  --record "$tmp/map.mcap" >"$tmp/run.log" 2>&1 &
pid=$!
wait_for_line "$tmp/run.log" "the map stays at" "$pid" || { echo "FAIL: the run did not finish with the viewer open"; tail -20 "$tmp/run.log"; exit 1; }
maps=$(jq -c '.server.merged_maps' "$tmp/out/report.json")
[ "$maps" = '[["robot0","robot1"]]' ] || { echo "FAIL: expected one merged map, report says $maps"; exit 1; }
# Occupied voxels of map.bt at the finest resolution (pruned leaves counted by volume).
voxels=$(occupied_voxels "$tmp/out/map.bt")
# The server's global 2-D map of the merged map (map_<id>.pgm, the largest if there are more): the viewer
# cuts its own from the streamed tree, so it has the same extent.
read -r grid_w grid_h < <(largest_grid "$tmp/out")
[ "$grid_w" -gt 0 ] || { echo "FAIL: no map_<id>.pgm in $tmp/out"; ls "$tmp/out"; exit 1; }
{
  printf '{"grid": {"width": %s, "height": %s}, "robots": {' "$grid_w" "$grid_h"
  sep=""
  for r in robot0 robot1; do
    printf '%s"%s": {"voxels": %s, "keyframes": [' "$sep" "$r" "$voxels"
    awk '!/^#/ {printf "%s[%s,%s,%s]", (n++ ? "," : ""), $2, $3, $4}' "$tmp/out/keyframes_$r.txt"
    printf ']}'
    sep=","
  done
  echo '}}'
} >"$tmp/expected.json"
echo "map.bt: $voxels occupied voxels; 2-D map ${grid_w} x ${grid_h}; keyframes: $(grep -vc '^#' "$tmp/out/keyframes_robot0.txt") + $(grep -vc '^#' "$tmp/out/keyframes_robot1.txt")"
NODE_PATH="$node_dir/node_modules" timeout 60 node "$here/foxglove_check.js" "ws://127.0.0.1:$port" "$tmp/expected.json" 30
status=$?
kill -INT "$pid"
wait "$pid"
run_status=$?
pid=""
[ "$run_status" -eq 0 ] || { echo "FAIL: rgbdmap run exited $run_status after Ctrl-C"; status=1; }
grep -q "recorded [0-9]* messages into" "$tmp/run.log" || { echo "FAIL: no recording logged"; tail -5 "$tmp/run.log"; status=1; }
NODE_PATH="$node_dir/node_modules" timeout 60 node "$here/mcap_check.js" "$tmp/map.mcap" "$tmp/expected.json" || status=1
[ "$status" -eq 0 ] && echo "viewer.foxglove: all checks passed"
exit "$status"
