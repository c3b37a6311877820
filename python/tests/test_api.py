"""The Python API against closed forms, the command line and its files."""
import json
import math
import pickle
import subprocess

import numpy as np
import pytest

import tensegrity as tg


def force_densities(scene, result):
    x = result.positions
    e = scene.elements
    lengths = np.linalg.norm(x[e[:, 1]] - x[e[:, 0]], axis=1)
    return result.forces / lengths


@pytest.mark.parametrize("n", [3, 4, 6, 9])
def test_prism_stress_qp_closed_form(n):
    # In equilibrium: force densities struts -1, verticals 1, rings 1/(2 sin(pi/n)), up to one factor.
    scene = tg.prism(n)
    result = tg.forces(scene)
    assert result.status == "converged"
    q = force_densities(scene, result)
    q = q / q[n]  # the first vertical cable
    np.testing.assert_allclose(q[:n], -1.0, rtol=1e-8)
    np.testing.assert_allclose(q[n:2 * n], 1.0, rtol=1e-8)
    np.testing.assert_allclose(q[2 * n:], 1.0 / (2.0 * math.sin(math.pi / n)), rtol=1e-8)


@pytest.mark.parametrize("solver", ["alternating-gn", "ipopt"])
@pytest.mark.parametrize("n", [3, 5])
def test_twisted_prism_returns_to_the_equilibrium_twist(n, solver):
    scene = tg.prism(n, twist_offset=0.1)
    assert tg.forces(scene).status == "infeasible"
    result = tg.solve(scene, solver=solver)
    assert result.status == "converged"
    assert result.positions.shape == (2 * n, 3)
    assert result.forces.shape == (4 * n,)
    assert result.positions.dtype == np.float64
    x = result.positions
    # Top node k sits above bottom node k turned by pi/2 - pi/n about the prism's axis.
    centre_bottom, centre_top = x[:n].mean(axis=0), x[n:].mean(axis=0)
    b, t = x[0] - centre_bottom, x[n] - centre_top
    twist = math.atan2(b[0] * t[1] - b[1] * t[0], b[0] * t[0] + b[1] * t[1])
    assert twist == pytest.approx(tg.prism_equilibrium_twist(n), abs=1e-5)
    q = force_densities(scene, result)
    q = q / q[n]
    np.testing.assert_allclose(q[2 * n:], 1.0 / (2.0 * math.sin(math.pi / n)), rtol=1e-5)
    assert result.verify().ok
    assert result.stats["geometry_change"] > 0.01


def test_octahedron_ratios():
    scene = tg.octahedron()
    result = tg.forces(scene)
    assert result.status == "converged"
    x, e = scene.positions, scene.elements
    lengths = np.linalg.norm(x[e[:, 1]] - x[e[:, 0]], axis=1)
    assert lengths[0] / lengths[6] == pytest.approx(math.sqrt(8.0 / 3.0), rel=1e-12)
    assert -result.forces[0] / result.forces[6] == pytest.approx(math.sqrt(6.0), rel=1e-8)


def test_solvers_match_the_program(cli):
    listed = subprocess.run([cli, "solvers"], capture_output=True, text=True, check=True).stdout.split()
    assert tg.solvers() == listed
    assert tg.default_solver() in listed


def _solution_without_time(text):
    data = json.loads(text)
    assert data["stats"].pop("seconds") >= 0.0
    return data


