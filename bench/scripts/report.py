#!/usr/bin/env python3
"""Tables and plots from compare_bench's Google Benchmark JSON and trace CSVs.

    python3 bench/scripts/report.py --json compare.json --traces traces --out DIR [--title TEXT]

Writes into DIR:
  results.csv             one row per scene x backend (medians over repetitions)
  table.md                the same as a Markdown table (also printed)
  scaling.csv             time and memory against elements (scaling/ and gravity-towers/ families)
  two_cores.csv           the two-core family: one row per repetition (one worker, then two);
                          its table and median speed-up are also appended to table.md
  profile.csv             Dolan-More performance profile points
  <scene>.png             relative residual and geometry change against seconds, per backend
  profile.png             performance profile (time to a verified solution)
  scaling.png             time and peak heap against elements, log-log, with fitted exponents
Standard library only; the PNGs need gnuplot (Debian: gnuplot-nox) and are
skipped with a note when it is missing.
"""
import argparse
import csv
import json
import math
import os
import shutil
import statistics
import subprocess
import sys
from collections import defaultdict

THRESHOLDS = ["t_1e-4", "t_1e-6", "t_1e-8", "t_1e-10"]
TWO_CORES = "two-cores"
TWO_CORE_FIELDS = ["jobs", "converged", "serial_wall_s", "parallel_wall_s", "parallel_cpu_s", "measured_speedup",
                   "speedup_estimate", "cores"]
UNIT = {"ns": 1e-9, "us": 1e-6, "ms": 1e-3, "s": 1.0}


def load_runs(paths):
    """Returns {(family, scene, backend): row} with medians over repetitions
    (later files win for a benchmark present in several)."""
    groups = defaultdict(list)
    aggregates = defaultdict(dict)
    benchmarks, data = [], {}
    for path in paths:
        with open(path) as f:
            data = json.load(f)
        names = {b.get("run_name", b["name"]) for b in data.get("benchmarks", [])}
        benchmarks = [b for b in benchmarks if b.get("run_name", b["name"]) not in names] + data.get("benchmarks", [])
    for b in benchmarks:
        name = b.get("run_name", b["name"])
        if b.get("run_type") == "aggregate":
            aggregates[name][b.get("aggregate_name")] = b
        else:
            groups[name].append(b)
    rows = {}
    for name in set(groups) | set(aggregates):
        parts = name.split("/")
        if len(parts) < 3:
            continue
        family, scene, backend = parts[0], parts[1], parts[2]
        if family == TWO_CORES:
            continue  # not a solve of one scene: two_core_runs
        runs = groups.get(name) or ([aggregates[name]["median"]] if "median" in aggregates.get(name, {}) else [])
        if not runs:
            continue
        scale = UNIT.get(runs[0].get("time_unit", "ns"), 1e-9)
        row = {
            "family": family, "scene": scene, "backend": backend, "repetitions": len(runs),
            "real_s": statistics.median(r["real_time"] for r in runs) * scale,
            "cpu_s": statistics.median(r["cpu_time"] for r in runs) * scale,
            "label": runs[-1].get("label", ""),
        }
        for key in ["success", "iterations", "relative_residual", "geometry_change", "geometry_change_L",
                    "elements", "nodes", "peak_heap_MB", "max_rss_MB", "solve_seconds", "converged",
                    "seconds_per_iteration"] + THRESHOLDS:
            values = [r[key] for r in runs if key in r]
            row[key] = statistics.median(values) if values else float("nan")
        # Success only when every repetition verified.
        row["success"] = min((r.get("success", 0.0) for r in runs), default=0.0)
        rows[(family, scene, backend)] = row
    return rows, data.get("context", {})


def add_relative_geometry_change(rows):
    best = {}
    for (fam, scene, _), r in rows.items():
        if r["success"] >= 1.0:
            best[(fam, scene)] = min(best.get((fam, scene), math.inf), r["geometry_change"])
    for (fam, scene, _), r in rows.items():
        b = best.get((fam, scene), math.inf)
        if r["success"] < 1.0 or not math.isfinite(b):
            r["geometry_change_rel"] = float("nan")
        else:
            # Changes below a nanometre are rounding: they count as zero.
            r["geometry_change_rel"] = max(r["geometry_change"], 1e-9) / max(b, 1e-9)


def fmt_t(x):
    if x is None or not math.isfinite(x) or x < 0:
        return "-"
    return f"{x:.3g}"


def fmt_exponent(fits, r):
    fit = fits.get(series_name(r["family"], r["scene"], r["backend"])) if fits else None
    return "-" if not fit or not math.isfinite(fit[0]) else f"{fit[0]:.2f}"


