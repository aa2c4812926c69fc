#!/usr/bin/env bash
# Map bundles from outside (rgbdmap map export / info / import, rgbdmap-server):
#   1. a map made by `rgbdmap run` (synthetic, one robot) is exported, described and imported;
#   2. the imported directory's store logs, robots.txt and MANIFEST are byte-identical to the original's;
#   3. rgbdmap-server started on the original and on the imported directory writes the same corrected
#      keyframe poses (keyframes_<robot>.txt: what it sends robots) and the same octree (map.bt, map.ot);
#   4. a bundle with a flipped byte, a truncated one and a forged one (valid checksums, a file entry named
#      "../escaped") are refused with exit 1, and nothing is written.
# Usage: map_bundle.sh BIN_DIR OUT_DIR. Exit 0 ok, 1 a check failed.
set -u
bin="$1" out="$2"
rm -rf "$out" && mkdir -p "$out"
fail() { echo "FAIL: $*"; exit 1; }
ok() { echo "ok: $*"; }

"$bin/rgbdmap" run --frames 60 --async --out "$out/run" >"$out/run.log" 2>&1 || fail "rgbdmap run (see $out/run.log)"
cp -r "$out/run/map" "$out/orig" && rm -f "$out/orig/LOCK"
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
echo "map bundles: all checks passed"
