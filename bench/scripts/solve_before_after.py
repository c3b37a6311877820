#!/usr/bin/env python3
"""Before/after medians of `tensegrity solve`: two binaries, same scenes, interleaved runs.

    /usr/bin/python3 bench/scripts/solve_before_after.py OLD_BINARY NEW_BINARY SCENE... \\
        [--solver alternating-gn] [--rounds 5] [--blas-as-installed] [--out FILE.md]

For every round and every scene the old binary solves, then the new one (one
OpenBLAS thread each, through OPENBLAS_NUM_THREADS=1; with --blas-as-installed
the variable is left as the caller has it, as a user runs the program), so
that a change of the machine's load hits both sides alike; the new binary
also solves once with --no-skip, which shows the backend's own share. Times
are the solve's own seconds (its solution file's stats.seconds), the driver's
check included, and the CPU seconds of the whole process (every thread, the
program's start included); a row's time is the median over the rounds. Every solution is re-verified with the new binary's `check`, and
a row says whether both sides reached the same status and geometry change.
The binaries are the caller's (any two builds); the table records their paths,
the load average and the date. Standard library only.
"""
import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time


def children_cpu_seconds():
    u = resource.getrusage(resource.RUSAGE_CHILDREN)
    return u.ru_utime + u.ru_stime


def solve(binary, scene, solver, out, env, extra=()):
    """The solve's own seconds, its status and geometry change, and the process's CPU seconds."""
    cpu = children_cpu_seconds()
    subprocess.run([binary, "solve", scene, "--solver", solver, "--quiet", "--out", out, *extra],
                   check=False, capture_output=True, env=env)
    cpu = children_cpu_seconds() - cpu
    with open(out) as f:
        d = json.load(f)
    return d["stats"]["seconds"], d["status"], d["stats"]["geometry_change"], cpu


def verified(binary, scene, solution):
    return subprocess.run([binary, "check", scene, solution], capture_output=True).returncode == 0


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("old")
    ap.add_argument("new")
    ap.add_argument("scenes", nargs="+")
    ap.add_argument("--solver", default="alternating-gn")
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--blas-as-installed", action="store_true",
                    help="leave OPENBLAS_NUM_THREADS as it is (default: set it to 1)")
    ap.add_argument("--out", help="Markdown table (default: standard output)")
    args = ap.parse_args()
    env = dict(os.environ) if args.blas_as_installed else dict(os.environ, OPENBLAS_NUM_THREADS="1")
    with open("/proc/loadavg") as f:
        load = " ".join(f.read().split()[:3])
    lines = [
        f"- command: `{' '.join([os.path.basename(sys.argv[0])] + sys.argv[1:])}`",
        f"- date: {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}; load average at the start: {load}",
        f"- old: `{args.old}`; new: `{args.new}`; solver `{args.solver}`; medians of {args.rounds} interleaved rounds",
        "",
        f"- OPENBLAS_NUM_THREADS: {env.get('OPENBLAS_NUM_THREADS', 'unset')}",
        "",
        "| scene | old s | new s | new / old | new, --no-skip s | old CPU s | new CPU s | CPU new / old "
        "| same answer | verified |",
        "|---|---:|---:|---:|---:|---:|---:|---:|:-:|:-:|",
    ]
    with tempfile.TemporaryDirectory() as work:
        for scene in args.scenes:
            old_s, new_s, old_cpu, new_cpu = [], [], [], []
            old_answer = new_answer = None
            for _ in range(args.rounds):
                t, status, change, cpu = solve(args.old, scene, args.solver, os.path.join(work, "old.json"), env)
                old_s.append(t)
                old_cpu.append(cpu)
                old_answer = (status, change)
                t, status, change, cpu = solve(args.new, scene, args.solver, os.path.join(work, "new.json"), env)
                new_s.append(t)
                new_cpu.append(cpu)
                new_answer = (status, change)
            no_skip = solve(args.new, scene, args.solver, os.path.join(work, "skip.json"), env, ["--no-skip"])[0]
            ok = verified(args.new, scene, os.path.join(work, "old.json")) and verified(
                args.new, scene, os.path.join(work, "new.json"))
            old_m, new_m = statistics.median(old_s), statistics.median(new_s)
            old_c, new_c = statistics.median(old_cpu), statistics.median(new_cpu)
            lines.append(f"| {os.path.basename(scene)} | {old_m:.3g} | {new_m:.3g} | {new_m / old_m:.2f} | "
                         f"{no_skip:.3g} | {old_c:.3g} | {new_c:.3g} | {new_c / old_c:.2f} | "
                         f"{'yes' if old_answer == new_answer else 'NO'} | {'yes' if ok else 'NO'} |")
    text = "\n".join(lines) + "\n"
    if args.out:
        with open(args.out, "w") as f:
            f.write(text)
    else:
        sys.stdout.write(text)


if __name__ == "__main__":
    main()
