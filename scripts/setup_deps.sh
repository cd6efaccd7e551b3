#!/usr/bin/env bash
# Installs the Debian 12 packages objscan needs to build, run and test. Idempotent: installs only what is missing,
# and nothing from anywhere but Debian's archive. Needs root (or sudo).
set -euo pipefail

PACKAGES=(
  build-essential cmake pkg-config git ninja-build
  liblcm-dev liblcm-bin liblcm-java libglib2.0-dev       # LCM 1.3.1 (+ glib for pkg-config lcm)
  libeigen3-dev libopencv-dev libceres-dev liboctomap-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  openjdk-17-jdk-headless libjchart2d-java                # lcm-spy with our types
  libglfw3-dev libimgui-dev libgl-dev xvfb xauth          # viewer, headless screenshots
  iproute2 procps                                         # network namespaces for multicast tests
  chromium                                                # the run report checked in a headless browser
)

missing=()
for p in "${PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
SUDO=""
[ "$(id -u)" -eq 0 ] || SUDO="sudo"

# LCM over udpm needs large socket receive buffers for images (objscan asks for 4 MiB); Debian's default cap is
# 208 KiB, which silently shrinks the buffer and drops 640x480 frames. Raise the cap for this boot.
want_rmem=4194304
if [ "$(cat /proc/sys/net/core/rmem_max 2>/dev/null || echo $want_rmem)" -lt $want_rmem ]; then
  echo "setup_deps: raising net.core.rmem_max to $want_rmem (LCM image traffic)"
  $SUDO sysctl -q -w net.core.rmem_max=$want_rmem || echo "setup_deps: WARNING: could not raise net.core.rmem_max"
fi

if [ ${#missing[@]} -eq 0 ]; then
  echo "setup_deps: all ${#PACKAGES[@]} packages present"
  exit 0
fi
echo "setup_deps: installing ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
