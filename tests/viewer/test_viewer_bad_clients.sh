#!/usr/bin/env bash
# Bad WebSocket clients against the viewer while it maps: rgbdmap run --viewer --realtime with one
# robot (memq://) in the private loopback-only namespace; bad_clients.js sends malformed frames, unknown ops,
# subscribe and connection storms, forged frame lengths and slow readers that never read, while the
# Foxglove reference client keeps receiving. Checks: the run completes as without a viewer (every keyframe
# acknowledged), a late client is still served, the viewer's counters show the drops, and the process's
# peak memory stays bounded. Skips (77) without Node or @foxglove/ws-protocol. Usage: ... BIN_DIR
set -u
here="$(cd "$(dirname "$0")" && pwd)"
bin="$1"
node_dir="${RGBDMAP_NODE_DIR:-/usr/local/lib/rgbdmap-node}"
if ! command -v node >/dev/null 2>&1 || [ ! -f "$node_dir/node_modules/@foxglove/ws-protocol/package.json" ]; then
  echo "SKIP: node or @foxglove/ws-protocol in $node_dir missing (bash deploy/install_deps.sh installs them)"
  exit 77
fi
tmp=$(mktemp -d)
pid=""
cleanup() { [ -n "$pid" ] && kill -INT "$pid" 2>/dev/null; wait 2>/dev/null; rm -rf "$tmp"; }
trap cleanup EXIT
port=18767
fail=0
"$bin/rgbdmap" run --frames 300 --realtime --out "$tmp/out" --viewer "$port" >"$tmp/run.log" 2>&1 &
pid=$!
for _ in $(seq 1 600); do grep -q "viewer: http" "$tmp/run.log" && break; sleep 0.2; done  # after the synthesis
grep -q "viewer: http" "$tmp/run.log" || { echo "FAIL: the viewer did not start"; tail -20 "$tmp/run.log"; exit 1; }
NODE_PATH="$node_dir/node_modules" timeout 120 node "$here/bad_clients.js" 127.0.0.1 "$port" 12 || fail=1
for _ in $(seq 1 240); do
  grep -q "the map stays at" "$tmp/run.log" && break
  kill -0 "$pid" 2>/dev/null || break
  sleep 0.5
done
grep -q "the map stays at" "$tmp/run.log" || { echo "FAIL: the run did not finish with the viewer open"; tail -20 "$tmp/run.log"; fail=1; }
rss_kb=$(awk '/VmHWM/ {print $2}' "/proc/$pid/status" 2>/dev/null || echo 0)
kill -INT "$pid"
wait "$pid" || { echo "FAIL: rgbdmap run exited $? after Ctrl-C"; fail=1; }
pid=""
grep "viewer: closing" "$tmp/run.log"
acked=$(jq "[.robots[] | .keyframes_acked == .keyframes] | all" "$tmp/out/report.json" 2>/dev/null)
[ "$acked" = true ] && echo "ok: every keyframe acknowledged" || { echo "FAIL: keyframes not all acknowledged"; fail=1; }
echo "peak memory: $((rss_kb / 1024)) MB"
[ "$rss_kb" -gt 0 ] && [ "$rss_kb" -lt $((1536 * 1024)) ] || { echo "FAIL: peak memory $rss_kb kB"; fail=1; }
# The replies to 400,000 refused subscriptions overflow the storming client's queue (and the slow readers'
# when the map is large enough): dropped and counted, never queued without bound.
grep -Eq "viewer: closing.* dropped [1-9].*refused subscriptions [0-9]{6}" "$tmp/run.log" \
  && echo "ok: messages dropped and counted, the subscribe storm refused" \
  || { echo "FAIL: no dropped messages or refused subscriptions counted"; fail=1; }
[ "$fail" -eq 0 ] && echo "viewer.bad_clients: all checks passed"
exit "$fail"
