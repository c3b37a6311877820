#!/usr/bin/env bash
# The main job (the README's first command), a compact version of the benchmark of docs/BENCHMARKS.md:
#   1. set up (apt-get, only what is missing) and build (Release) the program
#      and the benchmark;
#   2. every backend on a compact set of scenes (reference prism and
#      octahedron off equilibrium, perturbed ones with gravity, the tower, the
#      duck, scorpion and puppy, and the chain family for scaling), each
#      solution checked by the independent verifier; times to relative residual
#      1e-4 ... 1e-10 from the solvers' traces;
#   3. the two-core batch mode on the characters and chains, with the measured
#      speed-up, every batch solution re-checked by `tensegrity check`; then
#      compare_bench's two-core family, a mixed set with Ipopt solves and the
#      gravity towers of 10 to 40 layers, one worker process against two;
#   4. the comparison table (printed, with the two-core run) and the plots:
#      build/main-job/report/*.png.
# Runs in a few minutes on two cores. Environment: MAIN_TIME_LIMIT (s per
# solve, default 5), MAIN_CHAIN_SIZES (default 2,4,8,16,32), MAIN_TOWER_LAYERS
# (default 2,4,8), MAIN_BUILD_DIR
# (default build).
set -euo pipefail
cd "$(dirname "$0")/.."
root=$PWD
build=${MAIN_BUILD_DIR:-build}
out=$root/$build/main-job
time_limit=${MAIN_TIME_LIMIT:-5}
chain_sizes=${MAIN_CHAIN_SIZES:-2,4,8,16,32}
tower_layers=${MAIN_TOWER_LAYERS:-2,4,8}
# One solve = one core; the batch mode runs two of them side by side.
export OPENBLAS_NUM_THREADS=1 OMP_NUM_THREADS=1

step() { printf '\n== [%s] %s\n' "$1" "$2"; }
# Numbers compare_bench's one line per run as [k/N] (a shell loop: mawk would
# buffer its input and show nothing until the end).
progress() {
  local k=0 line
  while IFS= read -r line; do
    case $line in
      "run  "*) k=$((k + 1)); printf '[%3d/%d] %s\n' "$k" "$1" "${line#run  }" ;;
      *) printf '%s\n' "$line" ;;
    esac
  done
}

step 1/4 "setup and build (Release)"
bash scripts/setup.sh
cmake -S . -B "$build" -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build "$build" -j"$(nproc)" --target tensegrity compare_bench tensegrity_python 2>&1 |
  grep --line-buffered -E '^\[ *[0-9]+%\] (Built|Linking)|error|warning' || true
[ -x "$build"/tensegrity ] && [ -x "$build"/bench/compare_bench ] || { echo "build failed" >&2; exit 1; }
rm -rf "$out"
mkdir -p "$out/scenes" "$out/traces" "$out/batch"

step 2/4 "every backend x compact scene set (time limit ${time_limit} s per solve)"
scenes='prism-6-twist10|octahedron-noise5-s3|prism-6-gravity-noise5-s6|octahedron-gravity-noise5-s8|tower-80s-500c-gravity|duck|scorpion|puppy'
filter="^(compare/($scenes)|scaling/[a-z-]+[0-9]+)/"
bench=("$build"/bench/compare_bench --chain_sizes="$chain_sizes" --tower_layers="$tower_layers" --time_limit="$time_limit"
       --benchmark_filter="$filter" --benchmark_min_time=0.05 --benchmark_repetitions=1)
total=$("${bench[@]}" --benchmark_list_tests=true | wc -l)
echo "$total runs; one line each: scene, backend, status, seconds, iterations, relative residual, geometry change, heap"
"${bench[@]}" --trace_dir="$out/traces" --benchmark_out="$out/compare.json" --benchmark_out_format=json \
  2> >(progress "$total" >&2) >/dev/null
sleep 0.5  # let the progress filter print its last line

step 3/4 "two cores: batch mode (ipopt and alternating-gn on the characters and chains), then compare_bench's two-core family"
for c in duck scorpion puppy; do
  "$build"/tensegrity build "data/characters/$c.character.json" --out "$out/scenes/$c.scene.json" 2>/dev/null
done
for n in 4 8 12 16; do "$build"/tensegrity build --chain "$n" --out "$out/scenes/chain-$n.scene.json" 2>/dev/null; done
for solver in ipopt alternating-gn; do
  echo "-- $solver"
  "$build"/tensegrity batch "$out"/scenes/*.scene.json --solver "$solver" --jobs 2 --measure-speedup --no-skip \
    --time-limit "$time_limit" --out-dir "$out/batch/$solver" | tee "$out/batch/$solver.txt" || true
  bad=0
  for scene in "$out"/scenes/*.scene.json; do
    name=$(basename "$scene" .scene.json)
    "$build"/tensegrity check "$scene" "$out/batch/$solver/$name.solution.json" >/dev/null 2>&1 || bad=$((bad + 1))
  done
  echo "independent check (tensegrity check): $bad of $(ls "$out"/scenes/*.scene.json | wc -l) solutions rejected"
done
echo "-- compare_bench's two-core family: ipopt, alternating-gn and eq5-newton on a mixed set"
"$build"/bench/compare_bench --benchmark_filter='^two-cores/' --time_limit="$time_limit" --tolerance=1e-8 \
  --benchmark_out="$out/two-cores.json" --benchmark_out_format=json 2>&1 >/dev/null | grep '^run' || true

step 4/4 "comparison table and plots"
/usr/bin/python3 bench/scripts/report.py --json "$out/compare.json" "$out/two-cores.json" --traces "$out/traces" \
  --out "$out/report"
echo
echo "JSON: $out/compare.json   traces: $out/traces/   table and plots: $out/report/"
