#!/usr/bin/env bash
# Installs the Debian packages pano4d needs (only those missing), then
# configures and builds Release into build/ (ccache when present).
# Idempotent and quiet: a second run installs nothing and rebuilds nothing.
#   PANO4D_BUILD_DIR  build directory (default: build)
#   PANO4D_JOBS       parallel compile jobs (default: nproc)
#   PANO4D_TARGET     what to build (default: everything, tests included;
#                     scripts/demo.sh builds only the pano4d binary)
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

BUILD_DIR=${PANO4D_BUILD_DIR:-build}
JOBS=${PANO4D_JOBS:-$(nproc)}
# Paths relative to the checkout, so that fresh clones (as CI makes) share
# ccache's cache wherever they are.
export CCACHE_BASEDIR=${CCACHE_BASEDIR:-$PWD}
export CCACHE_NOHASHDIR=${CCACHE_NOHASHDIR:-true}
PACKAGES=(
  build-essential cmake ninja-build pkg-config ccache git
  libeigen3-dev libopencv-dev libopencv-contrib-dev nlohmann-json3-dev libcli11-dev
  libceres-dev libpcl-dev libflann-dev libtbb-dev
  libgtest-dev libgmock-dev libbenchmark-dev libsqlite3-dev
  colmap
)

source scripts/apt.sh
apt_install "${PACKAGES[@]}"

start=$SECONDS
mkdir -p "$BUILD_DIR"
if ! cmake -S . -B "$BUILD_DIR" -G Ninja -DCMAKE_BUILD_TYPE=Release >"$BUILD_DIR/configure.log" 2>&1; then
  tail -n 30 "$BUILD_DIR/configure.log" >&2
  echo "pano4d setup: CMake configure failed; the full log is $BUILD_DIR/configure.log" >&2
  exit 1
fi
TARGET_ARGS=()
if [[ -n "${PANO4D_TARGET:-}" ]]; then TARGET_ARGS=(--target "$PANO4D_TARGET"); fi
if ! cmake --build "$BUILD_DIR" -j "$JOBS" "${TARGET_ARGS[@]}" >"$BUILD_DIR/build.log" 2>&1; then
  grep -E "error|Error" "$BUILD_DIR/build.log" | head -n 30 >&2 || tail -n 30 "$BUILD_DIR/build.log" >&2
  echo "pano4d setup: build failed; the full log is $BUILD_DIR/build.log" >&2
  exit 1
fi
echo "pano4d setup: $("$BUILD_DIR/pano4d" --version) built in $BUILD_DIR/ in $((SECONDS - start)) s ($JOBS jobs)"
