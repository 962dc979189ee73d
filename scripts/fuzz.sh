#!/usr/bin/env bash
# Builds pano4d's libFuzzer targets with clang (AddressSanitizer and
# UndefinedBehaviorSanitizer) in build-fuzz/ and runs each for SECONDS
# (default 300). A crash, a sanitizer report, an allocation over 512 MB or an
# input that takes over 10 s stops the run and leaves the input in
# build-fuzz/ (crash-*, oom-*, timeout-*).
#   scripts/fuzz.sh [SECONDS] [TARGET...]   targets: npy json colmap_binary
#   colmap_text checkpoint frames trajectory scene4d sweep (default: all).
#   json covers the camera JSON and DyCheck's camera and split readers;
#   frames a workspace's frames.json; trajectory camera files and
#   trajectories.json; sweep a sweep's manifest and status files.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
SECONDS_EACH=${1:-300}
shift || true
TARGETS=("$@")
((${#TARGETS[@]})) || TARGETS=(npy json colmap_binary colmap_text checkpoint frames trajectory scene4d sweep)

bash scripts/setup.sh >/dev/null  # the Debian packages the project needs
source scripts/apt.sh
apt_install clang libclang-rt-14-dev

cmake -S . -B build-fuzz -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DCMAKE_CXX_COMPILER=clang++ -DPANO4D_BUILD_TESTS=OFF -DPANO4D_BUILD_FUZZERS=ON \
  -DCMAKE_CXX_FLAGS="-fsanitize=fuzzer-no-link,address,undefined -fno-sanitize-recover=undefined" \
  >build-fuzz.configure.log 2>&1 || { tail -n 20 build-fuzz.configure.log; exit 1; }
for target in "${TARGETS[@]}"; do
  cmake --build build-fuzz --target "pano4d_${target}_fuzzer" >/dev/null
done

for target in "${TARGETS[@]}"; do
  corpus=build-fuzz/corpus/$target
  mkdir -p "$corpus"
  cp -n tests/fuzz/seeds/"$target"/* "$corpus"/ 2>/dev/null || true
  [[ $target == npy ]] && cp -n tests/data/npy/*.npy "$corpus"/
  # The checkpoint seed is written by the target itself, in today's format.
  [[ $target == checkpoint || $target == scene4d ]] &&
    PANO4D_FUZZ_WRITE_SEED="$corpus/seed.$target" \
      "build-fuzz/tests/fuzz/pano4d_${target}_fuzzer" -runs=0 >/dev/null 2>&1
  echo "pano4d fuzz: $target for $SECONDS_EACH s"
  (cd build-fuzz && "./tests/fuzz/pano4d_${target}_fuzzer" "corpus/$target" \
     -max_total_time="$SECONDS_EACH" -malloc_limit_mb=512 -rss_limit_mb=2048 -timeout=10 \
     -print_final_stats=1 2>&1 | tail -n 12)
done
