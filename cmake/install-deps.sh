#!/bin/sh
# Installs the Debian 12 packages sph needs to build and test, if any are missing. Idempotent:
# when everything is present it changes nothing and needs no network. Runs apt-get through sudo
# when not root.
#
# Usage: cmake/install-deps.sh [--sanitizers]
#   --sanitizers  also clang-14 and libFuzzer (libclang-rt-14-dev), for the "asan" preset
set -eu
# libunwind-dev is named although libceres-dev pulls it in: glog's CMake package (which Ceres' needs)
# finds libunwind 1.6 through it, and installing libc++-14-dev replaces it by libunwind-14-dev, which
# satisfies the package's dependency but not glog-config.cmake ("Failed to find Ceres - Missing
# required Ceres dependency: glog"). chromium, poppler-utils and libxml2-utils: the test that renders
# the HTML reports (tests/apps/render_reports.sh). The firmware tests (tests/firmware/): the bare-metal
# Arm toolchain with newlib (gcc-arm-none-eabi, libnewlib-arm-none-eabi, libstdc++-arm-none-eabi-newlib)
# and qemu-system-arm for a Cortex-M7; the arm64 cross compiler (crossbuild-essential-arm64) and
# qemu-user for aarch64 Linux; googletest's sources (googletest) built for arm64.
packages="cmake ninja-build g++ ccache libeigen3-dev libceres-dev libunwind-dev libcli11-dev nlohmann-json3-dev \
libgtest-dev libgmock-dev libbenchmark-dev gnuplot-nox python3 chromium poppler-utils libxml2-utils \
pybind11-dev python3-dev python3-numpy python3-pytest python3-matplotlib \
gcc-arm-none-eabi libnewlib-arm-none-eabi libstdc++-arm-none-eabi-newlib qemu-system-arm qemu-user \
crossbuild-essential-arm64 googletest"
case "${1:-}" in
  --sanitizers) packages="$packages clang-14 libclang-rt-14-dev" ;;
  "") ;;
  *) echo "install-deps: unknown option '$1' (usage: cmake/install-deps.sh [--sanitizers])" >&2; exit 2 ;;
esac
missing=""
for p in $packages; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing="$missing $p"
done
if [ -z "$missing" ]; then
  echo "install-deps: all packages present"
  exit 0
fi
sudo=""
[ "$(id -u)" -eq 0 ] || sudo="sudo"
echo "install-deps: installing$missing"
$sudo apt-get update -qq
DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends $missing
