"""The commands of the `tensegrity` program as functions (solve, forces, check,
render, simulate, design): same validation, same messages, same files."""
import math
import numbers
import os

from . import _core

DEFAULT_TIME_LIMIT = 120.0  # s, the command line's --time-limit default
DEFAULT_PRESTRESS_FACTOR = _core.DEFAULT_PRESTRESS_FACTOR  # kappa, the command line's --prestress-factor default


def _as_scene(scene):
    """A Scene, or a path to a scene file (read with load_scene)."""
    if isinstance(scene, _core.Scene):
        return scene
    if isinstance(scene, (str, os.PathLike)):
        return _core.load_scene(os.fspath(scene))
    raise TypeError(f"expected a tensegrity.Scene or a path, got {type(scene).__name__}")


def _option_text(value):
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return repr(value)
    return str(value)


def _prestress_factor(value):
    """kappa as a float, the default for None (checked by the solve itself)."""
    return DEFAULT_PRESTRESS_FACTOR if value is None else float(value)


def solve(scene, solver=None, tol=1e-8, time_limit=None, options=None, *,
          max_iterations=0, skip_if_in_equilibrium=True, verbose=False, prestress_factor=None):
    """Form-finds a scene with one backend (``tensegrity solve``).

    Parameters
    ----------
    scene : Scene or path
    solver : str, optional
        A name from :func:`solvers`; default :func:`default_solver`.
    tol : float
        Relative residual for ``converged`` (finite, > 0).
    time_limit : float, optional
        Wall-clock budget in seconds (default 120, as on the command line).
    options : dict, optional
        Backend options, the command line's ``--option key=value`` pairs.
    max_iterations : int
        Backend iteration budget; 0 is the backend's own.
    skip_if_in_equilibrium : bool
        False is the command line's ``--no-skip``.
    prestress_factor : float, optional
        kappa, the command line's ``--prestress-factor``: under gravity Eq. 5
        caps the mean cable force at kappa times the part's weight (finite,
        > 0; default :data:`DEFAULT_PRESTRESS_FACTOR`, 2).

    Returns
    -------
    Result
        ``status``, ``positions`` (n, 3), ``forces`` (m,), ``stats``, ``trace``;
        ``save(path)`` writes the solution file the command line writes.

    Raises
    ------
    ValueError
        Bad scene file, unknown solver or option, out-of-range numbers: the
        command line's message.
    """
    scene = _as_scene(scene)
    backend_options = {}
    for key, value in (options or {}).items():
        key = str(key)
        if not key:
            raise ValueError(f"tensegrity: command line: --option ={_option_text(value)}: expected key=value")
        backend_options[key] = _option_text(value)
    limit = DEFAULT_TIME_LIMIT if time_limit is None else float(time_limit)
    return _core._solve(scene, solver or "", float(tol), limit, int(max_iterations),
                        _prestress_factor(prestress_factor), bool(skip_if_in_equilibrium), bool(verbose),
                        backend_options)


def forces(scene, tol=1e-8):
    """The stress QP (Eq. 4 of the paper) at the scene's own geometry
    (``tensegrity forces``): a Result by the solver "stress-qp" that is
    ``converged`` when the scene already is a tensegrity, else ``infeasible``."""
    return _core._forces(_as_scene(scene), float(tol))


def check(scene, result_or_path, tol=1e-8):
    """Independent re-check of a solution against its scene (``tensegrity check``).

    ``result_or_path`` is a Result, a solution file's path, or a pair
    ``(positions (n, 3), forces (m,))``. Returns a Verification (true when it
    verifies)."""
    scene = _as_scene(scene)
    tol = float(tol)
    if isinstance(result_or_path, _core.Result):
        return _core._check_arrays(scene, result_or_path.positions, result_or_path.forces, tol)
    if isinstance(result_or_path, (str, os.PathLike)):
        return _core._check_solution_file(scene, os.fspath(result_or_path), tol)
    if isinstance(result_or_path, tuple) and len(result_or_path) == 2:
        return _core._check_arrays(scene, result_or_path[0], result_or_path[1], tol)
    raise TypeError("expected a Result, a solution file's path or (positions, forces)")


