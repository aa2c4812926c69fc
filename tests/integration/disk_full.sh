#!/usr/bin/env bash
# Disk full, for real (ctest integration.disk_full): inside a private mount and network namespace
# (unshare -m -n: loopback only, a mount nobody else sees) the map directory is a small tmpfs. One
# rgbdmap-server and one rgbdmap-client (--fast, LCM) run on a synthetic loop while a filler file leaves the
# tmpfs room for only a few keyframes, so the store fails mid-run; the disk stays full for HOLD_S seconds,
# then the filler is removed. Checks:
#   phase 1 (full mid-run): the server reports "store failed" (log, rgbdmap-monitor), acknowledges nothing it
#     did not store, recovers by itself once space is back (time measured), and by the end every keyframe is
#     stored and acknowledged (client exit 0, all_acked; server_summary.json keyframes = client keyframes,
#     store_state "ok", store_failures and store_recoveries >= 1); map.bt/.ot load, the summary parses,
#     keyframes_robot0.txt has every keyframe;
#   phase 2 (full at shutdown): the server restarted on the same directory, the disk filled completely, then
#     SIGINT: writing the outputs fails (reported in the log, exit 1), and every earlier output is still there, byte
#     for byte (no truncated map.bt in place of a good one), and no temporary file is left;
#   phase 3 (the robot's disk full): the client's keyframe spool on a tmpfs with room for a few keyframes,
#     the server hanging (SIGSTOP) for 2.5 s of the run so that they pile up: the robot says it sends live
#     only, keeps running, and every keyframe is acknowledged (client exit 0);
#   after all: the store reopens with no corrupt record and no truncated tail.
# Exit 77 (skip) where the namespaces or the tmpfs mount are not permitted (needs root).
# Usage: disk_full.sh BIN_DIR
set -u
repo="$(cd "$(dirname "$0")/../.." && pwd)"
bin="${1:-$repo/build/bin}"
if [ -z "${RGBDMAP_DISK_FULL_NS:-}" ]; then
  if ! command -v ip >/dev/null 2>&1 || ! unshare -m -n true 2>/dev/null \
    || ! unshare -m -n sh -c 'd=$(mktemp -d) && mount -t tmpfs -o size=1m tmpfs "$d" && umount "$d"; r=$?; rmdir "$d"; exit $r' \
      2>/dev/null; then
    echo "SKIP: 'unshare -m -n' with a tmpfs mount is not permitted here (needs root); the disk-full test did not run."
    exit 77
  fi
  RGBDMAP_DISK_FULL_NS=1 exec unshare -m -n bash "$0" "$bin"
fi
ip link set lo up && ip link set lo multicast on && ip route add 224.0.0.0/4 dev lo || exit 1

frames=120 hold_s=4 retry_s=1 room_kb=600 tmpfs_mb=48 spool_room_kb=400
tmp=$(mktemp -d)
map="$tmp/map"
server=""
cleanup() {
  [ -n "$server" ] && kill "$server" 2>/dev/null
  umount "$map" "$tmp/spool" 2>/dev/null
  rm -rf "$tmp"
}
trap cleanup EXIT
fail=0
ok() { echo "ok: $*"; }
bad() { echo "FAIL: $*"; fail=1; }
now() { date +%s.%N; }
since() { awk -v a="$1" -v b="$(now)" 'BEGIN {printf "%.2f", b - a}'; }
# wait_for SECONDS CMD...: runs CMD every 0.1 s until it succeeds (true) or SECONDS passed (false).
wait_for() {
  local tries=$(awk -v s="$1" 'BEGIN {printf "%d", s * 10}')
  shift
  for _ in $(seq 1 "$tries"); do "$@" && return 0; sleep 0.1; done
  "$@"
}
in_log() { grep -q "$1" "$tmp/server.log"; }
avail_bytes() { df --output=avail -B1 "$map" | tail -n 1 | tr -d ' '; }

