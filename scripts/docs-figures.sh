#!/usr/bin/env bash
# Regenerates every figure quoted in README.md and docs/ into docs/figures/:
#   backends.md    every backend on the 13 comparison scenes (compare_bench) and
#                  a per-backend summary; compare.json is the raw output
#   scaling.md     the chain and tower-layers families (compare_bench scaling/)
#   stress.md      the node-noise stress test on all 27 benchmark scenes
#   stress-families.md  every perturbation family on the reference scenes
#                  (stress-*.json: the raw reports)
#   characters.md  the characters as built (struts, cables, nodes, mass), form-found
#                  with the default backend, checked with --stability, and
#                  form-found by the faithful Algorithm 1 (alternating)
#   blocks.md      every block of the characters alone, checked with --stability
#   relax.md       designed characters relaxed under gravity in four directions
#   character-design.md  the characters designed (default cord), against the
#                  constant-fraction baseline, and simulated (still, turned, dragged)
#   duck-neck.md   suggest-link and actuation on the duck's neck; the duck's
#                  stability under each cable model
#   link-stiffness.md  face against edge links (link_stiffness_test's output)
#   stress-characters.md  the faithful Algorithm 1 on the characters with node noise
#   side-by-side.md  every backend on the minimal scorpion as built and with 2 % node
#                  noise, on the 80/500 gravity tower and the 2 x 7 octahedron grid (compare_bench
#                  side-by-side/, 3 runs, FIGURES_SIDE_BY_SIDE_TIME_LIMIT s, default 30), at the
#                  solve's default target relative residual 1e-8
#   gravity-towers.md  the gravity tower family (compare_bench gravity-towers/),
#                  every backend; gravity-towers.json is the raw output
#   eq5-newton.md  eq5-newton, alternating-gn and warm-started Ipopt on the gravity towers
#                  (eq5_newton_bench, medians of 3)
#   gravity-towers-10k.md  the same family to 160 layers (9,280 elements) for
#                  alternating-gn, eq5-newton and ipopt (FIGURES_10K_TIME_LIMIT s, default 120),
#                  at the solve's default target relative residual 1e-8
#   gravity-towers-dense.md  alternating-gn, eq5-newton and ipopt on the same family
#                  every 20 layers from 20 to 160 (FIGURES_10K_TIME_LIMIT s, default 120)
#   ipopt-orderings.md  ipopt with MUMPS's QAMD (its default), METIS and PORD orderings
#                  and without threshold pivoting, on the chain family (32-128 blocks) and the
#                  gravity tower family (40-160 layers; FIGURES_10K_TIME_LIMIT s, default 120)
#   gravity-towers-driver.md  alternating-gn and eq5-newton on that family as
#                  `tensegrity solve` runs them: with the driver's check whether a scene stands
#   ipopt-starts.md  ipopt's starts on gravity prisms and a tower; MUMPS orderings
#   nlopt-variants.md  the nlopt backend's formulations and algorithms beside Ipopt on
#                  the reference and conformance scenes and the scorpions (nlopt_bench
#                  side-by-side/, medians of 3, FIGURES_TIME_LIMIT s per solve)
#   prestress-factor.md  Eq. 5's cap kappa (--prestress-factor) against the
#                  geometry change, ipopt and alternating-gn, gravity scenes and characters
#   towers-as-generated.md  alternating-gn, eq5-newton and ipopt through `solve` on the
#                  towers as generated (L = 10, 40, 160, with and without gravity;
#                  FIGURES_AS_GENERATED_TOWER_LAYERS, FIGURES_AS_GENERATED_TIME_LIMIT s, default 120)
#   check-qp.md    the stress QP of the driver's check with K and through the node
#                  space on the towers (stress_qp_bench, medians of 5)
#   two-cores.md   batch and stress-test with --measure-speedup on mixed sets that
#                  include Ipopt solves (one worker, then two; 3 runs each)
#   ipopt-auto-stress.md  ipopt start=scene against start=auto over the stress
#                  test (only when FIGURES_SECTIONS names ipopt_auto_stress)
#   ipopt-default-stress.md  ipopt start=auto against its default start=eq5-newton
#                  over the stress test (only when FIGURES_SECTIONS names ipopt_default_stress)
#   *.png          report.py's plots of the comparison and scaling runs
# Section outputs writes into docs/ instead (FIGURES_DOCS, default docs): what
# docs/OUTPUTS.md and docs/PYTHON.md show, each folder with its record:
#   outputs/compare-prism-6/  tensegrity compare on outputs/prism-6-noise5.scene.json
#                  (table.txt is what it prints); outputs/scorpion-*.png|svg the
#                  scorpion as built and form-found; outputs/ntrt-3prism-formfound.png
#                  NTRT's 3Prism imported and form-found; outputs/README.md the record
#   images/python-backends.png  python/examples/compare_backends.py (needs the
#                  Python module, target tensegrity_python); images/python-backends.md
# Every Markdown file starts with the command, the commit, the date and the
# machine; every JSON file carries the same record under "provenance".
#
#   bash scripts/docs-figures.sh   # several minutes on 2 cores; each file records the load
#
# Environment: FIGURES_BUILD_DIR (default build), FIGURES_OUT (default
# docs/figures), FIGURES_TIME_LIMIT (seconds per solve, default 10),
# FIGURES_NO_BUILD=1 (use the existing build as it is), FIGURES_SECTIONS (a
# subset of: characters blocks relax character_design duck_neck link_stiffness
# character_stress outputs backends side_by_side stress_noise scaling stress_families ipopt_starts
# eq5_newton nlopt_variants gravity_towers gravity_towers_10k gravity_towers_dense eq5_newton_barrier ipopt_orderings gravity_towers_driver forces_towers towers_as_generated check_qp prestress_factor two_cores; ipopt_auto_stress,
# ipopt_default_stress and nlopt_auto_stress only when named), FIGURES_GRAVITY_TOWER_LAYERS (default 10,20,40; the whole
# family is 10,20,40,80,160), FIGURES_FORCES_TOWER_LAYERS (default "10 20 40 80 160").
set -euo pipefail
cd "$(dirname "$0")/.."
build=${FIGURES_BUILD_DIR:-build}
out=${FIGURES_OUT:-docs/figures}
limit=${FIGURES_TIME_LIMIT:-10}
py=/usr/bin/python3
export LC_ALL=C

if [ "${FIGURES_NO_BUILD:-0}" != 1 ]; then
  echo "== build (Release): tensegrity, compare_bench, eq5_newton_bench, stress_qp_bench, link_stiffness_test, tensegrity_python"
  cmake -S . -B "$build" -DCMAKE_BUILD_TYPE=Release >/dev/null
  cmake --build "$build" -j"$(nproc --all)" --target tensegrity compare_bench eq5_newton_bench stress_qp_bench link_stiffness_test tensegrity_python >/dev/null
fi
tg=$build/tensegrity
cb=$build/bench/compare_bench
# need_executable PATH: stop with a message when a binary the section runs was not built.
need_executable() { [ -x "$1" ] || { echo "docs-figures: $1 missing" >&2; exit 1; }; }
need_executable "$tg"
need_bench() { need_executable "$cb"; }

export OPENBLAS_NUM_THREADS=1 OMP_NUM_THREADS=1  # one core per solve (nproc counts them too)
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
mkdir -p "$out"

# The provenance record, once for the whole run.
commit=$(git rev-parse HEAD)
git diff --quiet HEAD -- . ':!docs' ':!*.md' 2>/dev/null || commit="$commit (with uncommitted changes)"
cpu=$(sed -n 's/^model name[[:space:]]*: //p' /proc/cpuinfo | head -1)
machine="$(uname -m), $(nproc --all) cores, ${cpu:-unknown CPU}, $(uname -sr)"
started=$(date -u '+%Y-%m-%d %H:%M UTC')
export FIG_COMMIT=$commit FIG_MACHINE=$machine FIG_DATE=$started

# header FILE TITLE COMMAND...: starts a Markdown file with its provenance.
header() {
  local file=$1 title=$2
  shift 2
  {
    echo "# $title"
    echo
    echo "Generated by \`bash scripts/docs-figures.sh\`; do not edit by hand."
    echo
    echo "- command: \`$*\`"
    echo "- commit: $FIG_COMMIT"
    echo "- date: $FIG_DATE; load average at the start of this step: $(cut -d' ' -f1-3 /proc/loadavg)"
    echo "- machine: $FIG_MACHINE"
    echo
  } >"$file"
}

# stamp FILE COMMAND: adds the provenance record to a JSON file.
stamp() {
  "$py" - "$1" "$2" <<'EOF'
import json, os, sys
path, command = sys.argv[1], sys.argv[2]
with open(path) as f:
    data = json.load(f)
data["provenance"] = {"command": command, "commit": os.environ["FIG_COMMIT"],
                      "date": os.environ["FIG_DATE"], "machine": os.environ["FIG_MACHINE"]}
with open(path, "w") as f:
    json.dump(data, f, indent=1)
    f.write("\n")
EOF
}

step_start=$SECONDS
step() { echo "== [$((SECONDS - step_start)) s] $*"; }

# --- stress tables ---------------------------------------------------------------
stress_table() {  # stress_table REPORT.json: one row per backend and family
  "$py" - "$1" <<'EOF'
import json, sys
d = json.load(open(sys.argv[1]))
def level_key(text):  # numeric levels in numeric order, named ones (directions) after them
    try:
        return (0, float(text), "")
    except ValueError:
        return (1, 0.0, text)
print("| backend | family | trials | converged | verified | non-finite | median s | worst s | statuses "
      "| converged per level |")
print("|---|---|---:|---:|---:|---:|---:|---:|---|---|")
for solver, s in sorted(d["solvers"].items()):
    for fam, f in sorted(s["families"].items()):
        st = ", ".join(f"{k} {v}" for k, v in sorted(f["statuses"].items()))
        levels = sorted(f["by_level"].items(), key=lambda kv: level_key(kv[0]))
        per_level = ", ".join(f"{k}: {v['converged']}/{v['trials']}" for k, v in levels)
        print(f"| {solver} | {fam} | {f['trials']} | {f['converged']} ({100 * f['converged'] / f['trials']:.1f} %) "
              f"| {f['verified']} | {f['non_finite']} | {f['median_seconds']:.3g} | {f['worst_seconds']:.3g} | {st} "
              f"| {per_level} |")
print()
for solver, s in sorted(d["solvers"].items()):
    noise = s["families"].get("noise")
    if noise:
        low = [v for k, v in noise["by_level"].items() if level_key(k)[0] == 0 and float(k) <= 0.1]
        ok, n = sum(v["converged"] for v in low), sum(v["trials"] for v in low)
        print(f"- {solver}: node noise up to 0.1: {ok} of {n} converged ({100 * ok / n:.1f} %)")
print()
fails = d.get("failures", [])
if fails:
    print(f"Failed trials ({len(fails)}): scene, backend, family, level, status, relative residual")
    print()
    for x in fails[:40]:
        print(f"- {x['scene']}, {x['solver']}, {x['family']} {x['level']}, {x['status']}, {x['relative_residual']:.2g}")
    if len(fails) > 40:
        print(f"- ... {len(fails) - 40} more in the JSON report")
    print()
EOF
}
# --- 1. the backend comparison ------------------------------------------------
backends() {
  need_bench
  step "every backend on the comparison scenes (time limit $limit s per solve)"
  local cmd="$cb --benchmark_filter=^compare/ --time_limit=$limit --benchmark_min_time=0.05 --benchmark_repetitions=1 --trace_dir=traces --benchmark_out=compare.json --benchmark_out_format=json"
  header "$out/backends.md" "Every backend on the comparison scenes" "$cmd"
  "$cb" --benchmark_filter='^compare/' --time_limit="$limit" --benchmark_min_time=0.05 --benchmark_repetitions=1 \
    --trace_dir="$work/traces" --benchmark_out="$work/compare.json" --benchmark_out_format=json >/dev/null 2>"$work/compare.log"
  "$py" bench/scripts/report.py --json "$work/compare.json" --traces "$work/traces" --out "$work/report" >/dev/null
  cp "$work/compare.json" "$out/compare.json"
  stamp "$out/compare.json" "$cmd"
  "$py" - "$work/report/results.csv" >>"$out/backends.md" <<'EOF'
import csv, math, statistics, sys
from collections import defaultdict
rows = list(csv.DictReader(open(sys.argv[1])))
rows = [r for r in rows if r["family"] == "compare"]
def kind(scene):
    if scene in ("duck", "puppy", "scorpion"):
        return "characters"
    return "towers" if scene.startswith("tower") else "reference"
by_scene = defaultdict(dict)
for r in rows:
    by_scene[r["scene"]][r["backend"]] = r
backends = sorted({r["backend"] for r in rows})
print("Per backend over the", len(by_scene), "scenes (ok = verified at relative residual 1e-8; "
      "change = geometry change / the smallest of any verified backend on that scene; "
      "times are wall seconds of one solve, medians over the scenes of the group it solved).\n")
print("| backend | solved | fastest on | median change (reference / characters / towers) "
      "| median time (reference / characters / towers) |")
print("|---|---:|---:|---|---|")
for b in backends:
    solved = fastest = 0
    change, time = defaultdict(list), defaultdict(list)
    for scene, per in by_scene.items():
        r = per.get(b)
        if not r or float(r["success"]) < 1:
            continue
        solved += 1
        ok = {x: float(v["real_s"]) for x, v in per.items() if float(v["success"]) >= 1}
        if float(r["real_s"]) <= min(ok.values()):
            fastest += 1
        change[kind(scene)].append(float(r["geometry_change_rel"]))
        time[kind(scene)].append(float(r["real_s"]))
    def med(d, k, f):
        return f(statistics.median(d[k])) if d[k] else "-"
    groups = ("reference", "characters", "towers")
    print(f"| {b} | {solved} of {len(by_scene)} | {fastest} | "
          + " / ".join(med(change, k, lambda x: f"{x:.2f}") for k in groups) + " | "
          + " / ".join(med(time, k, lambda x: f"{x:.2g} s") for k in groups) + " |")
print()
EOF
  {
    echo "Every run (\`-\`: the trace never reached that relative residual):"
    echo
    cat "$work/report/table.md"
  } >>"$out/backends.md"
  for png in profile scorpion tower-80s-500c-gravity; do
    [ -f "$work/report/$png.png" ] && cp "$work/report/$png.png" "$out/$png.png"
  done
}

