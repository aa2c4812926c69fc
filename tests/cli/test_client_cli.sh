#!/usr/bin/env bash
# Command-line contract of `rgbdmap-client` without a server (memq://, nothing acknowledges): outputs, the
# JSON summary, Ctrl-C still writing outputs, exit 3 with the reason when keyframes were not accepted (here:
# no server heard at all), and configuration errors (exit 2, all named). Usage: test_client_cli.sh BIN_DIR
set -u
client="$1/rgbdmap-client"
source "$(dirname "$0")/cli_test_lib.sh"

check "synth writes a sequence" 0 "$1/rgbdmap" synth --out "$tmp/seq" --scene sweep --frames 30 --seed 2
printf 'robot:\n  id: alpha\nlink:\n  final_wait_s: 0.2\n' >"$tmp/client.yaml"
check "help" 0 "$client" --help
contains "help names DDS configuration" "$tmp/out.txt" "CYCLONEDDS_URI"
check "runs --fast without a server: exit 3, keyframes not accepted" 3 "$client" --config "$tmp/client.yaml" \
  --dataset "$tmp/seq" --fast --frames 2:30 --out "$tmp/out"
contains "says how many were not accepted" "$tmp/err.txt" "robot alpha: [0-9]* of [0-9]* keyframes not accepted"
contains "says why: no server heard" "$tmp/err.txt" "no server heard at all"
contains "names what to check" "$tmp/err.txt" "holds this robot's key"
[ "$(grep -vc '^#' "$tmp/out/trajectory_alpha.txt")" -eq 28 ] && echo "ok: one pose per frame" || { echo "FAIL: pose count"; fail=1; }
for f in trajectory_alpha_live.txt keyframes_alpha.txt; do [ -s "$tmp/out/$f" ] && echo "ok: $f" || { echo "FAIL: $f"; fail=1; }; done
json "json counts frames" "$tmp/out/client_alpha.json" '.frames == 28'
json "json says nothing was acked" "$tmp/out/client_alpha.json" '.all_acked == false'
json "json has bytes sent" "$tmp/out/client_alpha.json" '.bytes_sent > 0'
json "json counts the keyframes not accepted" "$tmp/out/client_alpha.json" \
  '.keyframes_not_accepted == .keyframes and .keyframes > 0 and .server_heard == false'
check "--robot-id overrides the config" 3 "$client" --config "$tmp/client.yaml" --dataset "$tmp/seq" --fast \
  --frames :5 --robot-id beta --out "$tmp/out"
[ -s "$tmp/out/client_beta.json" ] && echo "ok: robot id in file names" || { echo "FAIL: client_beta.json"; fail=1; }
# A corrupt image is skipped with a warning and counted (exit 3 here only because no server acknowledges);
# a robot that can read no frame exits 1 (a data error comes before the delivery verdict).
cp -r "$tmp/seq" "$tmp/bad"
img="$tmp/bad/$(grep -v '^#' "$tmp/bad/rgb.txt" | awk 'NR == 5 {print $2}')"  # frame 4's colour image
head -c 100 "$img" >"$tmp/cut.png" && mv "$tmp/cut.png" "$img"  # a truncated PNG
check "a corrupt image is skipped" 3 "$client" --config "$tmp/client.yaml" --dataset "$tmp/bad" --fast \
  --frames :10 --out "$tmp/bad_out"
contains "the skipped frame is a warning naming the image" "$tmp/err.txt" "skipping frame 4: .*rgb/.*cannot read"
contains "summary counts it" "$tmp/err.txt" "unreadable 1,"
json "json counts it" "$tmp/bad_out/client_alpha.json" '.unreadable_frames == 1 and .frames == 9'
rm -r "$tmp/bad/rgb"
check "no readable frame is a data error" 1 "$client" --config "$tmp/client.yaml" --dataset "$tmp/bad" --fast \
  --frames :10 --out "$tmp/bad_out"
contains "no readable frame is named" "$tmp/err.txt" "none of the 10 frames could be read"
json "json still written" "$tmp/bad_out/client_alpha.json" '.unreadable_frames == 10 and .frames == 0'

# Ctrl-C during a paced run: clean stop, outputs still written; the keyframes sent were not accepted (no
# server), so the exit code still says so.
# The signal goes once the link has started (a background job of a script ignores SIGINT until the client
# takes it over at start: sent earlier, on a busy machine, it would be lost).
"$client" --config "$tmp/client.yaml" --dataset "$tmp/seq" --robot-id gamma --out "$tmp/sig" >"$tmp/sig.log" 2>&1 &
pid=$!
for _ in $(seq 1 200); do grep -q "link started" "$tmp/sig.log" && break; sleep 0.1; done
kill -INT "$pid"
wait "$pid"
code=$?
want=$(jq -r 'if .keyframes > 0 then 3 else 0 end' "$tmp/sig/client_gamma.json" 2>/dev/null || echo missing)
[ "$code" = "$want" ] && echo "ok: SIGINT exits $want" || { echo "FAIL: SIGINT exit code $code, expected $want"; fail=1; }
json "interrupted run still reports" "$tmp/sig/client_gamma.json" '.interrupted == true'

printf 'robot:\n  id: "bad id"\n  key_file: nokey.hex\nlink:\n  jitter: 3\n  codec:\n    color: gif\n' >"$tmp/bad.yaml"
check "config errors are usage errors" 2 "$client" --config "$tmp/bad.yaml" --dataset "$tmp/seq"
contains "unknown key named" "$tmp/err.txt" "unknown key 'link.jitter'"
contains "bad codec named" "$tmp/err.txt" "link.codec.color"
contains "missing key file named" "$tmp/err.txt" "nokey.hex"
contains "bad robot id named" "$tmp/err.txt" "invalid robot id"
check "bad --frames" 2 "$client" --dataset "$tmp/seq" --frames 9:3
check "missing --dataset" 2 "$client" --fast
check "unknown transport is a configuration error" 2 "$client" --dataset "$tmp/seq" --transport "tcp://x" --fast
check "dds:// without CYCLONEDDS_URI is a configuration error" 2 env -u CYCLONEDDS_URI "$client" --dataset "$tmp/seq" \
  --transport "dds://?domain=0" --fast
contains "the refusal names CYCLONEDDS_URI" "$tmp/err.txt" "CYCLONEDDS_URI"
if [ "$fail" -eq 0 ]; then echo "client cli: all checks passed"; fi
exit "$fail"