"$bin/rgbdmap" synth --scene loop --frames "$frames" --out "$tmp/seq" >"$tmp/synth.log" 2>&1 \
  || { cat "$tmp/synth.log"; exit 1; }
mkdir -p "$map" "$tmp/keys" "$tmp/robot0"
mount -t tmpfs -o size=${tmpfs_mb}m tmpfs "$map" || { echo "FAIL: cannot mount a tmpfs"; exit 1; }
url='udpm://239.255.76.67:7667?ttl=0&recv_buf_size=8388608'
key=$(od -An -tx1 -N32 /dev/urandom | tr -d ' \n')
echo "$key" >"$tmp/keys/robot0.key"
echo "robot0 $key" >"$tmp/keys/server_keys.txt"
chmod 600 "$tmp/keys/"*
printf 'robot:\n  id: robot0\n  key_file: %s\ntransport:\n  url: "%s"\n' "$tmp/keys/robot0.key" "$url" \
  >"$tmp/client.yaml"
printf 'server:\n  map_dir: %s\n  robots: "robot0"\n  store_retry_s: %s\n  transport: "%s"\n  keys_file: %s\n' \
  "$map" "$retry_s" "$url" "$tmp/keys/server_keys.txt" >"$tmp/server.yaml"
start_server() {  # start_server LOG
  : >"$1"
  "$bin/rgbdmap-server" --config "$tmp/server.yaml" --status-every 1 >"$1" 2>&1 &
  server=$!
  wait_for 20 grep -q "serving" "$1" || { echo "FAIL: the server did not start"; cat "$1"; exit 1; }
}
stop_server() {  # stop_server: SIGINT, at most 60 s; the exit status
  kill -INT "$server"
  for _ in $(seq 1 600); do kill -0 "$server" 2>/dev/null || break; sleep 0.1; done
  kill -9 "$server" 2>/dev/null
  wait "$server"; local rc=$?
  server=""
  return "$rc"
}
monitor_state() {
  "$bin/rgbdmap-monitor" --transport "$url" --robots robot0 --keys-file "$tmp/keys/server_keys.txt" --once \
    --timeout 5 2>&1 | sed -n 's/.*state=\([a-z ]*\) .*/\1/p' | head -n 1
}

# --- phase 1: the disk fills up mid-run, then space comes back ---------------------------------------------
echo "== phase 1: map directory on a ${tmpfs_mb} MB tmpfs, filled to ${room_kb} KB free during the run"
start_server "$tmp/server.log"
filler_bytes=$(( $(avail_bytes) - room_kb * 1024 ))
head -c "$filler_bytes" /dev/zero >"$map/filler" || { echo "FAIL: cannot write the filler"; exit 1; }
echo "   filler $((filler_bytes / 1048576)) MB, $(( $(avail_bytes) / 1024 )) KB left"
t_start=$(now)
"$bin/rgbdmap-client" --config "$tmp/client.yaml" --dataset "$tmp/seq" --fast --out "$tmp/robot0" \
  >"$tmp/client.log" 2>&1 &
client=$!
if wait_for 60 in_log "append failed"; then
  t_full=$(now)
  ok "the store failed on the full disk $(since "$t_start") s into the run"
else
  bad "the store never failed (the disk did not fill up)"
fi
state=$(monitor_state)
[ "$state" = "store failed" ] && ok "rgbdmap-monitor shows state '$state'" || bad "monitor state '$state', not 'store failed'"
sleep "$hold_s"
grep -q "STORE FAILED" "$tmp/server.log" && ok "the server's status line says STORE FAILED" \
  || bad "no STORE FAILED status line"
ls "$map" | grep -q '\.tmp' && bad "a temporary file is left: $(ls "$map")"
rm -f "$map/filler"
t_free=$(now)
if wait_for 30 in_log "map store recovered"; then
  recover_s=$(since "$t_free")
  ok "the server recovered by itself ${recover_s} s after the space came back (store_retry_s $retry_s)"
