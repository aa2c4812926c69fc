#!/usr/bin/env bash
# Delivered fraction of keyframe-sized LCM messages vs UDP datagram loss, through rgbdmap-lossy-relay, in a
# private loopback-only network namespace (needs root for `unshare -n`; no netem needed).
#   bash deploy/bench_lcm_loss.sh [BUILD_BIN_DIR] [COUNT] [BYTES] [MTU]
# Prints one line per loss rate: loss, messages sent, received, fraction. With MTU (default 1500) the loss
# rate is per IP packet of that MTU (LCM's ~64 KB datagrams are lost when any IP fragment is, as on Wi-Fi);
# MTU 0: per LCM datagram.
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
bin="${1:-$here/../build/bin}"
count="${2:-100}"
bytes="${3:-140000}"
mtu="${4:-1500}"
if [ -z "${RGBDMAP_TRANSPORT_NETNS:-}" ]; then
  exec bash "$here/../tests/transport/run_in_netns.sh" bash "$0" "$(cd "$bin" && pwd)" "$count" "$bytes" "$mtu"
fi
a="udpm://239.255.76.67:7667?ttl=0&recv_buf_size=8388608"
b="udpm://239.255.76.68:7668?ttl=0&recv_buf_size=8388608"
echo "loss sent received fraction (messages of $bytes bytes, loss per packet of MTU $mtu)"
for p in 0 0.01 0.02 0.05; do
  "$bin/rgbdmap-lossy-relay" --a "$a" --b "$b" --drop-datagrams "$p" --mtu "$mtu" --seed 7 --duration 60 >/tmp/relay.$$ &
  relay=$!
  sleep 0.3
  line="$("$bin/lcm_loss_probe" "$a" "$b" "$count" "$bytes" 20)"
  kill -TERM "$relay"
  wait "$relay" || true
  echo "$p $(echo "$line" | awk '{print $3, $5, $9}')"
done
rm -f /tmp/relay.$$
