#!/usr/bin/python3
"""Progress of `tensegrity solve`, `simulate`, `batch` and `stress-test` on standard error (docs/USER-GUIDE.md).

On a terminal (a pseudo-terminal here) a solve shows one status line,
rewritten in place with a carriage return: iteration, relative residual and
seconds, ending with the last iteration record and a newline before the
summary. With --quiet, or when standard error is not a terminal, no status
line appears. TENSEGRITY_PROGRESS_AFTER=0 drops the two-second delay, so the
test does not depend on how long the solve takes on this machine; the batch
and stress-test checks with the default delay use jobs that run until their
time limit.

    /usr/bin/python3 tests/cli_progress_test.py --binary build/tensegrity --source .

Exit status 0 when every check passes, 1 otherwise (each failure is printed).
"""
import argparse
import copy
import csv
import json
import os
import pathlib
import pty
import random
import re
import select
import subprocess
import sys
import tempfile
import time

PROGRESS = re.compile(r"solve: (?:part (\d+)/(\d+), )?iteration (\d+), relative residual ([-+0-9.e]+), ([0-9.]+) s")
SIMULATE_STATUS = re.compile(r"simulate: step (\d+)/(\d+), t = ([0-9.]+) s, ([0-9.]+) s elapsed")
SIMULATE_TENTH = re.compile(r"simulate: step (\d+)/(\d+) \((\d+) %\), t = ([0-9.]+) s")
BATCH_STATUS = re.compile(r"batch: (\d+)/(\d+) solves done, (\d+) failed, ([0-9.]+) s")
BATCH_TENTH = re.compile(r"batch: (\d+)/(\d+) solves done \((\d+) %\), (\d+) failed, ([0-9.]+) s")
STRESS_STATUS = re.compile(r"stress-test: (\d+)/(\d+) solves done, (\d+) not converged or not verified, ([0-9.]+) s")
STRESS_TENTH = re.compile(
    r"stress-test: (\d+)/(\d+) solves done \((\d+) %\), (\d+) not converged or not verified, ([0-9.]+) s")
STRESS_SUMMARY = re.compile(r"stress-test: (\d+) solves; (\d+) with a non-finite number")
TIME_LIMIT = 300  # s, against a hang

failures = []


def check(condition, what, context=""):
    if not condition:
        failures.append(what)
        print("FAIL: " + what + ("\n" + context if context else ""), file=sys.stderr)


def environment(delay):
    env = dict(os.environ)
    env.pop("TENSEGRITY_PROGRESS_AFTER", None)
    if delay is not None:
        env["TENSEGRITY_PROGRESS_AFTER"] = str(delay)
    return env


def run_on_terminal(args, delay):
    """Runs the program with standard error on a pseudo-terminal; (status, text seen there)."""
    master, slave = pty.openpty()
    proc = subprocess.Popen(args, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=slave,
                            env=environment(delay))
    os.close(slave)
    chunks = []
    deadline = time.monotonic() + TIME_LIMIT
    while time.monotonic() < deadline:
        ready, _, _ = select.select([master], [], [], 1.0)
        if not ready:
            if proc.poll() is not None:
                break
            continue
        try:
            data = os.read(master, 4096)
        except OSError:  # EIO: every writer closed the terminal
            break
        if not data:
            break
        chunks.append(data)
    os.close(master)
    if proc.poll() is None:
        proc.kill()
    return proc.wait(), b"".join(chunks).decode()


def run_on_pipe(args, delay):
    r = subprocess.run(args, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                       env=environment(delay), timeout=TIME_LIMIT)
    return r.returncode, r.stderr.decode()


def last_trace_row(path):
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    return rows[-1], len(rows)


def perturbed_prism(source, work):
    """The 8-prism with every node moved by up to 5 cm (seeded): every backend converges on it."""
    scene = json.loads((source / "data/reference/prism-8.scene.json").read_text())
    rng = random.Random(5)
    for node in scene["nodes"]:
        node["x"] = [x + rng.uniform(-0.05, 0.05) for x in node["x"]]
    scene["name"] = "prism-8-perturbed"
    path = work / "prism-8-perturbed.scene.json"
    path.write_text(json.dumps(scene))
    return path


