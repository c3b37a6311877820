#!/usr/bin/python3
"""compare_bench's two-core family and its report, end to end.

    bench_two_cores_test.py COMPARE_BENCH REPORT_PY

Runs the family on the compare and side-by-side scenes (no gravity towers),
then bench/scripts/report.py on its JSON, and checks what does not depend on
the machine's speed: the job count (16 scenes x 3 backends), that every job
converged in the two-worker pass, that the estimate (the jobs' own wall times
over the pass's wall time) does not exceed the two workers, and that the
report carries the table and the median. Speed-ups are measured, not asserted.
"""
import csv
import json
import os
import subprocess
import sys
import tempfile

SCENES = 16            # 13 of the compare family, 3 of the side-by-side family (not the grid)
BACKENDS = 3           # ipopt, alternating-gn, eq5-newton
WORKERS = 2
ACCOUNTING_SLACK = 0.05  # the coordinator's clock reads of job ends and of the pass


def main(compare_bench, report):
    failures = []
    with tempfile.TemporaryDirectory() as work:
        out_json = os.path.join(work, "two-cores.json")
        subprocess.run([compare_bench, "--benchmark_filter=^two-cores/", "--gravity_tower_layers=",
                        "--time_limit=30", "--tolerance=1e-8", f"--benchmark_out={out_json}",
                        "--benchmark_out_format=json"], check=True, stdout=subprocess.DEVNULL)
        with open(out_json) as f:
            runs = [b for b in json.load(f)["benchmarks"] if b["name"].startswith("two-cores/")]
        if len(runs) != 1:
            failures.append(f"expected one two-cores run, found {len(runs)}")
        else:
            r = runs[0]
            if r["jobs"] != SCENES * BACKENDS:
                failures.append(f"jobs {r['jobs']}, expected {SCENES * BACKENDS}")
            if r["converged"] != r["jobs"]:
                failures.append(f"{r['converged']} of {r['jobs']} jobs converged")
            if not 0.0 < r["speedup_estimate"] <= WORKERS + ACCOUNTING_SLACK:
                failures.append(f"estimate {r['speedup_estimate']} outside (0, {WORKERS}]")
            if not (r["serial_wall_s"] > 0.0 and r["parallel_wall_s"] > 0.0 and r["parallel_cpu_s"] > 0.0):
                failures.append("a pass without wall or CPU time")
            expected = r["serial_wall_s"] / r["parallel_wall_s"]
            if abs(r["measured_speedup"] - expected) > 1e-9 * expected:
                failures.append(f"measured_speedup {r['measured_speedup']} is not serial / parallel wall {expected}")
        report_dir = os.path.join(work, "report")
        subprocess.run([sys.executable, report, "--json", out_json, "--out", report_dir], check=True,
                       stdout=subprocess.DEVNULL)
        with open(os.path.join(report_dir, "two_cores.csv")) as f:
            rows = list(csv.DictReader(f))
        if len(rows) != 1 or float(rows[0]["jobs"]) != SCENES * BACKENDS:
            failures.append(f"two_cores.csv: {rows}")
        with open(os.path.join(report_dir, "table.md")) as f:
            table = f.read()
        if "Median measured speed-up:" not in table or "| 1 | 48 | 48 |" not in table:
            failures.append("table.md lacks the two-core table or its median")
    for line in failures:
        print("FAIL:", line)
    if not failures:
        print(f"two-cores: {SCENES * BACKENDS} jobs, all converged, estimate within {WORKERS} workers, report written")
    return 1 if failures else 0


if __name__ == "__main__":
    if len(sys.argv) != 3:
        print(__doc__)
        sys.exit(2)
    sys.exit(main(sys.argv[1], sys.argv[2]))
