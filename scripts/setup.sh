#!/usr/bin/env bash
# Installs the Debian packages pano4d needs (only those missing) and the
# web viewer's pinned npm libraries (src/viewer/package-lock.json, `npm
# ci`, only when the lockfile changed), then configures and builds
# Release into build/ (ccache when present).
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
  libgtest-dev libgmock-dev libbenchmark-dev libsqlite3-dev libzip-dev
  python3-dev pybind11-dev python3-numpy python3-pytest  # the Python module
  colmap
  chromium  # the browser test of `pano4d view` (headless, software WebGL)
  slurm-wlm munge  # the sweep test's single-node cluster (scripts/slurm_local.sh)
)

source scripts/apt.sh
apt_install "${PACKAGES[@]}"
# Node's npm, unless one is there already (e.g. from NodeSource).
command -v npm >/dev/null || apt_install nodejs npm

# The viewer's libraries (three.js, Spark), exactly as the lockfile pins
# them; `pano4d view` copies them beside each scene.
viewer=src/viewer
lock_sum=$(sha256sum "$viewer/package-lock.json" | cut -d' ' -f1)
if [[ ! -f $viewer/node_modules/.pano4d-lock || $(cat "$viewer/node_modules/.pano4d-lock") != "$lock_sum" ]]; then
  npm_log=$(mktemp -t pano4d-npm.XXXXXX.log)
  npm_start=$SECONDS
  if ! npm ci --prefix "$viewer" --no-audit --no-fund --loglevel=error >"$npm_log" 2>&1; then
    tail -n 30 "$npm_log" >&2
    echo "pano4d setup: npm ci in $viewer failed; the full log is $npm_log" >&2
    exit 1
  fi
  echo "$lock_sum" >"$viewer/node_modules/.pano4d-lock"
  echo "pano4d: viewer libraries installed (npm ci) in $((SECONDS - npm_start)) s"
fi

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

# The Python module: a .pth file in Debian python3's user site names
# build/python, so that `python3 -c "import pano4d"` finds it (as `pip
# install -e` would; nothing is copied, a rebuild is seen at once).
if compgen -G "$BUILD_DIR/python/pano4d*.so" >/dev/null; then
  site=$(/usr/bin/python3 -m site --user-site)
  mkdir -p "$site"
  echo "$(cd "$BUILD_DIR/python" && pwd)" >"$site/pano4d.pth"
fi
