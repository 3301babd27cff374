#!/usr/bin/env bash
# Installs every Debian 12 package rumi needs to build, test and run, then
# configures and builds into build/. Idempotent: a second run changes nothing.
#   scripts/setup.sh                 everything (libraries, executables, tests, benchmarks)
#   scripts/setup.sh TARGET...       only these targets and what they need (the demo: the executables)
set -euo pipefail
cd "$(dirname "$0")/.."

PACKAGES=(
  build-essential cmake ccache pkg-config git ca-certificates
  libopencv-dev libeigen3-dev libceres-dev libspdlog-dev libfmt-dev libboost-dev
  libyaml-cpp-dev nlohmann-json3-dev libcli11-dev libsystemd-dev libsqlite3-dev libmbedtls-dev
  cyclonedds-dev cyclonedds-tools colmap
  libcpp-httplib-dev chromium
  libgtest-dev libgmock-dev libbenchmark-dev
  systemd util-linux iproute2
  clang libclang-rt-14-dev
)

SUDO=""
if [ "$(id -u)" -ne 0 ]; then
  command -v sudo >/dev/null || { echo "setup.sh: run as root or install sudo" >&2; exit 1; }
  SUDO=sudo
fi

missing=()
for p in "${PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "setup.sh: installing ${missing[*]}"
  $SUDO apt-get update
  $SUDO env DEBIAN_FRONTEND=noninteractive apt-get install -y --no-install-recommends "${PACKAGES[@]}"
fi

JOBS=${RUMI_JOBS:-$(nproc)}
cmake -S . -B build -DCMAKE_BUILD_TYPE=${RUMI_BUILD_TYPE:-Release} ${RUMI_CMAKE_ARGS:-}
if [ $# -gt 0 ]; then
  cmake --build build -j "$JOBS" --target "$@"
else
  cmake --build build -j "$JOBS"
fi