# --- 1b. side by side: Eq. 5's accuracy against speed ------------------------
side_by_side() {
  need_bench
  local side_limit=${FIGURES_SIDE_BY_SIDE_TIME_LIMIT:-30}
  step "every backend side by side: minimal scorpion as built and with 2 % noise, 80/500 gravity tower, 2 x 7 octahedron grid (time limit $side_limit s, 3 runs)"
  local cmd="$cb --benchmark_filter=^side-by-side/ --time_limit=$side_limit --tolerance=1e-8 --benchmark_min_time=0.05 --benchmark_repetitions=3 --benchmark_out=side-by-side.json --benchmark_out_format=json"
  header "$out/side-by-side.md" "Every backend side by side: Eq. 5's geometry change against time" "$cmd"
  "$cb" --benchmark_filter='^side-by-side/' --time_limit="$side_limit" --tolerance=1e-8 --benchmark_min_time=0.05 \
    --benchmark_repetitions=3 --benchmark_out="$work/side-by-side.json" --benchmark_out_format=json \
    >/dev/null 2>"$work/side-by-side.log"
  "$py" - "$work/side-by-side.json" >>"$out/side-by-side.md" <<'EOF'
import json, sys
runs = json.load(open(sys.argv[1]))["benchmarks"]
median = {}
for b in runs:
    if b.get("aggregate_name") == "median":
        _, scene, backend = b["run_name"].split("/")[:3]
        median[(scene, backend)] = b
scenes = list(dict.fromkeys(s for s, _ in median))
print("Scenes: the scorpion built from the minimal block templates (`data/characters/minimal/`) as built "
      "(within millimetres of equilibrium) and with every free node moved by up to 2 % of the longest strut "
      "(seed 1), the 80-strut / 500-cable gravity tower with 2 % node noise, and 14 expandable octahedra on a "
      "2 x 7 grid joined by the 8 shortest cables between grid neighbours (`tensegrity generate grid`, far from "
      "equilibrium). Medians of 3 runs (a sub-second solve is repeated until 0.05 s have passed and timed by its "
      "mean); wall seconds of one solve, with the time limit above. Every backend targets relative residual "
      "1e-8, the solve's default (`--tol`), which is also where `ok` is judged: verified at relative residual 1e-8; "
      "`change / best`: geometry change over the smallest of any verified backend on the scene; `time / "
      "alternating-gn`: wall time over alternating-gn's.\n")
for scene in scenes:
    rows = {b: r for (s, b), r in median.items() if s == scene}
    ok = {b: r for b, r in rows.items() if r["success"] >= 1}
    best = min(r["geometry_change"] for r in ok.values()) if ok else float("nan")
    gn = rows.get("alternating-gn")
    first = next(iter(rows.values()))
    print(f"**{scene}** ({int(first['elements'])} elements)\n")
    print("| backend | ok | wall s | iterations | geometry change (m) | change / best | time / alternating-gn |")
    print("|---|:-:|---:|---:|---:|---:|---:|")
    for b, r in sorted(rows.items()):
        seconds = r["real_time"] / 1e3  # the benchmarks report milliseconds
        good = r["success"] >= 1
        if not good:
            ratio = "-"
        elif best > 0:
            ratio = f"{r['geometry_change'] / best:.3f}"
        else:  # the scene stands: a backend either keeps it or moves it
            ratio = "1.000" if r["geometry_change"] == 0 else "moved"
        speed = f"{seconds / (gn['real_time'] / 1e3):.3g}" if gn else "-"
        print(f"| {b} | {'yes' if good else 'NO'} | {seconds:.3g} | {int(r['iterations'])} | "
              f"{r['geometry_change']:.4g} | {ratio} | {speed} |")
    print()
EOF
}

# --- 2. scaling -----------------------------------------------------------------
scaling() {
  need_bench
  step "scaling families"
  local cmd="$cb --benchmark_filter=^scaling/ --chain_sizes=2,8,32,128 --tower_layers=2,8,32 --time_limit=$limit --benchmark_min_time=0.05 --benchmark_repetitions=1 --benchmark_out=scaling.json --benchmark_out_format=json"
  header "$out/scaling.md" "Scaling families" "$cmd"
  "$cb" --benchmark_filter='^scaling/' --chain_sizes=2,8,32,128 --tower_layers=2,8,32 --time_limit="$limit" \
    --benchmark_min_time=0.05 --benchmark_repetitions=1 --benchmark_out="$work/scaling.json" \
    --benchmark_out_format=json >/dev/null 2>"$work/scaling.log"
  "$py" bench/scripts/report.py --json "$work/scaling.json" --out "$work/scale-report" >"$work/scale-report.txt"
  cp "$work/scaling.json" "$out/scaling.json"
  stamp "$out/scaling.json" "$cmd"
  {
    cat "$work/scale-report/table.md"
    echo
    echo "Fitted exponents over the verified sizes (report.py):"
    echo
    echo '```'
    sed -n '/^Scaling families/,/^$/p' "$work/scale-report.txt" | grep -E '^(Scaling|  )'
    echo '```'
  } >>"$out/scaling.md"
  [ -f "$work/scale-report/scaling.png" ] && cp "$work/scale-report/scaling.png" "$out/scaling.png"
}

# --- 3. stress test: node noise ----------------------------------------------------
stress_noise() {
  step "stress test: node noise on every benchmark scene"
  local cmd="$tg stress-test --families noise --trials 1 --jobs 2 --time-limit $limit --solvers alternating,alternating-gn,ipopt --quiet --out stress-noise.json"
  header "$out/stress.md" "Stress test: node noise on every benchmark scene" "$cmd"
  "$tg" stress-test --families noise --trials 1 --jobs 2 --time-limit "$limit" --solvers alternating,alternating-gn,ipopt \
    --quiet --out "$out/stress-noise.json"
  stamp "$out/stress-noise.json" "$cmd"
  {
    echo "Levels 0.001 .. 0.3 of the median element length, one trial per scene and level,"
    echo "all 27 benchmark scenes (22 reference scenes, 2 towers, 3 characters)."
    echo
    stress_table "$out/stress-noise.json"
  } >>"$out/stress.md"
}

# --- 4. stress test: every family -----------------------------------------------------
stress_families() {
  step "stress test: every family on the reference scenes"
  local cmd="$tg stress-test --scenes reference --trials 1 --jobs 2 --time-limit 5 --solvers alternating-gn,eq5-newton,ipopt --quiet --out stress-all-families.json"
  header "$out/stress-families.md" "Stress test: every family on the reference scenes" "$cmd"
  "$tg" stress-test --scenes reference --trials 1 --jobs 2 --time-limit 5 --solvers alternating-gn,eq5-newton,ipopt \
    --quiet --out "$out/stress-all-families.json"
  stamp "$out/stress-all-families.json" "$cmd"
  stress_table "$out/stress-all-families.json" >>"$out/stress-families.md"
}

# --- 5. the characters as built and form-found ---------------------------------------
characters() {
  step "characters: build, solve with the default backend, check --stability"
  mkdir -p "$work/chars/minimal"
  header "$out/characters.md" "The characters as built and form-found" \
    "$tg build data/characters/NAME.character.json --out NAME.scene.json && $tg solve NAME.scene.json --out NAME.solution.json --quiet && $tg check NAME.scene.json NAME.solution.json --stability [--design NAME.design.json] && $tg solve NAME.scene.json --solver alternating [--tol 1e-10] --trace NAME.csv"
  local names="duck scorpion puppy minimal/duck minimal/scorpion" c rc
  for c in $names; do
    "$tg" build "data/characters/$c.character.json" --out "$work/chars/$c.scene.json" 2>/dev/null
    "$tg" solve "$work/chars/$c.scene.json" --out "$work/chars/$c.solution.json" --quiet || true
    rc=0
    "$tg" check "$work/chars/$c.scene.json" "$work/chars/$c.solution.json" --stability \
      >"$work/chars/$c.check.txt" 2>&1 || rc=$?
    echo "$rc" >"$work/chars/$c.check.rc"
    rc=0
    { "$tg" design "$work/chars/$c.scene.json" --out "$work/chars/$c.design.json" --quiet &&
      "$tg" check "$work/chars/$c.scene.json" "$work/chars/$c.solution.json" --stability \
        --design "$work/chars/$c.design.json"; } >"$work/chars/$c.check-design.txt" 2>&1 || rc=$?
    echo "$rc" >"$work/chars/$c.check-design.rc"
    "$tg" solve "$work/chars/$c.scene.json" --solver alternating --trace "$work/chars/$c.alternating.csv" \
      --out "$work/chars/$c.alternating.json" --quiet || true
    "$tg" solve "$work/chars/$c.scene.json" --solver alternating --tol 1e-10 \
      --out "$work/chars/$c.alternating-tight.json" --quiet || true
  done
  "$py" - "$work/chars" $names >>"$out/characters.md" <<'EOF'
import csv, json, math, os, re, sys
folder, names = sys.argv[1], sys.argv[2:]
def path(c, suffix):
    return os.path.join(folder, c + suffix)
print("`minimal/duck` and `minimal/scorpion` are the characters with the minimal block templates")
print("(data/characters/minimal/).")
print()
print("| character | struts | cables | nodes (fixed) | mass | size (bounding-box diagonal) |")
print("|---|---:|---:|---|---:|---:|")
for c in names:
    s = json.load(open(path(c, ".scene.json")))
    kinds = [e["kind"] for e in s["elements"]]
    mass = sum(n.get("mass", 0.0) for n in s["nodes"]) + sum(e.get("mass", 0.0) for e in s["elements"])
    fixed = sum(1 for n in s["nodes"] if n.get("fixed", False))
    xs = [n["x"] for n in s["nodes"]]
    diag = math.dist([min(p[i] for p in xs) for i in range(3)], [max(p[i] for p in xs) for i in range(3)])
    print(f"| {c} | {kinds.count('strut')} | {kinds.count('cable')} | {len(xs)} ({fixed}) | {mass:.3f} kg | {diag:.2f} m |")
print()
print("Form finding with the default backend, then `check --stability` (exit 0 stable, 3 verified but")
print("marginal or unstable, 1 not verified). Without `--design` the stability test models every")
print("cable as a linear cord carrying its solution force at 10 % strain; with `--design` (made by")
print("`design NAME.scene.json --out NAME.design.json`, the 2 mm cord) it takes the designed cords.")
print("The prestress column is Connelly's test, which needs no cable model.")
print()
print("| character | backend | status | iterations | relative residual | geometry change | check | stability (cords at 10 %) | smallest eigenvalue (N/m) | with the design | prestress |")
print("|---|---|---|---:|---:|---:|---|---|---:|---|---|")
for c in names:
    sol = json.load(open(path(c, ".solution.json")))
    st = sol["stats"]
    text = open(path(c, ".check.txt")).read()
    rc = open(path(c, ".check.rc")).read().strip()
    def field(key):
        m = re.search(r"^" + key + r"\s+(.*)$", text, re.M)
        return m.group(1).strip() if m else "-"
    verdict = "verified" if re.search(r"^verified$", text, re.M) else "NOT verified"
    stability = field("stability")
    kind = stability.split(" (")[0]
    modes = re.search(r"\((\d+) (negative stiffness|zero-stiffness) mode", stability)
    if modes:
        kind += f", {modes.group(1)} {'negative' if modes.group(2).startswith('negative') else 'zero'} mode(s)"
    eigenvalues = field("eigenvalues").split()
    smallest = f"{float(eigenvalues[0]):.3g}" if eigenvalues and eigenvalues[0] != "-" else "-"
    prestress = field("prestress").split(" (")[0]
    designed = re.search(r"^stability\s+(\w+)", open(path(c, ".check-design.txt")).read(), re.M)
    designed = f"{designed.group(1) if designed else 'no design'} (exit {open(path(c, '.check-design.rc')).read().strip()})"
    print(f"| {c} | {sol['solver']} | {sol['status']} | {st['iterations']} | {st['relative_residual']:.2g} "
          f"| {1000 * st['geometry_change']:.3g} mm | {verdict} (exit {rc}) | {kind} | {smallest} | {designed} | {prestress} |")
print()
print("The faithful Algorithm 1 (`--solver alternating`), at the default tolerance 1e-8 with its trace")
print("(objective rises: outer iterations whose traced Eq. 4 objective exceeds the previous one by more")
print("than 1e-12 relative) and at `--tol 1e-10`:")
print()
print("| character | status | message | relative residual | geometry change | objective rises | at 1e-10: status, iterations, relative residual |")
print("|---|---|---|---:|---:|---:|---|")
for c in names:
    sol = json.load(open(path(c, ".alternating.json")))
    st = sol["stats"]
    rows = list(csv.DictReader(open(path(c, ".alternating.csv"))))
    objective = [float(r["objective"]) for r in rows if r.get("objective")]
    rises = sum(1 for a, b in zip(objective, objective[1:]) if b > a + 1e-12 * abs(a))
    tight = json.load(open(path(c, ".alternating-tight.json")))
    print(f"| {c} | {sol['status']} | {sol.get('message', '-')} | {st['relative_residual']:.2g} | {1000 * st['geometry_change']:.3g} mm "
          f"| {rises} of {max(0, len(objective) - 1)} | {tight['status']}, {tight['stats']['iterations']}, "
          f"{tight['stats']['relative_residual']:.2g} |")
print()
EOF
}

