#!/usr/bin/python3
"""Compares two `tensegrity stress-test` reports of the same trials (for
example one backend with two option settings): how many converged and
verified in each, and on the trials both solved, where the second ended closer
to the scene, farther or at the same geometry change; solver seconds in all.

    /usr/bin/python3 bench/scripts/compare_stress.py FIRST.json SECOND.json [--list]

Trials are matched by (scene, solver, family, level, trial). Two changes count
as the same within a relative 1e-6. --list prints the trials that only one
report solved and those where the second ended more than 1 % farther.
"""
import argparse
import json
import statistics

SAME = 1e-6
CLEARLY = 0.01  # a change more than 1 % apart: another local optimum, not rounding


def load(path):
    with open(path) as f:
        trials = json.load(f)["trials"]
    return {(t["scene"], t["solver"], t["family"], t["level"], t["trial"]): t for t in trials}


def solved(t):
    return t["status"] == "converged" and t["verified"]


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("first")
    parser.add_argument("second")
    parser.add_argument("--list", action="store_true")
    args = parser.parse_args()
    a, b = load(args.first), load(args.second)
    keys = sorted(set(a) & set(b))
    if len(keys) != len(a) or len(keys) != len(b):
        print(f"note: {len(a)} and {len(b)} trials, {len(keys)} in both; only those are compared")
    closer = farther = same = 0
    ratios = []
    for k in keys:
        x, y = a[k], b[k]
        if not (solved(x) and solved(y)):
            continue
        gx, gy = x["geometry_change"], y["geometry_change"]
        if gy < gx * (1 - SAME):
            closer += 1
            ratios.append(gy / gx)
        elif gy > gx * (1 + SAME):
            farther += 1
            ratios.append(gy / gx if gx > 0 else float("inf"))
        else:
            same += 1
    only_first = [k for k in keys if solved(a[k]) and not solved(b[k])]
    only_second = [k for k in keys if solved(b[k]) and not solved(a[k])]
    print(f"{len(keys)} trials; converged and verified: first {sum(solved(a[k]) for k in keys)}, "
          f"second {sum(solved(b[k]) for k in keys)}")
    print(f"solved by both: {closer + farther + same}; the second closer on {closer}, farther on {farther}, "
          f"the same change on {same}; solved by the first only {len(only_first)}, by the second only {len(only_second)}")
    if ratios:
        print(f"change second / first: smallest {min(ratios):.3g}, largest {max(ratios):.3g}; "
              f"more than 1 % closer on {sum(r < 1 - CLEARLY for r in ratios)}, "
              f"more than 1 % farther on {sum(r > 1 + CLEARLY for r in ratios)}")
    # Reports written with --no-times carry no seconds.
    if all("seconds" in a[k] and "seconds" in b[k] for k in keys):
        sa = sum(a[k]["seconds"] for k in keys)
        sb = sum(b[k]["seconds"] for k in keys)
        ma = statistics.median(a[k]["seconds"] for k in keys)
        mb = statistics.median(b[k]["seconds"] for k in keys)
        print(f"solver seconds in all: first {sa:.1f}, second {sb:.1f} ({sb / sa:.2f}x); "
              f"median per trial: first {ma:.4f}, second {mb:.4f}")
    if args.list:
        for k in only_first:
            print("  first only:", k, a[k]["iterations"], "iterations;", "second:", b[k]["status"])
        for k in only_second:
            print("  second only:", k, b[k]["iterations"], "iterations;", "first:", a[k]["status"])
        for k in keys:
            if solved(a[k]) and solved(b[k]) and b[k]["geometry_change"] > (1 + CLEARLY) * a[k]["geometry_change"]:
                print("  farther:", k, a[k]["geometry_change"], "->", b[k]["geometry_change"])
        for k in keys:
            if solved(a[k]) and solved(b[k]) and b[k]["geometry_change"] < (1 - CLEARLY) * a[k]["geometry_change"]:
                print("  closer:", k, a[k]["geometry_change"], "->", b[k]["geometry_change"])


if __name__ == "__main__":
    main()
