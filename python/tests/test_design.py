"""tensegrity.design against `tensegrity design`: the same design file, the
same numbers bit for bit, the same messages."""
import json
import subprocess
import threading

import numpy as np
import pytest

import tensegrity as tg


def _without_seconds(text):
    """The file's lines but those of measured times, which differ between runs."""
    return [line for line in text.splitlines() if '"seconds"' not in line]


def _program_design(cli, tmp_path, input_path, *options):
    out = tmp_path / "program.design.json"
    run = subprocess.run([cli, "design", str(input_path), *options, "--out", str(out)],
                         capture_output=True, text=True)
    return run, out


@pytest.mark.parametrize("case", ["form-found prism", "puppy", "naive prism", "compared prism"])
def test_design_file_equals_the_program_file(cli, root, tmp_path, case):
    options = []
    if case == "puppy":
        input_path = tmp_path / "puppy.scene.json"
        tg.build_character(str(root / "data" / "characters" / "puppy.character.json")).save(str(input_path))
    else:
        # Twisted off its equilibrium: the design form-finds it first.
        input_path = tmp_path / "prism.scene.json"
        tg.prism(6, twist_offset=0.1, cable_mass=0.01, strut_mass=0.05, gravity=True,
                 fix_bottom=True).save(str(input_path))
    if case == "naive prism":
        options = ["--naive-fraction", "0.8"]
    if case == "compared prism":
        options = ["--naive-fractions", "0.7:0.9:2"]
    run, program_out = _program_design(cli, tmp_path, input_path, "--strain", "0.25", *options)
    assert run.returncode == 0, run.stderr
    result = tg.design(input_path, strain=0.25, naive_fraction=0.8 if case == "naive prism" else None,
                       naive_fractions=(0.7, 0.9, 2) if case == "compared prism" else None)
    assert result.ok and result.message == ""
    python_out = tmp_path / "python.design.json"
    result.save(python_out)
    program_text, python_text = program_out.read_text(), python_out.read_text()
    assert _without_seconds(program_text) == _without_seconds(python_text)
    assert run.stderr.strip().splitlines()[-1] == result.summary()
    program = json.loads(program_text)
    # Rest lengths, forces and geometry bit for bit (17 significant digits round-trip).
    assert np.array_equal(result.rest_lengths, np.array(program["rest_lengths"]))
    assert np.array_equal(result.forces, np.array(program["forces"]))
    assert np.array_equal(result.positions, np.array(program["positions"]))
    assert np.array_equal(result.strains, np.array(program["strains"]))
    kinds = result.scene.kinds
    cables = np.array([k == "cable" for k in kinds])
    assert (result.forces[cables] > 0).all() and (result.forces[~cables] < 0).all()
    # eps = l / L - 1 for the cables; struts keep their length.
    np.testing.assert_allclose(result.lengths[cables] / result.rest_lengths[cables] - 1.0,
                               result.strains[cables], rtol=0, atol=1e-12)
    if case == "naive prism":
        np.testing.assert_allclose(result.rest_lengths[cables], 0.8 * result.lengths[cables], rtol=1e-14)
        assert result.info["mode"] == "naive"
    else:
        assert result.info["mode"] == "stiffness" and result.info["target_strain"] == 0.25
    if case == "compared prism":
        fractions = [row["fraction"] for row in result.info["naive_comparison"]["naive"]]
        assert fractions == [0.7, 0.9]
        assert result.comparison_table.strip() and result.comparison_table.strip() in run.stderr
    # The sheet beside the program's design is the one save_sheet writes.
    sheet = tmp_path / "python.sheet.csv"
    result.save_sheet(sheet)
    assert sheet.read_text() == (tmp_path / "program.sheet.csv").read_text()


def test_design_of_a_scene_and_of_a_result(tmp_path):
    scene = tg.prism(5, twist_offset=0.1)
    solved = tg.solve(scene, solver="alternating-gn")
    assert solved.status == "converged"
    from_scene = tg.design(scene)
    from_result = tg.design(solved)
    assert from_scene.ok and from_result.ok
    # The solved geometry is already a tensegrity: the design keeps it and skips form finding.
    assert np.array_equal(from_result.positions, solved.positions)
    assert from_result.info["form_finding"]["solver"] == "none (already in equilibrium)"
    assert from_scene.info["input"] == scene.name
    assert from_scene.info["form_finding"]["status"] == "converged"
    for made in (from_scene, from_result):
        check = tg.check(made.scene, (made.positions, made.forces))
        assert check.ok and check.relative_residual <= 1e-8
        # The prism's symmetry: one force per class (struts, verticals, bottom ring, top ring).
        for k in range(4):
            forces = made.forces[5 * k:5 * (k + 1)]
            np.testing.assert_allclose(forces, forces[0], rtol=1e-6)


