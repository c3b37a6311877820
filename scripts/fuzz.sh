#!/usr/bin/env bash
# Builds the libFuzzer targets (clang, ASan + UBSan) and runs each for a bounded
# time on a seed corpus made from tests/bad_inputs and data/:
#   scripts/fuzz.sh [SECONDS_PER_TARGET [BUILD_DIR]]   (default 60, build-fuzz)
# Without BUILD_DIR it configures build-fuzz (clang, fuzz targets only). With
# BUILD_DIR it uses that build, which must be configured with clang and
# -DTENSEGRITY_FUZZ=ON (scripts/test.sh passes its sanitizer build, build-asan),
# and only brings the two targets up to date.
# Exit status non-zero when a target finds a crash, a leak or undefined behaviour.
set -euo pipefail
cd "$(dirname "$0")/.."
seconds=${1:-60}
dir=${2:-}
if [ -z "$dir" ]; then
  dir=build-fuzz
  cmake -S . -B "$dir" -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_CXX_COMPILER=clang++ -DTENSEGRITY_FUZZ=ON \
    -DTENSEGRITY_BUILD_TESTS=OFF -DTENSEGRITY_BUILD_BENCH=OFF >/dev/null
elif ! grep -q "^TENSEGRITY_FUZZ:BOOL=ON" "$dir/CMakeCache.txt" 2>/dev/null; then
  echo "fuzz: $dir is not a build configured with -DTENSEGRITY_FUZZ=ON (and clang)" >&2
  exit 2
fi
cmake --build "$dir" -j"$(nproc)" --target scene_parser_fuzz character_parser_fuzz
corpus="$dir/corpus"
rm -rf "$corpus"
mkdir -p "$corpus/scene" "$corpus/character"
cp tests/bad_inputs/*.json data/reference/*.scene.json "$corpus/scene/"
cp data/characters/*.character.json "$corpus/character/"
[ -d tests/bad_inputs/characters ] && cp tests/bad_inputs/characters/*.json "$corpus/character/" 2>/dev/null || true
# A few scenes as characters and characters as scenes: wrong formats are inputs too.
cp data/reference/prism-3.scene.json "$corpus/character/"
cp data/characters/duck.character.json "$corpus/scene/"
export ASAN_OPTIONS=detect_leaks=1:allocator_may_return_null=1
export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
for target in scene character; do
  echo "== fuzz ${target}_parser_fuzz for ${seconds} s"
  # -rss_limit_mb bounds memory; -max_len allows multi-kilobyte scenes; the
  # artifacts (crashing inputs) land in $dir/ with their hash as name.
  rm -f "$dir/${target}-"*
  status=0
  "$dir/tests/fuzz/${target}_parser_fuzz" -max_total_time="$seconds" -max_len=16384 -timeout=10 \
    -rss_limit_mb=2048 -dict=tests/fuzz/json.dict -artifact_prefix="$dir/${target}-" \
    -print_final_stats=1 "$corpus/$target" >"$dir/${target}.log" 2>&1 || status=$?
  grep -E "^(#[0-9]+ +DONE|stat::number_of_executed_units|stat::new_units_added|stat::peak_rss_mb)" "$dir/${target}.log" || true
  if [ "$status" -ne 0 ] || ls "$dir/${target}-"* >/dev/null 2>&1; then
    echo "fuzz: ${target}_parser_fuzz found a problem (exit $status):"
    grep -E "ERROR|SUMMARY|runtime error|Test unit written" "$dir/${target}.log" | head -20
    exit 1
  fi
done
echo "fuzz: no crash, leak or undefined behaviour found"
