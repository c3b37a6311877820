#!/usr/bin/env python3
"""Before/after medians of compare_bench: two commits, same machine, interleaved runs.

    /usr/bin/python3 bench/scripts/before_after.py OLD NEW [--rounds 7] [--time-limit 10]
        [--take old|new:COMMIT:PATH] [--out docs/figures/layout-before-after.md]

Each commit is exported with `git archive` into WORK/<commit>/ (default WORK:
build/before-after) and its compare_bench is built there in WORK/<commit>/build
(Release, no precompiled headers, ccache), so that the shared compiler cache
serves both; an existing export and build folder are reused. The scenes are the
compare/ scenes that both binaries list (--benchmark_list_tests) minus the
towers, i.e. the reference scenes (prisms and octahedra, some under gravity) and
the characters, and the backends the four that both versions have. For every
round and every scene the old binary runs, then the new one, each once per
backend (Google Benchmark repeats a solve until --min-time has passed and
reports the mean; one OpenBLAS thread), so that a change of the machine's load
hits both sides alike. A row's time is the median over the rounds; the ratio is
new/old of the medians; a row counts as outside noise when the two sets of
round times do not overlap (with n rounds a side a chance of 2 in C(2n, n) if
nothing changed: 2 in 3432 for 7) and the ratio is off by more than --noise
(default 10 %).

Writes the Markdown table with its provenance (command, both commits, date,
load average, machine) to --out and the raw per-run records beside it as JSON.
Standard library only.
"""
import argparse
import hashlib
import json
import os
import re
import shutil
import statistics
import subprocess
import sys
import time

BACKENDS = ["alternating", "alternating-gn", "ipopt", "nlopt"]
CHARACTERS = ("duck", "puppy", "scorpion")
UNIT = {"ns": 1e-9, "us": 1e-6, "ms": 1e-3, "s": 1.0}
# compare_bench's own flags that turn off the scaling families (built at start-up otherwise).
NO_SCALING = ["--chain_sizes=", "--tower_layers="]
ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def git(*args):
    return subprocess.run(["git", "-C", ROOT, *args], check=True, capture_output=True, text=True).stdout.strip()


def load_average():
    with open("/proc/loadavg") as f:
        return " ".join(f.read().split()[:3])


def machine():
    cpu = "unknown CPU"
    with open("/proc/cpuinfo") as f:
        for line in f:
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    u = os.uname()
    return f"{u.machine}, {os.cpu_count()} cores, {cpu}, {u.sysname} {u.release}"


def build(commit, takes, work, jobs, log):
    """Exports `commit` (with the files of `takes`, [(commit, path)], replaced) and
    builds its compare_bench; returns the binary's path."""
    folder = commit[:12]
    if takes:
        folder += "+" + hashlib.sha1(repr(takes).encode()).hexdigest()[:8]
    src = os.path.join(work, folder)
    if not os.path.exists(os.path.join(src, "CMakeLists.txt")):
        os.makedirs(src, exist_ok=True)
        archive = subprocess.Popen(["git", "-C", ROOT, "archive", commit], stdout=subprocess.PIPE)
        subprocess.run(["tar", "-x", "-C", src], stdin=archive.stdout, check=True)
        if archive.wait() != 0:
            sys.exit(f"before_after: git archive {commit} failed")
        for source, path in takes:
            with open(os.path.join(src, path), "wb") as f:
                f.write(subprocess.run(["git", "-C", ROOT, "show", f"{source}:{path}"], check=True,
                                       capture_output=True).stdout)
    bld = os.path.join(src, "build")
    if not os.path.exists(os.path.join(bld, "CMakeCache.txt")):
        subprocess.run(["cmake", "-S", src, "-B", bld, "-DCMAKE_BUILD_TYPE=Release", "-DTENSEGRITY_PCH=OFF",
                        "-DTENSEGRITY_BUILD_TESTS=OFF", "-DCMAKE_CXX_COMPILER_LAUNCHER=ccache"],
                       check=True, stdout=log, stderr=log)
    subprocess.run(["cmake", "--build", bld, f"-j{jobs}", "--target", "compare_bench"],
                   check=True, stdout=log, stderr=log)
    binary = os.path.join(bld, "bench", "compare_bench")
    if not os.access(binary, os.X_OK):
        sys.exit(f"before_after: {binary} missing after the build")
    return binary