def read_solution(scene, path):
    """Reads a solution file, checked against its scene: a dict with status,
    solver, positions (n, 3), forces (m,) and stats."""
    return _core._read_solution(_as_scene(scene), os.fspath(path))


def render(scene, path, result=None, view="iso", width=1200, height=900, title="", reference=True,
           colour_by="force", labels=False, legend=True):
    """Draws a scene, or a solution of it coloured by its forces, to PNG or SVG
    by the extension of ``path`` (``tensegrity render``). ``result`` is a
    Result or a solution file's path; with it, ``reference`` draws the scene's
    own shape faintly behind (the command's default; ``--no-reference``).
    ``colour_by``: force, strain, block or kind; ``labels``: node and element
    ids; ``legend``: key, colour bar, scale bar and axes."""
    scene = _as_scene(scene)
    positions = forces_ = None
    if isinstance(result, _core.Result):
        positions, forces_ = result.positions, result.forces
    elif result is not None:
        solution = read_solution(scene, result)
        positions, forces_ = solution["positions"], solution["forces"]
    if not (isinstance(width, numbers.Integral) and isinstance(height, numbers.Integral)):
        raise TypeError("width and height are integers (pixels)")
    _core._render(scene, positions, forces_, os.fspath(path), str(view), int(width), int(height), str(title),
                  bool(reference), str(colour_by), bool(labels), bool(legend))
    return os.fspath(path)


def _gravity_vector(gravity):
    """Three finite floats from a sequence or the command line's 'gx,gy,gz' text."""
    if gravity is None:
        return None
    if isinstance(gravity, str):
        parts, text = gravity.split(","), gravity
    else:
        try:
            parts = list(gravity)
        except TypeError:
            parts = [gravity]
        text = ",".join(format(p, "g") if isinstance(p, (int, float)) else str(p) for p in parts)
    if len(parts) != 3:
        raise ValueError(f"tensegrity: command line: --gravity: expected 3 numbers in '{text}'")
    vector = []
    for part in parts:
        try:
            value = float(part.strip() if isinstance(part, str) else part)
        except (TypeError, ValueError):
            value = float("nan")
        if not math.isfinite(value):
            shown = format(part, "g") if isinstance(part, (int, float)) else str(part).strip()
            raise ValueError(f"tensegrity: command line: --gravity: '{shown}' is not a finite number")
        vector.append(value)
    return tuple(vector)


def simulate(design, dt=1.0 / 60.0, steps=60, gravity=None, damping=0.0, stiffness_damping=0.0,
             drags=None, drag_stiffness=None, every=1, tol=1e-9):
    """Implicit-Euler simulation of a built design (``tensegrity simulate``).

    Parameters
    ----------
    design : path
        A design file (``tensegrity design --out``).
    dt : float
        Time step (s). ``steps``: number of steps; ``every``: keep every k-th frame (and the last).
    gravity : 3 floats or 'gx,gy,gz', optional
        m/s^2. Default: the design's.
    damping, stiffness_damping : float
        Mass-proportional (1/s) and stiffness-proportional (s) damping.
    drags : dict node -> (x, y, z), optional
        Nodes pulled towards fixed targets by springs of ``drag_stiffness`` N/m
        (default: the command's, force scale / (0.05 length scale)).

    Returns
    -------
    dict of numpy arrays, one entry per kept frame (frame 0 is the start):
    ``step``, ``time`` (s), ``positions`` (frames, n, 3), ``forces`` (frames, m),
    ``kinetic_energy``, ``potential_energy`` (J), ``newton_iterations``, ``converged``.
    """
    targets = {int(node): tuple(float(c) for c in target) for node, target in (drags or {}).items()}
    if any(len(t) != 3 for t in targets.values()):
        raise ValueError("tensegrity: command line: --drag: expected 3 numbers per target")
    return _core._simulate(os.fspath(design), float(dt), int(steps), _gravity_vector(gravity), float(damping),
                           float(stiffness_damping), targets, drag_stiffness, int(every), float(tol))


