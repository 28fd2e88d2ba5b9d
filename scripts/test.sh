#!/usr/bin/env bash
# Sets up, builds and runs every test: the Release suite, then the same suite under ASan/UBSan.
# The ASan pass leaves out the tests labelled `slow` (client tools, browser) and `timing` (the
# studio's limits, asserted in seconds of the optimised build); the studio's server
# tests run in both passes.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
scripts/build.sh
(cd build && ctest --output-on-failure -j"$(nproc)")
if [ "${RELIEF_SKIP_SANITIZE:-0}" != 1 ]; then
  cmake -S . -B build-asan -G Ninja -DCMAKE_BUILD_TYPE=Debug -DRELIEF_SANITIZE=ON -DRELIEF_BUILD_BENCH=OFF >/dev/null
  cmake --build build-asan -j"$(nproc)"
  (cd build-asan && ASAN_OPTIONS=detect_leaks=1 UBSAN_OPTIONS=print_stacktrace=1 ctest --output-on-failure -j"$(nproc)" -LE 'slow|timing')
fi
