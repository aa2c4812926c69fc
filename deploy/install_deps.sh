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
  # frame sources (client/source): ROS 1 bags without ROS (rosbag_storage; ros/serialization.h from
  # libroscpp-core-dev), live OpenNI2 cameras;
  # python3-rosbag reads back the bags the tests write with the official Python reader
  librosbag-storage-dev libroscpp-core-dev libopenni2-dev python3-rosbag
  # commands the scripts under deploy/ and tests/ call beyond coreutils, grep, sed and bash:
  # ip (iproute2), unshare (util-linux), pgrep (procps), /usr/bin/time (time), awk (mawk), jq (JSON)
  iproute2 util-linux procps time mawk jq
  # packaging: dpkg-shlibdeps derives the .deb's Depends (deploy/package.sh)
  dpkg-dev
)
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  exit 0
fi
echo "install_deps: installing ${missing[*]}" >&2
if [ "$(id -u)" -ne 0 ]; then
  echo "install_deps: missing packages and not root; run: sudo $0" >&2
  exit 1
fi
export DEBIAN_FRONTEND=noninteractive
apt-get update -qq
apt-get install -y --no-install-recommends "${missing[@]}"
