#!/usr/bin/python3
"""compare_bench's --write_scenes and --extra_backends, end to end.

    bench_scene_export_test.py COMPARE_BENCH TENSEGRITY

Runs Ipopt on the 2-layer scaling tower twice, with its default MUMPS
ordering and as the extra label ipopt@mumps_pivot_order=5, writing every
scene as built. Checks that the written scenes have the benchmark scenes'
element counts, that a gravity tower no selected benchmark built is not
written, that `tensegrity solve` on the written tower ends at the
benchmark's geometry change (the file is the problem that was timed), that
both orderings verify at the same optimum, and that malformed, unknown or
repeated labels in --extra_backends exit 2 with a message naming the flag.
"""
import json
import os
import subprocess
import sys
import tempfile

# Element counts of scenes every run builds (docs/figures/scaling.md, side-by-side.md).
EXPECTED_ELEMENTS = {"tower-layers-2": 60, "octahedron-grid-2x7": 572, "scorpion-minimal": 503}
EXTRA_LABEL = "ipopt@mumps_pivot_order=5"
SAME_FILE_TOLERANCE = 1e-9     # relative: the same solver on the same scene and target
SAME_OPTIMUM_TOLERANCE = 1e-6  # relative: another ordering, the same local optimum
BAD_INPUT_STATUS = 2
TIME_LIMIT = "30"
UNBUILT_TOWER = "tower-10-gravity-noise1"  # of --gravity_tower_layers=10, which the filter does not select
BAD_LABELS = ["no-such-backend@key=1", "ipopt@=5", "ipopt@key=", "ipopt", "ipopt@a=1,ipopt@a=1",
              "eq5-newton@barrier=monotone"]


def run_geometry_changes(path):
    with open(path) as f:
        runs = json.load(f)["benchmarks"]
    out = {}
    for r in runs:
        label = r["name"].split("/")[2]
        out[label] = (r["geometry_change"], r["success"])
    return out


def main(compare_bench, tensegrity):
    failures = []
    with tempfile.TemporaryDirectory() as work:
        scenes = os.path.join(work, "scenes")
        out_json = os.path.join(work, "bench.json")
        bench = subprocess.run([compare_bench, f"--write_scenes={scenes}", "--chain_sizes=", "--tower_layers=2",
                                "--gravity_tower_layers=10",
                                "--benchmark_filter=^scaling/tower-layers-2/ipopt(/|@mumps)",
                                f"--extra_backends={EXTRA_LABEL}", f"--time_limit={TIME_LIMIT}", "--tolerance=1e-8",
                                "--benchmark_min_time=0.001", "--benchmark_repetitions=1",
                                f"--benchmark_out={out_json}", "--benchmark_out_format=json"],
                               stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
        if bench.returncode != 0:
            print(bench.stderr)
            print(f"FAIL: compare_bench exited {bench.returncode}")
            return 1
        if os.path.exists(os.path.join(scenes, UNBUILT_TOWER + ".scene.json")):
            failures.append(f"{UNBUILT_TOWER} written although no selected benchmark built it")
        for name, elements in EXPECTED_ELEMENTS.items():
            path = os.path.join(scenes, name + ".scene.json")
            if not os.path.exists(path):
                failures.append(f"{name}.scene.json not written")
                continue
            with open(path) as f:
                found = len(json.load(f)["elements"])
            if found != elements:
                failures.append(f"{name}: {found} elements, expected {elements}")

        changes = run_geometry_changes(out_json)
        if set(changes) != {"ipopt", EXTRA_LABEL}:
            failures.append(f"runs {sorted(changes)}, expected ipopt and {EXTRA_LABEL}")
        else:
            default_change, default_ok = changes["ipopt"]
            extra_change, extra_ok = changes[EXTRA_LABEL]
            if not (default_ok == 1 and extra_ok == 1):
                failures.append(f"not verified: ipopt {default_ok}, {EXTRA_LABEL} {extra_ok}")
            if abs(extra_change - default_change) > SAME_OPTIMUM_TOLERANCE * default_change:
                failures.append(f"orderings end apart: {default_change} m and {extra_change} m")
            solution = os.path.join(work, "tower.solution.json")
            subprocess.run([tensegrity, "solve", os.path.join(scenes, "tower-layers-2.scene.json"), "--solver",
                            "ipopt", "--no-skip", "--tol", "1e-8", "--time-limit", TIME_LIMIT, "--out", solution],
                           check=True, stdout=subprocess.DEVNULL)
            with open(solution) as f:
                cli_change = json.load(f)["stats"]["geometry_change"]
            if abs(cli_change - default_change) > SAME_FILE_TOLERANCE * default_change:
                failures.append(f"solve on the written scene: {cli_change} m, the benchmark {default_change} m")

        for label in BAD_LABELS:
            bad = subprocess.run([compare_bench, f"--extra_backends={label}"], capture_output=True, text=True)
            if bad.returncode != BAD_INPUT_STATUS or "--extra_backends" not in bad.stderr:
                failures.append(f"{label}: status {bad.returncode}, stderr {bad.stderr!r}")

    for f in failures:
        print("FAIL:", f)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1], sys.argv[2]))
