#!/usr/bin/env bash
# Installs what is missing, builds, and runs the main job on the built-in
# synthetic scene: `pano4d demo` (scene, planned pipeline, DyCheck metrics,
# report in pano4d_demo/report/index.md). Extra arguments go to pano4d demo,
# e.g. --workspace DIR or --iterations N.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
# The demo needs only the binary; scripts/test.sh builds the tests.
PANO4D_TARGET=${PANO4D_TARGET:-pano4d} bash scripts/setup.sh
BUILD_DIR=${PANO4D_BUILD_DIR:-build}
exec "$BUILD_DIR/pano4d" demo "$@"
