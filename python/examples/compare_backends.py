"""Every backend on one scene: relative residual against time from the solvers'
traces, plotted with matplotlib.

    PYTHONPATH=build/python /usr/bin/python3 python/examples/compare_backends.py \
        [--scene SCENE] [--out docs/images/python-backends.png]

Default scene: the duck built from the minimal block templates, moved off
equilibrium by the stress test's "noise" family at 10 % of its median element
length (seed 1). (The braced duck of data/characters/duck.character.json still
stands after that noise: its many cables balance the moved geometry, so every
backend would return it unchanged.)
"""
import argparse
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

import tensegrity as tg  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
NOISE_LEVEL = 4  # "noise" family level 0.1


def default_scene():
    duck = tg.build_character(str(ROOT / "data" / "characters" / "minimal" / "duck.character.json"))
    return tg.stress_case(duck, "noise", NOISE_LEVEL, 0, 1)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scene", help="scene file (default: the perturbed minimal duck)")
    parser.add_argument("--out", default=str(ROOT / "docs" / "images" / "python-backends.png"))
    parser.add_argument("--time-limit", type=float, default=20.0)
    args = parser.parse_args()
    scene = tg.load_scene(args.scene) if args.scene else default_scene()

    fig, ax = plt.subplots(figsize=(7, 4.5))
    print(f"{scene!r}")
    for solver in tg.solvers():
        result = tg.solve(scene, solver=solver, time_limit=args.time_limit)
        trace = result.trace
        verified = result.verify().ok
        print(f"{solver:16s} {result.status:15s} {result.stats['seconds']:9.4f} s "
              f"{result.stats['iterations']:6d} it  rel. residual {result.stats['relative_residual']:.2e}  "
              f"geometry change {result.stats['geometry_change']:.4g} m  verified {verified}")
        if len(trace["seconds"]) == 0:
            continue
        seconds = trace["seconds"].clip(min=1e-6)
        ax.loglog(seconds, trace["relative_residual"].clip(min=1e-17), marker=".", markersize=3,
                  label=f"{solver} ({result.status})")
    ax.axhline(1e-8, color="grey", linestyle=":", linewidth=1, label="tolerance 1e-8")
    ax.set_xlabel("time (s)")
    ax.set_ylabel("relative residual")
    ax.set_title(f"{scene.name}: {scene.num_nodes} nodes, {scene.num_elements} elements")
    ax.legend(fontsize=8)
    fig.tight_layout()
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(args.out, dpi=110)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
