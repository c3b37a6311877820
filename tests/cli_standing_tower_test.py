#!/usr/bin/python3
"""A tower that stands, through the command line: `forces` says so and `solve` leaves it.

The 40-layer 8-strut tower of `generate tower` without gravity (2,320
elements) is solved to an equilibrium with alternating-gn and written with
--out-scene. On that file `forces` exits 0 and `check` verifies its forces,
and `solve` returns geometry change exactly 0. The equilibrium is a large
near-mechanism on which the stress QP alone stops short of the forces that
exist, and `solve` then moved the standing tower by 6.4 cm.

    /usr/bin/python3 tests/cli_standing_tower_test.py --binary build/tensegrity

Exit status 0 when every check passes, 1 otherwise (each failure is printed).
"""
import argparse
import json
import pathlib
import subprocess
import sys
import tempfile

LAYERS = 40
TOLERANCE = 1e-8  # the default relative residual of `converged`


def run(binary, *args):
    return subprocess.run([str(binary)] + [str(a) for a in args], capture_output=True, text=True, timeout=600)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--binary", required=True, type=pathlib.Path)
    args = parser.parse_args()
    failures = []

    def expect(ok, message):
        if not ok:
            failures.append(message)
            print("FAIL: " + message)

    with tempfile.TemporaryDirectory() as tmp:
        tmp = pathlib.Path(tmp)
        scene, solution, standing = tmp / "tower.json", tmp / "solution.json", tmp / "standing.json"
        r = run(args.binary, "generate", "tower", "--layers", LAYERS, "--struts-per-layer", 8,
                "--cables", 50 * LAYERS, "--out", scene)
        expect(r.returncode == 0, "generate: " + r.stderr)
        r = run(args.binary, "solve", scene, "--solver", "alternating-gn", "--quiet", "--out", solution,
                "--out-scene", standing)
        expect(r.returncode == 0, "solve of the generated tower: " + r.stderr)

        forces = tmp / "forces.json"
        r = run(args.binary, "forces", standing, "--out", forces)
        expect(r.returncode == 0, "forces on the equilibrium exits %d: %s" % (r.returncode, r.stderr))
        if forces.exists():
            result = json.loads(forces.read_text())
            expect(result["status"] == "converged", "forces status " + result["status"])
            expect(result["stats"]["relative_residual"] <= TOLERANCE,
                   "forces relative residual %g" % result["stats"]["relative_residual"])
            r = run(args.binary, "check", standing, forces)
            expect(r.returncode == 0, "check of forces' answer: " + r.stdout + r.stderr)

        again = tmp / "again.json"
        r = run(args.binary, "solve", standing, "--solver", "alternating-gn", "--quiet", "--out", again)
        expect(r.returncode == 0, "solve of the standing tower exits %d: %s" % (r.returncode, r.stderr))
        if again.exists():
            result = json.loads(again.read_text())
            expect(result["stats"]["geometry_change"] == 0.0,
                   "solve moved the standing tower by %g m" % result["stats"]["geometry_change"])

    print("%d failure(s)" % len(failures) if failures else "all checks passed")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
