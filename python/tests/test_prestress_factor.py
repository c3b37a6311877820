"""prestress_factor= (kappa of Eq. 5 under gravity) of solve and sweep against
the command line's --prestress-factor."""
import json
import subprocess

import pytest

import tensegrity as tg

BACKEND = "ipopt"
SCENE = "prism-7-gravity.scene.json"
KAPPA = 5.0  # not the default, so that an ignored keyword shows


def program_geometry_change(cli, scene, tmp_path, kappa):
    out = tmp_path / f"kappa-{kappa}.solution.json"
    subprocess.run([cli, "solve", str(scene), "--solver", BACKEND, "--prestress-factor", repr(kappa),
                    "--out", str(out), "--quiet"], capture_output=True, check=True)
    return json.loads(out.read_text())["stats"]["geometry_change"]


def test_prestress_factor_moves_the_prism_as_the_program_does(cli, reference, tmp_path):
    scene = reference / SCENE
    expected = program_geometry_change(cli, scene, tmp_path, KAPPA)
    result = tg.solve(scene, solver=BACKEND, prestress_factor=KAPPA)
    assert result.status == "converged"
    assert result.stats["geometry_change"] == pytest.approx(expected, rel=1e-12, abs=0.0)
    # The default is kappa = 2, which lets less prestress carry the weight:
    # the prism moves clearly farther.
    default = tg.solve(scene, solver=BACKEND)
    assert tg.DEFAULT_PRESTRESS_FACTOR == 2.0
    assert default.stats["geometry_change"] == pytest.approx(
        program_geometry_change(cli, scene, tmp_path, 2.0), rel=1e-12, abs=0.0)
    assert default.stats["geometry_change"] > 1.5 * expected


def test_sweep_passes_prestress_factor_to_every_solve(cli, reference, tmp_path):
    scene = reference / SCENE
    expected = program_geometry_change(cli, scene, tmp_path, KAPPA)
    frame = tg.sweep({"prism-7-gravity": scene}, BACKEND, prestress_factor=KAPPA, jobs=1)
    assert frame["geometry_change"].iloc[0] == pytest.approx(expected, rel=1e-12, abs=0.0)


@pytest.mark.parametrize("bad", [0.0, -1.0, float("nan"), float("inf")])
def test_a_bad_prestress_factor_raises_the_program_message(cli, reference, tmp_path, bad):
    scene = reference / SCENE
    run = subprocess.run([cli, "solve", str(scene), f"--prestress-factor={bad!r}", "--out", str(tmp_path / "x.json")],
                         capture_output=True, text=True)
    assert run.returncode == 2
    message = "tensegrity: command line: --prestress-factor: must be a finite number > 0"
    assert run.stderr.strip() == message
    with pytest.raises(ValueError) as error:
        tg.solve(scene, solver=BACKEND, prestress_factor=bad)
    assert str(error.value) == message
    with pytest.raises(ValueError) as error:
        tg.sweep({"prism-7-gravity": scene}, BACKEND, prestress_factor=bad, jobs=1)
    assert str(error.value) == message