else
  bad "the server did not recover within 30 s of the space coming back"
fi
client_rc=1
for _ in $(seq 1 1200); do kill -0 "$client" 2>/dev/null || break; sleep 0.1; done  # at most 120 s
kill -0 "$client" 2>/dev/null && { kill -9 "$client"; bad "the client did not finish within 120 s"; }
wait "$client"; client_rc=$?
acked_s=$(since "$t_free")
stop_server; server_rc=$?
[ "$client_rc" -eq 0 ] && ok "client exit 0, ${acked_s} s after the space came back" || bad "client exit $client_rc"
[ "$server_rc" -eq 0 ] && ok "server exit 0" || bad "server exit $server_rc"
cj="$tmp/robot0/client_robot0.json" sj="$map/server_summary.json"
jq -e '.all_acked == true and .keyframes_acked == .keyframes' "$cj" >/dev/null \
  && ok "every keyframe acknowledged: $(jq -c '{keyframes, keyframes_acked, retransmissions}' "$cj")" \
  || bad "not every keyframe acknowledged: $(jq -c . "$cj" 2>&1 | head -c 400)"
jq -e --argjson k "$(jq .keyframes "$cj")" '.keyframes == $k and .store_state == "ok" and .store_failures >= 1
    and .store_recoveries >= 1 and .keyframes_unacked_store_failed >= 1' "$sj" >/dev/null \
  && ok "server_summary.json: $(jq -c '{keyframes, store_state, store_failures, store_recoveries, keyframes_unacked_store_failed}' "$sj")" \
  || bad "server_summary.json: $(jq -c . "$sj" 2>&1 | head -c 600)"
check_outputs() {  # check_outputs WHEN: every output whole and consistent
  local n
  jq -e . "$sj" >/dev/null 2>&1 && ok "$1: server_summary.json parses" || bad "$1: server_summary.json does not parse"
  n=$(grep -vc '^#' "$map/keyframes_robot0.txt")
  [ "$n" -eq "$(jq .keyframes "$sj")" ] && ok "$1: keyframes_robot0.txt holds all $n keyframes" \
    || bad "$1: keyframes_robot0.txt holds $n keyframes"
  for f in map.bt map.ot; do
    "$bin/rgbdmap" view-map "$map/$f" >"$tmp/view_$f.txt" 2>&1 \
      && ok "$1: $f loads ($(awk '$1 == "occupied_leaves" {print $2}' "$tmp/view_$f.txt") occupied leaves)" \
      || bad "$1: $f does not load: $(head -c 300 "$tmp/view_$f.txt")"
  done
}
check_outputs "after the run"
grep -q "No space left" "$tmp/server.log" && ok "the failure named its cause (No space left on device)" \
  || bad "no 'No space left' in the server log"

# --- phase 2: the disk is full when the server writes its outputs -------------------------------------------
echo "== phase 2: server restarted on the same directory, disk filled completely, then SIGINT"
mkdir -p "$tmp/before"
for f in map.bt map.ot server_summary.json keyframes_robot0.txt robots.txt; do cp "$map/$f" "$tmp/before/"; done
start_server "$tmp/server2.log"
head -c $(( tmpfs_mb * 1048576 )) /dev/zero >"$map/filler" 2>/dev/null  # until ENOSPC
echo "   $(( $(avail_bytes) / 1024 )) KB left"
stop_server; rc=$?
[ "$rc" -eq 1 ] && ok "server exit 1: its outputs could not be written" || bad "server exit $rc, not 1"
grep -q "No space left" "$tmp/server2.log" && grep -q "output file(s) could not be written" "$tmp/server2.log" \
  && ok "writing the outputs on a full disk failed and said so" || bad "no write failure reported in the log"
