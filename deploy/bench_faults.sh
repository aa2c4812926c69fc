#!/usr/bin/env bash
# Fault benchmark: every fault of tests/integration/faults.sh (clean, 30 % and 60 % message loss,
# 5 % datagram loss, 30 % datagram loss with the default link settings (LCM only), server kill -9 x5, a
# robot killed with unacknowledged keyframes and started again, a 20 s server outage) over LCM and over
# Cyclone DDS, two robots on a synthetic 200-frame loop, each run inside a private loopback-only network
# namespace. Prints one row per run: keyframes sent / acknowledged / stored (both robots), left in the
# robots' spools at the end / found in a spool at a start, retransmissions, ack latency median and p90
# (the worse robot), the robots' peak RSS, merged maps and the final ATE of the server's keyframes. Then the two faults that do not run over processes here: a flooding robot
# (in-process against the real MapServer, MapServerFair.*) and a full disk
# (tests/integration/disk_full.sh, a private tmpfs), with what they measured. Needs root; jq.
#
# Usage: bash deploy/bench_faults.sh [--out DIR] [--faults "clean loss30 ..."] [--transports "lcm dds"]
#          [--seed N]
# Outputs in --out (default out/bench_faults): dataset/, <fault>_<transport>/ (result.json, logs/), table.txt
set -u
repo="$(cd "$(dirname "$0")/.." && pwd)"
bin="${RGBDMAP_BIN:-$repo/build/bin}"
out="out/bench_faults" faults="clean loss30 loss60 dgram5 dgram30 kill9 robotkill9 outage" transports="lcm dds" seed=7
while [ $# -gt 0 ]; do
  case "$1" in
    --out) out="$2"; shift 2 ;;
    --faults) faults="$2"; shift 2 ;;
    --transports) transports="$2"; shift 2 ;;
    --seed) seed="$2"; shift 2 ;;
    -h|--help) awk 'NR > 1 && !/^#/ {exit} NR > 1 {sub(/^# ?/, ""); print}' "$0"; exit 0 ;;
    *) echo "unknown argument: $1 (see --help)" >&2; exit 2 ;;
  esac
done
command -v jq >/dev/null || { echo "jq is required (deploy/install_deps.sh)" >&2; exit 1; }
for b in rgbdmap rgbdmap-server rgbdmap-client; do
  [ -x "$bin/$b" ] || { echo "missing $bin/$b: run deploy/build.sh" >&2; exit 1; }
done
if ! command -v ip >/dev/null 2>&1 || ! unshare -n true 2>/dev/null; then
  echo "'unshare -n' is not permitted here (needs root): the fault benchmark runs only in a private namespace" >&2
  exit 77
fi
mkdir -p "$out"; out="$(cd "$out" && pwd)"
ds="$out/dataset"
if [ ! -s "$ds/groundtruth.txt" ]; then
  echo "synthesising the 200-frame loop into $ds"
  "$bin/rgbdmap" synth --scene loop --frames 200 --out "$ds" >"$out/synth.log" 2>&1 || { cat "$out/synth.log"; exit 1; }
fi

row() {  # row FAULT TRANSPORT RESULT_JSON SECONDS
  jq -r --arg f "$1" --arg t "$2" --arg s "$4" '
    def sum(k): [.robots[] | k] | add;
    def ms(k): ([.robots[] | k] | max | . * 10 | round / 10 | tostring);
    [$f, $t, (sum(.keyframes_sent) | tostring), (sum(.acked) | tostring), (sum(.stored) | tostring),
     (sum(.spool_depth) | tostring), (sum(.spool_recovered) | tostring),
     (sum(.retransmissions) | tostring), ms(.ack_ms_median), ms(.ack_ms_p90), ms(.rss_peak_mb), (.maps | tostring),
     (.ate_m | tonumber? // "nan" | if type == "number" then (. * 1e4 | round / 1e4 | tostring) else . end),
     $s] | @tsv' "$3"
}

table="$out/table.txt"
printf '%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\n' fault transport sent acked stored spooled \
  recovered retx ack_ms_med ack_ms_p90 rss_mb maps ATE_m wall_s >"$table"
for fault in $faults; do
  for transport in $transports; do
    d="$out/${fault}_$transport"
    start=$(date +%s)
    bash "$repo/tests/integration/faults.sh" --fault "$fault" --transport "$transport" --bin "$bin" \
      --dataset "$ds" --out "$d" --seed "$seed" >"$out/${fault}_$transport.log" 2>&1
    rc=$? secs=$(( $(date +%s) - start ))
    if [ "$rc" = 77 ]; then
      printf '%s\t%s\tskipped\t-\t-\t-\t-\t-\t-\t-\t-\t-\t-\t-\n' "$fault" "$transport" >>"$table"
    elif [ "$rc" = 0 ] && [ -s "$d/result.json" ]; then
      row "$fault" "$transport" "$d/result.json" "$secs" >>"$table"
    else
      printf '%s\t%s\tFAILED (exit %s, see %s)\n' "$fault" "$transport" "$rc" "$out/${fault}_$transport.log" >>"$table"
    fi
    tail -n 1 "$table"
  done
done
echo
column -t -s "$(printf '\t')" "$table"

echo
echo "== flooding robot (in-process, real MapServer; $bin/test_map_server --gtest_filter='MapServerFair.AFlooding*')"
if [ -x "$bin/test_map_server" ]; then
  "$bin/test_map_server" --gtest_filter='MapServerFair.AFloodingRobotDoesNotDelayAWellBehavedOne' 2>&1 \
    | grep -E '^\[ measured \]|OK \]|FAILED \]' || echo "no result"
else
  echo "not built (test_map_server)"
fi
echo
echo "== disk full, then space freed (tests/integration/disk_full.sh; needs a private tmpfs mount)"
bash "$repo/tests/integration/disk_full.sh" "$bin" >"$out/disk_full.log" 2>&1
rc=$?
grep -E '^measured|^SKIP' "$out/disk_full.log" || true
echo "disk_full.sh exit $rc (log: $out/disk_full.log)"
