#!/usr/bin/env python3
"""Before/after medians of `tensegrity solve`: two binaries, same scenes, interleaved runs.

    /usr/bin/python3 bench/scripts/solve_before_after.py OLD_BINARY NEW_BINARY SCENE... \\
        [--solver alternating-gn] [--rounds 5] [--out FILE.md]

For every round and every scene the old binary solves, then the new one (one
OpenBLAS thread each), so that a change of the machine's load hits both sides
alike; the new binary also solves once with --no-skip, which shows the
backend's own share. Times are the solve's own seconds (its solution file's
stats.seconds), the driver's check included; a row's time is the median over
the rounds. Every solution is re-verified with the new binary's `check`, and
a row says whether both sides reached the same status and geometry change.
The binaries are the caller's (any two builds); the table records their paths,
the load average and the date. Standard library only.
"""
import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time


def solve(binary, scene, solver, out, extra=()):
    subprocess.run([binary, "solve", scene, "--solver", solver, "--quiet", "--out", out, *extra],
                   check=False, capture_output=True, env=dict(os.environ, OPENBLAS_NUM_THREADS="1"))
    with open(out) as f:
        d = json.load(f)
    return d["stats"]["seconds"], d["status"], d["stats"]["geometry_change"]


def verified(binary, scene, solution):
    return subprocess.run([binary, "check", scene, solution], capture_output=True).returncode == 0


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("old")
    ap.add_argument("new")
    ap.add_argument("scenes", nargs="+")
    ap.add_argument("--solver", default="alternating-gn")
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--out", help="Markdown table (default: standard output)")
    args = ap.parse_args()
    with open("/proc/loadavg") as f:
        load = " ".join(f.read().split()[:3])
    lines = [
        f"- command: `{' '.join([os.path.basename(sys.argv[0])] + sys.argv[1:])}`",
        f"- date: {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}; load average at the start: {load}",
        f"- old: `{args.old}`; new: `{args.new}`; solver `{args.solver}`; medians of {args.rounds} interleaved rounds",
        "",
        "| scene | old s | new s | new / old | new, --no-skip s | same answer | verified |",
        "|---|---:|---:|---:|---:|:-:|:-:|",
    ]
    with tempfile.TemporaryDirectory() as work:
        for scene in args.scenes:
            old_s, new_s = [], []
            old_answer = new_answer = None
            for _ in range(args.rounds):
                t, status, change = solve(args.old, scene, args.solver, os.path.join(work, "old.json"))
                old_s.append(t)
                old_answer = (status, change)
                t, status, change = solve(args.new, scene, args.solver, os.path.join(work, "new.json"))
                new_s.append(t)
                new_answer = (status, change)
            no_skip, _, _ = solve(args.new, scene, args.solver, os.path.join(work, "skip.json"), ["--no-skip"])
            ok = verified(args.new, scene, os.path.join(work, "old.json")) and verified(
                args.new, scene, os.path.join(work, "new.json"))
            old_m, new_m = statistics.median(old_s), statistics.median(new_s)
            lines.append(f"| {os.path.basename(scene)} | {old_m:.3g} | {new_m:.3g} | {new_m / old_m:.2f} | "
                         f"{no_skip:.3g} | {'yes' if old_answer == new_answer else 'NO'} | {'yes' if ok else 'NO'} |")
    text = "\n".join(lines) + "\n"
    if args.out:
        with open(args.out, "w") as f:
            f.write(text)
    else:
        sys.stdout.write(text)


if __name__ == "__main__":
    main()
