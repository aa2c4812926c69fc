#!/usr/bin/env bash
# `rgbdmap run` with two robots over LCM (udpm://) and over Cyclone DDS, every party with its own transport
# instance: every keyframe acknowledged, one merged map, both robots accurate. Runs inside the loopback-only
# network namespace of tests/transport/run_in_netns.sh (ctest entry run.transports.netns).
set -u
bin="$1"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
fail=0
for transport in lcm dds; do
  out="$tmp/$transport"
  if ! "$bin/rgbdmap" run --robots 2 --transport "$transport" --frames 150 --out "$out" >"$tmp/log" 2>&1; then
    echo "FAIL: run over $transport exited non-zero"; tail -20 "$tmp/log"; fail=1; continue
  fi
  /usr/bin/python3 - "$out/report.json" "$transport" <<'PY' || fail=1
import json, sys
r = json.load(open(sys.argv[1])); t = sys.argv[2]; ok = True
def check(cond, what):
    global ok
    print(("ok: " if cond else "FAIL: ") + t + ": " + what)
    ok = ok and cond
s = r["server"]
check(s["merged"] and len(s["maps"]) == 1, "one merged map %s" % s["maps"])
for name, robot in r["robots"].items():
    check(robot["keyframes"] > 5 and robot["keyframes_acked"] == robot["keyframes"]
          and robot["keyframes_stored_by_server"] == robot["keyframes"],
          "%s: every keyframe acknowledged and stored (%d)" % (name, robot["keyframes"]))
    check(robot["ate_rmse_m"] is not None and robot["ate_rmse_m"] < 0.015, "%s: ATE %.4f m < 0.015" % (name, robot["ate_rmse_m"] or 1))
check(s["joint_ate_rmse_m"] < 0.015, "joint ATE (one alignment) %.4f m < 0.015" % s["joint_ate_rmse_m"])
sys.exit(0 if ok else 1)
PY
done
exit $fail
