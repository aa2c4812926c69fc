#!/usr/bin/env bash
# The README's quick start, run as written: the fenced block after the "quickstart" marker is copied out of
# README.md and run by bash -e in a scratch folder that has the repository's deploy/ and build/bin (BIN_DIR)
# as the user's checkout does, inside the loopback-only namespace (its robot and server talk LCM). Checks
# that it succeeds, and what it says it leaves: out/map.png, the keys, quickstart_map/ with the map files,
# quickstart_robot0/ with the trajectories, every keyframe acknowledged.
# Usage: test_quickstart.sh BIN_DIR   (inside tests/transport/run_in_netns.sh)
set -u
here="$(cd "$(dirname "$0")" && pwd)"
repo="$(cd "$here/../.." && pwd)"
bin="$(cd "$1" && pwd)"
source "$here/cli_test_lib.sh"  # $tmp, $fail
awk '/<!-- quickstart/ {on = 1; next} on && /^```bash/ {inside = 1; next} inside && /^```/ {exit} inside' \
  "$repo/README.md" >"$tmp/quickstart.sh"
lines=$(grep -c . "$tmp/quickstart.sh")
[ "$lines" -ge 4 ] || { echo "FAIL: no quick start block in README.md ($lines lines)"; exit 1; }
mkdir -p "$tmp/checkout/build"
ln -s "$repo/deploy" "$tmp/checkout/deploy"
ln -s "$bin" "$tmp/checkout/build/bin"
start=$(date +%s)
(cd "$tmp/checkout" && timeout 600 bash -e "$tmp/quickstart.sh") >"$tmp/quickstart.log" 2>&1
code=$?
echo "quick start: $lines lines, exit $code after $(( $(date +%s) - start )) s"
[ "$code" -eq 0 ] || { echo "FAIL: the quick start failed"; tail -30 "$tmp/quickstart.log"; exit 1; }
cd "$tmp/checkout"
for f in out/map.png out/synthetic_loop/groundtruth.txt keys/robot0.key keys/server_keys.txt \
  quickstart_map/map.bt quickstart_map/map.png quickstart_map/keyframes_robot0.txt \
  quickstart_robot0/trajectory_robot0.txt quickstart_robot0/client_robot0.json; do
  [ -s "$f" ] && echo "ok: $f" || { echo "FAIL: $f missing"; fail=1; }
done
json "the robot's keyframes were all acknowledged" quickstart_robot0/client_robot0.json \
  '.keyframes_sent > 0 and .keyframes_acked == .keyframes_sent'
[ "$fail" -eq 0 ] && echo "cli.quickstart: the README's quick start works as written"
exit "$fail"
