#!/usr/bin/env bash
# Set up, build (Release) and run the whole test suite; then the input-facing
# units again under AddressSanitizer + UndefinedBehaviorSanitizer; then a bounded
# libFuzzer run of the scene and character parsers (docs/ROBUSTNESS.md).
#   TENSEGRITY_SKIP_SANITIZERS=1   skip the sanitizer build and run
#   TENSEGRITY_SKIP_FUZZ=1         skip the fuzz run
#   TENSEGRITY_FUZZ_SECONDS=N      seconds per fuzz target (default 30)
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
bash scripts/build.sh build
(cd build && ctest --output-on-failure -j2 --timeout 900)
if [ "${TENSEGRITY_SKIP_SANITIZERS:-0}" != 1 ]; then
  # The units that parse hostile input and the numerical kernels under them:
  # scene/solution I/O, verification, every bad-input class through the real
  # program, equilibrium, parts and the stress QP. (The whole suite under the
  # sanitizers is not yet part of CI: see the README, "Robustness".)
  echo "== sanitizer job (ASan + UBSan): parsers, bad-input CLI, equilibrium, stress QP"
  targets="tensegrity model_scene_io_test model_verify_test model_solution_io_test cli_bad_input_test equilibrium_test components_test stress_qp_test"
  cmake -S . -B build-asan -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -g" \
    -DTENSEGRITY_SANITIZE=ON -DTENSEGRITY_BUILD_BENCH=OFF >/dev/null
  cmake --build build-asan -j"$(nproc)" --target $targets
  (cd build-asan && ASAN_OPTIONS=detect_leaks=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
     ctest --output-on-failure -j2 --timeout 900 -R '^(Scene|Validate|WriteTextFileAtomically|Solution|Verify|CliBadInput|Equilibrium|Components|FreeNodes|ForceScale|StressQp)')
fi
if [ "${TENSEGRITY_SKIP_FUZZ:-0}" != 1 ]; then
  echo "== fuzz job (libFuzzer, clang, ASan + UBSan): scene and character parsers"
  bash scripts/fuzz.sh "${TENSEGRITY_FUZZ_SECONDS:-30}"
fi