# --- 5b. every block of the characters, alone ------------------------------------------
blocks() {
  step "blocks: every block type and tie count of the characters, alone, check --stability"
  local w="$work/blocks"
  mkdir -p "$w"
  header "$out/blocks.md" "Every block of the characters, alone" \
    "$tg build B.character.json --out B.scene.json && $tg solve B.scene.json --out B.solution.json --quiet && $tg check B.scene.json B.solution.json --stability"
  # One character per distinct (template, ties) of the three characters: that block alone, scale 0.05, no gravity.
  local b rc
  for b in $("$py" - "$PWD/data" "$w" <<'EOF'
import json, os, sys
data, folder = sys.argv[1], sys.argv[2]
seen = {}
for c in ("duck", "scorpion", "puppy"):
    for block in json.load(open(os.path.join(data, "characters", c + ".character.json")))["blocks"]:
        key = (block["type"], block.get("ties", 0))
        seen.setdefault(key, []).append(f"{c} {block['id']}")
for (kind, ties), users in sorted(seen.items()):
    name = f"{kind}-ties-{ties}"
    character = {"format": "tensegrity-character", "version": 1, "name": name,
                 "block_library": os.path.join(data, "blocks"), "gravity": [0, 0, 0],
                 "blocks": [{"id": "b", "type": kind, "scale": 0.05, **({"ties": ties} if ties else {})}], "links": []}
    json.dump(character, open(os.path.join(folder, name + ".character.json"), "w"), indent=1)
    open(os.path.join(folder, name + ".users"), "w").write(", ".join(users))
    print(name)
EOF
); do
    "$tg" build "$w/$b.character.json" --out "$w/$b.scene.json" 2>/dev/null
    "$tg" solve "$w/$b.scene.json" --out "$w/$b.solution.json" --quiet || true
    rc=0
    "$tg" check "$w/$b.scene.json" "$w/$b.solution.json" --stability >"$w/$b.check.txt" 2>&1 || rc=$?
    echo "$rc" >"$w/$b.check.rc"
  done
  "$py" - "$w" >>"$out/blocks.md" <<'EOF'
import glob, json, os, re, sys
folder = sys.argv[1]
print("Each distinct block (template and number of interior ties) of the duck, the scorpion and the")
print("puppy, built alone as a one-block character (scale 0.05, no gravity), form-found with the default")
print("backend and checked with `--stability` (cables as linear cords at 10 % strain; exit 0 = verified")
print("and stable). Rigid-body modes are removed before the eigenvalues.")
print()
print("| block | ties | used by | struts | cables | relative residual | exit | stability | prestress |")
print("|---|---:|---|---:|---:|---:|---:|---|---|")
for path in sorted(glob.glob(os.path.join(folder, "*.check.txt"))):
    name = os.path.basename(path)[: -len(".check.txt")]
    kind, ties = name.rsplit("-ties-", 1)
    scene = json.load(open(os.path.join(folder, name + ".scene.json")))
    kinds = [e["kind"] for e in scene["elements"]]
    sol = json.load(open(os.path.join(folder, name + ".solution.json")))
    text = open(path).read()
    rc = open(os.path.join(folder, name + ".check.rc")).read().strip()
    stability = re.search(r"^stability\s+(.*?)(;|$)", text, re.M)
    stability = stability.group(1) + (")" if "(" in stability.group(1) else "") if stability else "-"
    prestress = re.search(r"^prestress\s+(.*?)( \(|$)", text, re.M)
    users = open(os.path.join(folder, name + ".users")).read()
    print(f"| {kind} | {ties} | {users} | {kinds.count('strut')} | {kinds.count('cable')} "
          f"| {sol['stats']['relative_residual']:.2g} | {rc} | {stability.replace('|', chr(92) + '|')} "
          f"| {prestress.group(1) if prestress else '-'} |")
print()
EOF
}

# --- 6. design and relax -------------------------------------------------------------
relax() {
  step "characters: design and relax under turned gravity"
  mkdir -p "$work/materials"
  "$py" - data/materials/elastic-cord-2mm.json "$work/materials/elastic-cord-2mm-x4.json" <<'EOF'
import json, sys
m = json.load(open(sys.argv[1]))
m["name"] = "elastic-cord-2mm-x4"
m["coefficients"] = [4 * c for c in m["coefficients"]]  # the force curve times 4 (linear in the coefficients)
m["description"] = "elastic-cord-2mm with every force times 4 (synthetic)"
m.pop("fit", None)
json.dump(m, open(sys.argv[2], "w"), indent=1)
EOF
  header "$out/relax.md" "Designed characters relaxed under turned gravity" \
    "$tg design data/characters/C.character.json --material M --out C-M.design.json && $tg relax C-M.design.json --gravity=gx,gy,gz"
  {
    echo "Largest node displacement from the designed shape divided by the bounding-box diagonal, after"
    echo "\`relax\` (static equilibrium, rest lengths fixed). The cords are synthetic;"
    echo "elastic-cord-2mm-x4 is the 2 mm curve with every force times 4."
    echo
    echo "| character | cord | design | design gravity (-z) | g along +x | g along -x | g along +y |"
    echo "|---|---|---|---:|---:|---:|---:|"
  } >>"$out/relax.md"
  for c in duck puppy scorpion; do
    for m in elastic-cord-1mm elastic-cord-2mm elastic-cord-2mm-x4; do
      d="$work/$c-$m.design.json"
      rc=0
      "$tg" design "data/characters/$c.character.json" --material "$m" --material-dir "$work/materials" \
        --out "$d" 2>"$work/design.err" >/dev/null || rc=$?
      if [ "$rc" != 0 ]; then
        echo "| $c | $m | none (exit $rc: no equilibrium keeps every cable inside the cord's range) | - | - | - | - |" >>"$out/relax.md"
        continue
      fi
      row="| $c | $m | written |"
      for g in design 9.81,0,0 -9.81,0,0 0,9.81,0; do
        gravity=()
        [ "$g" = design ] || gravity=(--gravity="$g")
        if "$tg" relax "$d" "${gravity[@]}" --out "$work/relax.json" 2>/dev/null; then
          v=$("$py" -c "import json,sys; print('%.3g' % json.load(open(sys.argv[1]))['relative_max_displacement'])" "$work/relax.json")
        else
          v="not converged"
        fi
        row="$row $v |"
      done
      echo "$row" >>"$out/relax.md"
    done
  done
}

# --- 7. design and simulation of the characters ---------------------------------------
character_design() {
  step "characters: design (default cord), naive baseline, simulate"
  mkdir -p "$work/cdesign"
  header "$out/character-design.md" "The characters designed and simulated" \
    "$tg design data/characters/C.character.json --out C.design.json --naive-fractions 0.5:0.98:25 && $tg simulate C.design.json --steps 60 [--gravity=9.81,0,0 --damping 2 --steps 120 | --drag NODE:x,y,z] --out C.jsonl --no-vtk --quiet"
  local c d
  for c in duck scorpion puppy; do
    d="$work/cdesign/$c.design.json"
    "$tg" design "data/characters/$c.character.json" --out "$d" --naive-fractions 0.5:0.98:25 \
      >/dev/null 2>"$work/cdesign/$c.design.err"
    "$tg" simulate "$d" --steps 60 --out "$work/cdesign/$c-still.jsonl" --no-vtk --quiet || true
    "$tg" simulate "$d" --steps 120 --gravity=9.81,0,0 --damping 2 --out "$work/cdesign/$c-turned.jsonl" \
      --no-vtk --quiet || true
    # The drag: the free node farthest along +x (the front of the character) pulled 5 cm along +y.
    local drag
    drag=$("$py" - "$d" <<'EOF'
import json, sys
d = json.load(open(sys.argv[1]))
free = [i for i, n in enumerate(d["nodes"]) if not n.get("fixed", False)]
i = max(free, key=lambda k: d["positions"][k][0])
x = d["positions"][i]
print(f"{i}:{x[0]:.6f},{x[1] + 0.05:.6f},{x[2]:.6f}")
EOF
)
    echo "$drag" >"$work/cdesign/$c.drag"
    "$tg" simulate "$d" --steps 120 --drag "$drag" --damping 2 --out "$work/cdesign/$c-drag.jsonl" \
      --no-vtk --quiet || true
  done
  "$py" - "$work/cdesign" >>"$out/character-design.md" <<'EOF'
import json, math, os, re, statistics, sys
folder = sys.argv[1]
names = ("duck", "scorpion", "puppy")
print("Design with the default cord (elastic-cord-2mm, synthetic) and target strain 0.3. \"Designed")
print("settles\" and \"best naive\" are `--naive-fractions 0.5:0.98:25`: the design and the paper's")
print("constant-fraction baseline (every rest length F times its length, 25 fractions F) settled")
print("under gravity by `relax`; the largest node displacement from the designed shape.")
print()
print("| character | stiffness QP relative residual | cable strain | designed settles | best naive fraction | best naive settles | slack cables there |")
print("|---|---:|---|---:|---:|---:|---:|")
for c in names:
    d = json.load(open(os.path.join(folder, c + ".design.json")))
    err = open(os.path.join(folder, c + ".design.err")).read()
    lo, hi = d["design"]["cable_strain_range"]
    summary = re.search(r"designed settles ([\d.eg+-]+) mm .*best naive fraction ([\d.eg+-]+) settles ([\d.eg+-]+) mm "
                        r"away \(([\d.eg+-]+) of the size\)", err)
    best = re.search(r"naive F=" + re.escape(summary.group(2)) + r"\s+\S+\s+\S+ mm\s+\S+\s+(\d+)", err) if summary else None
    if summary:
        print(f"| {c} | {d['stats']['relative_residual']:.2g} | {100 * lo:.3g} % .. {100 * hi:.3g} % | {summary.group(1)} mm "
              f"| {summary.group(2)} | {summary.group(3)} mm ({summary.group(4)} of the size) | {best.group(1) if best else '-'} |")
    else:
        print(f"| {c} | {d['stats']['relative_residual']:.2g} | {100 * lo:.3g} % .. {100 * hi:.3g} % | - | - | - | - |")
print()
print("Simulation (`simulate`, implicit Euler, dt 1/60 s): still = 60 steps under the design gravity;")
print("turned = 120 steps with gravity along +x and damping 2/s; drag = 120 steps with damping 2/s, the")
print("free node farthest along +x pulled towards a point 5 cm along +y of it (default drag stiffness).")
print("Displacement: the largest node distance from the designed shape over all frames, and at the")
print("last frame, over the bounding-box diagonal. Step time: median wall milliseconds per step")
print("(the frames' `seconds`; read with the load average above).")
print()
print("| character | run | steps not converged | Newton iterations per step | largest displacement | at the last frame | median ms per step |")
print("|---|---|---:|---:|---:|---:|---:|")
for c in names:
    d = json.load(open(os.path.join(folder, c + ".design.json")))
    x0 = d["positions"]
    size = math.dist([min(p[i] for p in x0) for i in range(3)], [max(p[i] for p in x0) for i in range(3)])
    for run in ("still", "turned", "drag"):
        label = run
        if run == "drag":
            label += " node " + open(os.path.join(folder, c + ".drag")).read().split(":")[0]
        frames = [json.loads(line) for line in open(os.path.join(folder, f"{c}-{run}.jsonl")) if line.strip()]
        steps = [f for f in frames if "converged" in f]
        failed = sum(1 for f in steps if not f["converged"])
        newton = sum(f["newton_iterations"] for f in steps) / max(1, len(steps))
        disp = [max(math.dist(p, q) for p, q in zip(f["positions"], x0)) for f in frames]
        ms = statistics.median(1000 * f["seconds"] for f in steps) if steps else float("nan")
        print(f"| {c} | {label} | {failed} of {len(steps)} | {newton:.2f} | {1000 * max(disp):.3g} mm ({max(disp) / size:.3g}) "
              f"| {1000 * disp[-1]:.3g} mm ({disp[-1] / size:.3g}) | {ms:.3g} |")
print()
EOF
}

