#!/usr/bin/python3
"""Checks that #include directives point one way between the project's folders.

    model <- scenes
    model <- formulations <- kernels <- solvers <- simulation <- design <- reports <- cli, bench, python
    solvers <- workers <- cli, bench
    tests may include everything; nothing outside tests/ and bench/ includes them.

Inside solvers/, the interface and driver (solvers/*.hpp, *.cpp) never include a
backend (solvers/NAME/), and no backend includes another backend.

Ipopt's headers (<coin/...>) stay private: only source files (.cpp) of kernels/
(the one Ipopt adapter) and solvers/ipopt/ (its option registry) include them,
and tests.

Usage: include_direction_test.py SOURCE_DIR      check the project
       include_direction_test.py --self-test     check the checker on a made-up tree
"""
import os
import re
import sys
import tempfile

LIBRARIES = ["model", "scenes", "formulations", "kernels", "solvers", "simulation", "design", "reports", "workers"]
ALLOWED = {
    "model": {"model"},
    "scenes": {"scenes", "model"},
    "formulations": {"formulations", "model"},
    "kernels": {"kernels", "formulations", "model"},
    "solvers": {"solvers", "kernels", "formulations", "model"},
    "simulation": {"simulation", "solvers", "kernels", "formulations", "model"},
    "design": {"design", "simulation", "solvers", "kernels", "formulations", "model"},
    "reports": {"reports", "design", "simulation", "solvers", "kernels", "formulations", "model"},
    "workers": {"workers", "solvers", "kernels", "formulations", "model"},
    "cli": {"cli", *LIBRARIES},
    "bench": {"bench", *LIBRARIES},
    "python": {"python", *LIBRARIES},
    "tests": {"tests", *LIBRARIES, "cli"},
}
INCLUDE = re.compile(r'^\s*#\s*include\s*"([^"]+)"', re.M)
IPOPT_INCLUDE = re.compile(r'^\s*#\s*include\s*<coin/([^>]+)>', re.M)
IPOPT_USERS = ("kernels/", "solvers/ipopt/")
SOURCE_SUFFIXES = (".hpp", ".cpp", ".h", ".cc")


def backend_of(path_parts):
    """The backend folder of a path under solvers/ (None for the interface)."""
    if path_parts[0] == "solvers" and len(path_parts) > 2:
        return path_parts[1]
    return None


def violations(root):
    found = []
    for folder in ALLOWED:
        base = os.path.join(root, folder)
        for dirpath, _, files in os.walk(base):
            if os.path.basename(dirpath) in ("build", "node_modules") or "/build" in dirpath:
                continue
            for name in files:
                if not name.endswith(SOURCE_SUFFIXES):
                    continue
                path = os.path.join(dirpath, name)
                rel = os.path.relpath(path, root)
                parts = rel.split(os.sep)
                with open(path, encoding="utf-8", errors="replace") as f:
                    text = f.read()
                if folder != "tests" and IPOPT_INCLUDE.search(text):
                    if not (rel.endswith(".cpp") and rel.startswith(IPOPT_USERS)):
                        found.append(f"{rel}: includes an Ipopt header (only .cpp files of "
                                     f"{' and '.join(IPOPT_USERS)} may)")
                for target in INCLUDE.findall(text):
                    target_parts = target.split("/")
                    if len(target_parts) < 2:
                        continue  # a file of the same folder, or a system-style header
                    top = target_parts[0]
                    if top not in ALLOWED and top not in ("tests", "bench"):
                        continue
                    if top not in ALLOWED[folder]:
                        found.append(f"{rel}: includes {target} ({folder}/ may not depend on {top}/)")
                        continue
                    if folder == "solvers" and top == "solvers":
                        mine, theirs = backend_of(parts), backend_of(target_parts)
                        if theirs is not None and theirs != mine:
                            who = f"backend {mine}" if mine else "the solver interface"
                            found.append(f"{rel}: includes {target} ({who} may not depend on backend {theirs})")
    return found


def self_test():
    """The checker must find each kind of violation in a made-up tree."""
    cases = {
        "model/a.hpp": '#include "solvers/solver.hpp"\n',                   # upwards
        "cli/b.cpp": '#include "tests/process_runner.hpp"\n',               # into tests/
        "solvers/c.cpp": '#include "solvers/ipopt/ipopt_solver.hpp"\n',     # interface -> backend
        "solvers/nlopt/d.cpp": '#include "solvers/ipopt/ipopt_solver.hpp"\n',  # backend -> backend
        "kernels/e.cpp": '#include "formulations/equilibrium.hpp"\n',       # allowed
        "design/f.cpp": '#include "bench/x.hpp"\n',                         # into bench/
        "design/g.cpp": '#include <coin/IpTNLP.hpp>\n',                     # Ipopt outside its adapter
        "kernels/h.hpp": '#include <coin/IpTNLP.hpp>\n',                    # Ipopt in a header
        "kernels/i.cpp": '#include <coin/IpTNLP.hpp>\n',                    # allowed
        "tests/j.cpp": '#include <coin/IpReturnCodes.hpp>\n',               # allowed
        "reports/k.cpp": '#include "cli/commands.hpp"\n',                   # into the program
        "design/l.cpp": '#include "reports/output.hpp"\n',                  # upwards
        "python/m.cpp": '#include "cli/commands.hpp"\n',                    # module -> program
        "python/n.cpp": '#include "reports/renderer.hpp"\n',                # allowed
        "workers/o.cpp": '#include "reports/output.hpp"\n',                 # sideways into reports/
        "workers/p.cpp": '#include "solvers/solver.hpp"\n',                 # allowed
        "bench/q.cpp": '#include "workers/solve_jobs.hpp"\n',               # allowed
    }
    with tempfile.TemporaryDirectory() as root:
        for rel, text in cases.items():
            os.makedirs(os.path.join(root, os.path.dirname(rel)), exist_ok=True)
            with open(os.path.join(root, rel), "w") as f:
                f.write(text)
        found = violations(root)
    expected_files = {"model/a.hpp", "cli/b.cpp", "solvers/c.cpp", "solvers/nlopt/d.cpp", "design/f.cpp",
                      "design/g.cpp", "kernels/h.hpp", "reports/k.cpp", "design/l.cpp", "python/m.cpp",
                      "workers/o.cpp"}
    reported = {line.split(":")[0] for line in found}
    if reported != expected_files:
        print("self-test failed: reported", sorted(reported), "expected", sorted(expected_files))
        return 1
    print(f"self-test: {len(found)} of {len(found)} planted violations found, the allowed includes passed")
    return 0


def main(argv):
    if len(argv) == 2 and argv[1] == "--self-test":
        return self_test()
    if len(argv) != 2:
        print(__doc__)
        return 2
    found = violations(argv[1])
    for line in found:
        print(line)
    print(f"{len(found)} include(s) against the dependency direction")
    return 1 if found else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
