"""Grids of solves (scenes x perturbations x seeds x solvers) on a Dask cluster
or on local worker processes, gathered into one pandas DataFrame.

Every solve is a pure function of its grid point (scene, perturbation, seed,
solver, options): the perturbed scene comes from a generator seeded by the
grid point, so the rows do not depend on where or in which order the solves
ran. Only the ``seconds`` column (measured solver time) differs between runs.
"""
import concurrent.futures
import multiprocessing
import os
from pathlib import Path

from . import _core
from ._api import DEFAULT_TIME_LIMIT, _as_scene, _option_text, _prestress_factor

#: Columns of the DataFrame returned by :func:`sweep`, in order.
SWEEP_COLUMNS = [
    "scene", "perturbation", "seed", "solver", "status", "seconds", "iterations",
    "residual", "relative_residual", "geometry_change", "verified", "message",
]
_DTYPES = {
    "scene": object, "perturbation": object, "seed": "int64", "solver": object, "status": object,
    "seconds": "float64", "iterations": "int64", "residual": "float64",
    "relative_residual": "float64", "geometry_change": "float64", "verified": "bool", "message": object,
}
#: Status of a grid point whose perturbed scene breaks a rule of the model (not solved).
REJECTED = "rejected"
# Each solve uses one core; BLAS threads would only compete with the other workers.
_ONE_THREAD = {"OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}


def stress_family(base, family, trials=1, seed=1):
    """Yields ``(level_label, trial, scene)`` for every level of a stress-test
    family (see :func:`stress_families`) and every trial, as ``tensegrity
    stress-test`` builds them; deterministic in (base, family, level, trial, seed)."""
    base = _as_scene(base)
    for index, (_, label) in enumerate(_core.stress_levels(family)):
        for trial in range(trials):
            yield label, trial, _core.stress_case(base, family, index, trial, seed)


def _named_scenes(scenes):
    """[(name, Scene)] from a Scene, a path, a list of those, or a dict name -> Scene/path."""
    if isinstance(scenes, (_core.Scene, str, os.PathLike)):
        scenes = [scenes]
    if isinstance(scenes, dict):
        return [(str(name), _as_scene(s)) for name, s in scenes.items()]
    named = []
    for s in scenes:
        scene = _as_scene(s)
        if scene.name:
            name = scene.name
        elif isinstance(s, (str, os.PathLike)):
            name = Path(s).name.split(".")[0]
        else:
            name = f"scene-{len(named)}"
        named.append((name, scene))
    return named


def _perturbation_spec(p):
    """(label, spec) of one perturbation: None, "family:level" (level index or
    label), ("family", level index) or a callable (scene, seed) -> Scene."""
    if p is None:
        return "none", None
    if callable(p):
        return getattr(p, "__name__", repr(p)), p
    if isinstance(p, str):
        family, sep, level = p.partition(":")
        if not sep:
            raise ValueError(f"tensegrity: perturbation {p!r}: expected 'family:level'")
    else:
        family, level = p
    levels = _core.stress_levels(family)  # ValueError for an unknown family
    labels = [label for _, label in levels]
    if isinstance(level, str) and level in labels:
        index = labels.index(level)
    else:
        try:
            index = int(level)
        except (TypeError, ValueError):
            raise ValueError(f"tensegrity: perturbation {p!r}: level {level!r} is neither an index "
                             f"nor one of {labels}") from None
        if not 0 <= index < len(levels):
            raise ValueError(f"tensegrity: perturbation {p!r}: level index must be within 0..{len(levels) - 1}")
    return f"{family}:{labels[index]}", (family, index)


def _run_one(task):
    """One grid point, solved where it lands (a Dask worker, a local process or here)."""
    name, scene, label, spec, seed, solver, tol, time_limit, max_iterations, prestress_factor, options = task
    row = {"scene": name, "perturbation": label, "seed": seed, "solver": solver}
    try:
        if callable(spec):
            scene = spec(scene, seed)
        elif spec is not None:
            scene = _core.stress_case(scene, spec[0], spec[1], 0, seed)
    except ValueError as error:
        row.update(status=REJECTED, seconds=0.0, iterations=0, residual=float("nan"),
                   relative_residual=float("nan"), geometry_change=float("nan"), verified=False,
                   message=str(error))
        return row
    result = _core._solve(scene, solver, tol, time_limit, max_iterations, prestress_factor, True, False, options)
    stats = result.stats
    row.update(status=result.status, seconds=stats["seconds"], iterations=stats["iterations"],
               residual=stats["residual"], relative_residual=stats["relative_residual"],
               geometry_change=stats["geometry_change"], verified=bool(result.verify(tol).ok),
               message=result.message)
    return row


_worker_prepared = False


def _prepare_worker():
    """Once per worker process: malloc keeps freed buffers for the next solve.
    A Dask nanny sets MALLOC_TRIM_THRESHOLD_, which otherwise makes every large
    buffer of a factorization a fresh mmap (page faults on every solve)."""
    global _worker_prepared
    if not _worker_prepared:
        _core._keep_freed_memory_for_reuse()
        _worker_prepared = True


def _run_on_worker(task):
    """_run_one in a worker process (a Dask worker or a local pool process)."""
    _prepare_worker()
    return _run_one(task)


def _local_rows(tasks, jobs):
    if jobs == 1:
        return [_run_one(t) for t in tasks]
    saved = {k: os.environ.get(k) for k in _ONE_THREAD}
    os.environ.update(_ONE_THREAD)  # inherited by the worker processes started below
    try:
        context = multiprocessing.get_context("forkserver")
        with concurrent.futures.ProcessPoolExecutor(max_workers=jobs, mp_context=context) as pool:
            return list(pool.map(_run_on_worker, tasks, chunksize=1))
    finally:
        for k, v in saved.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v


def sweep(scenes, solvers, perturbations=None, seeds=None, client=None, time_limit=20.0, *,
          tol=1e-8, options=None, max_iterations=0, jobs=None, prestress_factor=None):
    """Solves every (scene, perturbation, seed, solver) of a grid and returns a
    pandas DataFrame, one row per solve, in grid order (scene, perturbation,
    seed, solver), with the columns :data:`SWEEP_COLUMNS`.

    Parameters
    ----------
    scenes : Scene, path, list of them, or dict name -> Scene/path
    solvers : str or list of str
        Backend names (:func:`solvers`).
    perturbations : list, optional
        Each None (the scene as it is), ``"family:level"`` with a stress-test
        family (:func:`stress_families`) and a level index or label,
        ``(family, level_index)``, or a picklable callable ``f(scene, seed)``
        returning a Scene. Default: ``[None]``.
    seeds : list of int, optional
        Seeds of the perturbations (default ``[1]``); recorded in every row.
    client : dask.distributed.Client, optional
        Runs the solves on the client's workers; without it, on ``jobs`` local
        worker processes (default: the number of CPUs; 1 = in this process).
        Each worker process, before its first solve, sets glibc's malloc to keep
        freed buffers for the next solve (a Dask nanny's MALLOC_TRIM_THRESHOLD_
        would otherwise return them to the system after every solve).
    time_limit : float
        Seconds per solve.
    tol, options, max_iterations, prestress_factor
        As for :func:`solve`.

    A perturbed scene that breaks a rule of the model is not solved: its row
    has status ``"rejected"`` and the reason in ``message`` (for a solve, the
    solver's message). The scene as it is (perturbation None) is solved once
    per solver, its row repeated under every seed. Rows do not depend on
    where the solves ran; ``seconds`` is the measured solver time and varies
    between runs.
    """
    import pandas as pd

    named = _named_scenes(scenes)
    solver_list = [solvers] if isinstance(solvers, str) else list(solvers)
    if not solver_list:
        raise ValueError("tensegrity: sweep: solvers: give at least one solver")
    backend_options = {str(k): _option_text(v) for k, v in (options or {}).items()}
    limit = DEFAULT_TIME_LIMIT if time_limit is None else float(time_limit)
    kappa = _prestress_factor(prestress_factor)
    for s in solver_list:  # bad names and options fail here, before any work is sent
        _core._check_solver(s, float(tol), limit, int(max_iterations), kappa, backend_options)
    specs = [_perturbation_spec(p) for p in (perturbations if perturbations is not None else [None])]
    seed_list = [int(s) for s in (seeds if seeds is not None else [1])]
    # The scene as it is does not depend on the seed: it is solved once per
    # (scene, solver), with the first seed, and its row repeated under every seed.
    grid = [(name, scene, label, spec, seed, seed if spec is not None else seed_list[0], s)
            for name, scene in named for label, spec in specs for seed in seed_list for s in solver_list]
    tasks = {}
    for name, scene, label, spec, _, solve_seed, s in grid:
        tasks.setdefault((name, label, solve_seed, s), (name, scene, label, spec, solve_seed, s, float(tol), limit,
                                                        int(max_iterations), kappa, backend_options))
    if client is not None:
        futures = client.map(_run_on_worker, list(tasks.values()), pure=False)
        solved = client.gather(futures)
    else:
        solved = _local_rows(list(tasks.values()), jobs or os.cpu_count() or 1)
    row_of = dict(zip(tasks.keys(), solved))
    rows = [dict(row_of[(name, label, solve_seed, s)], seed=seed) for name, _, label, _, seed, solve_seed, s in grid]
    frame = pd.DataFrame(rows, columns=SWEEP_COLUMNS)
    return frame.astype(_DTYPES)