# --- 8. the duck's neck: suggest-link, actuation, stability of the cable models -----------
duck_neck() {
  step "the duck's neck: suggest-link, actuation, check --stability"
  local w="$work/neck"
  mkdir -p "$w"
  header "$out/duck-neck.md" "The duck's neck: link suggestions, actuation, stability" \
    "$tg suggest-link data/characters/duck.character.json --a body --b neck --axis 0 1 0 --range 20 --faces 2 --cables 2; $tg build data/characters/duck.character.json --out duck.scene.json && $tg solve duck.scene.json --out duck.solution.json --quiet && $tg design duck.scene.json --out duck.design.json --quiet && $tg actuation duck.scene.json --solution duck.solution.json --poses poses.json --max-actuators 3 --design duck.design.json --json act.json"
  "$tg" build data/characters/duck.character.json --out "$w/duck.scene.json" 2>/dev/null
  "$tg" solve "$w/duck.scene.json" --out "$w/duck.solution.json" --quiet
  "$tg" design "$w/duck.scene.json" --out "$w/duck.design.json" --quiet
  cat >"$w/poses.json" <<'EOF'
{"format": "tensegrity-poses", "version": 1, "poses": [
  {"name": "down", "targets": [{"block": "head", "by": [0, -0.01, 0]}]},
  {"name": "left", "targets": [{"block": "head", "by": [0, 0, 0.01]}]}]}
EOF
  "$py" -c 'import json, sys; d = json.load(open(sys.argv[1])); d["poses"] = d["poses"][:1]; json.dump(d, open(sys.argv[2], "w"))' \
    "$w/poses.json" "$w/down.json"
  local rc
  {
    echo "## suggest-link: body to neck, a nodding hinge about y"
    echo
    echo "Score = k_axis / k_perp, smallest first; stiffnesses in N m/rad."
    echo
    echo '```'
    "$tg" suggest-link data/characters/duck.character.json --a body --b neck --axis 0 1 0 --range 20 --faces 2 --cables 2
    echo '```'
    echo
    echo "## actuation: two head poses"
    echo
    echo "poses.json:"
    echo
    echo '```json'
    cat "$w/poses.json"
    echo '```'
    echo
    echo "\`$tg actuation duck.scene.json --solution duck.solution.json --poses poses.json --max-actuators 3 --design duck.design.json --json act.json\`"
    echo "(distances in m):"
    echo
    echo '```'
    "$tg" actuation "$w/duck.scene.json" --solution "$w/duck.solution.json" --poses "$w/poses.json" \
      --max-actuators 3 --design "$w/duck.design.json" --json "$w/act.json"
    echo '```'
    echo
    echo "Rest-length changes of the chosen elements (mm, negative = shorter) and cables slack in the reached state:"
    echo
    "$py" - "$w/act.json" <<'EOF'
import json, sys
d = json.load(open(sys.argv[1]))
print("| actuators | elements | pose | rest-length changes (mm) | slack cables | accepted steps |")
print("|---:|---|---|---|---:|---:|")
for level in d["levels"]:
    for p in level["poses"]:
        slack = p["cables_slack"]
        slack = len(slack) if isinstance(slack, list) else slack
        changes = ", ".join(f"{1000 * x:+.1f}" for x in p["rest_length_change"])
        print(f"| {level['actuators']} | {', '.join(map(str, level['elements']))} | {p['name']} | {changes} | {slack} | {p['steps_accepted']} |")
print()
EOF
    echo "\`down\` alone, \`--max-actuators 2\`, the same design:"
    echo
    echo '```'
    "$tg" actuation "$w/duck.scene.json" --solution "$w/duck.solution.json" --poses "$w/down.json" \
      --max-actuators 2 --design "$w/duck.design.json" --json "$w/act-down.json"
    echo '```'
    echo
    echo "Both poses with stiff linear cords instead of the design, \`--max-actuators 2 --cable-strain 0.003\`:"
    echo
    echo '```'
    "$tg" actuation "$w/duck.scene.json" --solution "$w/duck.solution.json" --poses "$w/poses.json" \
      --max-actuators 2 --cable-strain 0.003 --json "$w/act-stiff.json"
    echo '```'
    echo
    "$py" - "$w/act-stiff.json" <<'EOF'
import json, sys
d = json.load(open(sys.argv[1]))
for level in d["levels"]:
    slack = [len(p["cables_slack"]) if isinstance(p["cables_slack"], list) else p["cables_slack"] for p in level["poses"]]
    print(f"- {level['actuators']} actuator(s): cables slack in the reached states: "
          + ", ".join(f"{p['name']} {n}" for p, n in zip(level["poses"], slack)))
print()
EOF
    echo "Without \`--design\` and at the default strain (cords at 10 %):"
    echo
    echo '```'
    rc=0
    "$tg" actuation "$w/duck.scene.json" --solution "$w/duck.solution.json" --poses "$w/poses.json" \
      --max-actuators 2 --json "$w/act-soft.json" >"$w/soft.txt" 2>&1 || rc=$?
    sed "s|$w/||g" "$w/soft.txt"
    echo "(exit $rc)"
    echo '```'
    echo
    echo "## check --stability: the form-found duck under each cable model"
    echo
    echo "\`$tg check duck.scene.json duck.solution.json --stability --cable-strain S\` (or \`--design duck.design.json\`):"
    echo
    echo "| cable model | exit | verdict | smallest stiffness eigenvalues (N/m) |"
    echo "|---|---:|---|---|"
  } >>"$out/duck-neck.md"
  local model
  for model in 0.1:10 0.03:3 0.01:1 0.001:0.1 design; do  # strain:percent
    local args=(--cable-strain "${model%%:*}") label="cords at ${model##*:} %"
    [ "$model" = design ] && args=(--design "$w/duck.design.json") label="design (elastic-cord-2mm)"
    rc=0
    "$tg" check "$w/duck.scene.json" "$w/duck.solution.json" --stability "${args[@]}" >"$w/stab.txt" 2>&1 || rc=$?
    "$py" - "$w/stab.txt" "$label" "$rc" >>"$out/duck-neck.md" <<'EOF'
import re, sys
text = open(sys.argv[1]).read()
stability = re.search(r"^stability\s+(.*)$", text, re.M)
eig = re.search(r"^eigenvalues\s+(.*) N/m$", text, re.M)
verdict = stability.group(1).split(";")[0] + ")" if stability and "(" in stability.group(1) else (stability.group(1) if stability else "-")
values = ", ".join(f"{float(v):.3g}" for v in eig.group(1).split()[:4]) if eig else "-"
print(f"| {sys.argv[2]} | {sys.argv[3]} | {verdict.replace('|', chr(92) + '|')} | {values} |")
EOF
  done
  echo >>"$out/duck-neck.md"
}

# --- 9. the links' rotational stiffness (link_stiffness_test) --------------------------
link_stiffness() {
  step "link stiffness: face and edge links between two blocks"
  local test_bin=$build/tests/link_stiffness_test
  need_executable "$test_bin"
  header "$out/link-stiffness.md" "Rotational stiffness of face and edge links" \
    "$test_bin --gtest_filter=LinkStiffness.EdgeLinkIsMoreIsotropicThanFaceLink"
  {
    echo "Two blocks of scale 0.05 m, 0.16 m apart along x, joined by one face or one edge link;"
    echo "cables EA 20 N, struts effectively rigid, forces scaled to a mean cable force of 1 N; block A"
    echo "clamped, block B moved rigidly, the link's own nodes relaxed, B's translation condensed out."
    echo "Principal stiffnesses in N m/rad, anisotropy = max/min."
    echo
    echo '```'
    "$test_bin" --gtest_filter=LinkStiffness.EdgeLinkIsMoreIsotropicThanFaceLink | grep -E 'link|PASSED|FAILED'
    echo '```'
  } >>"$out/link-stiffness.md"
}

# --- 10. the faithful Algorithm 1 on the noisy characters ------------------------------
character_stress() {
  step "stress test: the faithful Algorithm 1 on the characters with node noise"
  local cmd="$tg stress-test --families noise --trials 4 --time-limit 20 --jobs 1 --solvers alternating --scenes character --quiet --out stress-characters.json"
  header "$out/stress-characters.md" "Stress test: the faithful Algorithm 1 on the noisy characters" "$cmd"
  "$tg" stress-test --families noise --trials 4 --time-limit 20 --jobs 1 --solvers alternating --scenes character \
    --quiet --out "$work/stress-characters.json"
  {
    echo "The three characters at the paper's counts, node noise 0.001 .. 0.3 of the median element"
    echo "length, four trials per scene and level, at most 20 s per solve."
    echo
    stress_table "$work/stress-characters.json"
  } >>"$out/stress-characters.md"
}

# --- ipopt: cold and warm start, MUMPS orderings ----------------------------------
# ipopt_start_stress FILE TITLE FIRST SECOND [SCENE ARGS...]: the stress test
# with ipopt at two starts, one after the other, and compare_stress.py's
# comparison of the two into $out/FILE.
ipopt_start_stress() {
  local file=$1 title=$2 first=$3 second=$4 start
  shift 4
  local scenes=${*:+$* }
  local cmd="$tg stress-test $scenes--trials 1 --jobs 2 --time-limit 20 --solvers ipopt --option start=$first|$second --quiet --out stress-ipopt-START.json"
  for start in "$first" "$second"; do
    "$tg" stress-test "$@" --trials 1 --jobs 2 --time-limit 20 --solvers ipopt --option "start=$start" \
      --quiet --out "$work/stress-ipopt-$start.json" >/dev/null || true
  done
  header "$out/$file" "$title" "$cmd" \
    "&& bench/scripts/compare_stress.py stress-ipopt-$first.json stress-ipopt-$second.json --list"
  {
    echo '```'
    "$py" bench/scripts/compare_stress.py "$work/stress-ipopt-$first.json" "$work/stress-ipopt-$second.json" --list
    echo '```'
  } >>"$out/$file"
}

