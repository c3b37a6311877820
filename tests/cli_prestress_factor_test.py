#!/usr/bin/python3
"""--prestress-factor (kappa of Eq. 5 under gravity) on every command that solves.

`batch`, `stress-test` and `compare` pass kappa to the solve exactly as `solve`
does: the same scene with the same backend gives the same geometry change, and
a different kappa a different one. A value that is not finite and > 0 is
refused by each command with the same line, exit status 2 and no output file;
every command's help describes the option in the same words.

    /usr/bin/python3 tests/cli_prestress_factor_test.py --binary build/tensegrity --source .

Exit status 0 when every check passes, 1 otherwise (each failure is printed).
"""
import argparse
import json
import math
import pathlib
import subprocess
import sys
import tempfile

SCENE = pathlib.Path("data") / "reference" / "prism-7-gravity.scene.json"
BACKEND = "ipopt"
KAPPA = "5"  # not the default, so that an ignored option shows
# The geometry change of one solve read back from two files (solution, report)
# that both print it with 17 significant digits.
SAME_NUMBER = 1e-12
# kappa = 1, 2 and 5 move the prism by clearly different amounts
# (docs/THEORY-force-scale.md); a tenth of the smaller is far beyond solver noise.
CLEARLY_DIFFERENT = 0.1
BAD_VALUES = ["0", "-1", "nan", "inf"]
BAD_LINE = "tensegrity: command line: --prestress-factor: must be a finite number > 0\n"
DEFAULT_KAPPA = "2"  # kDefaultPrestressFactor
HELP_WORDS = "kappa: under gravity Eq. 5 caps the mean cable force at kappa times the part's weight"


class Checks:
    def __init__(self):
        self.failures = 0

    def expect(self, ok, message):
        if not ok:
            print("FAIL: " + message)
            self.failures += 1
        return ok


def run(binary, *args):
    return subprocess.run([str(binary)] + [str(a) for a in args], capture_output=True, text=True, timeout=600)


def solve_change(binary, scene, work, kappa):
    out = work / f"solve-{kappa}.solution.json"
    extra = [] if kappa is None else ["--prestress-factor", kappa]
    done = run(binary, "solve", scene, "--solver", BACKEND, "--out", out, "--quiet", *extra)
    if done.returncode != 0:
        raise SystemExit(f"solve {scene} (kappa {kappa}): exit {done.returncode}\n{done.stderr}")
    return json.loads(out.read_text())["stats"]["geometry_change"]


def close(a, b):
    return abs(a - b) <= SAME_NUMBER * max(1.0, abs(a), abs(b))


def check_batch(checks, binary, scene, work, expected):
    report = work / "batch.json"
    done = run(binary, "batch", scene, "--solver", BACKEND, "--prestress-factor", KAPPA, "--jobs", "1",
               "--out-dir", work / "batch", "--json", report, "--quiet")
    if not checks.expect(done.returncode == 0, f"batch --prestress-factor {KAPPA}: exit {done.returncode}\n{done.stderr}"):
        return
    document = json.loads(report.read_text())
    change = document["jobs"][0]["geometry_change"]
    checks.expect(close(change, expected), f"batch geometry change {change!r}, solve's {expected!r}")
    solution = json.loads((work / "batch" / "prism-7-gravity.solution.json").read_text())
    checks.expect(close(solution["stats"]["geometry_change"], expected),
                  f"batch's solution file: geometry change {solution['stats']['geometry_change']!r}, solve's {expected!r}")
    checks.expect(document["options"].get("prestress_factor") == float(KAPPA),
                  f"batch report options.prestress_factor {document['options'].get('prestress_factor')!r}")


def check_compare(checks, binary, scene, work, expected):
    folder = work / "compare"
    done = run(binary, "compare", scene, "--solvers", BACKEND, "--prestress-factor", KAPPA, "--out", folder)
    if not checks.expect(done.returncode == 0, f"compare --prestress-factor {KAPPA}: exit {done.returncode}\n{done.stderr}"):
        return
    change = json.loads((folder / "compare.json").read_text())["rows"][0]["geometry_change"]
    checks.expect(close(change, expected), f"compare geometry change {change!r}, solve's {expected!r}")