def listed(binary):
    """{scene: set(backends)} of the compare/ benchmarks the binary registers."""
    out = subprocess.run([binary, *NO_SCALING, "--benchmark_list_tests", "--benchmark_filter=^compare/"],
                         check=True, capture_output=True, text=True).stdout
    scenes = {}
    for line in out.split():
        parts = line.split("/")
        if len(parts) >= 3 and parts[0] == "compare":
            scenes.setdefault(parts[1], set()).add(parts[2])
    return scenes


def kind(scene):
    if scene in CHARACTERS:
        return "character"
    return "tower" if scene.startswith("tower") else "reference"


def regex_escape(text):
    """Escapes what POSIX extended regular expressions (Google Benchmark's filter) treat as special."""
    return re.sub(r"([.^$|()\[\]{}*+?\\])", r"\\\1", text)


def run_once(binary, scene, backends, args, json_path, log):
    """One process: every backend on one scene; returns {backend: record}."""
    pattern = "^compare/" + regex_escape(scene) + "/(" + "|".join(regex_escape(b) for b in backends) + ")(/|$)"
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1", LC_ALL="C")
    cmd = [binary, *NO_SCALING, f"--benchmark_filter={pattern}", f"--time_limit={args.time_limit}",
           f"--benchmark_min_time={args.min_time}", "--benchmark_repetitions=1",
           f"--benchmark_out={json_path}", "--benchmark_out_format=json"]
    load_before = load_average()
    subprocess.run(cmd, check=True, env=env, stdout=subprocess.DEVNULL, stderr=log)
    with open(json_path) as f:
        data = json.load(f)
    records = {}
    for b in data["benchmarks"]:
        if b.get("run_type", "iteration") != "iteration":
            continue
        backend = b["name"].split("/")[2]
        records[backend] = {
            "seconds": b["real_time"] * UNIT[b.get("time_unit", "ns")],
            "cpu_seconds": b["cpu_time"] * UNIT[b.get("time_unit", "ns")],
            "status": b.get("label", ""),
            "error": b.get("error_message", ""),
            "load_before": load_before,
        }
        # The counter "iterations" (the backend's) takes the place of Google Benchmark's own.
        for counter in ("iterations", "geometry_change", "geometry_change_L", "relative_residual", "success",
                        "elements", "nodes"):
            records[backend][counter] = b.get(counter)
    return records


def median(values):
    values = [v for v in values if v is not None]
    return statistics.median(values) if values else None


def same(values):
    """The one value of a list of equal values, else None."""
    return values[0] if values and all(v == values[0] for v in values) else None


def fmt_s(x):
    if x is None:
        return "–"
    return f"{x:.3g}" if x >= 0.001 else f"{x:.2e}"


def fmt_change(x):
    return "–" if x is None else f"{x:.4g}"


def fmt_it(values):
    v = same(values)
    if v is not None:
        return f"{v:g}"
    return "/".join(f"{x:g}" for x in values if x is not None) or "–"


def summarise(rows_old, rows_new, time_limit, noise):
    """One table row from the per-round records of both sides."""
    t_old = [r["seconds"] for r in rows_old]
    t_new = [r["seconds"] for r in rows_new]
    m_old, m_new = median(t_old), median(t_new)
    ratio = m_new / m_old if m_old and m_new else None
    c_old, c_new = median([r["cpu_seconds"] for r in rows_old]), median([r["cpu_seconds"] for r in rows_new])
    separated = max(t_new) < min(t_old) or min(t_new) > max(t_old)
    outside = separated and ratio is not None and abs(ratio - 1.0) > noise
    # A solve counts as timed out at 95 % of the limit (the backends stop at their
    # next check of the clock, shortly after it).
    timed_out = {"old": any(t >= 0.95 * time_limit for t in t_old), "new": any(t >= 0.95 * time_limit for t in t_new)}
    it_old, it_new = [r["iterations"] for r in rows_old], [r["iterations"] for r in rows_new]
    ch_old, ch_new = median([r["geometry_change"] for r in rows_old]), median([r["geometry_change"] for r in rows_new])
    return {
        "old_s": m_old, "new_s": m_new, "ratio": ratio, "cpu_ratio": c_new / c_old if c_old and c_new else None,
        "outside_noise": outside, "separated": separated,
        "old_spread": (max(t_old) - min(t_old)) / m_old if m_old else None,
        "new_spread": (max(t_new) - min(t_new)) / m_new if m_new else None,
        "old_iterations": it_old, "new_iterations": it_new,
        "old_change": ch_old, "new_change": ch_new,
        "old_status": same([r["status"] for r in rows_old]) or "/".join(r["status"] for r in rows_old),
        "new_status": same([r["status"] for r in rows_new]) or "/".join(r["status"] for r in rows_new),
        "old_elements": same([r["elements"] for r in rows_old]),
        "new_elements": same([r["elements"] for r in rows_new]),
        "old_nodes": same([r["nodes"] for r in rows_old]), "new_nodes": same([r["nodes"] for r in rows_new]),
        "timed_out": timed_out,
        "iterations_agree": same(it_old) is not None and same(it_old) == same(it_new),
        "same_scene": (same([r["elements"] for r in rows_old]), same([r["nodes"] for r in rows_old]))
        == (same([r["elements"] for r in rows_new]), same([r["nodes"] for r in rows_new])),
        "change_agrees": ch_old is not None and ch_new is not None
        and abs(ch_old - ch_new) <= 1e-6 * max(1.0, abs(ch_old), abs(ch_new)),
    }