@pytest.mark.parametrize("solver", ["alternating-gn", "ipopt", "nlopt", "alternating"])
def test_python_and_program_write_the_same_solution(cli, tmp_path, solver):
    scene = tg.prism(6, twist_offset=0.15)
    scene_path = tmp_path / "prism.scene.json"
    scene.save(str(scene_path))
    program_out = tmp_path / "program.solution.json"
    run = subprocess.run([cli, "solve", str(scene_path), "--solver", solver, "--out", str(program_out)],
                         capture_output=True, text=True)
    result = tg.solve(tg.load_scene(scene_path), solver=solver)
    assert run.returncode == (0 if result.status == "converged" else 1)
    python_out = tmp_path / "python.solution.json"
    result.save(str(python_out))
    program_text, python_text = program_out.read_text(), python_out.read_text()
    # Every byte but the measured time: positions and forces bit for bit (17 digits).
    assert _solution_without_time(program_text) == _solution_without_time(python_text)
    strip = lambda t: [line for line in t.splitlines() if '"seconds"' not in line]
    assert strip(program_text) == strip(python_text)
    assert run.stderr.strip().split(" in ")[0] == result.summary().split(" in ")[0]
    # The program's independent check accepts the file written from Python.
    check = subprocess.run([cli, "check", str(scene_path), str(python_out)], capture_output=True, text=True)
    assert (check.returncode == 0) == (result.status == "converged")
    assert tg.check(scene_path, python_out).ok == (result.status == "converged")
    # A solution read back holds the very same numbers.
    back = tg.read_solution(scene, python_out)
    assert np.array_equal(back["positions"], result.positions)
    assert np.array_equal(back["forces"], result.forces)
    assert back["status"] == result.status


def test_reference_scene_solve_and_check(cli, reference, tmp_path):
    path = reference / "prism-6-gravity.scene.json"
    scene = tg.load_scene(path)
    result = tg.solve(scene, solver="alternating-gn")
    assert result.positions.shape == (scene.num_nodes, 3)
    out = tmp_path / "s.solution.json"
    result.save(str(out))
    check = subprocess.run([cli, "check", str(path), str(out)], capture_output=True, text=True)
    assert check.returncode == 0 and check.stdout.strip().endswith("verified")
    v = tg.check(path, out)
    assert v.ok and v.relative_residual <= 1e-8 and v.wrong_signs == 0


def test_trace_is_a_dict_of_equal_length_arrays():
    result = tg.solve(tg.prism(5, twist_offset=0.2), solver="ipopt")
    trace = result.trace
    assert set(trace) == {"seconds", "iteration", "evaluations", "residual", "relative_residual",
                          "geometry_change", "objective"}
    lengths = {len(v) for v in trace.values()}
    assert len(lengths) == 1 and lengths.pop() >= 2
    assert np.all(np.diff(trace["seconds"]) >= 0)
    assert trace["iteration"].dtype == np.int64
    assert trace["relative_residual"][-1] == pytest.approx(result.stats["relative_residual"], rel=1e-6, abs=1e-14)


def test_scene_file_round_trip(tmp_path, reference):
    scene = tg.load_scene(reference / "prism-4-gravity.scene.json")
    path = tmp_path / "copy.scene.json"
    scene.save(str(path))
    again = tg.load_scene(path)
    for field in ("positions", "elements", "fixed", "masses", "element_masses", "gravity"):
        assert np.array_equal(getattr(scene, field), getattr(again, field)), field
    assert again.kinds == scene.kinds and again.name == scene.name
    assert path.read_text() == (tmp_path / "copy.scene.json").read_text()
    # Built from arrays: the same scene, the same file.
    rebuilt = tg.Scene(scene.positions, scene.elements, scene.kinds, fixed=scene.fixed, masses=scene.masses,
                       element_masses=scene.element_masses, gravity=scene.gravity, name=scene.name)
    path2 = tmp_path / "rebuilt.scene.json"
    rebuilt.save(str(path2))
    assert path2.read_text() == path.read_text()
    # Pickling (how Dask ships scenes) keeps every bit.
    unpickled = pickle.loads(pickle.dumps(scene))
    assert np.array_equal(unpickled.positions, scene.positions)
    assert unpickled.to_json() == scene.to_json()


