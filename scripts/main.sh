#!/usr/bin/env bash
# The main job: set up, build (Release), then solve every reference scene with
# every backend, re-verify each solution independently and print a table.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
bash scripts/build.sh build
bin=build/tensegrity
out=build/main-job
mkdir -p "$out"
"$bin" generate reference --out-dir "$out/scenes" 2>/dev/null
printf '%-22s %-15s %-15s %5s %11s %12s %9s %s\n' scene solver status iters seconds rel_residual geom_chg check
for scene in "$out"/scenes/*.scene.json data/characters/*.scene.json; do
  [ -e "$scene" ] || continue
  name=$(basename "$scene" .scene.json)
  for solver in $("$bin" solvers); do
    sol="$out/$name.$solver.solution.json"
    "$bin" solve "$scene" --solver "$solver" --no-skip --out "$sol" 2>/dev/null || true
    if "$bin" check "$scene" "$sol" >/dev/null 2>&1; then ok=verified; else ok=FAILED; fi
    python3 - "$sol" "$name" "$solver" "$ok" <<'PY'
import json, sys
s = json.load(open(sys.argv[1])); st = s["stats"]
print(f"{sys.argv[2]:<22} {sys.argv[3]:<15} {s['status']:<15} {st['iterations']:>5} {st['seconds']:>11.4g} {st['relative_residual']:>12.3g} {st['geometry_change']:>9.3g} {sys.argv[4]}")
PY
  done
done
