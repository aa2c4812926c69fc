#!/usr/bin/env bash
# rgbdmap-lossy-relay end to end (run inside run_in_netns.sh): keyframe-sized LCM messages from one endpoint
# to another arrive through the relay without loss, about 1 - P of them with --drop-messages P, none come
# back to the sender's endpoint twice (the relay ignores its own datagrams), and the counters file is written.
set -euo pipefail
bin="$1"
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT
a="udpm://239.255.76.67:7667?ttl=0&recv_buf_size=8388608"
b="udpm://239.255.76.68:7668?ttl=0&recv_buf_size=8388608"
run() {  # run DROP_ARGS... ; prints the probe's received count
  "$bin/rgbdmap-lossy-relay" --a "$a" --b "$b" --seed 3 --duration 30 --stats "$tmp/stats.json" "$@" \
    >"$tmp/relay.out" &
  local relay=$!
  sleep 0.3
  "$bin/lcm_loss_probe" "$a" "$b" 60 140000 5 | awk '{print $5}'
  kill -TERM "$relay"
  wait "$relay"
}
clean="$(run)"
[ "$clean" = 60 ] || { echo "FAIL: $clean/60 delivered without loss"; exit 1; }
jq -e '.a_to_b.dropped == 0 and .a_to_b.forwarded >= 180 and .b_to_a.own_ignored >= 180' "$tmp/stats.json" \
  >/dev/null || { echo "FAIL: counters"; cat "$tmp/stats.json"; exit 1; }
lossy="$(run --drop-messages 0.3)"
[ "$lossy" -ge 30 ] && [ "$lossy" -le 54 ] || { echo "FAIL: $lossy/60 delivered at 30 % message loss"; exit 1; }
jq -e '.a_to_b.messages_dropped > 0 and .a_to_b.dropped >= 2 * .a_to_b.messages_dropped' "$tmp/stats.json" \
  >/dev/null || { echo "FAIL: message counters"; cat "$tmp/stats.json"; exit 1; }
all="$(run --drop-datagrams 1)"
[ "$all" = 0 ] || { echo "FAIL: $all delivered at 100 % datagram loss"; exit 1; }
echo "PASS lossy relay: clean 60/60, 30 % message loss $lossy/60, 100 % datagram loss 0/60"
