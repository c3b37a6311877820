"""Sweeps: the same rows serially, on local worker processes and on a Dask LocalCluster."""
import os
import platform
import subprocess
import sys
import threading
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import tensegrity as tg

SOLVERS = ["alternating-gn", "ipopt"]


def grid_scenes():
    return {"prism-3": tg.prism(3), "prism-5-gravity": tg.prism(5, strut_mass=0.1, gravity=True, fix_bottom=True),
            "octahedron": tg.octahedron()}


def sweep_kwargs():
    return dict(solvers=SOLVERS, perturbations=["noise:0.01", "twist:5deg"], seeds=[1, 2], time_limit=30.0)


def without_time(frame):
    return frame.drop(columns=["seconds"])


@pytest.fixture(scope="module")
def serial():
    return tg.sweep(grid_scenes(), jobs=1, **sweep_kwargs())


def test_serial_sweep_rows(serial):
    assert list(serial.columns) == tg.SWEEP_COLUMNS
    assert len(serial) == 3 * 2 * 2 * 2
    assert serial["seed"].dtype == np.int64 and serial["verified"].dtype == bool
    assert (serial["status"] == "converged").all(), serial[serial["status"] != "converged"]
    assert serial["verified"].all()
    assert (serial["relative_residual"] <= 1e-8).all()
    # Under gravity the load sets the force scale: a noisy scene may still stand.
    noisy = (serial["perturbation"] == "noise:0.01") & ~serial["scene"].str.contains("gravity")
    assert (serial.loc[noisy, "geometry_change"] > 0).all()
    assert (serial["geometry_change"] >= 0).all()
    first = serial.iloc[0]
    assert (first["scene"], first["perturbation"], first["seed"], first["solver"]) == \
        ("prism-3", "noise:0.01", 1, "alternating-gn")
    # A row is the solve of its grid point: the same numbers as tg.solve on the same perturbed scene.
    scene = tg.stress_case(tg.prism(3), "noise", 2, 0, 1)
    result = tg.solve(scene, solver="alternating-gn", time_limit=30.0)
    assert first["iterations"] == result.stats["iterations"]
    assert first["geometry_change"] == result.stats["geometry_change"]


def test_local_processes_give_the_serial_rows(serial):
    parallel = tg.sweep(grid_scenes(), jobs=2, **sweep_kwargs())
    pd.testing.assert_frame_equal(without_time(parallel), without_time(serial))


def test_dask_local_cluster_gives_the_serial_rows(serial):
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster, distributed.Client(cluster) as client:
        on_cluster = tg.sweep(grid_scenes(), client=client, **sweep_kwargs())
    pd.testing.assert_frame_equal(without_time(on_cluster), without_time(serial))


def test_unperturbed_and_callable_perturbations():
    def shift_up(scene, seed):
        return tg.Scene(scene.positions + [0.0, 0.0, float(seed)], scene.elements, scene.kinds, name=scene.name)

    frame = tg.sweep([tg.prism(4)], "alternating-gn", perturbations=[None, shift_up], seeds=[3], jobs=1)
    assert frame["perturbation"].tolist() == ["none", "shift_up"]
    assert frame["status"].tolist() == ["converged", "converged"]
    assert frame["geometry_change"].tolist() == [0.0, 0.0]  # already in equilibrium, moved or not
    assert frame["seed"].tolist() == [3, 3]


def test_bad_sweep_input_raises_before_solving():
    with pytest.raises(ValueError, match="no-such"):
        tg.sweep([tg.prism(3)], ["no-such"], jobs=1)
    with pytest.raises(ValueError, match="no-family"):
        tg.sweep([tg.prism(3)], ["ipopt"], perturbations=["no-family:0"], jobs=1)
    with pytest.raises(ValueError, match="level index"):
        tg.sweep([tg.prism(3)], ["ipopt"], perturbations=["noise:99"], jobs=1)