def mark_same_path(table):
    for _, s in table:
        s["same_path"] = s["same_scene"] and s["iterations_agree"] and s["change_agrees"]


def write_report(path, args, command, commits, takes, started, loads, table, scenes):
    lines = ["# Layout before and after: compare_bench medians of two commits", "",
             "Generated by `/usr/bin/python3 bench/scripts/before_after.py`; do not edit by hand.", "",
             f"- command: `{command}`",
             f"- old commit: {commits['old']} ({git('log', '-1', '--format=%ad', '--date=short', commits['old'])})",
             f"- new commit: {commits['new']} ({git('log', '-1', '--format=%ad', '--date=short', commits['new'])})",
             *[f"- the {side} side built with {path} as of {source}" for side in ("old", "new")
               for source, path in takes[side]],
             f"- date: {started}; load average at the start: {loads[0]}, at the end: {loads[-1]}, "
             f"highest at the start of a run: {max(loads, key=lambda s: float(s.split()[0]))}",
             f"- machine: {machine()}", ""]
    lines += [f"{args.rounds} rounds; in each round, scene by scene, the old binary runs every backend once, "
              "then the new one (interleaved, so that load changes hit both). Google Benchmark repeats a solve "
              f"for at least {args.min_time} s and reports the mean; time limit {args.time_limit} s per solve; "
              "one OpenBLAS thread. Times are wall seconds of one solve, medians over the rounds; ratio = "
              "new/old of the medians (CPU: the same for the process's CPU time, which a busy machine disturbs "
              "less); spread = (max - min)/median over the rounds. "
              f"**outside noise**: the two sides' round times do not overlap and the ratio is off by more than "
              f"{args.noise:.0%}. it = the backend's iterations (one value when every round agreed); change = "
              "geometry change (m) of the verified answer. Scenes: the compare/ scenes of both binaries except "
              "the towers; " + ", ".join(scenes) + ".", ""]
    lines += ["| scene | backend | old s | new s | new/old | spread old / new | CPU new/old | it old | it new "
              "| change old | change new | status old / new |",
              "|---|---|---:|---:|---:|---|---:|---:|---:|---:|---:|---|"]
    for (scene, backend), s in table:
        ratio = "–" if s["ratio"] is None else f"{s['ratio']:.2f}"
        ratio += " **outside noise**" if s["outside_noise"] else ""
        spread = f"{s['old_spread']:.0%} / {s['new_spread']:.0%}" if s["old_spread"] is not None else "–"
        cpu = "–" if s["cpu_ratio"] is None else f"{s['cpu_ratio']:.2f}"
        lines.append(f"| {scene} | {backend} | {fmt_s(s['old_s'])} | {fmt_s(s['new_s'])} | {ratio} | {spread} | {cpu} "
                     f"| {fmt_it(s['old_iterations'])} | {fmt_it(s['new_iterations'])} "
                     f"| {fmt_change(s['old_change'])} | {fmt_change(s['new_change'])} "
                     f"| {s['old_status']} / {s['new_status']} |")
    lines.append("")
    ratios = [s["ratio"] for _, s in table if s["ratio"] is not None]
    both_out = [k for k, s in table if s["timed_out"]["old"] and s["timed_out"]["new"]]
    timed = [s["ratio"] for k, s in table if s["ratio"] is not None and k not in both_out]
    lines.append("## Summary")
    lines.append("")
    if ratios:
        lines.append(f"- median ratio new/old over all {len(ratios)} rows: {statistics.median(ratios):.2f} "
                     f"(range {min(ratios):.2f} to {max(ratios):.2f})")
    if timed and len(timed) != len(ratios):
        lines.append(f"- without the {len(both_out)} rows where both sides ran into the time limit: "
                     f"{statistics.median(timed):.2f} over {len(timed)} rows")
    agree = [s for _, s in table if s["same_path"] and s["ratio"] is not None]
    if agree:
        lines.append(f"- rows where both commits take the same path (same scene size, equal iterations and "
                     f"geometry change): "
                     f"median ratio {statistics.median(s['ratio'] for s in agree):.2f} over {len(agree)} rows "
                     f"(range {min(s['ratio'] for s in agree):.2f} to {max(s['ratio'] for s in agree):.2f}; "
                     f"CPU time {statistics.median(s['cpu_ratio'] for s in agree):.2f}), "
                     f"{sum(s['outside_noise'] for s in agree)} of them outside noise")
    for group in ("reference", "character"):
        g = [s["ratio"] for (scene, _), s in table if kind(scene) == group and s["ratio"] is not None]
        if g:
            lines.append(f"- {group} scenes: median ratio {statistics.median(g):.2f} over {len(g)} rows")
    outside = [f"{scene}/{backend} ({s['ratio']:.2f})" for (scene, backend), s in table if s["outside_noise"]]
    lines.append("- outside noise: " + (", ".join(outside) if outside else "none"))
    timed_out = [f"{scene}/{backend} ({'/'.join(side for side in ('old', 'new') if s['timed_out'][side])})"
                 for (scene, backend), s in table if s["timed_out"]["old"] or s["timed_out"]["new"]]
    lines.append(f"- ran into the {args.time_limit} s time limit: " + (", ".join(timed_out) if timed_out else "none"))
    differ = [f"{scene}/{backend}" for (scene, backend), s in table
              if not (s["iterations_agree"] and s["change_agrees"])]
    lines.append("- iterations or geometry change differ: " + (", ".join(differ) if differ else "none"))
    changed_scenes = sorted({scene for (scene, _), s in table
                             if (s["old_elements"], s["old_nodes"]) != (s["new_elements"], s["new_nodes"])})
    for scene in changed_scenes:
        s = next(v for (sc, _), v in table if sc == scene)
        lines.append(f"- scene {scene} differs between the commits: {s['old_elements']:g} elements, "
                     f"{s['old_nodes']:g} nodes (old) against {s['new_elements']:g} elements, "
                     f"{s['new_nodes']:g} nodes (new)")
    lines.append("")
    with open(path, "w") as f:
        f.write("\n".join(lines))