def check_solve(binary, scene, work, solver):
    solution = work / "s.solution.json"
    trace = work / "s.csv"
    solve = [binary, "solve", str(scene), "--solver", solver, "--out", str(solution), "--trace", str(trace)]

    # On a terminal: status lines, the last one the final iteration record.
    status, err = run_on_terminal(solve, 0)
    check(status == 0, f"{solver}: solve on a terminal exits 0, got {status}", err)
    updates = PROGRESS.findall(err)
    # The first record is due at once (no delay), the last one is drawn at the end.
    check(len(updates) >= 2, f"{solver}: status lines appear on a terminal", repr(err))
    check("\r" in err, f"{solver}: the status line is rewritten with a carriage return", repr(err))
    if not updates:
        return
    row, rows = last_trace_row(trace)
    sol = json.loads(solution.read_text())
    last = updates[-1]
    check(int(last[2]) == int(row["iteration"]),
          f"{solver}: the last status shows the last iteration {row['iteration']}, got {last[2]}", repr(err))
    shown, recorded = float(last[3]), float(row["relative_residual"])
    check(abs(shown - recorded) <= 1e-3 * recorded,
          f"{solver}: the last status shows the last relative residual {recorded}, got {shown}", repr(err))
    check(recorded <= 1e-8, f"{solver}: the solve converged (relative residual {recorded})")
    iterations = [int(u[2]) for u in updates]
    check(iterations == sorted(iterations), f"{solver}: iterations in the status line never go back: {iterations}")
    seconds = [float(u[4]) for u in updates]
    check(seconds == sorted(seconds), f"{solver}: seconds in the status line never go back: {seconds}")
    check(seconds[-1] <= sol["stats"]["seconds"] + 0.05,
          f"{solver}: the status time {seconds[-1]} s is within the solve's {sol['stats']['seconds']} s")
    # At most one update per 0.25 s, plus the first and the final one.
    check(len(updates) <= 2 + sol["stats"]["seconds"] / 0.25,
          f"{solver}: {len(updates)} updates in {sol['stats']['seconds']} s is more than 4 per second")
    # Finished with a newline: the summary starts a line of its own.
    check(re.search(r"\n[^\r\n]*: converged by " + re.escape(solver), err) is not None,
          f"{solver}: the summary follows the status line on a new line", repr(err))

    check(int(updates[0][2]) <= 1, f"{solver}: the first status shows iteration 0 or 1, got {updates[0][2]}")

    # With the default delay of 2 s a solve this short (well under 0.1 s here)
    # shows no status line, only its summary.
    status, err = run_on_terminal(solve, None)
    check(status == 0 and not PROGRESS.search(err) and "\r\n" in err and err.count("\n") == 1,
          f"{solver}: a short solve shows only its summary on a terminal", repr(err))

    # --quiet: nothing at all for a converged solve.
    status, err = run_on_terminal(solve + ["--quiet"], 0)
    check(status == 0, f"{solver}: --quiet exits 0, got {status}", err)
    check(err == "", f"{solver}: --quiet prints nothing on a terminal", repr(err))

    # Not a terminal: only the summary line.
    status, err = run_on_pipe(solve, 0)
    check(status == 0, f"{solver}: solve without a terminal exits 0, got {status}", err)
    check(not PROGRESS.search(err) and "\r" not in err, f"{solver}: no status line without a terminal", repr(err))
    check(err.count("\n") == 1 and ": converged by " + solver in err,
          f"{solver}: exactly the summary line without a terminal", repr(err))


def check_verbose(binary, scene, work):
    # --verbose on a terminal: the per-iteration log, no status line over it.
    trace = work / "v.csv"
    status, err = run_on_terminal([binary, "solve", str(scene), "--solver", "alternating", "--out",
                                   str(work / "v.solution.json"), "--trace", str(trace), "--verbose"], 0)
    check(status == 0, f"--verbose exits 0, got {status}", err)
    check(not PROGRESS.search(err), "--verbose shows no status line", repr(err[:2000]))
    _, rows = last_trace_row(trace)
    logged = re.findall(r"alternating: iteration (\d+): residual", err)
    check(len(logged) == rows, f"--verbose logs one line per trace row ({rows}), got {len(logged)}")


