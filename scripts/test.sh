#!/usr/bin/env bash
# Installs what is missing, builds, and runs every test (ctest: labels unit,
# real-data, slow). real-data tests need ../shared/data and say loudly when
# it is absent. Extra arguments go to ctest, e.g. `scripts/test.sh -L unit`.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
bash scripts/setup.sh
BUILD_DIR=${PANO4D_BUILD_DIR:-build}
DATA_DIR=${PANO4D_DATA_DIR:-../shared/data}
if [[ ! -d $DATA_DIR ]]; then
  echo "pano4d test: REAL DATA MISSING: $DATA_DIR not found; the real-data tests will be" \
       "reported as skipped (set PANO4D_DATA_DIR to the folder of real captures)"
fi
exec ctest --test-dir "$BUILD_DIR" --output-on-failure --timeout 900 -j "$(nproc)" "$@"
