#!/usr/bin/env bash
# End-to-end over real processes (ctest integration.netns): inside a private loopback-only network namespace,
# one rgbdmap-server and two rgbdmap-client processes on a synthetic 200-frame loop (robot0 frames 0:113,
# robot1 87:200, --fast), first over LCM and then over Cyclone DDS. deploy/run_multiprocess.sh --check asserts
# that every keyframe was acknowledged (client_<R>.json), that both robots end in one merged map
# (server_summary.json), that the server's optimised keyframes of both robots, aligned once to the ground
# truth, have ATE below 2 cm (measured 2.8 mm), and that rgbdmap-monitor --once printed a status. Here we
# also check the map directory's outputs, a fleet of light robots replaying robot0's recorded keyframes
# (deploy/bench_fleet.sh), and (robot_restart.sh) a robot killed and restarted mid-run. Exit 77 (skip) where 'unshare -n' is not permitted.
# Usage: run_multiprocess_netns.sh BIN_DIR
set -u
repo="$(cd "$(dirname "$0")/../.." && pwd)"
bin="${1:-$repo/build/bin}"
# rgbdmap-monitor's command line (no network: memq://).
mon="$bin/rgbdmap-monitor"
"$mon" --robots robot0 --open >/dev/null 2>&1; [ $? -eq 2 ] || { echo "FAIL: monitor without --transport must exit 2"; exit 1; }
"$mon" --transport memq:// --robots robot0 >/dev/null 2>&1; [ $? -eq 2 ] || { echo "FAIL: monitor without keys must exit 2"; exit 1; }
"$mon" --transport memq:// --robots "bad id" --open >/dev/null 2>&1; [ $? -eq 2 ] || { echo "FAIL: monitor bad robot id must exit 2"; exit 1; }
"$mon" --transport memq:// --robots robot0 --open --once --timeout 0.3 >/dev/null 2>&1
[ $? -eq 1 ] && echo "ok: monitor --once without a server exits 1" || { echo "FAIL: monitor --once timeout"; exit 1; }
if ! command -v ip >/dev/null 2>&1 || ! unshare -n true 2>/dev/null; then
  echo "SKIP: 'unshare -n' is not permitted here (needs root); the multi-process test did not run."
  exit 77
fi
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
"$bin/rgbdmap" synth --scene loop --frames 200 --out "$tmp/seq" >"$tmp/synth.log" 2>&1 \
  || { cat "$tmp/synth.log"; exit 1; }
fail=0
for transport in lcm dds; do
  echo "== $transport"
  rec=(); [ "$transport" = lcm ] && rec=(--record-keyframes)
  if ! RGBDMAP_BIN="$bin" bash "$repo/deploy/run_multiprocess.sh" --transport "$transport" --robots 2 \
      --dataset "$tmp/seq" --out "$tmp/$transport" --check 0.02 "${rec[@]}"; then
    fail=1
    for f in "$tmp/$transport"/logs/*; do echo "--- $f"; tail -n 15 "$f"; done
    continue
  fi
  for f in map/keyframes_robot0.txt map/keyframes_robot1.txt map/server_summary.json map/MANIFEST; do
    [ -s "$tmp/$transport/$f" ] && echo "ok: $f" || { echo "FAIL: $transport: $f missing"; fail=1; }
  done
  n=$(grep -vc '^#' "$tmp/$transport/keyframes_merged.txt")
  kf=$(jq .keyframes "$tmp/$transport/map/server_summary.json")
  [ "$n" -eq "$kf" ] && [ "$n" -ge 20 ] && echo "ok: $n keyframes in the server's files" \
    || { echo "FAIL: $transport: $n keyframes in files, summary says $kf"; fail=1; }
  # One key set for the server's figures, the same as report.json's "server" (tests/cli/test_cli.sh).
  python3 "$repo/deploy/check_json_schema.py" "$repo/deploy/schemas/server_stats.schema.json" \
    "$tmp/$transport/map/server_summary.json" && echo "ok: $transport: server_summary.json matches the schema" \
    || { echo "FAIL: $transport: server_summary.json does not match deploy/schemas/server_stats.schema.json"; fail=1; }
done
# rgbdmap-replay's command line, and a small fleet of light robots replaying what robot0 sent over LCM
# (deploy/bench_fleet.sh --check: every keyframe acknowledged, each minute's p90 ack latency at most 5 s, one
# merged map).
rp="$bin/rgbdmap-replay"
"$rp" --transport memq:// >/dev/null 2>&1; [ $? -eq 2 ] || { echo "FAIL: replay without --stream must exit 2"; fail=1; }
printf 'RGBDKFS1\377\377' >"$tmp/bad.rkf"
"$rp" --stream "$tmp/bad.rkf" --transport memq:// >"$tmp/bad.log" 2>&1; code=$?
[ "$code" -eq 1 ] && grep -q "truncated size" "$tmp/bad.log" && echo "ok: a corrupt stream exits 1 with the reason" \
  || { echo "FAIL: corrupt stream: exit $code"; cat "$tmp/bad.log"; fail=1; }
stream="$tmp/lcm/robots/robot0/keyframes_robot0.rkf"
if [ -s "$stream" ]; then
  echo "== fleet: 3 replayed robots"
  RGBDMAP_BIN="$bin" bash "$repo/deploy/bench_fleet.sh" --robots 3 --rate 4 --minutes 0.2 --stream "$stream" \
    --out "$tmp/fleet" --check 5000 || { fail=1; for f in "$tmp/fleet"/logs/*; do echo "--- $f"; tail -n 15 "$f"; done; }
else
  echo "FAIL: robot0 recorded no keyframe stream"; fail=1
fi
# A robot killed and restarted mid-run, over LCM with the first run's configs and keys.
if [ -s "$tmp/lcm/server.yaml" ]; then
  echo "== lcm, robot0 killed and restarted"
  bash "$repo/tests/transport/run_in_netns.sh" bash "$repo/tests/integration/robot_restart.sh" "$tmp/lcm" "$bin" \
    "$tmp/seq" 0.02 || fail=1
fi
[ "$fail" -eq 0 ] && echo "integration: all checks passed"
exit "$fail"