def check_simulate(binary, source, work):
    design = work / "prism.design.json"
    subprocess.run([binary, "design", str(source / "data/reference/prism-6-gravity.scene.json"), "--out",
                    str(design), "--quiet"], check=True, timeout=TIME_LIMIT, stdin=subprocess.DEVNULL)
    steps = 40
    simulate = [binary, "simulate", str(design), "--dt", "0.01", "--steps", str(steps), "--no-vtk", "--out",
                str(work / "frames.jsonl")]
    # Not a terminal: a line at every tenth of the run instead of one per step, then the summary.
    status, err = run_on_pipe(simulate, 0)
    check(status == 0, f"simulate exits 0, got {status}", err)
    tenths = SIMULATE_TENTH.findall(err)
    check([int(t[0]) for t in tenths] == [4 * k for k in range(1, 11)],
          "simulate without a terminal reports steps 4, 8, ..., 40", err)
    check(all(int(t[2]) == 10 * (k + 1) for k, t in enumerate(tenths)), "simulate reports 10 %, 20 %, ...", err)
    if tenths:
        check(abs(float(tenths[-1][3]) - 0.4) < 1e-9, f"simulate ends at t = 0.4 s, got {tenths[-1][3]}", err)
    check(err.count("\n") == 11 and "\r" not in err, "simulate without a terminal: 10 lines and the summary", err)
    # A terminal: the status line, last at step 40 of 40, then the summary.
    status, err = run_on_terminal(simulate, 0)
    check(status == 0, f"simulate on a terminal exits 0, got {status}", err)
    shown = SIMULATE_STATUS.findall(err)
    check(len(shown) >= 1 and shown[-1][0] == str(steps) and shown[-1][1] == str(steps),
          "simulate's status line ends at the last step", repr(err))
    check(not SIMULATE_TENTH.search(err), "no tenth lines on a terminal", repr(err))
    # --quiet: nothing.
    status, err = run_on_terminal(simulate + ["--quiet"], 0)
    check(status == 0 and err == "", "simulate --quiet prints nothing", repr(err))


def not_converged(report):
    return sum(1 for job in json.loads(report.read_text())["jobs"] if job["status"] != "converged")


def check_batch(binary, source, work):
    folder = work / "batch-scenes"
    folder.mkdir()
    scene = json.loads((source / "data/reference/prism-8.scene.json").read_text())
    for seed in (1, 2, 3):
        rng = random.Random(seed)
        perturbed = copy.deepcopy(scene)
        for node in perturbed["nodes"]:
            node["x"] = [x + rng.uniform(-0.05, 0.05) for x in node["x"]]
        (folder / f"prism-{seed}.scene.json").write_text(json.dumps(perturbed))
    report = work / "batch-report.json"
    fast = [binary, "batch", str(folder), "--solver", "alternating-gn", "--jobs", "2", "--out-dir",
            str(work / "batch-out"), "--json", str(report)]

    # Not a terminal: the line naming the run, then a line at every tenth of the jobs (1, 2, 3 of 3).
    status, err = run_on_pipe(fast, 0)
    check(status == 0, f"batch without a terminal exits 0, got {status}", err)
    tenths = BATCH_TENTH.findall(err)
    check([(t[0], t[1], t[2]) for t in tenths] == [("1", "3", "33"), ("2", "3", "66"), ("3", "3", "100")],
          "batch without a terminal reports 1/3 (33 %), 2/3 (66 %), 3/3 (100 %)", err)
    check(all(t[3] == "0" for t in tenths) and not_converged(report) == 0, "batch without a terminal: 0 failed", err)
    check(not BATCH_STATUS.search(err) and "\r" not in err and err.count("\n") == 4,
          "batch without a terminal: the run's line and three tenth lines, no status line", err)
    status, err = run_on_pipe(fast + ["--quiet"], 0)
    check(status == 0 and err == "", "batch --quiet without a terminal prints nothing", err)

    # A terminal, no delay: the status line, last at 3 of 3.
    status, err = run_on_terminal(fast, 0)
    check(status == 0, f"batch on a terminal exits 0, got {status}", err)
    shown = BATCH_STATUS.findall(err)
    check(len(shown) >= 1 and shown[-1][:3] == ("3", "3", "0"), "batch's status line ends at 3/3, 0 failed",
          repr(err))
    check("\r" in err and not BATCH_TENTH.search(err), "batch on a terminal: rewritten in place, no tenth lines",
          repr(err))

    # The default delay of 2 s: a run longer than that shows the line. The
    # faithful scheme cannot finish the unsolved 80-strut tower in 3 s, so
    # that job ends time_limit and the run lasts more than 3 s.
    tower = folder / "tower.scene.json"
    subprocess.run([binary, "generate", "tower", "--out", str(tower)], check=True, timeout=TIME_LIMIT,
                   stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL)
    slow = [binary, "batch", str(folder), "--solver", "alternating", "--time-limit", "3", "--jobs", "2",
            "--out-dir", str(work / "batch-slow"), "--json", str(report)]
    status, err = run_on_terminal(slow, None)
    check(status == 1, f"batch with a job at its time limit exits 1, got {status}", err)
    wall = json.loads(report.read_text())["totals"]["wall_seconds"]
    check(wall > 2.5, f"the slow batch runs longer than the 2 s delay (took {wall} s)")
    failed = not_converged(report)
    check(failed >= 1, f"the tower job does not converge in 3 s ({failed} failed)")
    shown = BATCH_STATUS.findall(err)
    check(len(shown) >= 1 and shown[-1][:3] == ("4", "4", str(failed)),
          f"batch's status line after 2 s ends at 4/4, {failed} failed", repr(err))
    check(all(float(s[3]) >= 2.0 for s in shown), "no status line before 2 s", repr(err))
    done = [int(s[0]) for s in shown]
    check(done == sorted(done), f"solves done never go back: {done}")
    # At most 4 updates per second, plus the final one.
    check(len(shown) <= 2 + 4 * wall, f"{len(shown)} updates in {wall} s is more than 4 per second")
    # --quiet: nothing on the terminal (the table goes to standard output).
    status, err = run_on_terminal(slow + ["--quiet"], None)
    check(status == 1 and err == "", "batch --quiet prints nothing on a terminal", repr(err))


