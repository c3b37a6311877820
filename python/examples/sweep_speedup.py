"""Speed-up of a sweep on Dask LocalClusters of one and of two single-threaded
worker processes, with the same sweep in one process for reference, and a
check that every mode gives the same rows (all columns but the measured seconds;
rows that differ, solves whose path depends on the clock, are listed).

    PYTHONPATH=build/python /usr/bin/python3 python/examples/sweep_speedup.py [--set long] [--repeats 3] [--lean-dask]

--set mixed (default): 64 short solves (reference prisms and octahedra with and
without gravity, the characters, a chain; alternating-gn and ipopt).
--set long: 20 solves of about 0.2 to 4 s each (the puppy character at
"noise" 0.3 with seeds 1 to 20, ipopt).

Each repeat runs the three modes in turn; a cluster is started for its own run
and closed after it (its start and one untimed warm-up solve per worker are not
timed). Prints the median wall time of each mode, the solver seconds summed over
the solves of each mode (the `seconds` column: a solve slowed down inside a
worker shows here, overhead around the solves does not), the CPU seconds of all
the processes of each mode (this one, the workers, their nannies), the speed-ups, and the
machine's load average (`uptime`) before and after (other work takes cores away).
"""
import os

# One BLAS thread in this process too, as in the workers: set before numpy loads OpenBLAS.
os.environ.update(OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1")

import argparse  # noqa: E402
import resource  # noqa: E402
import statistics  # noqa: E402
import subprocess  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

from distributed import Client, LocalCluster  # noqa: E402

import dask  # noqa: E402
import tensegrity as tg  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]


def character(name):
    return tg.build_character(str(ROOT / "data" / "characters" / f"{name}.character.json"))


def mixed_grid(solvers):
    scenes = {
        "prism-6": tg.prism(6),
        "prism-9-gravity": tg.prism(9, strut_mass=0.1, gravity=True, fix_bottom=True),
        "octahedron": tg.octahedron(),
        "octahedron-gravity": tg.octahedron(strut_mass=0.1, gravity=True, fix_bottom=True),
        "chain-8": tg.chain(8),
    }
    for name in ("duck", "scorpion", "puppy"):
        scenes[name] = character(name)
    return dict(scenes=scenes, solvers=solvers, perturbations=["noise:0.01", "noise:0.03"], seeds=[1, 2],
                time_limit=30.0)


LONG_SEEDS = list(range(1, 21))


def long_grid():
    return dict(scenes={"puppy": character("puppy")}, solvers=["ipopt"],
                perturbations=["noise:0.3"], seeds=LONG_SEEDS, time_limit=30.0)


def uptime():
    return subprocess.run(["uptime"], capture_output=True, text=True).stdout.strip()


def differing_rows(reference, frame):
    """Indices of the rows whose columns but `seconds` differ: a solve whose path
    depends on time (stopped by a clock), or a row that is not a pure function of
    its grid point."""
    a, b = reference.drop(columns="seconds"), frame.drop(columns="seconds")
    same = (a == b) | (a.isna() & b.isna())
    return [int(i) for i in a.index[~same.all(axis=1)]]


#: --lean-dask: no statistical profiler in the workers (a stack sample every 10 ms) and an
#: event-loop health check every second instead of every 20 ms, in every process of a cluster.
LEAN_DASK = {"distributed.worker.profile.enabled": False, "distributed.admin.tick.interval": "1s"}

#: Worker processes of each mode (0: the sweep runs in this process, jobs=1).
MODES = {"serial": 0, "cluster-1": 1, "cluster-2": 2}


def cpu_seconds():
    """User + system CPU seconds of the calling process so far."""
    usage = resource.getrusage(resource.RUSAGE_SELF)
    return usage.ru_utime + usage.ru_stime


def cluster_cpu_seconds(client):
    """CPU seconds of this process (client and scheduler), the workers and their nannies."""
    return cpu_seconds() + sum(client.run(cpu_seconds).values()) + sum(client.run(cpu_seconds, nanny=True).values())


