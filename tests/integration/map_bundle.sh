#!/usr/bin/env bash
# Map bundles and merges from outside (rgbdmap map export / info / import / merge, rgbdmap-server):
#   1. a map made by `rgbdmap run` (frames 0-99 of a synthetic 160-frame loop) is exported, described and
#      imported;
#   2. the imported directory's store logs, robots.txt and MANIFEST are byte-identical to the original's;
#   3. rgbdmap-server started on the original and on the imported directory writes the same corrected
#      keyframe poses (keyframes_<robot>.txt: what it sends robots) and the same octree (map.bt, map.ot);
#   4. a bundle with a flipped byte, a truncated one and a forged one (valid checksums, a file entry named
#      "../escaped") are refused with exit 1, and nothing is written;
#   5. merge: that map and one of frames 60-159 (another run) become one map holding both, its keyframes'
#      ATE under 2 cm; a map of another scene (sweep, another seed) does not overlap: exit 1, nothing written.
# Usage: map_bundle.sh BIN_DIR OUT_DIR. Exit 0 ok, 1 a check failed.
set -u
bin="$1" out="$2"
rm -rf "$out" && mkdir -p "$out"
fail() { echo "FAIL: $*"; exit 1; }
ok() { echo "ok: $*"; }

"$bin/rgbdmap" synth --scene loop --frames 160 --out "$out/ds" >"$out/synth.log" 2>&1 || fail "synth"
subset() {  # subset NAME FIRST END: frames FIRST..END-1 of the dataset as a TUM folder (images linked)
  local d="$out/$1" t0 t1 f
  mkdir -p "$d" && cp "$out/ds/camera.yaml" "$d/" && ln -s "$out/ds/rgb" "$d/rgb" && ln -s "$out/ds/depth" "$d/depth"
  grep -v '^#' "$out/ds/rgb.txt" | sed -n "$(($2 + 1)),$3p" >"$d/rgb.txt"
  t0=$(head -n 1 "$d/rgb.txt" | cut -d' ' -f1) t1=$(tail -n 1 "$d/rgb.txt" | cut -d' ' -f1)
  for f in depth.txt groundtruth.txt; do
    grep -v '^#' "$out/ds/$f" | awk -v a="$t0" -v b="$t1" '$1 >= a - 0.02 && $1 <= b + 0.02' >"$d/$f"
  done
}
subset first 0 100 && subset second 60 160
for r in first second; do
  "$bin/rgbdmap" run --dataset "$out/$r" --async --out "$out/run_$r" >"$out/run_$r.log" 2>&1 || fail "rgbdmap run $r"
done
cp -r "$out/run_first/map" "$out/orig" && rm -f "$out/orig/LOCK"
"$bin/rgbdmap" map export "$out/orig" "$out/map.rmb" >"$out/export.txt" 2>&1 || fail "export: $(cat "$out/export.txt")"
"$bin/rgbdmap" map info "$out/map.rmb" >"$out/info.txt" 2>&1 || fail "info: $(cat "$out/info.txt")"
grep -q '^keyframes [1-9]' "$out/info.txt" && grep -q '^carried robots.txt ' "$out/info.txt" \
  || fail "info does not list the keyframes and robots.txt: $(cat "$out/info.txt")"
ok "exported and described: $(grep -E '^(keyframes|loops|bundle_bytes) ' "$out/info.txt" | tr '\n' ' ')"
"$bin/rgbdmap" map import "$out/map.rmb" "$out/imported" >"$out/import.txt" 2>&1 || fail "import: $(cat "$out/import.txt")"
for f in keyframes.log loops.log robots.txt MANIFEST; do
  cmp -s "$out/orig/$f" "$out/imported/$f" || fail "$f differs after export and import"
done
ok "the imported store is byte-identical"

serve() {  # serve DIR: rgbdmap-server on DIR until ready and its start-up optimisation is done, then SIGINT
  printf 'server:\n  map_dir: %s\n  robots: "robot0"\n  transport: "memq://"\n  open_mode: true\n' "$1" >"$1.yaml"
  "$bin/rgbdmap-server" --config "$1.yaml" --status-every 0 >"$1.log" 2>&1 &
  local pid=$! i
  for i in $(seq 600); do grep -q 'ready on' "$1.log" && break; kill -0 $pid 2>/dev/null || break; sleep 0.1; done
  grep -q 'ready on' "$1.log" || fail "server on $1 not ready: $(tail -n 3 "$1.log")"
  kill -INT $pid; wait $pid || fail "server on $1 exited $? ($(tail -n 3 "$1.log"))"
}
serve "$out/orig"
serve "$out/imported"
for f in keyframes_robot0.txt map.bt map.ot; do
  [ -s "$out/orig/$f" ] || fail "the server wrote no $f"
  cmp -s "$out/orig/$f" "$out/imported/$f" || fail "served from the import, $f differs"