def test_scene_arrays_and_repr():
    scene = tg.Scene([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1], [1, 2], [2, 0]], ["cable"] * 3,
                     fixed=[True, False, False], masses=[0, 0.5, 0.25], gravity=[0, 0, -9.81], name="tri")
    assert scene.positions.shape == (3, 3) and scene.elements.dtype == np.int64
    assert scene.lumped_masses.tolist() == [0.0, 0.5, 0.25]
    assert "tri" in repr(scene) and "3 cables" in repr(scene) and "1 fixed" in repr(scene)
    assert tg.solve.__doc__ and "Returns" in tg.solve.__doc__


def _program_message(cli, args):
    run = subprocess.run([cli, *args], capture_output=True, text=True)
    assert run.returncode == 2
    lines = run.stderr.strip().splitlines()
    assert len(lines) == 1
    return lines[0]


BAD_SCENES = {
    "nan.scene.json": '{"format": "tensegrity-scene", "version": 1, "nodes": [{"x": [0, 0, 0]}, '
                      '{"x": [1, 0, 1e999]}], "elements": [{"kind": "cable", "nodes": [0, 1]}]}',
    "kind.scene.json": '{"format": "tensegrity-scene", "version": 1, "nodes": [{"x": [0, 0, 0]}, '
                       '{"x": [1, 0, 0]}], "elements": [{"kind": "rope", "nodes": [0, 1]}]}',
    "index.scene.json": '{"format": "tensegrity-scene", "version": 1, "nodes": [{"x": [0, 0, 0]}, '
                        '{"x": [1, 0, 0]}], "elements": [{"kind": "cable", "nodes": [0, 2]}]}',
    "version.scene.json": '{"format": "tensegrity-scene", "version": 2, "nodes": [], "elements": []}',
    "malformed.scene.json": '{"format": "tensegrity-scene", ',
}


@pytest.mark.parametrize("name", sorted(BAD_SCENES))
def test_bad_scene_raises_value_error_with_the_program_message(cli, tmp_path, name):
    path = tmp_path / name
    path.write_text(BAD_SCENES[name])
    expected = _program_message(cli, ["solve", str(path), "--out", str(tmp_path / "never.json")])
    assert expected.startswith("tensegrity: " + str(path) + ": ")
    with pytest.raises(ValueError) as error:
        tg.load_scene(path)
    assert str(error.value) == expected
    with pytest.raises(ValueError) as error:
        tg.solve(str(path))
    assert str(error.value) == expected
    assert not (tmp_path / "never.json").exists()


def test_missing_file_and_bad_options_match_the_program(cli, tmp_path, reference):
    missing = tmp_path / "missing.scene.json"
    with pytest.raises(ValueError) as error:
        tg.load_scene(missing)
    assert str(error.value) == _program_message(cli, ["solve", str(missing)])
    scene = str(reference / "prism-3.scene.json")
    with pytest.raises(ValueError) as error:
        tg.solve(scene, solver="no-such-solver")
    assert str(error.value) == _program_message(cli, ["solve", scene, "--solver", "no-such-solver"])
    with pytest.raises(ValueError) as error:
        tg.solve(scene, tol=-1.0)
    assert str(error.value) == _program_message(cli, ["solve", scene, "--tol", "-1"])
    with pytest.raises(ValueError) as error:
        tg.solve(scene, solver="ipopt", options={"no_such_key": 1})
    assert str(error.value) == _program_message(cli, ["solve", scene, "--solver", "ipopt",
                                                      "--option", "no_such_key=1"])


def test_scene_from_arrays_is_validated_like_a_file():
    with pytest.raises(ValueError, match=r"^tensegrity: bad: elements\[0\]\.nodes: element joins node 0 to itself$"):
        tg.Scene([[0, 0, 0], [1, 0, 0]], [[0, 0]], ["cable"], name="bad")
    with pytest.raises(ValueError, match=r"^tensegrity: Scene: nodes\[1\].x.*not finite"):
        tg.Scene([[0, 0, 0], [np.nan, 0, 0]], [[0, 1]], ["cable"])
    with pytest.raises(ValueError, match=r"^tensegrity: Scene: positions: expected an array of shape \(n, 3\)"):
        tg.Scene([[0, 0], [1, 0]], [[0, 1]], ["cable"])


