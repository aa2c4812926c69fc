#!/usr/bin/env bash
# `--source mcap:` against the reference implementation: a synthetic sequence written into rosbag2-style MCAP
# files by npm @mcap/core's McapWriter with ROS 2 CDR from @foxglove/rosmsg2-serialization
# (mcap_reference_writer.js: realsense2_camera topics, bgr8 colour, 32FC1 depth in metres, camera_info) with
# zstd, lz4 (rosbag2's schema text) and plain chunks, read back by @mcap/core's readers; odometry on each gives
# the folder's trajectory byte for byte; 16UC1 millimetres (rgb8) within a rounding bound; a recording cut
# off mid-write reads up to the cut with a warning (a prefix of the folder's trajectory); random bytes, an
# empty file and a missing topic exit 1 with one clear error line.
# Skips (77) without node, the npm packages (deploy/install_deps.sh installs them into RGBDMAP_NODE_DIR,
# default /usr/local/lib/rgbdmap-node) or the zstd and lz4 commands.
# Usage: test_mcap_sources.sh BIN_DIR
set -u
here="$(cd "$(dirname "$0")" && pwd)"
bin="$1/rgbdmap"
node_dir="${RGBDMAP_NODE_DIR:-/usr/local/lib/rgbdmap-node}"
frames=40  # 40 frames keep the test well under a minute on 2 cores (the writer pipes each chunk through a CLI)
for p in @mcap/core @foxglove/rosmsg2-serialization @foxglove/rosmsg-msgs-common @foxglove/rosmsg; do
  if ! command -v node >/dev/null 2>&1 || [ ! -f "$node_dir/node_modules/$p/package.json" ]; then
    echo "SKIP: node or $p in $node_dir missing (bash deploy/install_deps.sh installs them)"
    exit 77
  fi
done
for c in zstd lz4; do
  command -v "$c" >/dev/null 2>&1 || { echo "SKIP: the $c command is not installed (deploy/install_deps.sh)"; exit 77; }
done
source "$here/cli_test_lib.sh"
trap 'kill $(jobs -p) 2>/dev/null; wait; rm -rf "$tmp"' EXIT  # and the reference tools still running
ref() {  # the reference writer / reader
  NODE_PATH="$node_dir/node_modules" node "$here/mcap_reference_writer.js" "$@"
}
declare -A job
start_ref() {  # start_ref NAME ARGS...: the reference tool in the background, its output in $tmp/NAME.ref.log
  local name="$1"; shift
  NODE_PATH="$node_dir/node_modules" node "$here/mcap_reference_writer.js" "$@" >"$tmp/$name.ref.log" 2>&1 &
  job[$name]=$!  # node's own pid (a simple command in the background), for the EXIT trap's kill
}
wait_ref() {  # wait_ref "description" NAME
  if wait "${job[$2]}"; then
    echo "ok: $1"; tail -1 "$tmp/$2.ref.log" | sed 's/^/  | /'
  else
    echo "FAIL: $1: exit $?"; sed 's/^/  | /' "$tmp/$2.ref.log" | tail -5; fail=1
  fi
}
poses() {  # poses FILE: the pose lines of a trajectory
  grep -v '^#' "$1"
}
topic_count() {  # topic_count VERIFY_OUTPUT TOPIC: the message count the reference reader printed
  awk -v t="$2:" '$1 == "topic" && $2 == t { print $3 }' "$1"
}

check "synth writes a sequence" 0 "$bin" synth --out "$tmp/seq" --scene sweep --frames "$frames" --seed 4
# The reference files, written side by side while the folder's odometry runs. The cut one has 3 MB chunks,
# which split frames (colour in one chunk, its depth in the next), so the cut may leave a colour image alone.
start_ref zstd "$tmp/seq" "$tmp/zstd.mcap" --compression zstd
start_ref lz4 "$tmp/seq" "$tmp/lz4.mcap" --compression lz4 --schema-text rosbag2
start_ref none "$tmp/seq" "$tmp/none.mcap" --compression none --nan-invalid
start_ref cut "$tmp/seq" "$tmp/cut.mcap" --compression zstd --cut 0.6 --chunk-size 3000000
start_ref mm "$tmp/seq" "$tmp/mm.mcap" --compression none --depth 16UC1 --color rgb8
check "odometry on the folder" 0 "$bin" odometry --dataset "$tmp/seq" --out "$tmp/folder.txt"
wait_ref "reference writer: zstd chunks (bgr8, 32FC1, camera_info)" zstd
wait_ref "reference writer: lz4 chunks, rosbag2's schema text" lz4
wait_ref "reference writer: plain chunks, no depth as NaN" none
wait_ref "reference writer: zstd, cut off at 60 %" cut
wait_ref "reference writer: 16UC1 millimetres, rgb8" mm

# The reference side reads what it wrote (in the background while odometry reads the files):
# @mcap/core's stream and indexed readers, CDR decoded with the file's own schema text, every image and
# camera_info against the folder.
start_ref zstd.verify --verify "$tmp/zstd.mcap" --against "$tmp/seq"
start_ref lz4.verify --verify "$tmp/lz4.mcap"
start_ref mm.verify --verify "$tmp/mm.mcap" --against "$tmp/seq"
start_ref cut.verify --verify "$tmp/cut.mcap" --against "$tmp/seq"