done
ok "served from the original and from the import: the same corrected poses, map.bt and map.ot"

refused() {  # refused NAME FILE: import must fail with exit 1 and write nothing
  "$bin/rgbdmap" map import "$2" "$out/target" >"$out/$1.txt" 2>&1
  local rc=$?
  [ $rc = 1 ] || fail "$1: import exited $rc, not 1"
  [ ! -e "$out/target" ] && [ -z "$(ls -d "$out"/target.import-* 2>/dev/null)" ] || fail "$1: import left files"
  ok "$1 refused: $(tail -n 1 "$out/$1.txt")"
}
size=$(stat -c %s "$out/map.rmb")
cp "$out/map.rmb" "$out/flipped.rmb"
printf '\x5a' | dd of="$out/flipped.rmb" bs=1 seek=$((size / 2)) conv=notrunc status=none
refused "a flipped byte" "$out/flipped.rmb"
head -c $((size - 100)) "$out/map.rmb" >"$out/truncated.rmb"
refused "a truncated bundle" "$out/truncated.rmb"
# A forged bundle: the real one's entries with a file entry named "../escaped" inserted before its end
# entry, every CRC and the SHA-256 recomputed (what a hostile file would do).
python3 - "$out/map.rmb" "$out/forged.rmb" <<'EOF' || fail "could not forge a bundle"
import hashlib, struct, sys, zlib
data = open(sys.argv[1], 'rb').read()[:-32]
body, at = data[:12], 12
while at < len(data):
    kind, _, n, crc = struct.unpack_from('<HHII', data, at)
    if kind == 15:
        name, content = b'../escaped', b'pwned'
        payload = struct.pack('<H', len(name)) + name + content
        body += struct.pack('<HHII', 2, 0, len(payload), zlib.crc32(payload)) + payload
    body += data[at:at + 12 + n]
    at += 12 + n
open(sys.argv[2], 'wb').write(body + hashlib.sha256(body).digest())
EOF
refused "a forged file entry" "$out/forged.rmb"
[ ! -e "$out/escaped" ] || fail "the forged entry wrote $out/escaped"

"$bin/rgbdmap" map merge "$out/orig" "$out/run_second/map" "$out/merged" >"$out/merge.log" 2>&1 \
  || fail "merge of overlapping maps: $(tail -n 2 "$out/merge.log")"
serve "$out/merged"
"$bin/rgbdmap" eval --gt "$out/ds/groundtruth.txt" --est "$out/merged/keyframes_robot0.txt" >"$out/merged_ate.txt" \
  || fail "eval of the merged map"
kf() { grep -vc '^#' "$1"; }
[ "$(kf "$out/merged/keyframes_robot0.txt")" = $(($(kf "$out/run_first/keyframes_robot0.txt") + \
  $(kf "$out/run_second/keyframes_robot0.txt"))) ] || fail "the merged map does not hold both maps' keyframes"
ate=$(awk '$1 == "ate_rmse_m" {print $2}' "$out/merged_ate.txt")
awk -v a="$ate" 'BEGIN {exit !(a < 0.02)}' || fail "merged ATE $ate m"
ok "merged: $(kf "$out/merged/keyframes_robot0.txt") keyframes in one map, ATE $ate m"
"$bin/rgbdmap" run --scene sweep --seed 9 --frames 40 --async --out "$out/run_other" >"$out/run_other.log" 2>&1 \
  || fail "rgbdmap run (another scene)"
"$bin/rgbdmap" map merge "$out/orig" "$out/run_other/map" "$out/merged_other" >"$out/merge_other.log" 2>&1
rc=$?
[ $rc = 1 ] && grep -q 'do not overlap' "$out/merge_other.log" || fail "merge of unrelated maps exited $rc"
[ -z "$(ls -d "$out"/merged_other* 2>/dev/null)" ] || fail "a merge that failed left files"
ok "another scene: $(tail -n 1 "$out/merge_other.log")"
echo "map bundles and merges: all checks passed"