def stress_failures(report):
    """The report's failures: trials that did not converge, verify or stay finite, what the status line counts."""
    return len(json.loads(report.read_text())["failures"])


def check_stress_test(binary, source, work):
    data = str(source / "data")
    # Six trials (the six noise levels of the 3-prism), each converging in milliseconds.
    fast = [binary, "stress-test", "--scenes", "prism-3", "--families", "noise", "--trials", "1", "--solvers",
            "alternating-gn", "--jobs", "2", "--no-times", "--data", data, "--out"]

    # Not a terminal: the line naming the run, a line at every tenth of the
    # trials (each of the six ends a new tenth), the summary; no status line.
    report = work / "stress-pipe.json"
    status, err = run_on_pipe(fast + [str(report)], 0)
    check(status == 0, f"stress-test without a terminal exits 0, got {status}", err)
    check(stress_failures(report) == 0, "the six fast stress trials converge and verify")
    tenths = STRESS_TENTH.findall(err)
    check([(t[0], t[1], t[2], t[3]) for t in tenths] ==
          [(str(k), "6", str(100 * k // 6), "0") for k in range(1, 7)],
          "stress-test without a terminal reports 1/6 (16 %), 2/6 (33 %), ..., 6/6 (100 %), 0 not converged", err)
    check(err.startswith("stress-test: 6 solves, 2 jobs...\n"), "stress-test names its run first", err)
    check(STRESS_SUMMARY.findall(err) == [("6", "0")], "stress-test ends with its summary: 6 solves, 0 bad", err)
    check(not STRESS_STATUS.search(err) and "\r" not in err and err.count("\n") == 8,
          "stress-test without a terminal: the run's line, six tenth lines and the summary, no status line", err)

    # The report does not depend on where progress goes: byte-identical on a
    # terminal, with --quiet and on a pipe (--no-times).
    quiet_report = work / "stress-quiet.json"
    status, err = run_on_pipe(fast + [str(quiet_report), "--quiet"], 0)
    check(status == 0 and err == "", "stress-test --quiet without a terminal prints nothing", err)
    terminal_report = work / "stress-terminal.json"
    status, err = run_on_terminal(fast + [str(terminal_report)], 0)
    check(status == 0, f"stress-test on a terminal exits 0, got {status}", err)
    check(report.read_bytes() == quiet_report.read_bytes() == terminal_report.read_bytes(),
          "the --no-times report is the same on a pipe, with --quiet and on a terminal")

    # A terminal, no delay: the status line, rewritten in place, last at 6/6.
    shown = STRESS_STATUS.findall(err)
    check(len(shown) >= 1 and shown[-1][:3] == ("6", "6", "0"), "stress-test's status line ends at 6/6, 0 not converged",
          repr(err))
    check("\r" in err and not STRESS_TENTH.search(err), "stress-test on a terminal: rewritten in place, no tenth lines",
          repr(err))
    check(re.search(r"\r[^\r\n]*6/6 solves done[^\r\n]*\r?\nstress-test: 6 solves; ", err) is not None,
          "the summary follows the status line on a new line", repr(err))

    # The default delay of 2 s: a run this short shows no status line.
    status, err = run_on_terminal(fast + [str(terminal_report)], None)
    check(status == 0 and not STRESS_STATUS.search(err) and "\r" not in err.replace("\r\n", "\n"),
          "a short stress-test shows no status line on a terminal", repr(err))
    check(err.replace("\r\n", "\n").count("\n") == 2, "a short stress-test: the run's line and the summary", repr(err))

    # --measure-speedup: the one-worker pass first, named and counted the same way.
    status, err = run_on_pipe(fast + [str(work / "stress-speedup.json"), "--measure-speedup"], 0)
    check(status == 0, f"stress-test --measure-speedup exits 0, got {status}", err)
    names = re.findall(r"stress-test: 6 solves, (1 job \(for the speed-up\)|2 jobs)\.\.\.", err)
    check(names == ["1 job (for the speed-up)", "2 jobs"], "--measure-speedup names both passes", err)
    check([t[0] for t in STRESS_TENTH.findall(err)] == [str(k) for k in range(1, 7)] * 2,
          "--measure-speedup: tenth lines for both passes", err)

    # The default delay with a run longer than 2 s: the faithful scheme cannot
    # finish the 80-strut tower (near-parallel, three levels) in 1.2 s, so each
    # of the three trials ends time_limit, one after the other.
    slow_report = work / "stress-slow.json"
    slow = [binary, "stress-test", "--scenes", "tower-80s-500c", "--families", "near-parallel", "--trials", "1",
            "--solvers", "alternating", "--time-limit", "1.2", "--jobs", "1", "--data", data, "--out",
            str(slow_report)]
    status, err = run_on_terminal(slow, None)
    check(status == 0, f"the slow stress-test exits 0 (time_limit is no broken rule), got {status}", err)
    j = json.loads(slow_report.read_text())
    wall = j["totals"]["wall_seconds"]
    check(wall > 2.5, f"the slow stress-test runs longer than the 2 s delay (took {wall} s)")
    failed = stress_failures(slow_report)
    check(failed >= 1, f"the tower trials do not converge in 1.2 s ({failed} of 3 not converged)")
    shown = STRESS_STATUS.findall(err)
    check(len(shown) >= 1 and shown[-1][:3] == ("3", "3", str(failed)),
          f"stress-test's status line after 2 s ends at 3/3, {failed} not converged", repr(err))
    check(all(float(s[3]) >= 2.0 for s in shown), "no stress-test status line before 2 s", repr(err))
    done = [int(s[0]) for s in shown]
    check(done == sorted(done), f"stress trials done never go back: {done}")
    check(len(shown) >= 2, f"the time on the status line moves while a trial runs ({len(shown)} updates)", repr(err))
    check(len(shown) <= 2 + 4 * wall, f"{len(shown)} stress-test updates in {wall} s is more than 4 per second")
    check(re.search(r"\r\nstress-test: 3 solves; 0 with", err) is not None,
          "the slow run's summary starts a line of its own", repr(err))
    # --quiet: nothing on the terminal.
    status, err = run_on_terminal(slow + ["--quiet"], None)
    check(status == 0 and err == "", "stress-test --quiet prints nothing on a terminal", repr(err))
    # Not a terminal: tenth lines only (1/3, 2/3, 3/3), never a status line.
    status, err = run_on_pipe(slow, None)
    check(status == 0, f"the slow stress-test on a pipe exits 0, got {status}", err)
    check([(t[0], t[2]) for t in STRESS_TENTH.findall(err)] == [("1", "33"), ("2", "66"), ("3", "100")],
          "the slow stress-test on a pipe reports 1/3 (33 %), 2/3 (66 %), 3/3 (100 %)", err)
    check(not STRESS_STATUS.search(err) and "\r" not in err, "the slow stress-test on a pipe: no status line", err)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--binary", required=True)
    parser.add_argument("--source", required=True)
    a = parser.parse_args()
    source = pathlib.Path(a.source)
    with tempfile.TemporaryDirectory(prefix="tensegrity-progress-") as tmp:
        work = pathlib.Path(tmp)
        scene = perturbed_prism(source, work)
        for solver in ["alternating", "alternating-gn", "ipopt", "nlopt"]:
            check_solve(a.binary, scene, work, solver)
        check_verbose(a.binary, scene, work)
        check_simulate(a.binary, source, work)
        check_batch(a.binary, source, work)
        check_stress_test(a.binary, source, work)
    print(f"cli_progress: {len(failures)} failures")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
