"""Google Benchmark's JSON output (--benchmark_out) as the figure scripts read it."""
import json
from collections import defaultdict


def iteration_runs(path, key):
    """The repetitions (not the aggregates) of every benchmark in `path`,
    grouped by key(name split at '/')."""
    runs = defaultdict(list)
    with open(path) as f:
        for b in json.load(f)["benchmarks"]:
            if b.get("run_type") == "iteration":
                runs[key(b["name"].split("/"))].append(b)
    return runs


def median(values):
    """The middle value (the upper one of an even count)."""
    v = sorted(values)
    return v[len(v) // 2]
