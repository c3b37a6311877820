#!/usr/bin/env bash
# Set up, build (Release) and run the whole test suite; then the whole suite
# again under AddressSanitizer + UndefinedBehaviorSanitizer; then a bounded
# libFuzzer run of the scene and character parsers (docs/ROBUSTNESS.md).
#   TENSEGRITY_SKIP_SANITIZERS=1   skip the sanitizer build and run
#   TENSEGRITY_SKIP_FUZZ=1         skip the fuzz run
#   TENSEGRITY_FUZZ_SECONDS=N      seconds per fuzz target (default 60)
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
bash scripts/build.sh build
(cd build && ctest --output-on-failure -j2 --timeout 900)
if [ "${TENSEGRITY_SKIP_SANITIZERS:-0}" != 1 ]; then
  echo "== sanitizer job (ASan + UBSan): the whole test suite"
  # -O1 keeps the sanitized build and run affordable on two cores; no benchmarks.
  bash scripts/build.sh build-asan -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -g" \
    -DTENSEGRITY_SANITIZE=ON -DTENSEGRITY_BUILD_BENCH=OFF
  (cd build-asan && ASAN_OPTIONS=detect_leaks=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
     ctest --output-on-failure -j2 --timeout 900)
fi
if [ "${TENSEGRITY_SKIP_FUZZ:-0}" != 1 ]; then
  echo "== fuzz job (libFuzzer, clang, ASan + UBSan): scene and character parsers"
  bash scripts/fuzz.sh "${TENSEGRITY_FUZZ_SECONDS:-60}"
fi
