#!/usr/bin/env bash
# A robot process killed mid-run (SIGKILL) and started again (issue #6): the server keeps the first session's
# keyframes, the new process is a second session of the same robot, every keyframe it sends is acknowledged,
# and loop closure re-anchors it: both robots end in one map, all server keyframes within MAX_ATE of the
# ground truth after one alignment. Runs inside run_in_netns.sh, reusing the configs and keys that
# deploy/run_multiprocess.sh wrote into RUN_DIR (transport LCM).
# Usage: robot_restart.sh RUN_DIR BIN_DIR DATASET MAX_ATE_M
set -u
run="$1" bin="$2" ds="$3" max_ate="$4"
d="$run/restart"
rm -rf "$d"; mkdir -p "$d"
sed "s|map_dir: .*|map_dir: $d/map|" "$run/server.yaml" >"$d/server.yaml"
"$bin/rgbdmap-server" --config "$d/server.yaml" >"$d/server.log" 2>&1 & server=$!
"$bin/rgbdmap-client" --config "$run/client_robot1.yaml" --dataset "$ds" --fast --frames 87:200 \
  --out "$d/robot1" >"$d/client_robot1.log" 2>&1 & robot1=$!
# robot0 at the dataset's frame rate, killed once the server has seen it and a second has passed.
"$bin/rgbdmap-client" --config "$run/client_robot0.yaml" --dataset "$ds" --frames 0:113 \
  --out "$d/robot0_first" >"$d/client_robot0_first.log" 2>&1 & first=$!
"$bin/rgbdmap-monitor" --transport "$(sed -n 's/^  transport: "\(.*\)"/\1/p' "$d/server.yaml")" --robots robot0 \
  --keys-file "$run/keys/server_keys.txt" --once --timeout 60 >"$d/monitor.txt" 2>&1
sleep 1
kill -9 "$first"; wait "$first" 2>/dev/null
"$bin/rgbdmap-client" --config "$run/client_robot0.yaml" --dataset "$ds" --fast --frames 40:113 \
  --out "$d/robot0" >"$d/client_robot0.log" 2>&1
second=$?
wait "$robot1"; r1=$?
kill -INT "$server"; wait "$server"; srv=$?
fail=0
[ "$second" -eq 0 ] && [ "$r1" -eq 0 ] && [ "$srv" -eq 0 ] || { echo "FAIL: exit codes $second $r1 $srv"; fail=1; }
sj="$d/map/server_summary.json"
jq -e 'any(.robots[]; .robot == "robot0" and .sessions == 2)' "$sj" >/dev/null \
  && echo "ok: robot0 has two sessions" || { echo "FAIL: robot0 sessions"; fail=1; }
jq -e '.all_acked == true' "$d/robot0/client_robot0.json" >/dev/null \
  && echo "ok: restarted robot0: every keyframe acknowledged" || { echo "FAIL: restarted robot0 acks"; fail=1; }
jq -e '.merged_maps | length == 1 and (.[0] | sort) == ["robot0", "robot1"]' "$sj" >/dev/null \
  && echo "ok: one merged map" || { echo "FAIL: not one map"; fail=1; }
cat "$d"/map/keyframes_robot*.txt | grep -v '^#' | sort -n >"$d/merged.txt"
ate=$("$bin/rgbdmap" eval --gt "$ds/groundtruth.txt" --est "$d/merged.txt" | awk '$1 == "ate_rmse_m" {print $2}')
awk -v a="$ate" -v m="$max_ate" 'BEGIN {exit !(a == a + 0 && a < m)}' \
  && echo "ok: merged ATE after restart $ate m" || { echo "FAIL: merged ATE '$ate' not below $max_ate"; fail=1; }
[ "$fail" -eq 0 ] || { tail -n 5 "$d"/*.log; }
exit "$fail"
