#!/usr/bin/env bash
# `rgbdmap run` with two robots over LCM (udpm://) and over Cyclone DDS, every party with its own transport
# instance: every keyframe acknowledged, one merged map, both robots accurate. Runs inside the loopback-only
# network namespace of tests/transport/run_in_netns.sh (ctest entry run.transports.netns).
set -u
bin="$1"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
fail=0
ok() {  # ok "description" JQ_CONDITION: an ok/FAIL line for a condition on $r, report.json (false, null: FAIL)
  if jq -e "$2" "$r" >/dev/null; then echo "ok: $transport: $1"; else echo "FAIL: $transport: $1"; fail=1; fi
}
metres() { jq "$1" "$r" | awk '{printf "%.4f", ($1 == "null" ? 1 : $1)}'; }  # null prints 1.0000
for transport in lcm dds; do
  out="$tmp/$transport"
  if ! "$bin/rgbdmap" run --robots 2 --transport "$transport" --frames 150 --out "$out" >"$tmp/log" 2>&1; then
    echo "FAIL: run over $transport exited non-zero"; tail -n 20 "$tmp/log"; fail=1; continue
  fi
  r="$out/report.json"
  ok "one merged map $(jq -c .server.merged_maps "$r")" '.server.merged and (.server.merged_maps | length) == 1'
  for name in $(jq -r '.robots | keys_unsorted[]' "$r"); do
    robot=".robots[\"$name\"]"
    ok "$name: every keyframe acknowledged and stored ($(jq "$robot.keyframes" "$r"))" \
      "$robot | .keyframes > 5 and .keyframes_acked == .keyframes and .keyframes_stored_by_server == .keyframes"
    ok "$name: ATE $(metres "$robot.ate_rmse_m") m < 0.015" "$robot.ate_rmse_m | . != null and . < 0.015"
  done
  ok "joint ATE (one alignment) $(metres .server.joint_ate_rmse_m) m < 0.015" \
    '.server.joint_ate_rmse_m | . != null and . < 0.015'
done
exit $fail
