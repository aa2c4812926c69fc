#!/usr/bin/env bash
# A new user's mistakes, each named by the program on one line, with one exit code per class (README, "Exit
# codes"): real processes over LCM inside the loopback-only namespace of tests/transport/run_in_netns.sh
# (ctest integration.mistakes.netns). The table below is the contract: program, mistake, exit code, the line
# expected. The robot's link mistakes are named within 5 s of its start, while it keeps retrying (a wrong
# key: the server's status fails verification; a robot id the server does not serve: the server's unsigned
# notice, over LCM and DDS; no server at all: silence). After the table: the server's log names each claimed sender, the
# monitor says "bad signature" (and, with the wrong key, that it cannot verify), server_summary.json counts
# the bad signatures and the notice. Usage: mistakes.sh BIN_DIR
set -u
bin="$1"
tmp=$(mktemp -d)
server="" dds_server=""
trap '[ -n "$server" ] && kill "$server" $dds_server 2>/dev/null; rm -rf "$tmp"' EXIT
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
echo "$right" >"$tmp/robot2.key"
chmod 600 "$tmp"/*.txt "$tmp"/*.key
printf 'server:\n  map_dir: %s\n  robots: "robot0"\n  transport: "%s"\n  keys_file: %s\n' \
  "$tmp/map" "$url" "$tmp/server_keys.txt" >"$tmp/server.yaml"
printf 'robot:\n  id: robot0\n  key_file: %s\ntransport:\n  url: "%s"\nlink:\n  final_wait_s: 3\n' \
  "$tmp/robot0.key" "$url" >"$tmp/client.yaml"
client_with() {  # client_with NAME YAML_LINES...: a client configuration of these lines
  local f="$tmp/client_$1.yaml"; shift
  printf '%s\n' "$@" >"$f"; echo "$f"
}
printf 'server:\n  map_dir: %s\n  transport: "%s"\n' "$tmp/map_nokeys" "$url" >"$tmp/server_nokeys.yaml"

# within_5s LOG PATTERN: seconds from the log's first timestamped line to PATTERN's first line ("" if none)
seconds_to() {
  awk -v p="$2" 'match($0, /^\[[0-9:.]+/) {
      split(substr($0, 2, RLENGTH - 1), t, ":"); sec = t[1] * 3600 + t[2] * 60 + t[3]
      if (first == "") first = sec
      if ($0 ~ p) {printf "%.1f", sec - first; exit}
    }' "$1"
}
# mistake NAME EXIT PATTERN WITHIN_5S COMMAND...: the command exits EXIT and prints PATTERN (an extended
# regular expression); WITHIN_5S=1: that line comes at most 5 s after its first. A configuration error
# (exit 2) prints no usage text.
mistake() {
  local name="$1" want="$2" pattern="$3" timed="$4"; shift 4
  local log="$tmp/mistake_${name//[^A-Za-z0-9]/_}.log"
  "$@" >"$log" 2>&1
  local got=$?
  local verdict="exit $got"
  [ "$got" -eq "$want" ] || { bad "$name: exit $got, expected $want"; tail -n 5 "$log"; return; }
  grep -Eq -- "$pattern" "$log" || { bad "$name: no line '$pattern'"; tail -n 5 "$log"; return; }
  if [ "$timed" = 1 ]; then
    local s; s=$(seconds_to "$log" "$pattern")
    [ -n "$s" ] && awk -v s="$s" 'BEGIN {exit !(s <= 5)}' || { bad "$name: named after '$s' s"; return; }
    verdict="$verdict, named $s s after the start"
  fi
  if [ "$want" -eq 2 ] && grep -qi -- '^usage\|--help' "$log"; then bad "$name: usage text after the error"; return; fi
  ok "$name: $verdict: $(grep -Em1 -- "$pattern" "$log" | cut -c1-160)"
}

export CYCLONEDDS_URI="file://$(cd "$(dirname "$0")/../.." && pwd)/deploy/dds/cyclonedds-loopback.xml"
dds_url='dds://?domain=0'
"$bin/rgbdmap-server" --config "$tmp/server.yaml" >"$tmp/server.log" 2>&1 & server=$!
"$bin/rgbdmap-server" --config "$tmp/server.yaml" --transport "$dds_url" --map-dir "$tmp/map_dds" \
  >"$tmp/server_dds.log" 2>&1 & dds_server=$!
sleep 1
run_client() { "$bin/rgbdmap-client" --dataset "$tmp/seq" --fast --frames 2:30 "$@"; }
#       name                 exit  the line expected                                                  timed
mistake "client, wrong key"     3 "warn\] robot robot0: a server is there but the keys differ"        1 \
  run_client --config "$tmp/client.yaml" --out "$tmp/out"
has "wrong key: the final line says the server refused its messages for a bad signature" \
  "$tmp/mistake_client__wrong_key.log" "keyframes not accepted: the server refused [0-9]* messages from robot0 (hellos, heartbeats, keyframe chunks) for a bad signature (wrong key?)"
mistake "client, robot id not served" 3 \
  "warn\] robot robot2: the server does not serve robot id 'robot2': it is not in the server's robot list" 1 \
  run_client --config "$tmp/client.yaml" --robot-id robot2 --key-file "$tmp/robot2.key" --out "$tmp/out2"
has "robot id not served: the final line says why" "$tmp/mistake_client__robot_id_not_served.log" \
  "keyframes not accepted: the server does not serve robot id 'robot2'"
mistake "client, robot id not served (DDS)" 3 \
  "warn\] robot robot2: the server does not serve robot id 'robot2': it is not in the server's robot list" 1 \
  run_client --config "$tmp/client.yaml" --transport "$dds_url" --robot-id robot2 --key-file "$tmp/robot2.key" \
  --out "$tmp/out2dds"
mistake "client, no server at all" 3 "warn\] robot robot0: no server heard in 3 s" 1 \
  run_client --config "$tmp/client.yaml" --transport 'udpm://239.255.76.68:7668?ttl=0' --out "$tmp/out3"
mistake "server, missing server.keys_file" 2 "no server.keys_file and open mode is off" 0 \
  "$bin/rgbdmap-server" --config "$tmp/server_nokeys.yaml"
mistake "client, a value left empty" 2 "robot.key_file: has no value" 0 \
  run_client --config "$(client_with empty 'robot:' '  id: robot0' '  key_file:')"
mistake "client, malformed value" 2 "link.final_wait_s: 'soon' is not a valid number" 0 \
  run_client --config "$(client_with nan 'link:' '  final_wait_s: soon')" --key-file "$tmp/robot0.key"
mistake "client, value out of range" 2 "link.codec.jpeg_quality = 200 is outside \[1, 100\]" 0 \
  run_client --config "$(client_with range 'link:' '  codec:' '    jpeg_quality: 200')" --key-file "$tmp/robot0.key"
mistake "client, missing key file" 2 "cannot read key file $tmp/nowhere.key" 0 \
  run_client --config "$tmp/client.yaml" --key-file "$tmp/nowhere.key"
mistake "client, dds:// without CYCLONEDDS_URI" 2 "CYCLONEDDS_URI is not set" 0 \
  env -u CYCLONEDDS_URI "$bin/rgbdmap-client" --config "$tmp/client.yaml" --transport 'dds://?domain=0' \
  --dataset "$tmp/seq"

"$bin/rgbdmap-monitor" --transport "$url" --robots robot0 --keys-file "$tmp/server_keys.txt" --once \
  --timeout 10 >"$tmp/monitor.txt" 2>&1
has "monitor says bad signature" "$tmp/monitor.txt" "robot0 .*status=bad signature ([0-9]*)"
"$bin/rgbdmap-monitor" --transport "$url" --robots robot0 --keys-file "$tmp/wrong_keys.txt" --once \
  --timeout 3 >"$tmp/monitor_wrong.txt" 2>&1
code=$?
[ "$code" -eq 1 ] && ok "monitor with the wrong key: no status, exit 1" || bad "monitor exit code $code"
has "monitor says it cannot verify" "$tmp/monitor_wrong.txt" "cannot verify the server's status for robot0"
kill -INT "$server" "$dds_server"; wait "$server" "$dds_server"; server=""
has "the DDS server's log names the unknown robot" "$tmp/server_dds.log" "claiming to be from 'robot2'"
has "server log names the unknown robot" "$tmp/server.log" "claiming to be from 'robot2'"
has "server log names the claimed sender" "$tmp/server.log" "claiming to be from 'robot0': bad signature"
jq -e '.rejects_by_robot.robot0.bad_signature > 0 and .keyframes == 0 and .refusal_notices_sent >= 1' \
  "$tmp/map/server_summary.json" >/dev/null \
  && ok "server_summary.json: bad_signature for robot0, the notice to robot2" || { bad "server_summary.json"; cat "$tmp/map/server_summary.json"; }
[ "$fail" -eq 0 ] && echo "mistakes: all checks passed"
exit "$fail"
