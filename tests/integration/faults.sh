#!/usr/bin/env bash
# Fault harness: one rgbdmap-server and two rgbdmap-client processes (robot0 frames 0:113, robot1
# 87:200 of a synthetic 200-frame loop, the same shares of a longer one; --fast but for kill9, robotkill9
# and outage) over LCM or Cyclone DDS, inside a private loopback-only
# network namespace, under one fault; then it compares what the robots sent and had acknowledged
# (client_<R>.json, keyframes_<R>.txt) with what the server stored (map/keyframes_<R>.txt, written from the
# map store at the end) and writes OUT/result.json. Used by the ctest entries faults.* (with --check) and by
# deploy/bench_faults.sh (without).
#
# Usage: faults.sh --fault F --transport lcm|dds --bin BIN_DIR --dataset DIR --out DIR [--check MAX_ATE_M]
#          [--seed N]
# Faults (fault_<name> below):
#   clean     no fault
#   loss30    30 % of the messages every process publishes are dropped (drop=0.3 on every transport URL)
#   loss60    60 % likewise
#   dgram5    5 % of the UDP datagrams: DDS via Cyclone's Internal/Test/XmitLossiness (a test config
#             derived from deploy/dds/cyclonedds-loopback.xml); LCM: 5 % of the IP packets (MTU 1500)
#             through rgbdmap-lossy-relay between the robots' and the server's multicast groups
#   dgram30   30 % of the datagrams (LCM: through the relay; DDS: XmitLossiness 300), the robots' link at
#             its defaults; a robot that ends with keyframes spooled starts again on its last frame to deliver
#             them
#   kill9     the server is killed (SIGKILL) at five random moments of the run and restarted on the same
#             map directory each time (the robots at 30 Hz here, not --fast: the run must last the kills)
#   robotkill9  while the server hangs (SIGSTOP) and keyframes are unacknowledged, robot0 is killed (SIGKILL)
#             and robot1 stopped (SIGINT); both start again on the rest of their frames with the same output
#             folder: their keyframe spools hold what was not acknowledged, and the new starts must deliver
#             it, each exactly once
#   outage    the server is killed 3 s into the run and started again 20 s later; the robots map on (the
#             dataset slowed 8 x, ~1 keyframe/s each) with the shipped link defaults: every keyframe made
#             during the outage must be stored
#   flood, diskfull: exit 77 here, see fault_flood and fault_diskfull below
# An acknowledged keyframe is never sent again, so "every keyframe sent is stored at the end" also shows
# that no kill -9 lost a keyframe the server had acknowledged before it.
# --check M: exit 1 unless every keyframe a robot sent is stored, every keyframe it had acknowledged is
# stored, the two robots end in one merged map with ATE below M (not checked for robotkill9) (clean, loss30, dgram5, kill9: and every
# keyframe is acknowledged; loss60: stored within the robot's final wait is enough).
# Exit 0 ok, 1 a check failed, 2 usage, 77 skipped (no network namespace; flood, diskfull).
set -u
fault="" transport="" bin="" ds="" out="" check="" seed=7
while [ $# -gt 0 ]; do
  case "$1" in
    --fault) fault="$2"; shift 2 ;;
    --transport) transport="$2"; shift 2 ;;
    --bin) bin="$2"; shift 2 ;;
    --dataset) ds="$2"; shift 2 ;;
    --out) out="$2"; shift 2 ;;
    --check) check="$2"; shift 2 ;;
    --seed) seed="$2"; shift 2 ;;
    *) echo "unknown argument: $1" >&2; exit 2 ;;
  esac
done
case "$transport" in lcm|dds) ;; *) echo "--transport must be lcm or dds" >&2; exit 2 ;; esac
[ -n "$fault" ] && [ -x "$bin/rgbdmap-server" ] && [ -s "$ds/groundtruth.txt" ] && [ -n "$out" ] \
  || { echo "usage: faults.sh --fault F --transport T --bin DIR --dataset DIR --out DIR" >&2; exit 2; }
repo="$(cd "$(dirname "$0")/../.." && pwd)"
if [ -z "${RGBDMAP_TRANSPORT_NETNS:-}" ]; then  # re-run inside the namespace (exit 77 where not permitted)
  exec bash "$repo/tests/transport/run_in_netns.sh" bash "$0" --fault "$fault" --transport "$transport" \
    --bin "$bin" --dataset "$ds" --out "$out" ${check:+--check "$check"} --seed "$seed"