def test_the_gil_is_released_while_solving():
    # While a thread is inside the C++ solve, the main thread keeps running Python:
    # with the GIL held it could not run a single loop pass until the solve ended.
    # The 48-block chain takes tens of milliseconds, so that a busy machine that
    # holds the main thread back for a while still leaves it far above the bound.
    scene = tg.stress_case(tg.chain(48), "noise", 4, 0, 1)
    results = []
    solver = threading.Thread(target=lambda: results.append(tg.solve(scene, solver="ipopt")))
    passes = 0
    solver.start()
    while solver.is_alive():
        passes += 1
    solver.join()
    assert results[0].status == "converged"
    assert passes > 1000


def test_threads_give_the_same_result():
    scene = tg.stress_case(tg.octahedron(), "noise", 4, 0, 1)
    results = [None] * 4

    def work(i):
        results[i] = tg.solve(scene, solver="ipopt")

    workers = [threading.Thread(target=work, args=(i,)) for i in range(4)]
    for w in workers:
        w.start()
    for w in workers:
        w.join()
    assert all(r.status == "converged" for r in results)
    assert all(np.array_equal(r.positions, results[0].positions) for r in results)
    assert all(np.array_equal(r.forces, results[0].forces) for r in results)


# Run under MALLOC_TRIM_THRESHOLD_=65536, as a Dask nanny starts its workers: the
# minor page faults of a repeated ipopt solve before and after _prepare_worker.
_FAULTS_OF_A_REPEATED_SOLVE = """
import resource
import tensegrity as tg
from tensegrity.sweep import _prepare_worker

scene = tg.stress_case(tg.build_character(CHARACTER), "noise", 2, 0, 1)

# Ipopt's two runs from alternating-gn's equilibrium and the scene: many factorizations.
def faults_of_a_repeated_solve():
    tg.solve(scene, solver="ipopt", options={"start": "auto"})
    before = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
    assert tg.solve(scene, solver="ipopt", options={"start": "auto"}).status == "converged"
    return resource.getrusage(resource.RUSAGE_SELF).ru_minflt - before

untuned = faults_of_a_repeated_solve()
_prepare_worker()
print(untuned, faults_of_a_repeated_solve())
"""


@pytest.mark.skipif(platform.libc_ver()[0] != "glibc", reason="the malloc thresholds are glibc's")
def test_a_dask_style_worker_reuses_freed_buffers(root):
    # With the nanny's trim threshold glibc maps each large buffer of the factorization
    # anew and the kernel zero-fills it page by page; a prepared worker reuses its heap.
    character = str(root / "data" / "characters" / "puppy.character.json")
    env = dict(os.environ, MALLOC_TRIM_THRESHOLD_="65536", PYTHONPATH=str(Path(tg.__file__).parents[1]))
    out = subprocess.run([sys.executable, "-c", f"CHARACTER = {character!r}\n" + _FAULTS_OF_A_REPEATED_SOLVE],
                         env=env, capture_output=True, text=True, check=True).stdout
    untuned, tuned = (int(x) for x in out.split())
    assert untuned > 1000, out
    assert tuned * 10 < untuned, out


def test_unperturbed_scene_is_solved_once_and_rejections_say_why():
    def self_loop(scene, seed):
        return tg.Scene(scene.positions, [[0, 0]] + scene.elements.tolist()[1:], scene.kinds, name="broken")

    frame = tg.sweep([tg.prism(4, twist_offset=0.1)], "alternating-gn", perturbations=[None, self_loop],
                     seeds=[1, 2, 3], jobs=1)
    assert frame["seed"].tolist() == [1, 2, 3, 1, 2, 3]
    unperturbed = frame[frame["perturbation"] == "none"]
    assert (unperturbed["status"] == "converged").all()
    # One solve, its row under every seed: the same measured seconds.
    assert unperturbed["seconds"].nunique() == 1 and unperturbed["geometry_change"].iloc[0] > 0
    rejected = frame[frame["perturbation"] == "self_loop"]
    assert (rejected["status"] == "rejected").all()
    assert rejected["message"].tolist() == \
        ["tensegrity: broken: elements[0].nodes: element joins node 0 to itself"] * 3
    assert frame["message"].dtype == object
