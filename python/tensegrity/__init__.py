"""Form finding of tensegrity structures, after Gauge, Coros, Mani and
Thomaszewski, "Interactive Design of Modular Tensegrity Characters" (SCA 2014).

numpy in, numpy out: scenes hold (n, 3) node positions and (m, 2) element node
indices; a solve returns (n, 3) positions and (m,) axial forces (N, positive =
tension). The solvers are the project's C++ library; the GIL is released while
they run, so threads and Dask workers solve in parallel.

    >>> import tensegrity as tg
    >>> scene = tg.load_scene("data/reference/prism-3.scene.json")   # doctest: +SKIP
    >>> result = tg.solve(scene, solver="alternating-gn")             # doctest: +SKIP
    >>> result.positions.shape, result.status                         # doctest: +SKIP
    ((6, 3), 'converged')

Bad input raises ValueError with the command line's one-line message
("tensegrity: FILE: ITEM: REASON").
"""
from ._core import (
    DesignResult,
    Result,
    Scene,
    Verification,
    build_character,
    chain,
    default_solver,
    load_scene,
    octahedron,
    prism,
    prism_equilibrium_twist,
    scene_from_json,
    solvers,
    stress_base_scenes,
    stress_case,
    stress_families,
    stress_levels,
)
from ._api import DEFAULT_PRESTRESS_FACTOR, check, design, forces, read_solution, render, simulate, solve
from .sweep import stress_family, sweep, SWEEP_COLUMNS

__all__ = [
    "DEFAULT_PRESTRESS_FACTOR", "DesignResult", "Result", "Scene", "Verification", "SWEEP_COLUMNS",
    "build_character", "chain", "check", "default_solver", "design", "forces", "load_scene",
    "octahedron", "prism", "prism_equilibrium_twist", "read_solution", "render",
    "scene_from_json", "simulate", "solve", "solvers", "stress_base_scenes", "stress_case",
    "stress_families", "stress_family", "stress_levels", "sweep",
]

__version__ = "0.1"
