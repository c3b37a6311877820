#!/usr/bin/env bash
# Set up, build (Release) and run the whole test suite and the Python tests
# (pytest, python/tests, for /usr/bin/python3); then the whole suite
# again built with AddressSanitizer + UndefinedBehaviorSanitizer (clang, with the
# libFuzzer targets in the same build); then a bounded libFuzzer run of the scene
# and character parsers (docs/ROBUSTNESS.md).
# Prints the wall time of every step (docs/ROBUSTNESS.md).
#   TENSEGRITY_SKIP_SANITIZERS=1   skip the sanitizer build and run
#   TENSEGRITY_SKIP_FUZZ=1         skip the fuzz run
#   TENSEGRITY_FUZZ_SECONDS=N      seconds per fuzz target (default 20)
set -euo pipefail
cd "$(dirname "$0")/.."
jobs=$(nproc)
step_start=$SECONDS
step() {  # step NAME: ends the previous step's clock
  echo "== test.sh: $1 ($((SECONDS - step_start)) s since the previous step, $SECONDS s in all)"
  step_start=$SECONDS
}

bash scripts/setup.sh
step "setup done; Release build"
bash scripts/build.sh build
step "Release build done; test suite"
(cd build && ctest --output-on-failure -j"$jobs" --timeout 900)
step "Release test suite done; Python tests (pytest, /usr/bin/python3, module from build/python)"
PYTHONPATH=build/python PYTHONDONTWRITEBYTECODE=1 /usr/bin/python3 -m pytest python/tests -q
step "Python tests done"

if [ "${TENSEGRITY_SKIP_SANITIZERS:-0}" != 1 ]; then
  # Every test executable and every ctest entry, built with ASan + UBSan.
  # -O1 keeps the suite fast enough to run; -g1 (line tables only) halves the
  # compile time of -g and still gives file:line in every report. Assertions
  # stay on (no NDEBUG): Eigen's index checks run too. The benchmarks are not
  # built: their ctest entries only check that they run and report, which the
  # Release run above does; their timings mean nothing under the sanitizers.
  # Compiled with clang, which compiles faster than GCC, and the libFuzzer
  # targets are built here too, so the fuzz job below needs no build of its own;
  # lld links the many large sanitized executables faster than GNU ld.
  # (The Release build above is GCC's: the suite runs under both compilers.)
  step "sanitizer build (clang, ASan + UBSan, whole suite and fuzz targets)"
  # A build-asan configured by GCC (before this script used clang) is started afresh.
  if [ -f build-asan/CMakeCache.txt ] && ! grep -q "^CMAKE_CXX_COMPILER:[A-Z]*=.*clang++" build-asan/CMakeCache.txt; then
    rm -rf build-asan
  fi
  cmake -S . -B build-asan -DCMAKE_CXX_COMPILER=clang++ -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -g1" -DTENSEGRITY_SANITIZE=ON -DTENSEGRITY_FUZZ=ON \
    -DTENSEGRITY_BUILD_BENCH=OFF -DCMAKE_EXE_LINKER_FLAGS=-fuse-ld=lld >/dev/null
  cmake --build build-asan -j"$jobs"
  step "sanitizer build done; test suite under ASan + UBSan"
  # exitcode=23: a sanitizer report in the program run by a CLI test can never
  # pass for one of its documented exit statuses (0, 1, 2).
  # Six convergence sweeps of the faithful scheme are left to the Release run:
  # under ASan at -O1 they take ten minutes of the two cores and repeat code
  # paths that shorter alternating tests already cover. The schema check of
  # the file formats is left there too: the programs it starts run under the
  # sanitizers in the CLI tests, and the formats do not depend on the build.
  # So are the stress test's run-to-run determinism check and the prestress
  # factor's CLI sweep: they repeat solves that other CLI tests run under the
  # sanitizers, and only compare their numbers. The stress QP on the 40-layer
  # tower's equilibrium without gravity (about 10 s in Release) runs there as
  # well, alone, through Ipopt's residual form and through the command line
  # (a minute each under ASan); the same kernels run sanitized on smaller
  # scenes. So does Ipopt on the 160- and 140-layer gravity towers (about 5
  # and 3 s in Release); the same start runs sanitized on the scorpion, and
  # the stress QP of the force polishes (whose regulariser is an option) in
  # its own tests. And so does the
  # sweep of every bad input in every role a command reads a file in (675
  # program runs, five minutes of the two cores under ASan): every bad input
  # still runs sanitized through `solve` and `forces` (CliBadInput), every
  # role still runs sanitized on the hostile files of CliHostileInput, and
  # the parsers are fuzzed below. The check's stall end against the QP's
  # 100-step cap on the as-generated 40-layer tower (1 s in Release, 38 s
  # under ASan) is left there too: the stall itself runs sanitized wherever
  # a check stalls (StressQp.GivingUpLeavesAStandingTowerUntouched ends so).
  long_sweeps='^ForceScaleGravity\.TowerOf40LayersWithoutGravityEquilibriumPassesForces$|^AlternatingSolver\.MarginOptionSetsTheSmallestCableForce$|^AlternatingSolver/StronglyPerturbedPrisms\.ConvergeExceptOnTheNamedScenesAndFailCleanly/alternating(_sdc)?( |$)|^AlternatingSolver\.FaithfulSchemeConvergesOnPerturbedCharacters$|^AlternatingSolver\.PerturbedOctahedraConverge$|^ForceScaleGravity\.EquilibriaOfTheMassFamilyStand$|^StressTestCommand\.ReportIsBitIdenticalRunToRunAndOnOneOrTwoThreads$|^cli_prestress_factor$|^schema_test$|^IpoptSolver\.Eq5NewtonStartVerifiesTheLargestGravityTower$|^IpoptSolver\.ASecondForcePolishVerifiesThe140LayerGravityTower$|^StressQpIpopt\.FindsTheEquilibriumOfALargeNearMechanism$|^cli_standing_tower$|^StressQp\.TheChecksStallEndsTheStepsThatBringNothing$|^Roles/CliHostileInputPerRole\.EveryBadInputClass/'
  (cd build-asan &&
     ASAN_OPTIONS=detect_leaks=1:exitcode=23:strict_string_checks=1:detect_stack_use_after_return=1 \
     UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1:exitcode=23 \
     LSAN_OPTIONS=suppressions="$PWD/../tests/lsan.supp" \
     ctest --output-on-failure -j"$jobs" --timeout 900 -E "$long_sweeps")
  step "sanitizer test suite done"
fi
if [ "${TENSEGRITY_SKIP_FUZZ:-0}" != 1 ]; then
  step "fuzz job (libFuzzer, clang, ASan + UBSan): scene and character parsers"
  if [ "${TENSEGRITY_SKIP_SANITIZERS:-0}" != 1 ]; then
    bash scripts/fuzz.sh "${TENSEGRITY_FUZZ_SECONDS:-20}" build-asan  # targets built above
  else
    bash scripts/fuzz.sh "${TENSEGRITY_FUZZ_SECONDS:-20}"  # its own clang build, build-fuzz
  fi
  step "fuzz job done"
fi