# Odometry on each file: the folder's trajectory, byte for byte (32FC1 converts back to the same 16-bit
# depth; NaN is no depth, like 0).
for name in zstd lz4 none; do
  check "odometry on the $name file" 0 "$bin" odometry --source "mcap:$tmp/$name.mcap" --out "$tmp/$name.txt"
  [ "$name" = zstd ] && contains "camera from camera_info" "$tmp/err.txt" "camera from mcap:.*zstd.mcap.*fx 525"
  if cmp -s "$tmp/folder.txt" "$tmp/$name.txt"; then
    echo "ok: $name: the folder's trajectory, byte for byte"
  else
    echo "FAIL: $name: trajectory differs from the folder's"; fail=1
  fi
done
check "odometry on the 16UC1 file" 0 "$bin" odometry --source "mcap:$tmp/mm.mcap" --out "$tmp/mm.txt"
below "16UC1: trajectory within 5 mm of the folder's" "$(ate "$tmp/folder.txt" "$tmp/mm.txt")" 0.005
check "odometry on the cut file" 0 "$bin" odometry --source "mcap:$tmp/cut.mcap" --out "$tmp/cut.txt"
contains "warns that the recording is cut off" "$tmp/err.txt" "cut off"

wait_ref "reference reader: the zstd file, every image the folder's" zstd.verify
v="$tmp/zstd.verify.ref.log"
contains "reference reader: $frames colour messages" "$v" "^topic /camera/camera/color/image_raw: $frames messages$"
contains "reference reader: $frames depth messages" "$v" "^topic /camera/camera/aligned_depth_to_color/image_raw: $frames messages$"
contains "reference reader: $frames camera_info messages" "$v" "^topic /camera/camera/color/camera_info: $frames messages$"
contains "reference reader: colour is bgr8" "$v" "^first image on /camera/camera/color/image_raw: 640x480 bgr8"
contains "reference reader: summary and indexes" "$v" "^complete: yes"
wait_ref "reference reader: the lz4 file (rosbag2 schema text)" lz4.verify
contains "reference reader: lz4, $frames colour messages" "$tmp/lz4.verify.ref.log" "^topic /camera/camera/color/image_raw: $frames messages$"
wait_ref "reference reader: the 16UC1 file against the folder" mm.verify
wait_ref "reference reader: the cut file up to the cut" cut.verify
v="$tmp/cut.verify.ref.log"
contains "reference reader: the cut file has no footer" "$v" "^complete: no"
ref_color=$(topic_count "$v" /camera/camera/color/image_raw)
ref_depth=$(topic_count "$v" /camera/camera/aligned_depth_to_color/image_raw)
ref_pairs=$(( ${ref_color:-0} < ${ref_depth:-0} ? ${ref_color:-0} : ${ref_depth:-0} ))

# Cut off mid-write: read up to the cut; the frames before it are the folder's.
n=$(poses "$tmp/cut.txt" | wc -l)
if [ "$n" -ge 1 ] && [ "$n" -lt "$frames" ]; then echo "ok: cut file: $n of $frames poses"; else echo "FAIL: cut file: $n poses"; fail=1; fi
if [ "$n" -eq "$ref_pairs" ]; then
  echo "ok: cut file: every colour/depth pair of the complete chunks (the reference reader reads ${ref_color:-0} colour, ${ref_depth:-0} depth images)"
else
  echo "FAIL: cut file: $n poses; the reference reader reads ${ref_color:-0} colour and ${ref_depth:-0} depth images"; fail=1
fi
if [ "$n" -ge 1 ] && diff <(poses "$tmp/cut.txt") <(poses "$tmp/folder.txt" | head -n "$n") >/dev/null; then
  echo "ok: cut file: the first $n poses of the folder's trajectory"
else
  echo "FAIL: cut file: not a prefix of the folder's trajectory"; fail=1
fi

# Not MCAP, or not the topics: exit 1, one error line naming the file (or the topics there are).
LC_ALL=C awk 'BEGIN { srand(4); for (i = 0; i < 65536; i++) printf "%c", int(rand() * 255) + 1 }' >"$tmp/random.mcap"
check "random bytes" 1 "$bin" odometry --source "mcap:$tmp/random.mcap" --out "$tmp/x.txt"
contains "random bytes: names the file" "$tmp/err.txt" "random.mcap"
one_error_line "random bytes: one line" "$tmp/err.txt"
{ printf '\x89MCAP0\r\n'; cat "$tmp/random.mcap"; } >"$tmp/garbled.mcap"
check "MCAP magic, then random bytes" 1 "$bin" odometry --source "mcap:$tmp/garbled.mcap" --out "$tmp/x.txt"
contains "garbled: names the file" "$tmp/err.txt" "garbled.mcap"
one_error_line "garbled: one line" "$tmp/err.txt"
: >"$tmp/empty.mcap"
check "an empty file" 1 "$bin" odometry --source "mcap:$tmp/empty.mcap" --out "$tmp/x.txt"
contains "empty file: names the file" "$tmp/err.txt" "empty.mcap"
one_error_line "empty file: one line" "$tmp/err.txt"
check "a colour topic the file does not have" 1 "$bin" odometry --source "mcap:$tmp/zstd.mcap?rgb=/nope" --out "$tmp/x.txt"
contains "names the topics the file has" "$tmp/err.txt" "has: .*/camera/camera/color/image_raw"
one_error_line "missing topic: one line" "$tmp/err.txt"
exit $fail