fi
RANDOM=$seed
robots=(robot0 robot1)
# robot0 the first 56.5 % of the frames, robot1 the last 56.5 % (0:113 and 87:200 of the 200-frame loop).
nframes=$(grep -vc '^#' "$ds/rgb.txt")
ranges=("0:$(( (nframes * 565 + 500) / 1000 ))" "$(( nframes - (nframes * 565 + 500) / 1000 )):$nframes")
# outage: how long the server is down, and how many times slower than recorded the robots run.
outage_s=${RGBDMAP_OUTAGE_S:-20} outage_slow=${RGBDMAP_OUTAGE_SLOW:-8}
drop="" final_wait=20 max_attempts=20 chunk_bytes=-1 server_pid="" ready_before=0 pace=--fast server_url="" client_pids=()
lcm_url='udpm://239.255.76.67:7667?ttl=0&recv_buf_size=8388608'
dds_url='dds://?domain=0'
export CYCLONEDDS_URI="file://$repo/deploy/dds/cyclonedds-loopback.xml"

# --- processes -----------------------------------------------------------------------------------------------
url_for() {  # url_for INDEX: the base URL, plus message loss with a seed of its own per process
  local u; u=$([ "$transport" = lcm ] && echo "$lcm_url" || echo "$dds_url")
  [ -n "$drop" ] && u="$u&drop=$drop&drop_seed=$((seed * 10 + $1))"
  echo "$u"
}
write_configs() {
  rm -rf "$out"; mkdir -p "$out/keys" "$out/logs"; chmod 700 "$out/keys"
  : >"$out/keys/server_keys.txt"
  local i=0 r
  for r in "${robots[@]}"; do
    i=$((i + 1))
    od -An -tx1 -N32 /dev/urandom | tr -d ' \n' >"$out/keys/$r.key"
    echo "$r $(cat "$out/keys/$r.key")" >>"$out/keys/server_keys.txt"
    printf 'robot:\n  id: %s\n  key_file: keys/%s.key\ntransport:\n  url: "%s"\nlink:\n  chunk_bytes: %s\n' \
      "$r" "$r" "$(url_for "$i")" "$chunk_bytes" >"$out/client_$r.yaml"
    # empty: the default
    [ -n "$final_wait" ] && printf '  final_wait_s: %s\n' "$final_wait" >>"$out/client_$r.yaml"
    [ -n "$max_attempts" ] && printf '  reliable: {max_attempts: %s}\n' "$max_attempts" >>"$out/client_$r.yaml"
  done
  chmod 600 "$out/keys/"*
  printf 'server:\n  map_dir: %s\n  robots: "robot0,robot1"\n  transport: "%s"\n  keys_file: %s\n' \
    "$out/map" "${server_url:-$(url_for 0)}" "$out/keys/server_keys.txt" >"$out/server.yaml"
}
start_server() {  # appends to logs/server.log (a restarted server continues the same log)
  echo "=== server start $(date +%T.%N)" >>"$out/logs/server.log"
  ready_before=$(grep -c '] ready on ' "$out/logs/server.log")
  "$bin/rgbdmap-server" --config "$out/server.yaml" --status-every 0 >>"$out/logs/server.log" 2>&1 &
  server_pid=$!
}
wait_ready() {  # until the server last started logs "ready on" (at most 30 s), or it is gone
  local i
  for i in $(seq 300); do
    [ "$(grep -c '] ready on ' "$out/logs/server.log")" -gt "$ready_before" ] && return 0
    kill -0 "$server_pid" 2>/dev/null || return 1
    sleep 0.1
  done
  echo "server not ready after 30 s" >>"$out/logs/exits.txt"; return 1
}
start_clients() {
  local i
  for i in "${!robots[@]}"; do
    "$bin/rgbdmap-client" --config "$out/client_${robots[$i]}.yaml" --dataset "$ds" $pace \
      --frames "${ranges[$i]}" --out "$out/robots/${robots[$i]}" >"$out/logs/client_${robots[$i]}.log" 2>&1 &
    client_pids+=($!)
  done
}
clients_running() { local p; for p in "${client_pids[@]}"; do kill -0 "$p" 2>/dev/null && return 0; done; return 1; }
wait_clients() { local p; for p in "${client_pids[@]}"; do wait "$p"; echo "client exit $?" >>"$out/logs/exits.txt"; done; }
stop_server() {
  kill -0 "$server_pid" 2>/dev/null || echo "server $server_pid no longer running at the end" >>"$out/logs/exits.txt"
  wait_ready  # a server stopped while it restores the map store still stops cleanly; this keeps the log readable
  kill -INT "$server_pid"; wait "$server_pid"; echo "server exit $?" >>"$out/logs/exits.txt"
}
run_plain() { start_server; wait_ready; start_clients; wait_clients; ${after_clients:-true}; stop_server; }
# A robot whose run ended with keyframes left in its spool starts again (on its last frame, same --out):
# the new start must deliver them. The first run's keyframes_R.txt and client_R.json are kept as *.run1.*.
restart_spooled() {
  local i r d end
  for i in "${!robots[@]}"; do
    r=${robots[$i]} d="$out/robots/${robots[$i]}"
    [ "$(jq .spool_depth "$d/client_$r.json" 2>/dev/null)" = 0 ] && continue
    cp "$d/keyframes_$r.txt" "$d/keyframes_$r.run1.txt"; cp "$d/client_$r.json" "$d/client_$r.run1.json"
    end=${ranges[$i]#*:}
    grep -v '^#' "$ds/rgb.txt" | awk -v n="$((end - 1))" 'NR == n + 1 {print $1}' >"$out/restart_t_$r.txt"
    echo "$r restarted on $((end - 1)):$end with $(jq .spool_depth "$d/client_$r.json") keyframes spooled" \
      >>"$out/logs/kills.txt"
    "$bin/rgbdmap-client" --config "$out/client_$r.yaml" --dataset "$ds" --frames "$((end - 1)):$end" \
      --out "$d" >"$out/logs/client_${r}_restart.log" 2>&1
    echo "client $r restart exit $?" >>"$out/logs/exits.txt"
  done
}

# --- faults --------------------------------------------------------------------------------------------------
fault_clean() { write_configs; run_plain; }
# Message loss drops whole transport messages. Over LCM the robots send whole keyframes here (chunk_bytes
# 0, one keyframe = one message): with the udpm:// default of 1100-byte chunks every chunk would be lost
# at that rate, a link losing 30-60 % of its packets (deploy/lcm.md: chunks are for packet loss, DDS for
# links that bad; measured there).
# The robots are configured for such a link: a keyframe is resent until acknowledged (max_attempts 0) and
# the final wait is 60 s. The defaults (20 s, 20 attempts) gave the last keyframes ~14 sends (backoff capped
# at 2 s) before the robot exited: all lost with 0.6^14 = 8e-4 each, ~2 % of loss60 runs lost a keyframe
# (README.md, Faults). With 60 s they get ~30 sends (0.6^30 = 2e-7); the wait ends as soon as
# every keyframe is acknowledged.
message_loss() {
  drop=$1 final_wait=60 max_attempts=0
  [ "$transport" = lcm ] && chunk_bytes=0
  write_configs; run_plain
}
fault_loss30() { message_loss 0.3; }
fault_loss60() { message_loss 0.6; }
# Five SIGKILLs while the robots run, each 0.2..0.6 s after the (re)start (so at any stage: restoring the
# store, before or after the transport started, mid-keyframe), restarted 0.2 s later. The robots run at the
# dataset's 30 Hz (~3.8 s each, plus their wait for acknowledgements), so that all five fall in the run.
fault_kill9() {
  pace=""; write_configs; start_server; wait_ready; start_clients
  local k
  for k in 1 2 3 4 5; do
    sleep "$(awk -v r=$RANDOM 'BEGIN {printf "%.2f", 0.2 + 0.4 * r / 32767}')"
    local when="after the clients ended"; clients_running && when="during the run"
    kill -9 "$server_pid"; wait "$server_pid" 2>/dev/null
    echo "kill $k at $(date +%T.%N) $when" >>"$out/logs/kills.txt"
    sleep 0.2; start_server
  done
  wait_clients; stop_server
}
# The dataset with its timestamps stretched FACTOR times (the same images: a robot at 30/FACTOR Hz).
slow_dataset() {
  local f=$1 d="$out/ds_slow" n
  mkdir -p "$d"; ln -sfn "$(cd "$ds" && pwd)/rgb" "$d/rgb"; ln -sfn "$(cd "$ds" && pwd)/depth" "$d/depth"
  [ -f "$ds/camera.yaml" ] && cp "$ds/camera.yaml" "$d/"
  for n in rgb.txt depth.txt groundtruth.txt; do
    awk -v f="$f" '/^#/ {print; next} {t0 = (t0 == "" ? $1 : t0); $1 = sprintf("%.6f", t0 + ($1 - t0) * f); print}' \
      "$ds/$n" >"$d/$n"
  done
  ds="$d"
}
# Both robots at 7.5 Hz (the dataset slowed 4 x: 113 frames in 15 s). The server hangs (SIGSTOP) 2 s into
# the run, so the keyframes from then on stay unacknowledged; 3..7 s later robot0 is killed (SIGKILL) and
# robot1 is asked to stop (SIGINT: it waits its final 3 s, exits 0 and says what stays spooled); then the
# server resumes and both start again 0.2 s later, 2 s before where they were, with the same --out: their
# spools.
fault_robotkill9() {
  pace="" final_wait=3; write_configs; slow_dataset 4; start_server; wait_ready; start_clients
  local t0 kill_after elapsed i r first
  t0=$(date +%s.%N)
  kill_after=$(awk -v r=$RANDOM 'BEGIN {printf "%.2f", 3 + 4 * r / 32767}')
  sleep 2; kill -STOP "$server_pid"
  sleep "$kill_after"
  kill -9 "${client_pids[0]}"; kill -INT "${client_pids[1]}"
  wait "${client_pids[0]}" 2>/dev/null
  wait "${client_pids[1]}"; echo "robot1 exit $? after SIGINT" >>"$out/logs/exits.txt"
  elapsed=$(awk -v a="$t0" -v b="$(date +%s.%N)" 'BEGIN {print b - a}')
  kill -CONT "$server_pid"
  for i in 0 1; do
    r=${robots[$i]}
    ls "$out/robots/$r/spool/$r" | grep -c '^kf-' >"$out/spooled_at_stop_$r.txt"
    # 15 frames (2 s) before where it was by the time it ran (its start-up came first): the new start sees
    # what its last keyframes saw, as a robot restarted where it stopped.
    first=$(awk -v e="$elapsed" -v range="${ranges[$i]}" \
      'BEGIN {split(range, b, ":"); f = b[1] + int(e * 7.5) - 15; f = (f < b[1] ? b[1] : f); print (f > b[2] - 1 ? b[2] - 1 : f)}')
    grep -v '^#' "$ds/rgb.txt" | awk -v n="$first" 'NR == n + 1 {print $1}' >"$out/restart_t_$r.txt"
    echo "$r stopped at $elapsed s ($(cat "$out/spooled_at_stop_$r.txt") keyframes spooled); restarted on $first:${ranges[$i]#*:}" \
      >>"$out/logs/kills.txt"
    cp "$out/logs/client_$r.log" "$out/logs/client_${r}_stopped.log"
    ranges[$i]="$first:${ranges[$i]#*:}"
  done
  sleep 0.2
  client_pids=(); start_clients
  wait_clients; stop_server
}
# The server down for 20 s (RGBDMAP_OUTAGE_S) from 3 s into the run; the robots (the dataset slowed 8 x,
# RGBDMAP_OUTAGE_SLOW: ~30 s each on the 200-frame loop, about a keyframe a second) with the shipped link
# defaults map through it.
fault_outage() {
  pace="" final_wait="" max_attempts=""; write_configs; slow_dataset "$outage_slow"; start_server; wait_ready
  # rgbdmap-monitor throughout: the robots' LinkStatus shows their spools fill and drain.
  "$bin/rgbdmap-monitor" --transport "$(url_for 0)" --robots robot0,robot1 --keys-file "$out/keys/server_keys.txt" \
    --period 1 >"$out/logs/monitor.log" 2>&1 &
  local monitor=$!
  start_clients
  sleep 3
  kill -9 "$server_pid"; wait "$server_pid" 2>/dev/null
  echo "server killed at $(date +%T.%N) for $outage_s s" >>"$out/logs/kills.txt"
  sleep "$outage_s"; start_server
  wait_clients; stop_server
  kill -INT "$monitor"; wait "$monitor"
}
fault_dgram5() { if [ "$transport" = dds ]; then fault_dgram5_dds; else fault_dgram5_lcm; fi; }
fault_dgram5_dds() { dds_lossiness 50; }
dds_lossiness() {  # PER_MILLE of Cyclone's outgoing datagrams dropped, in every process
  write_configs
  sed "s|^    <Internal>|    <Internal>\n      <Test><XmitLossiness>$1</XmitLossiness></Test>|" \
    "$repo/deploy/dds/cyclonedds-loopback.xml" >"$out/cyclonedds-lossy.xml"
  grep -q "<XmitLossiness>$1<" "$out/cyclonedds-lossy.xml" || { echo "FAIL: lossy DDS config"; exit 1; }
  export CYCLONEDDS_URI="file://$out/cyclonedds-lossy.xml"
  run_plain
}
# LCM: the robots on one multicast group and port, the server on another, rgbdmap-lossy-relay between them
# dropping 5 % of the IP packets (--mtu 1500: a datagram is lost with any of its fragments). The robots
# send keyframes in chunks of 1100 bytes (the udpm:// default), one datagram each.
fault_dgram5_lcm() { relay_loss 0.05; }
# dgram30 (LCM): 30 % of the datagrams through the relay, the robots with the default link configuration
# (final wait, attempts): what a robot on a bad Wi-Fi link meets.
fault_dgram30() {
  final_wait="" max_attempts="" after_clients=restart_spooled
  if [ "$transport" = dds ]; then dds_lossiness 300; else relay_loss 0.3; fi
}
relay_loss() {
  [ -x "$bin/rgbdmap-lossy-relay" ] || { echo "FAIL: no $bin/rgbdmap-lossy-relay"; exit 1; }
  server_url='udpm://239.255.76.68:7668?ttl=0&recv_buf_size=8388608'
  write_configs
  "$bin/rgbdmap-lossy-relay" --a "$lcm_url" --b "$server_url" --drop-datagrams "$1" --mtu 1500 \
    --seed "$seed" --duration 170 --stats "$out/relay.json" >"$out/logs/relay.log" 2>&1 &
  local relay=$!
  sleep 0.3
  run_plain
  kill -INT "$relay" 2>/dev/null; wait "$relay"
}
# Not over processes here (exit 77; deploy/bench_faults.sh prints their measurements after the table):
# a flooding robot needs a sender faster than any real client, so it runs in-process against the real
# MapServer (ctest -R MapServerFair: tests/server/test_map_server_fair.cpp); a full disk needs a private
# tmpfs (ctest -R integration.disk_full: tests/integration/disk_full.sh).
fault_flood() { echo "SKIP: flood runs in-process: test_map_server --gtest_filter='MapServerFair.*'"; exit 77; }
fault_diskfull() { echo "SKIP: disk full runs in tests/integration/disk_full.sh (ctest -R integration.disk_full)"; exit 77; }

# --- what was sent, acknowledged, stored ---------------------------------------------------------------------
stamps() { [ -s "$1" ] && grep -v '^#' "$1" | awk '{print $1}' | sort -u; }
collect() {
  local r j sent acked stored missing acked_missing dups run1 rows=()
  for r in "${robots[@]}"; do
    j="$out/robots/$r/client_$r.json"
    [ -s "$j" ] || { echo "FAIL: $r wrote no client_$r.json"; tail -n 5 "$out/logs/client_$r.log"; return 1; }
    cat "$out/robots/$r/keyframes_$r.txt" "$out/robots/$r/keyframes_$r.run1.txt" 2>/dev/null >"$out/made_$r.txt"
    stamps "$out/made_$r.txt" >"$out/sent_$r.txt"
    [ -s "$out/map/keyframes_$r.txt" ] && grep -v '^#' "$out/map/keyframes_$r.txt" | awk '{print $1}' | sort \
      >"$out/stored_all_$r.txt"
    stamps "$out/map/keyframes_$r.txt" >"$out/stored_$r.txt"
    sent=$(wc -l <"$out/sent_$r.txt"); stored=$(comm -12 "$out/sent_$r.txt" "$out/stored_$r.txt" | wc -l)
    missing=$(comm -23 "$out/sent_$r.txt" "$out/stored_$r.txt" | head -n 5 | tr '\n' ' ')
    # Stored twice: a timestamp twice, among those before a restart's first frame (from there on, the new
    # start may make a keyframe of a frame its killed predecessor made one of too).
    dups=$(awk -v t="$(cat "$out/restart_t_$r.txt" 2>/dev/null)" 't == "" || $1 < t' "$out/stored_all_$r.txt" \
      2>/dev/null | uniq -d | wc -l)
    run1=null
    [ -s "$out/robots/$r/client_$r.run1.json" ] && run1=$(jq -c '{keyframes_sent, acked: .keyframes_acked,
      spool_depth, lost: .keyframes_lost, ack_ms_median: .ack_latency_ms_median, ack_ms_p90: .ack_latency_ms_p90}' \
      "$out/robots/$r/client_$r.run1.json")
    rows+=("$(jq -c --arg r "$r" --arg dups "$dups" --argjson run1 "$run1" --argjson sent "$sent" --argjson stored "$stored" --arg missing "$missing" \
      '{robot: $r, sent: $sent, keyframes_sent: .keyframes_sent, acked: .keyframes_acked, stored: $stored,
        missing: $missing, given_up: .keyframes_given_up, retransmissions: .retransmissions,
        ack_ms_median: .ack_latency_ms_median, ack_ms_p90: .ack_latency_ms_p90, all_acked: .all_acked,
        corrections: .corrections_received, final_correction: .final_correction_received,
        spool_recovered, spool_recovered_acked, spool_depth, spool_damaged, rss_peak_mb,
        duplicates: ($dups | tonumber), run1: $run1}' "$j")")
  done
  [ -s "$out/map/server_summary.json" ] || { echo "FAIL: no server_summary.json (the last server did not stop cleanly)"
    cat "$out/logs/exits.txt"; return 1; }
  cat "$out"/map/keyframes_robot*.txt 2>/dev/null | grep -v '^#' | sort -n >"$out/merged.txt"
  local ate
  ate=$("$bin/rgbdmap" eval --gt "$ds/groundtruth.txt" --est "$out/merged.txt" 2>/dev/null \
    | awk '$1 == "ate_rmse_m" {print $2}')
  printf '%s\n' "${rows[@]}" | jq -s --arg fault "$fault" --arg t "$transport" --arg ate "${ate:-nan}" \
    --slurpfile s "$out/map/server_summary.json" --arg kills "$(grep -c '^kill' "$out/logs/kills.txt" 2>/dev/null)" \
    --arg during "$(grep -c 'during the run' "$out/logs/kills.txt" 2>/dev/null)" \
    '{fault: $fault, transport: $t, robots: ., ate_m: $ate, maps: $s[0].maps, merged_maps: $s[0].merged_maps,
      server_keyframes: $s[0].keyframes, kills: ($kills | tonumber? // 0),
      kills_during_run: ($during | tonumber? // 0)}' >"$out/result.json"
}

check_result() {
  local res="$out/result.json" ok=1 need_acked=1
  [ "$fault" = loss60 ] && need_acked=0
  # A robot started again to deliver its spool (dgram30): its two runs' keyframes are "sent". A keyframe a
  # start recovers from the spool may be answered before it goes out again (robotkill9: the server stored it
  # from the killed run's transmission): acknowledged, not counted as sent.
  jq -e 'all(.robots[]; .stored == .sent and .sent > 0 and (.run1 != null or .sent + .spool_recovered == .keyframes_sent
      or (.spool_recovered > 0 and .sent + .spool_recovered == .acked)))' \
    "$res" >/dev/null \
    && echo "ok: every keyframe sent is stored" \
    || { echo "FAIL: keyframes not stored: $(jq -c '[.robots[] | {robot, sent, stored, missing}]' "$res")"; ok=0; }
  if [ "$need_acked" = 1 ]; then
    jq -e 'all(.robots[]; (.acked == .sent + .spool_recovered or (.run1 != null and .run1.lost == 0
        and .spool_recovered == .run1.spool_depth and .spool_recovered_acked == .spool_recovered))
        and .all_acked and .spool_depth == 0)' "$res" \
      >/dev/null && echo "ok: every keyframe acknowledged (by the end, or by the next start), the spools empty" \
      || { echo "FAIL: not all acknowledged: $(jq -c '[.robots[] | {robot, sent, acked}]' "$res")"; ok=0; }
  fi
  if [ "$fault" = robotkill9 ]; then
    # Each restart is a new chain that loop closure must place; whether four chains end in one map is the
    # server's matter (not always: deploy/bench_faults.sh shows it), not the spool's: stated, not checked.
    echo "info: maps $(jq -c .merged_maps "$res"), ATE $(jq -r .ate_m "$res") m (not checked for robotkill9)"
  else
    jq -e '.maps == 1 and (.merged_maps | length == 1 and (.[0] | sort) == ["robot0", "robot1"])' "$res" >/dev/null \
      && echo "ok: one merged map" || { echo "FAIL: not one merged map: $(jq -c .merged_maps "$res")"; ok=0; }
    awk -v a="$(jq -r .ate_m "$res")" -v m="$check" 'BEGIN {exit !(a == a + 0 && a < m)}' \
      && echo "ok: merged ATE $(jq -r .ate_m "$res") m < $check m" || { echo "FAIL: ATE $(jq -r .ate_m "$res") m"; ok=0; }
  fi
  if [ "$fault" = kill9 ]; then
    jq -e '.kills_during_run == 5' "$res" >/dev/null && echo "ok: five kills -9 while the robots ran" \
      || { echo "FAIL: only $(jq .kills_during_run "$res") of the kills hit a running robot"; ok=0; }
    # A restarted server hears no Hello over LCM; it must still correct the robots' keyframes (before the
    # fix in RobotRegistry::noteSession: no PoseCorrections at all after the first kill). Not required: one
    # covering the last keyframe (lost when a kill falls between its ack and its correction; see README).
    jq -e 'all(.robots[]; .corrections > 0)' "$res" >/dev/null \
      && echo "ok: the robots got corrections" \
      || { echo "FAIL: corrections after the restarts: $(jq -c '[.robots[] | {robot, corrections}]' "$res")"; ok=0; }
  fi
  if [ "$fault" = robotkill9 ]; then
    local n i
    for i in 0 1; do
      n=$(cat "$out/spooled_at_stop_${robots[$i]}.txt")
      jq -e --argjson n "$n" --argjson i "$i" '.robots[$i] | .spool_recovered == $n and .spool_recovered_acked == $n and $n > 0' \
        "$res" >/dev/null && echo "ok: the $n keyframes ${robots[$i]} left spooled were delivered by its next start" \
        || { echo "FAIL: ${robots[$i]} left $n: $(jq -c --argjson i "$i" '.robots[$i] | {spool_recovered, spool_recovered_acked}' "$res")"; ok=0; }
    done
    grep -q 'robot1 exit 0 after SIGINT' "$out/logs/exits.txt" \
      && grep -q "keyframes not yet acknowledged stay in the spool" "$out/logs/client_robot1_stopped.log" \
      && echo "ok: robot1 stopped by SIGINT exited 0 and said what stays spooled" \
      || { echo "FAIL: robot1 after SIGINT: $(grep robot1 "$out/logs/exits.txt"; tail -n 3 "$out/logs/client_robot1_stopped.log")"; ok=0; }
  fi
  if [ "$fault" = outage ]; then
    local most; most=$(grep -o 'spool=[0-9]*' "$out/logs/monitor.log" | cut -d= -f2 | sort -n | tail -n 1)
    [ "${most:-0}" -gt 0 ] && echo "ok: rgbdmap-monitor showed up to $most keyframes in a robot's spool during the outage" \
      || { echo "FAIL: the monitor never showed a spooled keyframe: $(tail -n 2 "$out/logs/monitor.log")"; ok=0; }
  fi
  jq -e 'all(.robots[]; .duplicates == 0)' "$res" >/dev/null && echo "ok: every keyframe stored once" \
    || { echo "FAIL: keyframes stored twice: $(jq -c '[.robots[] | {robot, duplicates}]' "$res")"; ok=0; }
  grep -q 'server exit 0' "$out/logs/exits.txt" || { echo "FAIL: the last server did not exit 0"; ok=0; }
  [ "$ok" = 1 ]
}

start_s=$(date +%s)
trap 'kill $server_pid "${client_pids[@]}" 2>/dev/null' EXIT
declare -F "fault_$fault" >/dev/null || { echo "unknown fault '$fault'" >&2; exit 2; }
"fault_$fault"
trap - EXIT
collect || { tail -n 25 "$out"/logs/*; exit 1; }
echo "== $fault over $transport: $(( $(date +%s) - start_s )) s; $(jq -c '{ate_m, maps, kills_during_run, robots: [.robots[] |
  {robot, sent, acked, stored, retransmissions, ack_ms_median, ack_ms_p90}]}' "$out/result.json")"
[ -z "$check" ] && exit 0
check_result && exit 0
tail -n 20 "$out"/logs/*.log
exit 1
