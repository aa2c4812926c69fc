#!/usr/bin/env bash
# A robot with the wrong key ("clear failure"), real processes over LCM inside the loopback-only
# namespace of tests/transport/run_in_netns.sh (ctest integration.wrong_key.netns): the client names the
# differing keys within 5 s of its start, exits 3 and says the server refused its messages for a bad
# signature; a robot id the server does not serve is named within 5 s too, and in the server's log; the
# server log names the claimed sender; the monitor says
# "bad signature"; a monitor with the wrong key says it cannot verify instead of "no status";
# server_summary.json counts bad_signature for robot0. Usage: wrong_key.sh BIN_DIR
set -u
bin="$1"
tmp=$(mktemp -d)
server=""
trap '[ -n "$server" ] && kill "$server" 2>/dev/null; rm -rf "$tmp"' EXIT
fail=0
ok() { echo "ok: $1"; }
bad() { echo "FAIL: $1"; fail=1; }
has() { grep -q -- "$3" "$2" && ok "$1" || { bad "$1 (no '$3' in $2)"; tail -n 5 "$2"; }; }
url='udpm://239.255.76.67:7667?ttl=0&recv_buf_size=8388608'
"$bin/rgbdmap" synth --scene sweep --frames 30 --out "$tmp/seq" >"$tmp/synth.log" 2>&1 || { cat "$tmp/synth.log"; exit 1; }
right=$(printf '11%.0s' $(seq 32)) wrong=$(printf '22%.0s' $(seq 32))
echo "robot0 $right" >"$tmp/server_keys.txt"
echo "robot0 $wrong" >"$tmp/wrong_keys.txt"
echo "$wrong" >"$tmp/robot0.key"
chmod 600 "$tmp"/*.txt "$tmp/robot0.key"
printf 'server:\n  map_dir: %s\n  robots: "robot0"\n  transport: "%s"\n  keys_file: %s\n' \
  "$tmp/map" "$url" "$tmp/server_keys.txt" >"$tmp/server.yaml"
printf 'robot:\n  id: robot0\n  key_file: %s\ntransport:\n  url: "%s"\nlink:\n  final_wait_s: 3\n' \
  "$tmp/robot0.key" "$url" >"$tmp/client.yaml"
"$bin/rgbdmap-server" --config "$tmp/server.yaml" >"$tmp/server.log" 2>&1 & server=$!
sleep 1
"$bin/rgbdmap-client" --config "$tmp/client.yaml" --dataset "$tmp/seq" --fast --frames 2:30 --out "$tmp/out" \
  >"$tmp/client.log" 2>&1
code=$?
[ "$code" -eq 3 ] && ok "client exits 3" || bad "client exit code $code, expected 3"
has "client says the server refused its messages for a bad signature" "$tmp/client.log" \
  "keyframes not accepted: the server refused [0-9]* messages from robot0 (hellos, heartbeats, keyframe chunks) for a bad signature (wrong key?)"
# Named within 5 s of the start, on one line, while the robot keeps retrying.
within_5s() {  # within_5s "description" LOG PATTERN: PATTERN's first log line at most 5 s after the log's first
  local s
  s=$(awk -v p="$3" 'match($0, /^\[[0-9:.]+/) {
      split(substr($0, 2, RLENGTH - 1), t, ":"); sec = t[1] * 3600 + t[2] * 60 + t[3]
      if (first == "") first = sec
      if ($0 ~ p) {printf "%.1f", sec - first; exit}
    }' "$2")
  [ -n "$s" ] && awk -v s="$s" 'BEGIN {exit !(s <= 5)}' && ok "$1 ($s s after the start)" || { bad "$1 ('$s' s)"; cat "$2"; }
}
within_5s "the client names the differing keys" "$tmp/client.log" "warn\\] robot robot0: a server is there but the keys differ"
"$bin/rgbdmap-monitor" --transport "$url" --robots robot0 --keys-file "$tmp/server_keys.txt" --once \
  --timeout 10 >"$tmp/monitor.txt" 2>&1
has "monitor says bad signature" "$tmp/monitor.txt" "robot0 .*status=bad signature ([0-9]*)"
"$bin/rgbdmap-monitor" --transport "$url" --robots robot0 --keys-file "$tmp/wrong_keys.txt" --once \
  --timeout 3 >"$tmp/monitor_wrong.txt" 2>&1
code=$?
[ "$code" -eq 1 ] && ok "monitor with the wrong key: no status, exit 1" || bad "monitor exit code $code"
has "monitor says it cannot verify" "$tmp/monitor_wrong.txt" "cannot verify the server's status for robot0"
# A robot id the server does not serve: the client says so at 3 s, the server names the claimed sender.
echo "$right" >"$tmp/robot2.key"
chmod 600 "$tmp/robot2.key"
"$bin/rgbdmap-client" --config "$tmp/client.yaml" --robot-id robot2 --key-file "$tmp/robot2.key" --dataset "$tmp/seq" \
  --fast --frames 2:30 --out "$tmp/out2" >"$tmp/client2.log" 2>&1
code=$?
[ "$code" -eq 3 ] && ok "unknown robot: client exits 3" || bad "unknown robot: client exit code $code, expected 3"
within_5s "the client names what to check for robot2" "$tmp/client2.log" \
  "warn\\] robot robot2: no server heard in 3 s.*serves robot id 'robot2'"
kill -INT "$server"; wait "$server"; server=""
has "server log names the unknown robot" "$tmp/server.log" "claiming to be from 'robot2'"
has "server log names the claimed sender" "$tmp/server.log" "claiming to be from 'robot0': bad signature"
jq -e '.rejects_by_robot.robot0.bad_signature > 0 and .keyframes == 0' "$tmp/map/server_summary.json" >/dev/null \
  && ok "server_summary.json: bad_signature for robot0" || { bad "server_summary.json"; cat "$tmp/map/server_summary.json"; }
[ "$fail" -eq 0 ] && echo "wrong key: all checks passed"
exit "$fail"