def write_tables(rows, out, fits=None):
    keys = sorted(rows, key=lambda k: (k[0], rows[k]["elements"], k[1], k[2]))
    fields = ["family", "scene", "backend", "elements", "success", "label", "real_s", "cpu_s", "iterations",
              "seconds_per_iteration", "relative_residual", "geometry_change", "geometry_change_rel"] + THRESHOLDS + \
             ["peak_heap_MB", "repetitions"]
    with open(os.path.join(out, "results.csv"), "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(fields)
        for k in keys:
            w.writerow([rows[k][x] for x in fields])
    lines = ["| scene | elem | backend | ok | wall s | CPU s | iters | t(1e-4) | t(1e-6) | t(1e-8) | t(1e-10) "
             "| final rr | geom chg (m) | geom chg / best | s / iter | time exp | heap MB |",
             "|---|---:|---|:-:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for k in keys:
        r = rows[k]
        ok = "yes" if r["success"] >= 1.0 else "NO"
        rel = r["geometry_change_rel"]
        lines.append(
            f"| {r['scene']} | {int(r['elements'])} | {r['backend']} | {ok} | {r['real_s']:.3g} | {r['cpu_s']:.3g} "
            f"| {int(r['iterations'])} | " + " | ".join(fmt_t(r[t]) for t in THRESHOLDS) +
            f" | {r['relative_residual']:.1e} | {r['geometry_change']:.4g} "
            f"| {'-' if not math.isfinite(rel) else f'{rel:.3f}'} | {fmt_t(r['seconds_per_iteration'])} "
            f"| {fmt_exponent(fits, r)} | {r['peak_heap_MB']:.2f} |")
    text = "\n".join(lines) + "\n"
    with open(os.path.join(out, "table.md"), "w") as f:
        f.write(text)
    return text


def two_core_runs(paths):
    """The two-core family's repetitions, in file order: one dict of counters each."""
    runs = []
    for path in paths:
        with open(path) as f:
            data = json.load(f)
        for b in data.get("benchmarks", []):
            if b.get("run_type") == "aggregate" or not b.get("run_name", b["name"]).startswith(TWO_CORES + "/"):
                continue
            runs.append({"name": b.get("run_name", b["name"]).split("/iterations:")[0],
                         **{k: b[k] for k in TWO_CORE_FIELDS if k in b}})
    return runs


def write_two_cores(runs, out, after_other_tables):
    """two_cores.csv and the Markdown table with the median measured speed-up, appended to
    table.md after the other tables, or table.md's only content."""
    with open(os.path.join(out, "two_cores.csv"), "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["name", "run"] + TWO_CORE_FIELDS)
        for i, r in enumerate(runs, 1):
            w.writerow([r["name"], i] + [r.get(k, "") for k in TWO_CORE_FIELDS])
    lines = ["", f"Two cores ({runs[0]['name']}): one worker process, then two, longest job first", "",
             "| run | jobs | converged | one worker: wall s | two workers: wall s | two workers: CPU s "
             "| measured speed-up | estimate |",
             "|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for i, r in enumerate(runs, 1):
        lines.append(f"| {i} | {int(r['jobs'])} | {int(r['converged'])} | {r['serial_wall_s']:.2f} "
                     f"| {r['parallel_wall_s']:.2f} | {r['parallel_cpu_s']:.2f} | {r['measured_speedup']:.2f} "
                     f"| {r['speedup_estimate']:.2f} |")
    lines += ["", f"Median measured speed-up: {statistics.median(r['measured_speedup'] for r in runs):.2f} "
              f"over {len(runs)} run(s) on {int(runs[0]['cores'])} core(s)."]
    text = "\n".join(lines) + "\n"
    with open(os.path.join(out, "table.md"), "a" if after_other_tables else "w") as f:
        f.write(text)
    return text


def performance_profile(rows, out):
    """Dolan-More: rho_b(tau) = share of scenes solved by b within tau x the best time."""
    scenes = sorted({(k[0], k[1]) for k in rows})
    backends = sorted({k[2] for k in rows})
    ratios = defaultdict(list)
    for fam, scene in scenes:
        times = {b: rows[(fam, scene, b)]["real_s"] for b in backends
                 if (fam, scene, b) in rows and rows[(fam, scene, b)]["success"] >= 1.0}
        best = min(times.values(), default=None)
        for b in backends:
            ratios[b].append(times[b] / best if b in times and best and best > 0 else math.inf)
    finite = [x for v in ratios.values() for x in v if math.isfinite(x)]
    tau_max = max(finite + [2.0]) * 1.5
    with open(os.path.join(out, "profile.csv"), "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["backend", "tau", "fraction"])
        for b in backends:
            xs = sorted(ratios[b])
            n = len(xs)
            points = [(1.0, sum(1 for x in xs if x <= 1.0) / n)]
            points += [(x, sum(1 for y in xs if y <= x) / n) for x in xs if math.isfinite(x)]
            points.append((tau_max, sum(1 for y in xs if math.isfinite(y)) / n))
            with open(os.path.join(out, f"profile_{b}.dat"), "w") as g:
                for t, frac in points:
                    w.writerow([b, t, frac])
                    g.write(f"{t} {frac}\n")
    summary = {b: (sum(1 for x in ratios[b] if x <= 1.0), sum(1 for x in ratios[b] if math.isfinite(x)), len(ratios[b]))
               for b in backends}
    return backends, tau_max, summary


def fit_exponent(points):
    """Least-squares slope of log y against log x."""
    pts = [(math.log(x), math.log(y)) for x, y in points if x > 0 and y > 0 and math.isfinite(y)]
    if len(pts) < 2:
        return float("nan")
    mx = sum(p[0] for p in pts) / len(pts)
    my = sum(p[1] for p in pts) / len(pts)
    sxx = sum((p[0] - mx) ** 2 for p in pts)
    return sum((p[0] - mx) * (p[1] - my) for p in pts) / sxx if sxx > 0 else float("nan")


def family_of(scene):
    """chain-16 -> chain, tower-layers-8 -> tower-layers."""
    return scene.rstrip("0123456789").rstrip("-") or scene


SCALING_FAMILIES = ("scaling", "gravity-towers")


def series_family(family, scene):
    """The scaling series a scene belongs to: scaling/chain-16 -> chain; every
    gravity-towers/ scene -> gravity-towers; None outside the scaling families."""
    if family not in SCALING_FAMILIES:
        return None
    return family_of(scene) if family == "scaling" else family


def series_name(family, scene, backend):
    f = series_family(family, scene)
    return None if f is None else f"{backend} {f}"


def scaling(rows, out):
    """Fits per (family, backend): keys of the result are 'backend family'."""
    fam = [r for k, r in rows.items() if k[0] in SCALING_FAMILIES]
    for r in fam:
        r["series"] = series_family(r["family"], r["scene"])
    series = sorted({(r["series"], r["backend"]) for r in fam})
    fits = {}
    with open(os.path.join(out, "scaling.csv"), "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["backend", "scene", "elements", "success", "real_s", "cpu_s", "peak_heap_MB"])
        for family, backend in series:
            b = f"{backend} {family}"
            mine = sorted((r for r in fam if r["backend"] == backend and r["series"] == family),
                          key=lambda r: r["elements"])
            for r in mine:
                w.writerow([backend, r["scene"], int(r["elements"]), int(r["success"]), r["real_s"], r["cpu_s"], r["peak_heap_MB"]])
            ok = [r for r in mine if r["success"] >= 1.0]
            with open(os.path.join(out, f"scaling_{backend}_{family}.dat"), "w") as g:
                for r in ok:
                    g.write(f"{int(r['elements'])} {r['real_s']} {r['peak_heap_MB']}\n")
            fits[b] = (fit_exponent([(r["elements"], r["real_s"]) for r in ok]),
                       fit_exponent([(r["elements"], r["peak_heap_MB"]) for r in ok]),
                       len(ok), len(mine), max((int(r["elements"]) for r in ok), default=0))
    return [f"{backend} {family}" for family, backend in series], fits


def gnuplot(script, out):
    if not shutil.which("gnuplot"):
        return False
    path = os.path.join(out, "plot.gp")
    with open(path, "w") as f:
        f.write(script)
    res = subprocess.run(["gnuplot", path], capture_output=True, text=True)
    if res.returncode != 0:
        sys.stderr.write("gnuplot failed:\n" + res.stderr[-2000:])
    return res.returncode == 0


def trace_plots(rows, traces, out):
    """One PNG per scene: relative residual and geometry change against seconds."""
    if not traces or not os.path.isdir(traces):
        return ""
    by_scene = defaultdict(list)
    for fname in sorted(os.listdir(traces)):
        if fname.endswith(".csv") and "__" in fname:
            scene, backend = fname[:-4].split("__", 1)
            by_scene[scene].append((backend, os.path.join(traces, fname)))
    script = ['set terminal pngcairo size 1100,420 font ",10"', "set datafile separator ','", "set key top right"]
    for scene, items in sorted(by_scene.items()):
        usable = []
        for backend, path in items:
            with open(path) as f:
                n = sum(1 for _ in f) - 1
            if n > 0:
                usable.append((backend, path))
        if not usable:
            continue
        script += [f"set output '{os.path.join(out, scene + '.png')}'",
                   "set datafile separator ','", "set multiplot layout 1,2 title '" + scene + " (trace of the last timed run)'",
                   "set logscale y", "set format y '10^{%L}'", "set xlabel 'seconds'",
                   "set ylabel 'relative residual'", "set logscale x", "set format x '%g'",
                   "plot " + ", ".join(f"'{p}' using ($1>0?$1:1e-6):($5>0?$5:1e-17) every ::1 with linespoints pt 7 ps 0.4 title '{b}'" for b, p in usable),
                   "unset logscale y", "set format y '%g'", "set ylabel 'geometry change (m)'",
                   "plot " + ", ".join(f"'{p}' using ($1>0?$1:1e-6):6 every ::1 with linespoints pt 7 ps 0.4 title '{b}'" for b, p in usable),
                   "unset multiplot", "unset logscale x"]
    return "\n".join(script) + "\n"


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--json", required=True, nargs="+", help="compare_bench --benchmark_out JSON file(s)")
    ap.add_argument("--traces", default="", help="compare_bench --trace_dir folder")
    ap.add_argument("--out", required=True)
    ap.add_argument("--title", default="")
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    rows, context = load_runs(a.json)
    two_cores = two_core_runs(a.json)
    if not rows and not two_cores:
        sys.exit("report.py: no compare_bench benchmarks in " + " ".join(a.json))
    if not rows:
        print(write_two_cores(two_cores, a.out, after_other_tables=False))
        return
    add_relative_geometry_change(rows)
    sc_backends, fits = scaling(rows, a.out)
    print(write_tables(rows, a.out, fits))
    if two_cores:
        print(write_two_cores(two_cores, a.out, after_other_tables=True))

    backends, tau_max, summary = performance_profile(rows, a.out)
    print("Performance profile over", len({(k[0], k[1]) for k in rows}), "scenes (time to a verified solution):")
    for b, (wins, solved, n) in summary.items():
        print(f"  {b:<15} fastest on {wins:>3}, solved {solved:>3} of {n}")
    if fits:
        print("Scaling families, fitted exponents over verified runs: time ~ elements^a, heap ~ elements^b")
        for b, (ta, ma, ok, n, emax) in fits.items():
            print(f"  {b:<28} a = {ta:.2f}  b = {ma:.2f}  ({ok} of {n} sizes verified, up to {emax} elements)")
    with open(os.path.join(a.out, "fits.json"), "w") as f:
        json.dump({"profile": summary, "scaling": fits, "context": context}, f, indent=1, default=str)

    script = trace_plots(rows, a.traces, a.out)
    script += "\n".join([
        'set terminal pngcairo size 700,480 font ",10"', "set datafile separator whitespace",
        f"set output '{os.path.join(a.out, 'profile.png')}'",
        "set title 'Dolan-More performance profile (wall time to a verified solution)'",
        "set logscale x 2", "set xlabel 'tau (time / best time)'", "set ylabel 'fraction of scenes'",
        f"set xrange [1:{tau_max:g}]", "set yrange [0:1.05]", "set key bottom right", "unset logscale y",
        "plot " + ", ".join(f"'{os.path.join(a.out, 'profile_' + b + '.dat')}' using 1:2 with steps lw 2 title '{b}'" for b in backends),
        "unset title", ""])
    if any(f[2] > 0 for f in fits.values()):
        script += "\n".join([
            'set terminal pngcairo size 1100,420 font ",10"', f"set output '{os.path.join(a.out, 'scaling.png')}'",
            "set datafile separator whitespace", "set multiplot layout 1,2 title 'scaling families (verified runs)'",
            "set logscale xy", "set xlabel 'elements'", "set ylabel 'wall seconds'", "set key top left",
            "set autoscale x", "set autoscale y", "set format y '%g'",
            "plot " + ", ".join(f"'{os.path.join(a.out, 'scaling_' + b.replace(' ', '_') + '.dat')}' using 1:2 with linespoints pt 7 title '{b} (a={fits[b][0]:.2f})'" for b in sc_backends if fits[b][2] > 0),
            "set ylabel 'peak heap (MB)'",
            "plot " + ", ".join(f"'{os.path.join(a.out, 'scaling_' + b.replace(' ', '_') + '.dat')}' using 1:3 with linespoints pt 7 title '{b} (b={fits[b][1]:.2f})'" for b in sc_backends if fits[b][2] > 0),
            "unset multiplot", ""])
    if gnuplot(script, a.out):
        print("plots written to", a.out)
    else:
        print("gnuplot missing or failed: CSVs only in", a.out)


if __name__ == "__main__":
    main()
