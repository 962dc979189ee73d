#!/usr/bin/env bash
# Installs what is missing, builds, and runs every test (ctest: labels unit,
# real-data, slow). real-data tests need ../shared/data and say loudly when
# it is absent. Extra arguments go to ctest, e.g. `scripts/test.sh -L unit`.
# Ends with a line of what the install, the build and the tests took, so that
# the tail of a CI log shows a fresh machine's times.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
setup_log=$(mktemp -t pano4d-setup.XXXXXX.log)
start=$SECONDS
bash scripts/setup.sh 2>&1 | tee "$setup_log"
setup_seconds=$((SECONDS - start))
BUILD_DIR=${PANO4D_BUILD_DIR:-build}
DATA_DIR=${PANO4D_DATA_DIR:-../shared/data}
if [[ ! -d $DATA_DIR ]]; then
  echo "pano4d test: REAL DATA MISSING: $DATA_DIR not found; the real-data tests will be" \
       "reported as skipped (set PANO4D_DATA_DIR to the folder of real captures)"
fi
start=$SECONDS
status=0
ctest --test-dir "$BUILD_DIR" --output-on-failure --timeout 900 -j "$(nproc)" "$@" || status=$?
echo "pano4d test: setup ${setup_seconds} s, ctest $((SECONDS - start)) s," \
     "exit status $status; setup said:"
grep -E '^pano4d' "$setup_log" | sed 's/^/  /'
rm -f "$setup_log"
exit "$status"