def test_render_writes_a_png(tmp_path):
    scene = tg.prism(4, twist_offset=0.1)
    result = tg.solve(scene, solver="alternating-gn")
    out = tg.render(scene, tmp_path / "p.png", result=result, view="front", width=200, height=150)
    assert open(out, "rb").read(8) == b"\x89PNG\r\n\x1a\n"
    with pytest.raises(ValueError, match="--width"):
        tg.render(scene, tmp_path / "q.png", width=10)


@pytest.mark.parametrize("reference", [True, False])
def test_render_svg_equals_the_program(cli, tmp_path, reference):
    scene_file, solution_file = tmp_path / "p.scene.json", tmp_path / "p.solution.json"
    scene = tg.prism(4, twist_offset=0.1)
    scene.save(scene_file)
    tg.solve(scene, solver="alternating-gn").save(solution_file)
    tg.render(scene, tmp_path / "py.svg", result=solution_file, reference=reference, labels=True)
    subprocess.run([cli, "render", str(scene_file), "--solution", str(solution_file), "--labels",
                    "--out", str(tmp_path / "cli.svg")] + ([] if reference else ["--no-reference"]),
                   capture_output=True, check=True)
    assert (tmp_path / "py.svg").read_bytes() == (tmp_path / "cli.svg").read_bytes()


def test_character_builds_like_the_program(cli, root, tmp_path):
    character = root / "data" / "characters" / "duck.character.json"
    out = tmp_path / "duck.scene.json"
    subprocess.run([cli, "build", str(character), "--out", str(out)], capture_output=True, check=True)
    scene = tg.build_character(str(character))
    scene.save(str(tmp_path / "py.scene.json"))
    assert (tmp_path / "py.scene.json").read_text() == out.read_text()
    subprocess.run([cli, "build", "--chain", "4", "--out", str(tmp_path / "chain.scene.json")],
                   capture_output=True, check=True)
    chain = tg.chain(4)
    chain.save(tmp_path / "py-chain.scene.json")
    assert (tmp_path / "py-chain.scene.json").read_text() == (tmp_path / "chain.scene.json").read_text()
    assert chain.num_nodes == 54 and chain.fixed.sum() == 12  # as `tensegrity build --chain 4` reports


def test_stress_family_generator_is_deterministic():
    base = tg.prism(6)
    levels = tg.stress_levels("noise")
    first = list(tg.stress_family(base, "noise", trials=2, seed=7))
    again = list(tg.stress_family(base, "noise", trials=2, seed=7))
    assert len(first) == 2 * len(levels)
    assert all(np.array_equal(a[2].positions, b[2].positions) for a, b in zip(first, again))
    moved = [np.abs(s.positions - base.positions).max() for _, _, s in first]
    assert moved[0] > 0 and moved[-1] > moved[0]
    assert "noise" in tg.stress_families()


