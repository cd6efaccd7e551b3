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
)

missing=()
for p in "${PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  echo "setup_deps: all ${#PACKAGES[@]} packages present"
  exit 0
fi
SUDO=""
[ "$(id -u)" -eq 0 ] || SUDO="sudo"
echo "setup_deps: installing ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