def write_raw(f, raw):
    """The raw records as JSON, one run a line."""
    f.write('{"provenance": ' + json.dumps(raw["provenance"], indent=1) + ',\n"runs": [\n')
    def compact(run):
        return {k: float(f"{v:.6g}") if isinstance(v, float) else v for k, v in run.items()
                if k != "geometry_change_L" and not (k == "error" and not v)}
    f.write(",\n".join(json.dumps(compact(r), sort_keys=True) for r in raw["runs"]))
    f.write("\n]}\n")


def parse_args():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("old")
    p.add_argument("new")
    p.add_argument("--rounds", type=int, default=7, help="interleaved runs of each binary (at least 3)")
    p.add_argument("--time-limit", type=float, default=10.0, help="seconds per solve (compare_bench --time_limit)")
    p.add_argument("--min-time", type=float, default=0.2, help="Google Benchmark's --benchmark_min_time")
    p.add_argument("--noise", type=float, default=0.10, help="relative change a separated row must exceed")
    p.add_argument("--scenes", default="", help="comma-separated subset of the common scenes")
    p.add_argument("--work", default=os.path.join(ROOT, "build", "before-after"))
    p.add_argument("--jobs", type=int, default=2)
    p.add_argument("--take", action="append", default=[], metavar="SIDE:COMMIT:PATH",
                   help="build SIDE (old or new) with PATH as of COMMIT, e.g. a one-line fix of a work-in-progress "
                        "commit's benchmark; recorded in the output")
    p.add_argument("--out", default=os.path.join(ROOT, "docs", "figures", "layout-before-after.md"))
    args = p.parse_args()
    if args.rounds < 3:
        p.error("--rounds must be at least 3 (a median of fewer says nothing about noise)")
    args.takes = {"old": [], "new": []}
    for spec in args.take:
        side, source, path = (spec.split(":", 2) + ["", ""])[:3]
        if side not in args.takes or not source or not path:
            p.error(f"--take {spec}: expected old|new:COMMIT:PATH")
        args.takes[side].append((git("rev-parse", source + "^{commit}"), path))
    return args


