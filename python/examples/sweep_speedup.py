"""Speed-up of a sweep on a two-worker Dask LocalCluster over the same sweep in
one process, on a mixed set of scenes (reference prisms and octahedra with and
without gravity, the characters, a chain), with a check that both give the same
rows (all columns but the measured seconds).

    PYTHONPATH=build/python /usr/bin/python3 python/examples/sweep_speedup.py [--repeats 3]

Prints the median wall time of each mode, the speed-up, and the load average
of the machine before and after (other work on the machine takes cores away).
"""
import argparse
import os
import statistics
import time
from pathlib import Path

import pandas as pd
from distributed import Client, LocalCluster

import tensegrity as tg

ROOT = Path(__file__).resolve().parents[2]


def mixed_scenes():
    scenes = {
        "prism-6": tg.prism(6),
        "prism-9-gravity": tg.prism(9, strut_mass=0.1, gravity=True, fix_bottom=True),
        "octahedron": tg.octahedron(),
        "octahedron-gravity": tg.octahedron(strut_mass=0.1, gravity=True, fix_bottom=True),
        "chain-8": tg.chain(8),
    }
    for name in ("duck", "scorpion", "puppy"):
        scenes[name] = tg.build_character(str(ROOT / "data" / "characters" / f"{name}.character.json"))
    return scenes


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--solvers", default="alternating-gn,ipopt")
    args = parser.parse_args()
    os.environ.update(OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1")
    grid = dict(scenes=mixed_scenes(), solvers=args.solvers.split(","),
                perturbations=["noise:0.01", "noise:0.03"], seeds=[1, 2], time_limit=30.0)
    print(f"grid: {len(grid['scenes'])} scenes x 2 perturbations x 2 seeds x {len(grid['solvers'])} solvers; "
          f"load average before: {os.getloadavg()[0]:.1f}")
    serial_times, cluster_times = [], []
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster, \
            Client(cluster) as client:
        for _ in range(args.repeats):
            start = time.perf_counter()
            serial = tg.sweep(jobs=1, **grid)
            serial_times.append(time.perf_counter() - start)
            start = time.perf_counter()
            on_cluster = tg.sweep(client=client, **grid)
            cluster_times.append(time.perf_counter() - start)
            pd.testing.assert_frame_equal(serial.drop(columns="seconds"), on_cluster.drop(columns="seconds"))
    s, c = statistics.median(serial_times), statistics.median(cluster_times)
    print(f"{len(serial)} solves, {int((serial['status'] == 'converged').sum())} converged, "
          f"{int(serial['verified'].sum())} verified; rows identical serial vs cluster: yes")
    print(f"sum of solver seconds (serial run): {serial['seconds'].sum():.2f} s")
    print(f"serial (1 process)       median wall {s:.2f} s  (runs: {', '.join(f'{t:.2f}' for t in serial_times)})")
    print(f"LocalCluster (2 workers) median wall {c:.2f} s  (runs: {', '.join(f'{t:.2f}' for t in cluster_times)})")
    print(f"speed-up {s / c:.2f}x; load average after: {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main()
