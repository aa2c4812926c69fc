#!/usr/bin/env bash
# Installs the Debian 12 packages rgbdmap needs; installs only what is missing (idempotent). Run as root.
set -euo pipefail
packages=(
  cmake g++ pkg-config ninja-build libgtest-dev libbenchmark-dev
  libeigen3-dev libopencv-dev liboctomap-dev octomap-tools libceres-dev liblcm-dev liblcm-bin
  cyclonedds-dev cyclonedds-tools libzstd-dev libjpeg-dev zlib1g-dev libyaml-cpp-dev libssl-dev iproute2
  dpkg-dev  # dpkg-shlibdeps: the .deb's Depends (deploy/package.sh)
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