def common_scenes(binaries, wanted):
    """The non-tower compare/ scenes of both binaries, reference scenes first, and
    for each the backends of BACKENDS that both have."""
    lists = {side: listed(binaries[side]) for side in ("old", "new")}
    scenes = [s for s in lists["old"] if s in lists["new"] and kind(s) != "tower" and (not wanted or s in wanted)]
    scenes.sort(key=lambda s: (kind(s) != "reference", s))
    only = sorted(set(lists["old"]) ^ set(lists["new"]))
    if only:
        print("scenes in one version only (skipped):", ", ".join(only))
    return scenes, {s: [b for b in BACKENDS if b in lists["old"][s] and b in lists["new"][s]] for s in scenes}


def run_rounds(binaries, scenes, backends, args, runs_dir, log, loads):
    """Old then new, scene by scene, `args.rounds` times; (scene, backend, side) -> records."""
    records = {}
    for rnd in range(args.rounds):
        for scene in scenes:
            for side in ("old", "new"):
                path = os.path.join(runs_dir, f"{rnd}-{scene}-{side}.json")
                loads.append(load_average())
                for backend, rec in run_once(binaries[side], scene, backends[scene], args, path, log).items():
                    rec["round"] = rnd
                    records.setdefault((scene, backend, side), []).append(rec)
            print(f"round {rnd + 1}/{args.rounds} {scene}: " + ", ".join(
                f"{b} {records[(scene, b, 'old')][-1]['seconds']:.3g}/{records[(scene, b, 'new')][-1]['seconds']:.3g} s"
                for b in backends[scene]) + f"  (load {loads[-1]})", flush=True)
    return records


def main():
    args = parse_args()
    command = "/usr/bin/python3 bench/scripts/before_after.py " + " ".join(sys.argv[1:])
    commits = {"old": git("rev-parse", args.old + "^{commit}"), "new": git("rev-parse", args.new + "^{commit}")}
    os.makedirs(args.work, exist_ok=True)
    runs_dir = os.path.join(args.work, "runs-" + commits["old"][:12] + "-" + commits["new"][:12])
    shutil.rmtree(runs_dir, ignore_errors=True)
    os.makedirs(runs_dir)
    log = open(os.path.join(runs_dir, "log.txt"), "w")
    binaries = {}
    for side in ("old", "new"):
        print(f"== build {side} {commits[side][:12]}", flush=True)
        binaries[side] = build(commits[side], args.takes[side], args.work, args.jobs, log)
    scenes, backends = common_scenes(binaries, [s for s in args.scenes.split(",") if s])
    started = time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime())
    loads = [load_average()]
    records = run_rounds(binaries, scenes, backends, args, runs_dir, log, loads)
    loads.append(load_average())
    table = [((scene, b), summarise(records[(scene, b, "old")], records[(scene, b, "new")],
                                    args.time_limit, args.noise))
             for scene in scenes for b in backends[scene]]
    mark_same_path(table)
    os.makedirs(os.path.dirname(os.path.abspath(args.out)), exist_ok=True)
    write_report(args.out, args, command, commits, args.takes, started, loads, table, scenes)
    raw = {"provenance": {"command": command, "old_commit": commits["old"], "new_commit": commits["new"],
                          "takes": args.takes, "date": started, "machine": machine(),
                          "load_average_start": loads[0], "load_average_end": loads[-1], "load_averages": loads,
                          "settings": {"rounds": args.rounds, "time_limit_s": args.time_limit,
                                       "min_time_s": args.min_time, "noise": args.noise}},
           "runs": [dict(rec, scene=scene, backend=backend, side=side)
                    for (scene, backend, side), recs in sorted(records.items()) for rec in recs]}
    with open(os.path.splitext(args.out)[0] + ".json", "w") as f:
        write_raw(f, raw)
    print(open(args.out).read())

if __name__ == "__main__":
    main()