def timed_mode(workers, grid):
    """(wall seconds, CPU seconds, frame) of one sweep; the CPU seconds of all the
    processes of the mode, which other work on the machine inflates less than the
    wall time. A cluster lives only for its own run, so no idle cluster shares the
    cores; starting it and one untimed solve per worker (which imports the module
    there) are not timed."""
    if workers == 0:
        cpu, start = cpu_seconds(), time.perf_counter()
        frame = tg.sweep(jobs=1, **grid)
        return time.perf_counter() - start, cpu_seconds() - cpu, frame
    with LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None) as cluster, \
            Client(cluster) as client:
        client.run(lambda: tg.solve(tg.prism(3), solver="alternating-gn").status)
        cpu, start = cluster_cpu_seconds(client), time.perf_counter()
        frame = tg.sweep(client=client, **grid)
        wall = time.perf_counter() - start
        return wall, cluster_cpu_seconds(client) - cpu, frame


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--set", choices=["mixed", "long"], default="mixed")
    parser.add_argument("--solvers", default="alternating-gn,ipopt", help="solvers of --set mixed")
    parser.add_argument("--lean-dask", action="store_true", help=f"clusters with {LEAN_DASK}")
    args = parser.parse_args()
    if args.lean_dask:
        dask.config.set(LEAN_DASK)
    grid = mixed_grid(args.solvers.split(",")) if args.set == "mixed" else long_grid()
    print(f"set {args.set}: {len(grid['scenes'])} scenes x {len(grid['perturbations'])} perturbations x "
          f"{len(grid['seeds'])} seeds x {len(grid['solvers'])} solvers")
    print(f"before: {uptime()}")
    times = {mode: [] for mode in MODES}
    solver_sums = {mode: [] for mode in MODES}
    cpu = {mode: [] for mode in MODES}
    differing = {}  # row index -> [(mode, row)] of the rows that differ from the serial row
    for _ in range(args.repeats):
        for mode, workers in MODES.items():
            seconds, cpu_used, frame = timed_mode(workers, grid)
            cpu[mode].append(cpu_used)
            if workers == 0:
                serial = frame
            else:
                for i in differing_rows(serial, frame):
                    differing.setdefault(i, []).append((mode, serial.iloc[i].to_dict(), frame.iloc[i].to_dict()))
            times[mode].append(seconds)
            solver_sums[mode].append(float(frame["seconds"].sum()))
    print(f"after:  {uptime()}")
    print(f"{len(serial)} solves, {int((serial['status'] == 'converged').sum())} converged, "
          f"{int(serial['verified'].sum())} verified (last serial run); "
          f"rows differing from the serial row in any column but seconds: {sorted(differing) or 'none'}")
    for i in sorted(differing):
        for mode, serial_row, row in differing[i]:
            print(f"  row {i}, {mode}:\n    serial {serial_row}\n    {mode} {row}")
    solver_seconds = serial["seconds"]
    print(f"solver seconds per solve (last serial run): min {solver_seconds.min():.2f}, "
          f"median {solver_seconds.median():.2f}, max {solver_seconds.max():.2f}")
    medians = {mode: statistics.median(t) for mode, t in times.items()}
    labels = {"serial": "one process (jobs=1)", "cluster-1": "LocalCluster, 1 worker",
              "cluster-2": "LocalCluster, 2 workers"}
    for mode, t in times.items():
        print(f"{labels[mode]:<26} median wall {medians[mode]:.2f} s  (runs: {', '.join(f'{x:.2f}' for x in t)}); "
              f"solver seconds summed over the solves: median {statistics.median(solver_sums[mode]):.2f} s "
              f"(runs: {', '.join(f'{x:.2f}' for x in solver_sums[mode])}); "
              f"CPU seconds of all its processes: median {statistics.median(cpu[mode]):.2f} s "
              f"(runs: {', '.join(f'{x:.2f}' for x in cpu[mode])})")
    print(f"speed-up 2 workers over 1 worker: {medians['cluster-1'] / medians['cluster-2']:.2f}x; "
          f"over one process: {medians['serial'] / medians['cluster-2']:.2f}x")


if __name__ == "__main__":
    main()