def stress_changes(binary, scene, data, work, kappa):
    """Geometry change per trial of a small stress test of the scene."""
    report = work / f"stress-{kappa}.json"
    done = run(binary, "stress-test", "--scenes", scene.name[: -len(".scene.json")], "--solvers", BACKEND,
               "--families", "noise", "--trials", "1", "--jobs", "1", "--no-times", "--quiet", "--data", data,
               "--prestress-factor", kappa, "--out", report)
    if done.returncode not in (0, 1):
        raise SystemExit(f"stress-test --prestress-factor {kappa}: exit {done.returncode}\n{done.stderr}")
    document = json.loads(report.read_text())
    return document, [t["geometry_change"] for t in document["trials"] if t["status"] == "converged"]


def check_stress_test(checks, binary, scene, data, work):
    one, at_one = stress_changes(binary, scene, data, work, "1")
    five, at_five = stress_changes(binary, scene, data, work, KAPPA)
    checks.expect(five["options"].get("prestress_factor") == float(KAPPA),
                  f"stress report options.prestress_factor {five['options'].get('prestress_factor')!r}")
    if checks.expect(at_one and len(at_one) == len(at_five), f"stress-test: converged trials {at_one} / {at_five}"):
        # A noisy prism that already stands stays put at any kappa; every one that moves depends on kappa.
        moved = [(a, b) for a, b in zip(at_one, at_five) if max(a, b) > 0.0]
        differ = [(a, b) for a, b in moved if abs(a - b) > CLEARLY_DIFFERENT * min(a, b)]
        checks.expect(moved and differ == moved,
                      f"stress-test: kappa 1 and {KAPPA} give geometry changes {at_one} and {at_five}")


def check_bad_values(checks, binary, scene, data, work):
    commands = {
        "solve": ["solve", scene, "--out", work / "bad.solution.json"],
        "batch": ["batch", scene, "--out-dir", work / "bad-batch", "--json", work / "bad-batch.json"],
        "stress-test": ["stress-test", "--scenes", "prism-3", "--data", data, "--out", work / "bad-stress.json"],
        "compare": ["compare", scene, "--out", work / "bad-compare"],
    }
    for name, args in commands.items():
        for value in BAD_VALUES:
            before = sorted(work.rglob("*"))
            done = run(binary, *args, f"--prestress-factor={value}")
            checks.expect(done.returncode == 2 and done.stderr == BAD_LINE and not done.stdout,
                          f"{name} --prestress-factor={value}: exit {done.returncode}, stderr {done.stderr!r}")
            checks.expect(sorted(work.rglob("*")) == before, f"{name} --prestress-factor={value} wrote a file")
        help_text = " ".join(run(binary, name, "--help").stdout.split())
        checks.expect(HELP_WORDS in help_text and f"default {DEFAULT_KAPPA};" in help_text,
                      f"{name} --help does not describe --prestress-factor")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--binary", type=pathlib.Path, required=True)
    parser.add_argument("--source", type=pathlib.Path, required=True)
    args = parser.parse_args()
    checks = Checks()
    scene, data = args.source / SCENE, args.source / "data"
    with tempfile.TemporaryDirectory(prefix="tensegrity-kappa-") as folder:
        work = pathlib.Path(folder)
        at_default = solve_change(args.binary, scene, work, None)
        at_five = solve_change(args.binary, scene, work, DEFAULT_KAPPA)
        at_one = solve_change(args.binary, scene, work, "1")
        at_kappa = solve_change(args.binary, scene, work, KAPPA)
        checks.expect(at_default == at_five,
                      f"solve: the default kappa moves {at_default!r}, kappa {DEFAULT_KAPPA} {at_five!r}")
        checks.expect(math.isfinite(at_kappa) and abs(at_kappa - at_one) > CLEARLY_DIFFERENT * min(at_one, at_kappa),
                      f"solve: kappa 1 moves {at_one!r}, kappa {KAPPA} {at_kappa!r}: not clearly different")
        check_batch(checks, args.binary, scene, work, at_kappa)
        check_compare(checks, args.binary, scene, work, at_kappa)
        check_stress_test(checks, args.binary, scene, data, work)
        bad = work / "bad"
        bad.mkdir()
        check_bad_values(checks, args.binary, scene, data, bad)
    print(f"cli_prestress_factor: {checks.failures} failures")
    return 1 if checks.failures else 0


if __name__ == "__main__":
    sys.exit(main())