def test_simulate_gives_the_program_frames(cli, root, tmp_path):
    scene = tmp_path / "puppy.scene.json"
    design = tmp_path / "puppy.design.json"
    subprocess.run([cli, "build", str(root / "data" / "characters" / "puppy.character.json"), "--out", str(scene)],
                   capture_output=True, check=True)
    subprocess.run([cli, "design", str(scene), "--material", "elastic-cord-2mm", "--out", str(design)],
                   capture_output=True, check=True)
    start = tg.load_scene(scene).positions[5]
    target = start + [0.0, 0.0, 0.02]
    frames_file = tmp_path / "frames.jsonl"
    subprocess.run([cli, "simulate", str(design), "--dt", "0.01", "--steps", "6", "--every", "2",
                    "--drag", "5:" + ",".join(repr(float(c)) for c in target), "--out", str(frames_file),
                    "--no-vtk"], capture_output=True, check=True)
    program = [json.loads(line) for line in frames_file.read_text().splitlines()]
    frames = tg.simulate(design, dt=0.01, steps=6, every=2, drags={5: target})
    assert frames["step"].tolist() == [f["step"] for f in program] == [0, 2, 4, 6]
    assert frames["positions"].shape == (4, tg.load_scene(scene).num_nodes, 3)
    assert np.array_equal(frames["positions"], np.array([f["positions"] for f in program]))
    assert np.array_equal(frames["forces"], np.array([f["forces"] for f in program]))
    assert frames["positions"][-1, 5, 2] > start[2] + 1e-4  # the dragged node rose
    with pytest.raises(ValueError) as error:
        tg.simulate(design, dt=-1.0)
    run = subprocess.run([cli, "simulate", str(design), "--dt", "-1", "--out", str(tmp_path / "x.jsonl")],
                         capture_output=True, text=True)
    assert run.returncode == 2 and str(error.value) == run.stderr.strip()


@pytest.mark.parametrize("gravity, cli_text", [((0.0, 1.0), "0,1"), ("0,1", "0,1"), ((0.0, 0.0, "x"), "0,0,x"),
                                               ((0.0, float("nan"), 0.0), "0,nan,0")])
def test_simulate_bad_gravity_raises_the_program_message(cli, root, tmp_path, gravity, cli_text):
    scene = tmp_path / "duck.scene.json"
    design = tmp_path / "duck.design.json"
    subprocess.run([cli, "build", str(root / "data" / "characters" / "duck.character.json"), "--out", str(scene)],
                   capture_output=True, check=True)
    subprocess.run([cli, "design", str(scene), "--out", str(design)], capture_output=True, check=True)
    with pytest.raises(ValueError) as error:
        tg.simulate(design, steps=1, gravity=gravity)
    run = subprocess.run([cli, "simulate", str(design), "--steps", "1", "--gravity", cli_text,
                          "--out", str(tmp_path / "x.jsonl")], capture_output=True, text=True)
    assert run.returncode == 2 and str(error.value) == run.stderr.strip()
    assert not (tmp_path / "x.jsonl").exists()


@pytest.mark.parametrize("elements", [np.array([[0, 1.5]]), np.array([[0, 2**63]], dtype=np.uint64)])
def test_scene_rejects_indices_that_are_not_integers(elements):
    positions = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    with pytest.raises(ValueError, match="elements: expected integer node indices"):
        tg.Scene(positions, elements, ["strut"])


@pytest.mark.parametrize("solver", ["alternating-gn", "ipopt"])
def test_result_pickles_to_the_same_solution(tmp_path, solver):
    result = tg.solve(tg.prism(5, twist_offset=0.1), solver=solver)
    back = pickle.loads(pickle.dumps(result))
    assert back.status == result.status and back.solver == result.solver and back.message == result.message
    assert np.array_equal(back.positions, result.positions) and np.array_equal(back.forces, result.forces)
    assert back.stats == result.stats
    assert all(np.array_equal(back.trace[k], result.trace[k]) for k in result.trace)
    result.save(tmp_path / "a.json")
    back.save(tmp_path / "b.json")
    assert (tmp_path / "a.json").read_bytes() == (tmp_path / "b.json").read_bytes()  # details included
    assert back.verify().ok


def test_result_comes_back_from_a_dask_worker():
    distributed = pytest.importorskip("distributed")
    scene = tg.prism(4, twist_offset=0.1)
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster, distributed.Client(cluster) as client:
        remote = client.submit(tg.solve, scene, solver="alternating-gn").result()
    local = tg.solve(scene, solver="alternating-gn")
    assert remote.status == "converged"
    assert np.array_equal(remote.positions, local.positions) and np.array_equal(remote.forces, local.forces)