for f in map.bt map.ot server_summary.json keyframes_robot0.txt robots.txt; do
  cmp -s "$tmp/before/$f" "$map/$f" && ok "$f unchanged (the old file stays whole)" || bad "$f changed or is gone"
done
ls "$map" | grep -q '\.tmp' && bad "a temporary file is left: $(ls "$map")" || ok "no temporary file left"
check_outputs "after the failed writes"
rm -f "$map/filler"

# --- phase 3: the robot's disk is full ----------------------------------------------------------------------
echo "== phase 3: the robot's keyframe spool on a 4 MB tmpfs with ${spool_room_kb} KB free"
start_server "$tmp/server4.log"
mkdir -p "$tmp/spool" "$tmp/robot0b"
mount -t tmpfs -o size=4m tmpfs "$tmp/spool" || { echo "FAIL: cannot mount the spool's tmpfs"; exit 1; }
head -c $(( $(df --output=avail -B1 "$tmp/spool" | tail -n 1) - spool_room_kb * 1024 )) /dev/zero >"$tmp/spool/filler"
# At 30 Hz; the server hangs (SIGSTOP) from 1 s to 3.5 s, so that keyframes pile up in the spool.
"$bin/rgbdmap-client" --config "$tmp/client.yaml" --dataset "$tmp/seq" --out "$tmp/robot0b" \
  --spool "$tmp/spool" >"$tmp/client_spool_full.log" 2>&1 &
client=$!
sleep 1; kill -STOP "$server"; sleep 2.5; kill -CONT "$server"
wait "$client"; client_rc=$?
stop_server >/dev/null
cj="$tmp/robot0b/client_robot0.json"
[ "$client_rc" -eq 0 ] && ok "client exit 0 with its spool's disk full" || bad "client exit $client_rc"
grep -q "keyframes are sent live only" "$tmp/client_spool_full.log" \
  && ok "the robot said it runs live only: $(grep -o 'keyframe spool: [^:]*: [^:]*' "$tmp/client_spool_full.log" | head -n 1)" \
  || bad "no 'live only' in the client's log"
jq -e '.keyframes_live_only > 0 and .keyframes_spooled > 0 and .all_acked and .keyframes_acked == .keyframes
    and .spool_depth == 0' "$cj" >/dev/null \
  && ok "spooled while there was room, live only after, all acknowledged: $(jq -c '{keyframes, keyframes_spooled, keyframes_live_only, keyframes_acked}' "$cj")" \
  || bad "client: $(jq -c '{keyframes, keyframes_spooled, keyframes_live_only, keyframes_acked, all_acked, spool_depth}' "$cj" 2>&1)"
umount "$tmp/spool"

# --- the store itself ---------------------------------------------------------------------------------------
start_server "$tmp/server3.log"
stop_server >/dev/null
grep -q "0 corrupt records skipped, 0 bytes of incomplete tail cut off" "$tmp/server3.log" \
  && ok "the store reopens clean: $(grep -o "map store '[^']*': [0-9]* keyframes" "$tmp/server3.log" | sed 's/.*: //')" \
  || bad "the store reopened with damage: $(grep "map store" "$tmp/server3.log" | head -n 3)"
echo "measured: store failed $(awk -v a="$t_start" -v b="${t_full:-0}" 'BEGIN {printf "%.1f", b - a}') s into the run," \
  "recovered ${recover_s:-n/a} s after space came back, all acknowledged ${acked_s:-n/a} s after;" \
  "$(jq -c '{keyframes, store_failures, store_recoveries, keyframes_unacked_store_failed}' "$tmp/before/server_summary.json")," \
  "client $(jq -c '{keyframes, keyframes_acked, retransmissions}' "$cj")"
if [ "$fail" -ne 0 ]; then
  for f in server.log server2.log client.log; do echo "--- $f"; tail -n 15 "$tmp/$f"; done
fi
[ "$fail" -eq 0 ] && echo "disk full: all checks passed"
exit "$fail"