# Not in the default list (about 30 minutes on two cores): ipopt's start=scene
# against start=auto over every stress-test family of the reference scenes.
ipopt_auto_stress() {
  step "ipopt-auto-stress.md: ipopt start=scene vs start=auto, stress test of the reference scenes"
  ipopt_start_stress ipopt-auto-stress.md "ipopt: start=scene against start=auto on the stress test" \
    scene auto --scenes reference
}

# Not in the default list (about 8 minutes on two cores): ipopt's start=auto
# against its default, start=eq5-newton, over every stress-test family and
# scene, then both on the as-generated towers without gravity.
ipopt_default_stress() {
  step "ipopt-default-stress.md: ipopt start=auto vs the default start=eq5-newton, stress test of every scene"
  ipopt_start_stress ipopt-default-stress.md "ipopt: start=auto against the default start=eq5-newton on the stress test" \
    auto eq5-newton
  {
    echo
    echo "The as-generated towers without gravity (\`$tg generate tower --layers L --struts-per-layer 8"
    echo "--cables 50L\`), where the optimum lies far from alternating-gn's equilibrium; solver seconds, one run each:"
    echo
    echo "| layers | start | status | iterations (every stage's) | seconds | geometry change (m) |"
    echo "|---:|---|---|---:|---:|---:|"
    local layers start
    for layers in 10 20; do
      "$tg" generate tower --layers "$layers" --struts-per-layer 8 --cables $((50 * layers)) \
        --out "$work/plain-$layers.scene.json" >/dev/null
      for start in auto eq5-newton; do
        "$tg" solve "$work/plain-$layers.scene.json" --solver ipopt --option "start=$start" --time-limit 60 \
          --out "$work/plain.json" >/dev/null 2>&1 || true
        "$py" - "$work/plain.json" "$layers" "$start" <<'EOF2'
import json, sys
d = json.load(open(sys.argv[1])); s = d["stats"]
print(f"| {sys.argv[2]} | {sys.argv[3]} | {d['status']} | {s['iterations']} | {s['seconds']:.3g} | {s['geometry_change']:.5g} |")
EOF2
      done
    done
  } >>"$out/ipopt-default-stress.md"
}

nlopt_auto_stress() {
  step "nlopt-auto-stress.md: nlopt varpro_algorithm=slsqp vs auto, the whole stress test"
  local cmd="$tg stress-test --trials 1 --jobs 2 --time-limit 10 --solvers nlopt --option varpro_algorithm=slsqp|auto --quiet --out stress-nlopt-ALGORITHM.json"
  for algorithm in slsqp auto; do
    "$tg" stress-test --trials 1 --jobs 2 --time-limit 10 --solvers nlopt --option "varpro_algorithm=$algorithm" \
      --data data --quiet --out "$work/stress-nlopt-$algorithm.json" >/dev/null || true
  done
  header "$out/nlopt-auto-stress.md" "nlopt: varpro_algorithm=slsqp against auto on the stress test" "$cmd" \
    "&& bench/scripts/compare_stress.py stress-nlopt-slsqp.json stress-nlopt-auto.json --list"
  {
    echo "Every stress-test scene has at most 600 position variables, where \`slsqp\` is what"
    echo "\`auto\` falls back to; \`auto\` runs the multiplier method (\`al-lbfgs\`) first."
    echo
    echo '```'
    "$py" bench/scripts/compare_stress.py "$work/stress-nlopt-slsqp.json" "$work/stress-nlopt-auto.json" --list
    echo '```'
  } >>"$out/nlopt-auto-stress.md"
}