DEFAULT_MATERIAL = "elastic-cord-2mm"  # the command line's --material default


def _fraction_grid_text(naive_fractions):
    """The command line's FROM:TO:N from a string or a (from, to, n) triple."""
    if naive_fractions is None:
        return ""
    if isinstance(naive_fractions, str):
        return naive_fractions
    start, stop, count = naive_fractions
    return f"{float(start)!r}:{float(stop)!r}:{int(count)}"


def design(scene_or_result, strain=0.3, material=DEFAULT_MATERIAL, material_dirs=None, naive_fraction=None,
           solver=None, tol=1e-8, time_limit=None, *, compare_naive=False, naive_fractions=None,
           settle="relax", settle_duration=5.0):
    """Stiffness scaling and cable rest lengths: a buildable design (``tensegrity design``).

    Parameters
    ----------
    scene_or_result : Scene, Result or path
        A path is read as the command reads its input (scene, character or
        design file). A Scene is designed as it stands; a Result (of
        :func:`solve`) at its solved geometry. A Scene or Result is named by
        the scene's name (else ``Scene``) in messages and in the design's
        ``input`` record.
    strain : float
        Target cable strain (``--strain``); elements may carry ``target_strain``.
    material : str
        Cable material name or file (``--material``); elements may carry ``material``.
    material_dirs : list of paths, optional
        Extra folders to find NAME.json in (``--material-dir``), searched
        first; then the materials of the checkout the module was built from
        (``data/materials``, which the program finds beside itself), then
        ``$TENSEGRITY_DATA/materials`` and ``./data/materials``.
    naive_fraction : float, optional
        The baseline instead: every cable's rest length is this fraction of its length.
    solver : str, optional
        Form-finding backend when the input is not in equilibrium.
    tol, time_limit : float
        Relative residual of form finding and verification; form-finding
        budget in seconds (default 120, as on the command line).
    compare_naive : bool
        Settle the design and the constant-fraction baseline for a sweep of
        fractions (``--compare-naive``); the table is ``comparison_table``
        and the record ``info["naive_comparison"]``.
    naive_fractions : "FROM:TO:N" or (from, to, n), optional
        The fractions of the comparison (implies ``compare_naive``).
    settle : "relax" or "simulate"; settle_duration : float
        How the comparison settles, and the simulated seconds of ``simulate``.

    Returns
    -------
    DesignResult
        ``ok``; ``positions``, ``forces``, ``rest_lengths``, ``strains``,
        ``info``; ``save(path)`` writes the design file the command writes
        (``save_sheet``, ``save_cut_list`` its sheet and cut list). When no
        buildable design exists, ``ok`` is False and ``message`` is the
        command's last line.

    Raises
    ------
    ValueError
        Bad input file, option or material: the command line's message.
    """
    positions = None
    if isinstance(scene_or_result, _core.Result):
        scene, positions = scene_or_result.scene, scene_or_result.positions
    elif isinstance(scene_or_result, (str, os.PathLike)):
        scene = None
    elif isinstance(scene_or_result, _core.Scene):
        scene = scene_or_result
    else:
        raise TypeError(f"expected a tensegrity.Scene, a Result or a path, got {type(scene_or_result).__name__}")
    source = os.fspath(scene_or_result) if scene is None else (scene.name or "Scene")
    fraction = float("nan") if naive_fraction is None else float(naive_fraction)
    limit = DEFAULT_TIME_LIMIT if time_limit is None else float(time_limit)
    dirs = [os.fspath(d) for d in (material_dirs or [])]
    return _core._design(scene, positions, source, float(strain), os.fspath(material), dirs, fraction,
                         solver or "", float(tol), limit, bool(compare_naive),
                         _fraction_grid_text(naive_fractions), str(settle), float(settle_duration))
