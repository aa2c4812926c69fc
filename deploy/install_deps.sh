#!/usr/bin/env bash
# Installs the Debian 12 packages rgbdmap needs; installs only what is missing (idempotent, silent when
# nothing is). Run as root.
set -euo pipefail
packages=(
  # build: compilers, CMake/CTest, Ninja, lcm-gen (liblcm-bin) and idlc (cyclonedds-tools) code generators
  cmake g++ pkg-config ninja-build liblcm-bin cyclonedds-tools
  # libraries
  libgtest-dev libbenchmark-dev libeigen3-dev libopencv-dev liboctomap-dev octomap-tools libceres-dev
  liblcm-dev cyclonedds-dev libzstd-dev libjpeg-dev zlib1g-dev libyaml-cpp-dev libssl-dev nlohmann-json3-dev
  # MCAP chunks (common/mcap): LZ4 frames; the zstd and lz4 commands compress the chunks of the reference
  # writer's files (tests/cli/mcap_reference_writer.js)
  liblz4-dev zstd lz4
  # frame sources (client/source): ROS 1 bags without ROS (rosbag_storage; ros/serialization.h from
  # libroscpp-core-dev), live OpenNI2 cameras;
  # python3-rosbag reads back the bags the tests write with the official Python reader
  librosbag-storage-dev libroscpp-core-dev libopenni2-dev python3-rosbag
  # the live map viewer (apps/viewer): HTTP + WebSocket server, three.js for its page (served, no CDN)
  libcivetweb-dev libjs-three
  # the viewer's tests: headless Chromium (page screenshot), Node (the Foxglove reference client, below)
  chromium
  # commands the scripts under deploy/ and tests/ call beyond coreutils, grep, sed and bash:
  # ip (iproute2), unshare (util-linux), pgrep (procps), /usr/bin/time (time), awk (mawk), jq (JSON)
  iproute2 util-linux procps time mawk jq
  # python3: deploy/check_sizes.py (the size rules the lint.source_sizes test checks),
  # deploy/check_json_schema.py (report.json and server_summary.json against deploy/schemas/) and
  # tests/viewer/page_probe.py (drives headless Chromium over the DevTools pipe)
  python3
  # packaging: dpkg-shlibdeps derives the .deb's Depends (deploy/package.sh)
  dpkg-dev
)
# Node.js and npm from Debian unless some other installation already provides the commands.
command -v node >/dev/null 2>&1 || packages+=(nodejs)
command -v npm >/dev/null 2>&1 || packages+=(npm)
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "install_deps: installing ${missing[*]}" >&2
  if [ "$(id -u)" -ne 0 ]; then
    echo "install_deps: missing packages and not root; run: sudo $0" >&2
    exit 1
  fi
  export DEBIAN_FRONTEND=noninteractive
  apt-get update -qq
  apt-get install -y --no-install-recommends "${missing[@]}"
fi

# Reference implementations for the tests, npm packages in a folder outside the source tree, never at build
# time: the Foxglove WebSocket client for the viewer's test (tests/viewer/foxglove_check.js); the MCAP
# writer and reader and the ROS 2 CDR serialisation with the standard message definitions for the MCAP
# source's test (tests/cli/mcap_reference_writer.js). RGBDMAP_NODE_DIR moves it (the test
# reads the same variable); RGBDMAP_SKIP_NODE=1 skips it (the test then skips with a message).
# Without a route to the npm registry, npm's default retries take 2 min 20 s to fail, and the README's test
# command runs this script twice (the Release and the sanitizer builds): short timeouts, and a failure is
# remembered for an hour ($node_dir/npm_install_failed; delete it to try again at once).
node_dir="${RGBDMAP_NODE_DIR:-/usr/local/lib/rgbdmap-node}"
failed_mark="$node_dir/npm_install_failed"
node_packages=(@foxglove/ws-protocol@0.8.0 ws@8.23.0 @mcap/core@2.2.2 @foxglove/rosmsg2-serialization@3.1.0
  @foxglove/rosmsg-msgs-common@3.2.3 @foxglove/rosmsg@5.0.5)
node_missing=0
for p in "${node_packages[@]}"; do
  [ -f "$node_dir/node_modules/${p%@*}/package.json" ] || node_missing=1
done
if [ -z "${RGBDMAP_SKIP_NODE:-}" ] && [ "$node_missing" = 1 ]; then
  if [ "$(id -u)" -ne 0 ] && [ ! -w "$(dirname "$node_dir")" ]; then
    echo "install_deps: cannot write $node_dir; run as root or set RGBDMAP_NODE_DIR" >&2
    exit 1
  fi
  if [ -f "$failed_mark" ] && [ -n "$(find "$failed_mark" -mmin -60 2>/dev/null)" ]; then
    echo "install_deps: npm install failed less than an hour ago ($failed_mark); the tests with Node" \
      "reference implementations will skip" >&2
  else
    echo "install_deps: npm install ${node_packages[*]} into $node_dir" >&2
    mkdir -p "$node_dir"
    if npm install --silent --no-audit --no-fund --fetch-retries=1 --fetch-retry-mintimeout=2000 \
      --fetch-retry-maxtimeout=5000 --fetch-timeout=20000 --prefix "$node_dir" \
      "${node_packages[@]}" >&2; then
      rm -f "$failed_mark"
    else
      touch "$failed_mark"
      echo "install_deps: npm install failed; the tests with Node reference implementations will skip" >&2
    fi
  fi
fi
