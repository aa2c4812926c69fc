#!/usr/bin/env bash
# `rgbdmap run` on a recording as fast as possible waits for the server's correction after each keyframe,
# so the map does not depend on the machine's load: the synthetic loop twice, the second time with every
# core kept busy by another job, gives byte-identical trajectories (--async, which does not wait, is checked in
# test_cli.sh).
set -uo pipefail
bin=$1
source "$(dirname "$0")/cli_test_lib.sh"
busy=()
stop_busy() { for p in "${busy[@]}"; do kill "$p" 2>/dev/null; done; busy=(); }
trap 'stop_busy; rm -rf "$tmp"' EXIT

run() { "$bin/rgbdmap" run --scene loop --frames 100 --log-level warn --out "$@"; }
check "idle run" 0 run "$tmp/idle"
for _ in $(seq 1 "$(nproc)"); do
  sh -c 'while :; do :; done' &
  busy+=($!)
done
check "run with every core busy" 0 run "$tmp/busy"
stop_busy
json "the robot waited for the server" "$tmp/idle/report.json" '.robots.robot0.waited_for_server == true'
json "... also on the busy machine" "$tmp/busy/report.json" '.robots.robot0.waited_for_server == true'
for f in trajectory_robot0.txt keyframes_robot0.txt; do
  check "$f byte-identical idle and busy" 0 cmp "$tmp/idle/$f" "$tmp/busy/$f"
done
exit "$fail"