ipopt_starts() {
  step "ipopt-starts.md: start=scene vs start=alternating-gn vs alternating-gn; MUMPS orderings"
  local tower10="$work/tower-10.scene.json" tower40="$work/tower-40.scene.json"
  local scorpion="$work/scorpion-minimal.scene.json"
  "$tg" build data/characters/minimal/scorpion.character.json --out "$scorpion" >/dev/null 2>&1
  "$tg" generate tower --layers 10 --struts-per-layer 8 --cables 500 --gravity --out "$tower10" >/dev/null
  "$tg" generate tower --layers 40 --struts-per-layer 8 --cables 2000 --gravity --out "$tower40" >/dev/null
  header "$out/ipopt-starts.md" "ipopt: where it starts, the MUMPS ordering and its workspace" \
    "tensegrity solve SCENE --solver ipopt [--option start=scene|alternating-gn] [--option mumps_pivot_order=N] [--option mumps_mem_percent=N] --time-limit $limit"
  run_row() {  # run_row LABEL SCENE SOLVER OPTION...: one table row from the solution file
    local label=$1 scene=$2 solver=$3
    shift 3
    local opts=()
    for o in "$@"; do opts+=(--option "$o"); done
    "$tg" solve "$scene" --solver "$solver" "${opts[@]}" --time-limit "$limit" --out "$work/s.json" >/dev/null 2>&1 || true
    "$py" - "$work/s.json" "$label" <<'EOF2'
import json, sys
d = json.load(open(sys.argv[1])); s = d["stats"]
print(f"| {sys.argv[2]} | {d['status']} | {s['iterations']} | {s['seconds']:.3g} | {s['geometry_change']:.4g} |")
EOF2
  }
  {
    echo "Solver's own seconds, one run each. Geometry change in m."
    echo
    echo "| scene, configuration | status | iterations | seconds | geometry change |"
    echo "|---|---|---:|---:|---:|"
    for scene in data/reference/prism-3-gravity.scene.json data/reference/prism-6-gravity.scene.json \
                 data/reference/prism-12-gravity.scene.json "$scorpion" "$tower10"; do
      name=$(basename "$scene" .scene.json)
      [ "$scene" = "$scorpion" ] && name="scorpion of the minimal blocks (503 elements, gravity)"
      [ "$scene" = "$tower10" ] && name="tower, 10 layers x 8 struts, 500 cables, gravity"
      run_row "$name: ipopt start=scene" "$scene" ipopt start=scene
      run_row "$name: ipopt start=alternating-gn" "$scene" ipopt start=alternating-gn
      run_row "$name: ipopt start=auto" "$scene" ipopt start=auto
      run_row "$name: alternating-gn" "$scene" alternating-gn
    done
    echo
    echo "MUMPS orderings on the 40-layer gravity tower (2,320 elements), ipopt start=alternating-gn:"
    echo
    echo "| mumps_pivot_order | status | iterations | seconds | geometry change |"
    echo "|---|---|---:|---:|---:|"
    for order in 0 2 4 5 6 7; do
      run_row "$order" "$tower40" ipopt start=alternating-gn "mumps_pivot_order=$order"
    done
    echo
    echo "MUMPS's workspace (mumps_mem_percent: the percentage above MUMPS's own estimate; Ipopt's"
    echo "default 1000, the backend's 100), ipopt start=alternating-gn; process CPU seconds and minor"
    echo "page faults of the whole command (getrusage of the child):"
    echo
    echo "| scene | mumps_mem_percent | status | iterations | seconds | user CPU s | system CPU s | minor page faults | geometry change |"
    echo "|---|---:|---|---:|---:|---:|---:|---:|---:|"
    for scene in "$tower10" "$tower40"; do
      for percent in 1000 100; do
        "$py" - "$tg" "$scene" "$percent" "$limit" "$work/m.json" <<'EOF2'
import json, os, resource, subprocess, sys
tg, scene, percent, limit, out = sys.argv[1:]
before = resource.getrusage(resource.RUSAGE_CHILDREN)
subprocess.run([tg, "solve", scene, "--solver", "ipopt", "--option", "start=alternating-gn",
                "--option", f"mumps_mem_percent={percent}", "--time-limit", limit, "--out", out],
               stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
after = resource.getrusage(resource.RUSAGE_CHILDREN)
d = json.load(open(out)); s = d["stats"]
layers = "10" if "tower-10" in scene else "40"
print(f"| tower, {layers} layers x 8 struts, gravity | {percent} | {d['status']} | {s['iterations']} | "
      f"{s['seconds']:.3g} | {after.ru_utime - before.ru_utime:.2f} | {after.ru_stime - before.ru_stime:.2f} | "
      f"{after.ru_minflt - before.ru_minflt} | {s['geometry_change']:.6g} |")
EOF2
      done
    done
  } >>"$out/ipopt-starts.md"
}

# --- gravity tower family ----------------------------------------------------------
# `forces` on the equilibria alternating-gn returns for the as-generated
# towers, with and without gravity (docs/THEORY-force-scale.md quotes it).
forces_towers() {
  local layers=${FIGURES_FORCES_TOWER_LAYERS:-10 20 40 80 160}
  step "forces on tower equilibria, layers $layers"
  local cmd="for L in $layers, with and without --gravity: $tg generate tower --layers L --struts-per-layer 8 --cables 50L; $tg solve --solver alternating-gn --out-scene E; $tg forces E; $tg check E"
  header "$out/forces-towers.md" "forces on the towers' equilibria" "$cmd"
  {
    echo "Scenes: the equilibria that \`solve --solver alternating-gn\` returns for"
    echo "\`generate tower --layers L --struts-per-layer 8 --cables 50L [--gravity]\`. One run each;"
    echo "seconds are \`forces\`'s own; \`check\` re-verifies its forces at the scene geometry."
    echo
    echo "| layers | elements | gravity | forces status | seconds | relative residual | found by | check |"
    echo "|---|---|---|---|---|---|---|---|"
  } >>"$out/forces-towers.md"
  local L g flag
  for L in $layers; do
    for g in no yes; do
      flag=""
      [ "$g" = yes ] && flag="--gravity"
      "$tg" generate tower --layers "$L" --struts-per-layer 8 --cables $((50 * L)) $flag --out "$work/ft.json" >/dev/null
      "$tg" solve "$work/ft.json" --solver alternating-gn --quiet --out "$work/ft.sol.json" --out-scene "$work/ft.eq.json" >/dev/null || true
      "$tg" forces "$work/ft.eq.json" --out "$work/ft.forces.json" >/dev/null 2>&1 || true
      local verdict
      verdict=$("$tg" check "$work/ft.eq.json" "$work/ft.forces.json" 2>&1 | tail -1 || true)
      "$py" - "$work/ft.forces.json" "$L" "$g" "$verdict" >>"$out/forces-towers.md" <<'EOF2'
import json, sys
d = json.load(open(sys.argv[1]))
st = d["stats"]
by = "Ipopt, residual form" if "Ipopt" in d.get("message", "") else "stress QP"
print(f"| {sys.argv[2]} | {58 * int(sys.argv[2]):,} | {sys.argv[3]} | {d['status']} | {st['seconds']:.3g} | "
      f"{st['relative_residual']:.2g} | {by} | {sys.argv[4]} |")
EOF2
    done
  done
}

# The recommended backends on the towers as `generate tower` writes them (far
# from equilibrium): alternating-gn, eq5-newton (which starts from
# alternating-gn's equilibrium) and ipopt (which starts from eq5-newton's
# answer), each through `tensegrity solve`, each answer re-verified by `check`.
towers_as_generated() {
  local layers=${FIGURES_AS_GENERATED_TOWER_LAYERS:-10 40 160}
  local as_limit=${FIGURES_AS_GENERATED_TIME_LIMIT:-120}
  step "towers as generated, layers $layers, alternating-gn, eq5-newton, ipopt ($as_limit s per solve)"
  local cmd="for L in $layers, with and without --gravity: $tg generate tower --layers L --struts-per-layer 8 --cables 50L; $tg solve --solver B --time-limit $as_limit (and alternating-gn with --no-skip); $tg check"
  header "$out/towers-as-generated.md" "The towers as generated: alternating-gn, eq5-newton and ipopt" "$cmd"
  {
    echo "Scenes: \`generate tower --layers L --struts-per-layer 8 --cables 50L [--gravity]\` as written"
    echo "(58 L elements, far from equilibrium). One run each through \`tensegrity solve\` (the"
    echo "driver's check included), at most $as_limit s, target relative residual 1e-8; seconds are the"
    echo "solve's own; \`check\` re-verifies the solution file. \`change / best\`: geometry change over"
    echo "the smallest verified one of the three on the scene. \`alternating-gn --no-skip\`: the same"
    echo "backend without the driver's check, so that the check's share of its time shows."
    echo
    echo "| layers | elements | gravity | backend | status | seconds | iterations | geometry change (m) | change / best | check | how it ended |"
    echo "|---:|---:|---|---|---|---:|---:|---:|---:|---|---|"
  } >>"$out/towers-as-generated.md"
  local L g flag backend
  for L in $layers; do
    for g in no yes; do
      flag=""
      [ "$g" = yes ] && flag="--gravity"
      "$tg" generate tower --layers "$L" --struts-per-layer 8 --cables $((50 * L)) $flag --out "$work/ag.json" >/dev/null
      for backend in alternating-gn alternating-gn-no-skip eq5-newton ipopt; do
        "$tg" solve "$work/ag.json" --solver "${backend%-no-skip}" --time-limit "$as_limit" --quiet \
          $([ "$backend" = alternating-gn-no-skip ] && echo --no-skip) \
          --out "$work/ag.$backend.json" >/dev/null 2>&1 || true
        if "$tg" check "$work/ag.json" "$work/ag.$backend.json" >/dev/null 2>&1; then
          echo verified >"$work/ag.$backend.check"
        else
          echo "NOT verified" >"$work/ag.$backend.check"
        fi
      done
      "$py" - "$work" "$L" "$g" >>"$out/towers-as-generated.md" <<'EOF2'
import json, sys
work, layers, gravity = sys.argv[1], int(sys.argv[2]), sys.argv[3]
rows = []
for backend in ("alternating-gn", "alternating-gn-no-skip", "eq5-newton", "ipopt"):
    d = json.load(open(f"{work}/ag.{backend}.json"))
    verdict = open(f"{work}/ag.{backend}.check").read().strip()
    rows.append((backend.replace("-no-skip", " --no-skip"), d, verdict))
verified = [d["stats"]["geometry_change"] for b, d, v in rows if v == "verified" and "--no-skip" not in b]
best = min(verified) if verified else float("nan")
for backend, d, verdict in rows:
    st = d["stats"]
    ratio = f"{st['geometry_change'] / best:.3f}" if verdict == "verified" and best > 0 else "-"
    how = d.get("message", "").split(";")[0].replace("|", "/")[:110]
    print(f"| {layers} | {58 * layers:,} | {gravity} | {backend} | {d['status']} | {st['seconds']:.3g} | "
          f"{st['iterations']} | {st['geometry_change']:.4g} | {ratio} | {verdict} | {how} |")
EOF2
    done
  done
}

# eq5-newton against the alternating-gn equilibrium it starts from and Ipopt
# warm-started at that equilibrium (eq5_newton_bench, medians of 3, one BLAS thread).
eq5_newton() {
  local eb="$build/bench/eq5_newton_bench"
  need_executable "$eb"
  step "eq5-newton, alternating-gn and ipopt-warm on the gravity towers (medians of 3)"
  local cmd="OPENBLAS_NUM_THREADS=1 $eb --tower_layers=10,20,40 --time_limit=60 --benchmark_filter=^(alternating-gn|eq5-newton|ipopt-warm)/ --benchmark_repetitions=3 --benchmark_out=eq5-newton.json --benchmark_out_format=json"
  header "$out/eq5-newton.md" "eq5-newton against alternating-gn and a warm-started Ipopt" "$cmd"
  OPENBLAS_NUM_THREADS=1 "$eb" --tower_layers=10,20,40 --time_limit=60 \
    --benchmark_filter='^(alternating-gn|eq5-newton|ipopt-warm)/' --benchmark_repetitions=3 \
    --benchmark_out="$work/eq5-newton.json" --benchmark_out_format=json >/dev/null 2>"$work/eq5-newton.log"
  "$py" - "$work/eq5-newton.json" >>"$out/eq5-newton.md" <<'EOF2'
import sys
sys.path.insert(0, "bench/scripts")
from bench_runs import iteration_runs, median
runs = iteration_runs(sys.argv[1], lambda parts: (parts[1], parts[0]))  # (scene, backend)
print("Scenes: `generate tower --layers L --struts-per-layer 8 --cables 50L --gravity`, solved to an")
print("equilibrium by alternating-gn, then 1 % node noise (seed 1); `tower-80s-500c-gravity-noise2` is")
print("`data/bench/tower-80s-500c-gravity.scene.json` with 2 % noise. `ipopt-warm` is")
print("`ipopt --option start=alternating-gn`. Wall milliseconds, medians of 3; `/ best`: geometry")
print("change over the smallest on the scene; every row converged and verified.")
print()
print("| scene (elements) | backend | ms | iterations (Newton) | geometry change (m) | / best | time / alternating-gn |")
print("|---|---|---:|---:|---:|---:|---:|")
scenes = sorted({s for s, _ in runs}, key=lambda s: (s.startswith("tower-80s"), int(s.split("-")[1]) if s.split("-")[1].isdigit() else 0))
for scene in scenes:
    rows = {b: r for (s, b), r in runs.items() if s == scene}
    best = min(median([x["geometry_change"] for x in r]) for r in rows.values())
    gn_ms = median([x["real_time"] for x in rows["alternating-gn"]])
    for backend in ("alternating-gn", "eq5-newton", "ipopt-warm"):
        if backend not in rows:
            continue
        r = rows[backend]
        ms = median([x["real_time"] for x in r])
        change = median([x["geometry_change"] for x in r])
        ok = all(x.get("converged", 0) == 1 for x in r)
        its = int(median([x["iterations"] for x in r]))
        newton = int(median([x.get("newton_iterations", 0) for x in r]))
        its_text = f"{its} ({newton})" if backend == "eq5-newton" else f"{its}"
        label = f"{scene} ({int(r[0]['elements']):,})"
        ms_text = f"{ms:,.0f}" if ms >= 100 else f"{ms:.3g}"
        print(f"| {label} | {backend}{'' if ok else ' (not converged)'} | {ms_text} | {its_text} | {change:.7f} | "
              f"{change / best:.5f} | {ms / gn_ms:.1f} |")
EOF2
}

# The arguments as one line that a shell reads back as the same words: a word
# with a character outside [A-Za-z0-9_./=,:@+-] in single quotes.
shell_words() {
  local word line=""
  for word in "$@"; do
    [[ $word =~ ^[A-Za-z0-9_./=,:@+-]*$ ]] || word="'$word'"
    line+="${line:+ }$word"
  done
  printf '%s' "$line"
}

# bench_figure NAME TITLE REPORT ARGS...: the header of $out/NAME.md with the
# command, compare_bench ARGS with its JSON in $work/NAME.json (copied to $out
# and stamped), and report.py's tables of it in $work/REPORT.
bench_figure() {
  local name=$1 title=$2 report=$3
  shift 3
  local cmd
  cmd="$cb $(shell_words "$@") --benchmark_out=$name.json --benchmark_out_format=json"
  header "$out/$name.md" "$title" "$cmd"
  "$cb" "$@" --benchmark_out="$work/$name.json" --benchmark_out_format=json >/dev/null 2>"$work/$name.log"
  rm -rf "$work/$report"
  "$py" bench/scripts/report.py --json "$work/$name.json" --out "$work/$report" >"$work/$report.txt"
  cp "$work/$name.json" "$out/$name.json"
  stamp "$out/$name.json" "$cmd"
}

# gravity_tower_figure NAME TITLE LAYERS FILTER LIMIT: the family at LAYERS, the
# benchmarks FILTER selects, LIMIT s per solve, into NAME.md and NAME.json.
gravity_tower_figure() {
  local name=$1 title=$2 layers=$3 filter=$4 limit=$5 tolerance=${6:-1e-10} check=${7:-0}
  need_bench
  step "gravity tower family, layers $layers, $filter (time limit $limit s per solve, target $tolerance)"
  bench_figure "$name" "$title" gt-report --benchmark_filter="$filter" --gravity_tower_layers="$layers" \
    --chain_sizes= --tower_layers= --time_limit="$limit" --tolerance="$tolerance" --driver_check="$check" \
    --benchmark_repetitions=1
  {
    echo "Scenes: \`tensegrity generate tower --layers L --struts-per-layer 8 --cables 50L --gravity\`"
    echo "(58 L elements), solved to an equilibrium by alternating-gn, then every free node moved by"
    echo "up to 1 % of the first element's length (seed 1). One solve per scene and backend, at most"
    echo "$limit s of wall time each: a run marked NO stopped at that limit or failed (its label says"
    echo "which). Every backend aims at relative residual $tolerance. Timings are wall seconds on a shared"
    echo "2-core machine, read them together with the load average above."
    if [ "$check" = 1 ]; then
      echo
      echo "Each solve as \`tensegrity solve\` runs it: the driver first asks the stress QP whether the"
      echo "scene already stands (docs/BACKENDS.md). Wall and CPU seconds include that check; the"
      echo "t(1e-4) ... t(1e-10) columns count from the backend's start, as its trace does."
    fi
    if [ "$tolerance" = 1e-8 ]; then
      echo
      echo "The target is the solve's default, 1e-8: near Eq. 5's optimum on the towers from 80 layers the"
      echo "mean cable force nears the cap, the largest forces exceed the largest free-node weight 70,000"
      echo "(80 layers) to 110,000 times (160 layers), and rounding alone leaves a relative residual of"
      echo "5e-10 to 2e-9 (docs/BACKENDS.md, eq5-newton's stationary stop)."
    fi
    echo
    "$py" - "$work/gt-report/results.csv" "$limit" <<'EOF2'
import csv, sys
rows = [r for r in csv.DictReader(open(sys.argv[1])) if r["family"] == "gravity-towers"]
stopped = sorted({(int(float(r["elements"])), r["backend"], r["label"]) for r in rows if float(r["success"]) < 1})
print(f"{len(rows) - len(stopped)} of {len(rows)} runs verified at relative residual 1e-8.", end="")
if stopped:
    print(" Not verified: " + "; ".join(f"{b} at {e} elements ({l})" for e, b, l in stopped) + ".")
else:
    print()
limit = float(sys.argv[2])
over = sorted((int(float(r["elements"])), r["backend"], float(r["real_s"])) for r in rows
              if float(r["real_s"]) > 1.2 * limit)
if over:
    print()
    print("Past the time limit (the limit is checked between iterations, and one iteration of these took longer): "
          + "; ".join(f"{b} at {e} elements, {s:.3g} s" for e, b, s in over) + ".")
EOF2
    echo
    cat "$work/gt-report/table.md"
    echo
    echo "Fitted exponents a of time ~ elements^a (least squares on log-log over the verified sizes; report.py):"
    echo
    echo '```'
    sed -n '/^Scaling families/,/^$/p' "$work/gt-report.txt" | grep -E '^(Scaling|  )'
    echo '```'
  } >>"$out/$name.md"
}

# The recommended backends as `tensegrity solve` runs them, with the driver's check.
gravity_towers_driver() {
  gravity_tower_figure gravity-towers-driver "The gravity tower family through tensegrity solve's driver" \
    10,20,40,80,160 '^gravity-towers/[^/]+/(alternating-gn|eq5-newton)/' "${FIGURES_10K_TIME_LIMIT:-120}" 1e-8 1
}

# Every backend on the family up to FIGURES_GRAVITY_TOWER_LAYERS (default 40 layers).
gravity_towers() {
  gravity_tower_figure gravity-towers "The gravity tower family" "${FIGURES_GRAVITY_TOWER_LAYERS:-10,20,40}" \
    '^gravity-towers/' "$limit"
}

# The scaling fit to 9,280 elements (160 layers) for eq5-newton, the
# alternating-gn it starts from, and Ipopt; the faithful scheme and nlopt,
# which stop at the limit from 20 layers on, are left out.
gravity_towers_10k() {
  gravity_tower_figure gravity-towers-10k "The gravity tower family to 9,280 elements" 10,20,40,80,160 \
    '^gravity-towers/[^/]+/(alternating-gn|eq5-newton|ipopt|ipopt@auto)/' "${FIGURES_10K_TIME_LIMIT:-120}" 1e-8
}

# The family every 20 layers from 20 to 160 for eq5-newton, the
# alternating-gn it starts from and Ipopt (from eq5-newton's answer): how
# regular the growth is between the sizes of the fit above.
gravity_towers_dense() {
  gravity_tower_figure gravity-towers-dense "The gravity tower family every 20 layers" 20,40,60,80,100,120,140,160 \
    '^gravity-towers/[^/]+/(alternating-gn|eq5-newton|ipopt)/' "${FIGURES_10K_TIME_LIMIT:-120}" 1e-8
}

# Ipopt's MUMPS orderings side by side on the chain and gravity tower
# families: QAMD (the backend's default), METIS, PORD, and QAMD without
# threshold pivoting (mumps_pivtol=0), what dropping MUMPS's pivoting costs.
ipopt_orderings() {
  need_bench
  local name=ipopt-orderings limit=${FIGURES_10K_TIME_LIMIT:-120}
  local filter='^(scaling/chain-[0-9]+|gravity-towers/[^/]+)/ipopt(/|@mumps)'
  local extra=ipopt@mumps_pivot_order=5,ipopt@mumps_pivot_order=4,ipopt@mumps_pivtol=0
  step "ipopt's MUMPS orderings on the chain and gravity tower families (time limit $limit s per solve)"
  bench_figure "$name" "Ipopt's MUMPS orderings on the chain and gravity tower families" ord-report \
    --benchmark_filter="$filter" --extra_backends="$extra" --chain_sizes=32,64,128 --tower_layers= \
    --gravity_tower_layers=40,80,160 --time_limit="$limit" --tolerance=1e-8 --benchmark_repetitions=1
  {
    echo "Scenes: the chain family (N face-linked expandable octahedra under gravity, 2 % node noise;"
    echo "bench/compare_bench.cpp) and the gravity tower family (\`generate tower --layers L"
    echo "--struts-per-layer 8 --cables 50L --gravity\`, solved to an equilibrium, then 1 % node noise)."
    echo "\`ipopt\` is the backend's default, MUMPS with the QAMD ordering (\`mumps_pivot_order=6\`);"
    echo "\`@mumps_pivot_order=5\` METIS, \`=4\` PORD; \`@mumps_pivtol=0\` QAMD without threshold"
    echo "pivoting. Every run starts at eq5-newton's answer (the default start; where Ipopt gives no"
    echo "verified answer from there it runs again from alternating-gn's equilibrium, then from the"
    echo "scene), so times and iteration counts include eq5-newton's (t(1e-8) is mostly eq5-newton's"
    echo "part) and any such further run. One solve per"
    echo "scene and label, at most $limit s each, target relative residual 1e-8; wall seconds on a"
    echo "shared 2-core machine."
    echo
    cat "$work/ord-report/table.md"
    echo
    echo "Fitted exponents a of time ~ elements^a (least squares on log-log over the verified sizes; report.py):"
    echo
    echo '```'
    sed -n '/^Scaling families/,/^$/p' "$work/ord-report.txt" | grep -E '^(Scaling|  )'
    echo '```'
  } >>"$out/$name.md"
}

# eq5-newton's two barrier rules, Mehrotra's (its default) and the monotone
# one, side by side on the family to 9,280 elements.
eq5_newton_barrier() {
  gravity_tower_figure eq5-newton-barrier "eq5-newton's barrier rules on the gravity tower family" 10,20,40,80,160 \
    '^gravity-towers/[^/]+/eq5-newton(@barrier=monotone)?/' "${FIGURES_10K_TIME_LIMIT:-120}" 1e-8
}

# --- the outputs shown in docs/OUTPUTS.md and docs/PYTHON.md ------------------------
# outputs_record FILE TITLE: a provenance record for the pictures and tables in a
# docs folder; each output then adds its command and what the program printed.
outputs_record() {
  {
    echo "# $2"
    echo
    echo "Generated by \`bash scripts/docs-figures.sh\` (section \`outputs\`); do not edit by hand."
    echo
    echo "- commit: $FIG_COMMIT"
    echo "- date: $FIG_DATE; load average at the start of this step: $(cut -d' ' -f1-3 /proc/loadavg)"
    echo "- machine: $FIG_MACHINE"
    echo
  } >"$1"
}

outputs() {
  local docs=${FIGURES_DOCS:-docs} rc
  local o=$docs/outputs w="$work/outputs" readme="$docs/outputs/README.md"
  mkdir -p "$w" "$o" "$docs/images"
  outputs_record "$readme" "The outputs shown in OUTPUTS.md"

  step "outputs: tensegrity compare on the noisy 6-strut prism"
  local cmp=$o/compare-prism-6
  rm -rf "$cmp"
  rc=0
  "$tg" compare "$o/prism-6-noise5.scene.json" --out "$cmp" >"$w/table.txt" 2>"$w/compare.err" || rc=$?
  [ "$rc" -le 1 ] || { cat "$w/compare.err" >&2; exit 1; }
  cp "$w/table.txt" "$cmp/table.txt"
  {
    echo "## compare-prism-6/"
    echo
    echo "\`tensegrity compare $o/prism-6-noise5.scene.json --out $cmp\` (exit $rc);"
    echo "\`table.txt\` is what it printed:"
    echo
    echo '```'
    cat "$w/table.txt"
    echo '```'
    echo
    echo "Each backend's own trace, first and last record (\`tensegrity solve $o/prism-6-noise5.scene.json --solver NAME --trace NAME.csv\`):"
    echo
    echo "| backend | first iteration | its relative residual | last iteration | its relative residual |"
    echo "|---|---:|---:|---:|---:|"
  } >>"$readme"
  local solver
  for solver in $("$tg" solvers); do
    "$tg" solve "$o/prism-6-noise5.scene.json" --solver "$solver" --trace "$w/$solver.csv" \
      --out "$w/$solver.solution.json" --quiet >/dev/null 2>&1 || true
    "$py" - "$w/$solver.csv" "$solver" >>"$readme" <<'EOF2'
import csv, sys
rows = list(csv.DictReader(open(sys.argv[1])))
if rows:
    a, b = rows[0], rows[-1]
    print(f"| {sys.argv[2]} | {a['iteration']} | {float(a['relative_residual']):.3g} | {b['iteration']} | {float(b['relative_residual']):.3g} |")
EOF2
  done
  echo >>"$readme"

  step "outputs: the scorpion before and after form finding"
  local s="$w/scorpion.scene.json" sol="$w/scorpion.solution.json"
  "$tg" build data/characters/scorpion.character.json --out "$s" 2>/dev/null
  "$tg" solve "$s" --out "$sol" >"$w/scorpion-solve.txt" 2>&1
  "$tg" render "$s" --out "$o/scorpion-before.png" --colour-by block --title "scorpion as built (blocks)"
  "$tg" render "$s" --solution "$sol" --out "$o/scorpion-after.png" --title "scorpion form-found (forces)"
  "$tg" render "$s" --solution "$sol" --out "$o/scorpion-after.svg" --title "scorpion form-found (forces)"
  {
    echo "## scorpion-before.png, scorpion-after.png, scorpion-after.svg"
    echo
    echo "    tensegrity build data/characters/scorpion.character.json --out S"
    echo "    tensegrity solve S --out SOL"
    echo "    tensegrity render S --out $o/scorpion-before.png --colour-by block --title \"scorpion as built (blocks)\""
    echo "    tensegrity render S --solution SOL --out $o/scorpion-after.png --title \"scorpion form-found (forces)\""
    echo "    tensegrity render S --solution SOL --out $o/scorpion-after.svg --title \"scorpion form-found (forces)\""
    echo
    echo "\`solve\` printed:"
    echo
    echo '```'
    sed "s|$w/||g" "$w/scorpion-solve.txt"
    echo '```'
    echo
    "$py" - "$s" "$sol" <<'EOF2'
import json, sys
scene, sol = json.load(open(sys.argv[1])), json.load(open(sys.argv[2]))
kinds = [e["kind"] for e in scene["elements"]]
forces = sol["forces"]
struts = [abs(f) for f, k in zip(forces, kinds) if k == "strut"]
cables = sorted(f for f, k in zip(forces, kinds) if k == "cable")
print(f"The scene: {kinds.count('strut')} struts, {kinds.count('cable')} cables, {len(scene['nodes'])} nodes. "
      f"Largest strut compression {max(struts):.3g} N; cable tensions {cables[0]:.3g} .. {cables[-1]:.3g} N, "
      f"median {cables[len(cables) // 2]:.3g} N.")
print()
EOF2
  } >>"$readme"

  step "outputs: NTRT's 3Prism imported and form-found"
  local p="$w/3prism.scene.json" psol="$w/3prism.solution.json"
  "$tg" import tests/data/ntrt/3Prism.yaml --out "$p" --length-scale 0.01 >"$w/3prism-import.txt" 2>&1
  "$tg" solve "$p" --solver alternating --out "$psol" >"$w/3prism-solve.txt" 2>&1
  "$tg" render "$p" --solution "$psol" --labels --out "$o/ntrt-3prism-formfound.png"
  {
    echo "## ntrt-3prism-formfound.png"
    echo
    echo "    tensegrity import tests/data/ntrt/3Prism.yaml --out 3prism.scene.json --length-scale 0.01"
    echo "    tensegrity solve 3prism.scene.json --solver alternating --out 3prism.solution.json"
    echo "    tensegrity render 3prism.scene.json --solution 3prism.solution.json --labels --out $o/ntrt-3prism-formfound.png"
    echo
    echo "\`import\` and \`solve\` printed:"
    echo
    echo '```'
    sed "s|$w/||g" "$w/3prism-import.txt" "$w/3prism-solve.txt"
    echo '```'
    echo
  } >>"$readme"

  step "outputs: the duck's NTRT YAML round trip"
  "$tg" build data/characters/duck.character.json --out "$w/duck.scene.json" 2>/dev/null
  "$tg" export "$w/duck.scene.json" --out "$w/duck.yaml"
  "$tg" import "$w/duck.yaml" --out "$w/back.scene.json"
  {
    echo "## The duck's NTRT YAML round trip (no picture)"
    echo
    echo "    tensegrity build data/characters/duck.character.json --out duck.scene.json"
    echo "    tensegrity export duck.scene.json --out duck.yaml"
    echo "    tensegrity import duck.yaml --out back.scene.json"
    echo
    "$py" - "$w/duck.scene.json" "$w/back.scene.json" <<'EOF2'
import json, sys
a, b = (json.load(open(f)) for f in sys.argv[1:3])
def counts(s):
    return len(s["nodes"]), len(s["elements"]), sum(1 for n in s["nodes"] if n.get("fixed", False))
def elements(s):
    return sorted((e["kind"], *sorted(e["nodes"])) for e in s["elements"])
same = ([n["x"] for n in a["nodes"]] == [n["x"] for n in b["nodes"]]
        and [n.get("fixed", False) for n in a["nodes"]] == [n.get("fixed", False) for n in b["nodes"]]
        and elements(a) == elements(b))
for label, s in (("duck.scene.json", a), ("back.scene.json", b)):
    print(f"- {label}: %d nodes, %d elements, %d fixed" % counts(s))
print(f"- positions bit for bit, fixed nodes and the set of elements identical: {'yes' if same else 'NO'}")
print()
EOF2
  } >>"$readme"

  step "outputs: python/examples/compare_backends.py (time limit 20 s per backend)"
  [ -d "$build/python/tensegrity" ] || { echo "docs-figures: $build/python/tensegrity missing" >&2; exit 1; }
  local pyrecord="$docs/images/python-backends.md"
  outputs_record "$pyrecord" "docs/images/python-backends.png"
  PYTHONPATH=$build/python "$py" python/examples/compare_backends.py --out "$docs/images/python-backends.png" \
    >"$w/python-backends.txt" 2>&1
  {
    echo "- command: \`PYTHONPATH=$build/python $py python/examples/compare_backends.py --out $docs/images/python-backends.png\`"
    echo
    echo "It printed (seconds are the solver's own):"
    echo
    echo '```'
    cat "$w/python-backends.txt"
    echo '```'
  } >>"$pyrecord"
}

prestress_factor() {
  step "prestress-factor.md: Eq. 5's cap kappa on the gravity scenes and characters"
  local kappas="1 2 3 5 10" scenes=()
  for f in data/reference/*-gravity.scene.json; do scenes+=("$f"); done
  for c in duck puppy scorpion minimal/duck minimal/scorpion; do
    "$tg" build "data/characters/$c.character.json" --out "$work/${c//\//-}.scene.json" >/dev/null
    scenes+=("$work/${c//\//-}.scene.json")
  done
  header "$out/prestress-factor.md" "The prestress cap kappa under gravity" \
    "tensegrity solve SCENE --solver ipopt|alternating-gn --prestress-factor K --time-limit $limit"
  {
    echo "Geometry change (m) of each answer, then its iterations and the solver's own seconds in"
    echo "brackets (one run, on a shared machine); \`-\` where the solve did not converge (its status in"
    echo "brackets). alternating-gn: \`H\` where its free answer lay above the cap and the answer"
    echo "comes from the run held at the cap (docs/THEORY-force-scale.md)."
    echo
    printf '| scene | backend |'; for k in $kappas; do printf ' kappa = %s |' "$k"; done; echo
    printf '|---|---|'; for k in $kappas; do printf -- '---:|'; done; echo
    for scene in "${scenes[@]}"; do
      name=$(basename "$scene" .scene.json)
      for solver in ipopt alternating-gn; do
        printf '| %s | %s |' "$name" "$solver"
        for k in $kappas; do
          "$tg" solve "$scene" --solver "$solver" --prestress-factor "$k" --time-limit "$limit" --quiet \
            --out "$work/k.json" >/dev/null 2>&1 || true
          "$py" - "$work/k.json" <<'EOF2'
import json, sys
d = json.load(open(sys.argv[1]))
details = d.get("details") or {}
if isinstance(details, list):
    details = details[0] if details else {}
held = "H" if details.get("held_at_prestress_cap") else ""
stats = d["stats"]
if d["status"] == "converged":
    print(f" {stats['geometry_change']:.4g}{held} ({stats['iterations']}, {stats['seconds']:.2g} s) |", end="")
else:
    print(f" - ({d['status']}) |", end="")
EOF2
        done
        echo
      done
    done
  } >>"$out/prestress-factor.md"
}

# The nlopt backend's variants side by side with Ipopt on the reference and
# conformance scenes and the scorpions (nlopt_bench side-by-side/, medians of 3).
nlopt_variants() {
  local nb="$build/bench/nlopt_bench"
  need_executable "$nb"
  step "nlopt variants and ipopt side by side (medians of 3)"
  local cmd="$nb --benchmark_filter=^side-by-side/ --benchmark_repetitions=3 --time_limit=$limit --table=nlopt-variants.md"
  header "$out/nlopt-variants.md" "The nlopt backend's variants side by side with Ipopt" "$cmd"
  "$nb" --benchmark_filter='^side-by-side/' --benchmark_repetitions=3 --time_limit="$limit" \
    --table="$work/nlopt-variants-table.md" >/dev/null 2>"$work/nlopt-variants.log"
  {
    echo "Every solve without the driver's check that a scene already stands. Solver seconds"
    echo "(\`stats.seconds\`), medians of 3; geometry change in m; a status in place of a change"
    echo "means a repetition ended with it (the median change in brackets). \`nlopt-full\`:"
    echo "\`formulation=full\`; \`varpro-slsqp\`: \`varpro_algorithm=slsqp\`; \`varpro-al-tnewton\`: the"
    echo "multiplier method around NLopt's truncated Newton; \`nlopt-varpro\`: the default (the"
    echo "multiplier method around L-BFGS). \`scorpion\` balances at Eq. 5's force level as built;"
    echo "\`scorpion-minimal\` (the minimal blocks) lies 0.12 mm from an optimum that moves it."
    echo
    cat "$work/nlopt-variants-table.md"
  } >>"$out/nlopt-variants.md"
}

# The stress QP of the driver's check whether a scene already stands, with K
# and through the node space, side by side on the towers (stress_qp_bench,
# medians of 5): the set-up and the solve at the scene's own geometry.
check_qp() {
  local qb="$build/bench/stress_qp_bench"
  need_executable "$qb"
  step "the check's stress QP with K and through the node space (medians of 5)"
  local cmd="$qb --benchmark_repetitions=5 --benchmark_out=check-qp.json --benchmark_out_format=json"
  header "$out/check-qp.md" "The check's stress QP: K against the node space" "$cmd"
  "$qb" --benchmark_repetitions=5 --benchmark_out="$work/check-qp.json" --benchmark_out_format=json \
    >/dev/null 2>"$work/check-qp.log"
  "$py" - "$work/check-qp.json" >>"$out/check-qp.md" <<'EOF2'
import sys
sys.path.insert(0, "bench/scripts")
from bench_runs import iteration_runs, median
runs = iteration_runs(sys.argv[1], lambda parts: (parts[1], parts[2]))  # (scene, linear algebra)
print("Scenes: the gravity tower family (`generate tower --struts-per-layer 8 --cables 50L --gravity`,")
print("alternating-gn's equilibrium with 1 % node noise, seed 1), `generate tower` as written without")
print("gravity, and alternating-gn's equilibria of those. One StressQp built and solved with the")
print("check's options (`standing_check_qp_options`), with K (`k`) and through the node space")
print("(`node-space`, the check's). Wall milliseconds, medians of 5; factorizations, projected-Newton")
print("steps and the forces' relative residual from the last run.")
print()
print("| scene | elements | K ms | node space ms | speed-up | factorizations K / node space | steps | relative residual K / node space | gave up |")
print("|---|---:|---:|---:|---:|---:|---:|---:|:-:|")
scenes = []
for s, _ in runs:
    if s not in scenes:
        scenes.append(s)
for scene in scenes:
    k, n = runs[(scene, "k")], runs[(scene, "node-space")]
    km, nm = median([x["real_time"] for x in k]), median([x["real_time"] for x in n])
    layers = int(scene.split("-")[1])
    kl, nl = k[-1], n[-1]
    print(f"| {scene} | {58 * layers:,} | {km:.3g} | {nm:.3g} | {km / nm:.2f} | {kl['factorizations']:.0f} / {nl['factorizations']:.0f} | "
          f"{kl['iterations']:.0f} / {nl['iterations']:.0f} | {kl['relative_residual']:.3g} / {nl['relative_residual']:.3g} | "
          f"{'yes' if nl['gave_up'] else 'no'} |")
EOF2
}

# Both cores: `batch` and `stress-test` with --measure-speedup, each run three
# times. The batch set mixes what users solve: the reference scenes, the
# characters as built and generated towers with node noise (gravity towers of
# 4 to 80 layers, plain 10-layer towers that start far from equilibrium).
two_cores() {
  step "two-cores.md: batch, stress-test and compare_bench's two-core family, one worker then two (5 runs each)"
  need_bench
  local set="$work/two-cores-set" rounds=5
  mkdir -p "$set"
  cp data/reference/*.scene.json "$set/"
  for c in duck puppy scorpion; do
    "$tg" build "data/characters/$c.character.json" --out "$set/$c.scene.json" >/dev/null 2>&1
  done
  tower() {  # tower LAYERS STRUTS CABLES SEED NOISE [--gravity]
    "$tg" generate tower --layers "$1" --struts-per-layer "$2" --cables "$3" --noise "$5" --seed "$4" "${@:6}" \
      --out "$set/tower-$1x$2${6:+-gravity}-s$4.scene.json" >/dev/null
  }
  for seed in 1 2 3 4 5 6; do tower 4 6 100 "$seed" 0.02 --gravity; done
  tower 3 8 150 1 0.02
  for seed in 1 2 3 4; do tower 10 8 500 "$seed" 0.01 --gravity; tower 40 8 2000 "$seed" 0.01 --gravity; done
  for seed in 1 2; do tower 20 8 1000 "$seed" 0.01 --gravity; tower 80 8 4000 "$seed" 0.01 --gravity; done
  for seed in 1 2 3; do tower 10 8 500 "$seed" 0.01; done
  local solvers=ipopt,alternating-gn,eq5-newton
  local batch_cmd="$tg batch SET --solver $solvers --no-skip --time-limit 20 --jobs 2 --measure-speedup --json batch.json --out-dir OUT"
  local stress_cmd="$tg stress-test --scenes tower,character --families noise,twist --trials 1 --solvers $solvers --time-limit 10 --jobs 2 --measure-speedup --out stress.json"
  local bench_args=(--benchmark_filter='^two-cores/' --gravity_tower_layers=10,20,40,80 --time_limit=20 --tolerance=1e-8)
  local bench_cmd="$cb ${bench_args[*]} --benchmark_out=two-cores.json --benchmark_out_format=json"
  local bench_json=()
  for round in $(seq 1 "$rounds"); do
    rm -rf "$work/two-cores-out" && mkdir -p "$work/two-cores-out"
    "$tg" batch "$set" --solver "$solvers" --no-skip --time-limit 20 --jobs 2 --measure-speedup --quiet \
      --json "$work/two-cores-batch-$round.json" --out-dir "$work/two-cores-out" >/dev/null
    "$tg" stress-test --scenes tower,character --families noise,twist --trials 1 --solvers "$solvers" \
      --time-limit 10 --jobs 2 --measure-speedup --quiet --data data --out "$work/two-cores-stress-$round.json" >/dev/null
    "$cb" "${bench_args[@]}" --benchmark_out="$work/two-cores-bench-$round.json" --benchmark_out_format=json \
      >/dev/null 2>&1
    bench_json+=("$work/two-cores-bench-$round.json")
  done
  header "$out/two-cores.md" "Both cores: batch, stress-test and compare_bench, one worker against two" \
    "$batch_cmd" "; $stress_cmd" "; $bench_cmd"
  "$py" - "$work" "$rounds" "$(ls "$set" | wc -l)" >>"$out/two-cores.md" <<'EOF2'
import json, statistics, sys
work, rounds, scenes = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
print(f"The batch set: {scenes} scenes (the 22 reference scenes; the duck, the puppy and the scorpion as built; "
      "`generate tower` with node noise: six 4-layer 6-strut and one 3-layer 8-strut tower at 2 %, four "
      "10-layer, two 20-layer, four 40-layer and two 80-layer 8-strut gravity towers at 1 %, three 10-layer "
      "8-strut towers without gravity at 1 %, far from equilibrium), each solved by every backend named. The "
      "stress-test set: the tower and character scenes of the stress test, noise and twist families, one trial "
      "each. Each command first solves everything with one worker process, then with two (longest estimated "
      "job first); `measured` is the one-worker wall time over the two-worker wall time, `estimate` the sum of "
      "the jobs' wall times over the two-worker wall time. One OpenBLAS thread per process. On a shared machine "
      "a pass's wall time varies by tens of per cent from run to run, which moves `measured` either way (above 2 "
      "where the one-worker pass ran slower than the two-worker pass's CPU time suggests); `estimate` divides "
      "times of the same pass.\n")
print("| command | run | jobs | converged | one worker: wall s | two workers: wall s | two workers: CPU s | measured | estimate |")
print("|---|---:|---:|---:|---:|---:|---:|---:|---:|")
medians = {}
for name, label in (("batch", "`batch`"), ("stress", "`stress-test`")):
    measured = []
    for r in range(1, rounds + 1):
        d = json.load(open(f"{work}/two-cores-{name}-{r}.json"))
        t, sp = d["totals"], d["speedup"]
        jobs = t["jobs"] if "jobs" in t else t["solves"]
        print(f"| {label} | {r} | {jobs} | {t['converged']} | {sp['serial_wall_seconds']:.2f} | "
              f"{t['wall_seconds']:.2f} | {t['cpu_seconds']:.2f} | {sp['measured']:.2f} | {sp['estimate']:.2f} |")
        measured.append(sp["measured"])
    medians[label] = statistics.median(measured)
print()
print("Median measured speed-up: " + "; ".join(f"{k} {v:.2f}" for k, v in medians.items()) + ".")
EOF2
  {
    echo
    echo "\`compare_bench\`'s two-core family: the compare family's scenes, the side-by-side family's but the"
    echo "octahedron grid (where Ipopt spends its whole time limit), and the gravity towers of 10, 20, 40 and 80"
    echo "layers with 1 % noise, each solved by ipopt, alternating-gn and eq5-newton, one benchmark run per round"
    echo "(\`bench/scripts/report.py\`):"
    "$py" bench/scripts/report.py --json "${bench_json[@]}" --out "$work/two-cores-report" >/dev/null
    cat "$work/two-cores-report/table.md"
  } >>"$out/two-cores.md"
}

# The deterministic figures first, the timed ones after them, so that a run
# cut short still leaves complete files.
for section in ${FIGURES_SECTIONS:-characters blocks relax character_design duck_neck link_stiffness character_stress outputs backends side_by_side stress_noise scaling stress_families ipopt_starts eq5_newton nlopt_variants gravity_towers gravity_towers_10k gravity_towers_dense eq5_newton_barrier ipopt_orderings gravity_towers_driver forces_towers towers_as_generated check_qp prestress_factor two_cores}; do
  "$section"
done
step "done; figures in $out"
