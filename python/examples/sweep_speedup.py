"""Speed-up of a sweep on Dask LocalClusters of one and of two single-threaded
worker processes, with the same sweep in one process for reference, and a
check that every mode gives the same rows (all columns but the measured seconds;
rows that differ, solves whose path depends on the clock, are listed).

    PYTHONPATH=build/python /usr/bin/python3 python/examples/sweep_speedup.py [--set long] [--repeats 3]

--set mixed (default): 64 short solves (reference prisms and octahedra with and
without gravity, the characters, a chain; alternating-gn and ipopt).
--set long: 20 solves of about 0.2 to 2 s each (the puppy character at
"noise" 0.3 with seeds 1 to 20, ipopt).

Prints the median wall time of each mode, the speed-ups, and the machine's
load average (`uptime`) before and after (other work takes cores away).
"""
import os

# One BLAS thread in this process too, as in the workers: set before numpy loads OpenBLAS.
os.environ.update(OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1")

import argparse  # noqa: E402
import statistics  # noqa: E402
import subprocess  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

from distributed import Client, LocalCluster  # noqa: E402

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
    """Rows whose columns but `seconds` differ: a solve whose path depends on time (stopped by a clock)."""
    a, b = reference.drop(columns="seconds"), frame.drop(columns="seconds")
    assert (a["status"] == b["status"]).all() and (a["verified"] == b["verified"]).all()
    same = (a == b) | (a.isna() & b.isna())
    return [int(i) for i in a.index[~same.all(axis=1)]]


def timed(run):
    start = time.perf_counter()
    frame = run()
    return time.perf_counter() - start, frame


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--set", choices=["mixed", "long"], default="mixed")
    parser.add_argument("--solvers", default="alternating-gn,ipopt", help="solvers of --set mixed")
    args = parser.parse_args()
    grid = mixed_grid(args.solvers.split(",")) if args.set == "mixed" else long_grid()
    print(f"set {args.set}: {len(grid['scenes'])} scenes x {len(grid['perturbations'])} perturbations x "
          f"{len(grid['seeds'])} seeds x {len(grid['solvers'])} solvers")
    print(f"before: {uptime()}")
    times = {"serial": [], "cluster-1": [], "cluster-2": []}
    differing = set()
    with LocalCluster(n_workers=1, threads_per_worker=1, processes=True, dashboard_address=None) as one, \
            Client(one) as client_one, \
            LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as two, \
            Client(two) as client_two:
        for _ in range(args.repeats):
            seconds, serial = timed(lambda: tg.sweep(jobs=1, **grid))
            times["serial"].append(seconds)
            for mode, client in (("cluster-1", client_one), ("cluster-2", client_two)):
                seconds, frame = timed(lambda: tg.sweep(client=client, **grid))
                times[mode].append(seconds)
                differing.update(differing_rows(serial, frame))
    print(f"after:  {uptime()}")
    solver_seconds = serial["seconds"]
    print(f"{len(serial)} solves, {int((serial['status'] == 'converged').sum())} converged, "
          f"{int(serial['verified'].sum())} verified; same status and verdict in every mode; "
          f"rows differing in other columns: {sorted(differing) or 'none'}")
    for i in sorted(differing):
        print(f"  row {i}: {serial.iloc[i].to_dict()}")
    print(f"solver seconds per solve (last serial run): min {solver_seconds.min():.2f}, "
          f"median {solver_seconds.median():.2f}, max {solver_seconds.max():.2f}, sum {solver_seconds.sum():.2f}")
    medians = {mode: statistics.median(t) for mode, t in times.items()}
    labels = {"serial": "one process (jobs=1)", "cluster-1": "LocalCluster, 1 worker",
              "cluster-2": "LocalCluster, 2 workers"}
    for mode, t in times.items():
        print(f"{labels[mode]:<26} median wall {medians[mode]:.2f} s  (runs: {', '.join(f'{x:.2f}' for x in t)})")
    print(f"speed-up 2 workers over 1 worker: {medians['cluster-1'] / medians['cluster-2']:.2f}x; "
          f"over one process: {medians['serial'] / medians['cluster-2']:.2f}x")


if __name__ == "__main__":
    main()
