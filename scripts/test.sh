#!/usr/bin/env bash
# Set up, build (Release) and run the whole test suite; then the bad-input and
# model tests again under AddressSanitizer + UndefinedBehaviorSanitizer.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
bash scripts/build.sh build
(cd build && ctest --output-on-failure -j2 --timeout 900)
if [ "${TENSEGRITY_SKIP_SANITIZERS:-0}" != 1 ]; then
  echo "== sanitizer job (ASan + UBSan): model, scene I/O and bad-input tests"
  bash scripts/build.sh build-asan -DCMAKE_BUILD_TYPE=RelWithDebInfo -DTENSEGRITY_SANITIZE=ON -DTENSEGRITY_BUILD_BENCH=OFF
  (cd build-asan && ASAN_OPTIONS=detect_leaks=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
     ctest --output-on-failure -j2 --timeout 900 -R 'Model|Scene|Solution|Verify|BadInput|Cli')
fi