def test_no_buildable_design_is_reported_like_the_program(cli, root, tmp_path):
    # The 1 mm cord cannot carry the shipped characters: the program exits 1 and writes nothing.
    path = tmp_path / "puppy.scene.json"
    tg.build_character(str(root / "data" / "characters" / "puppy.character.json")).save(str(path))
    run, out = _program_design(cli, tmp_path, path, "--material", "elastic-cord-1mm")
    assert run.returncode == 1 and not out.exists()
    result = tg.design(path, material="elastic-cord-1mm")
    assert not result.ok and not result
    assert result.message == run.stderr.strip().splitlines()[-1]
    assert result.message.endswith("; no design written")
    with pytest.raises(RuntimeError, match="no design written"):
        result.save(tmp_path / "python.design.json")
    assert not (tmp_path / "python.design.json").exists()


def _program_error(cli, tmp_path, input_path, *options):
    run, out = _program_design(cli, tmp_path, input_path, *options)
    assert run.returncode == 2 and not out.exists()
    return run.stderr.strip()


@pytest.mark.parametrize("python_options, program_options", [
    ({"strain": -2.0}, ["--strain=-2"]),
    ({"strain": 5.0}, ["--strain", "5"]),
    ({"naive_fraction": 1.5}, ["--naive-fraction", "1.5"]),
    ({"settle": "wobble"}, ["--settle", "wobble"]),
    ({"settle_duration": 0.0}, ["--settle-duration", "0"]),
    ({"naive_fractions": "0.5:0.9"}, ["--naive-fractions", "0.5:0.9"]),
    ({"naive_fractions": (0.5, 1.5, 3)}, ["--naive-fractions", "0.5:1.5:3"]),
    ({"compare_naive": True, "naive_fraction": 0.8}, ["--compare-naive", "--naive-fraction", "0.8"]),
    ({"solver": "no-such-solver"}, ["--solver", "no-such-solver"]),
    ({"tol": -1.0}, ["--tol=-1"]),
    ({"material": "no-such-cord"}, ["--material", "no-such-cord"]),
])
def test_bad_design_options_raise_the_program_message(cli, tmp_path, python_options, program_options):
    path = tmp_path / "prism.scene.json"
    tg.prism(4).save(str(path))
    with pytest.raises(ValueError) as error:
        tg.design(path, **python_options)
    expected = _program_error(cli, tmp_path, path, *program_options)
    message = str(error.value)
    assert message.startswith("tensegrity: command line: ")
    if "no-such-cord" in message:
        # The folders searched differ (the program looks beside itself): all up to them agrees.
        assert message.split("(searched")[0] == expected.split("(searched")[0]
    else:
        assert message == expected


def test_bad_design_input_raises_the_program_message(cli, tmp_path):
    path = tmp_path / "broken.scene.json"
    path.write_text('{"format": "tensegrity-scene", "version": 1, "nodes": []')
    with pytest.raises(ValueError) as error:
        tg.design(path)
    assert str(error.value) == _program_error(cli, tmp_path, path)
    with pytest.raises(ValueError) as error:
        tg.design(tmp_path / "missing.scene.json")
    assert str(error.value) == _program_error(cli, tmp_path, tmp_path / "missing.scene.json")
    with pytest.raises(TypeError):
        tg.design(42)


def test_the_gil_is_released_while_designing(root):
    # While a thread is inside the C++ design, the main thread keeps running Python;
    # two threads designing the same input get the same numbers.
    puppy = tg.build_character(str(root / "data" / "characters" / "puppy.character.json"))
    scene = tg.stress_case(puppy, "noise", 4, 0, 1)
    results = [None, None]

    def work(i):
        results[i] = tg.design(scene)

    workers = [threading.Thread(target=work, args=(i,)) for i in range(2)]
    passes = 0
    for w in workers:
        w.start()
    while any(w.is_alive() for w in workers):
        passes += 1
    for w in workers:
        w.join()
    assert all(r.ok for r in results)
    assert passes > 1000
    assert np.array_equal(results[0].rest_lengths, results[1].rest_lengths)
    assert np.array_equal(results[0].forces, results[1].forces)
