"""Liveness detours on the gridworld that no suite holds, trained as ``noisybolt train`` does.

The spec suite (``spec_suite.py``) is mostly made of specs that an episode without events
keeps (``G``-type: 22 of its 24 accept the empty trace), so it says little about specs
that ask the agent to *do* something off its shortest route. These do: each is an ``F``
spec over the gridworld's fluents that the shortest route (east along the top, then
south) breaks, from a nine-step two-corner detour to one turn. Each is trained with the
built-in defaults (PPO, the classifier bolt, the best evaluation kept), under each
``--schemes`` (``default``: no scheme named, what ``noisybolt train`` gives), and the
table gives, per spec, compliance and goal rate of the model each run writes, and the
frames at which an evaluation first complied and reached the goal.

    .venv/bin/python benchmarks/liveness_detours.py --schemes default,compliance --seeds 1 \\
        --out runs/liveness_detours

``--arm NAME:PATH=VALUE,...`` names a set of settings to run as one more column, e.g. the
constrained scheme as it was before its budget's anneal and starting price were chosen by
the scale (``annealed:bolt.constraint.anneal=0.5,bolt.constraint.start=0``).

Finished trials are read, not trained again (their ``summary.json``).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

#: The detours: none is in the spec suite or the world suite.
DETOURS: tuple[str, ...] = (
    "F(top_right_corner) & F(bottom_left_corner)",
    "F(bottom_left_corner & F(top_right_corner))",
    "F(facing_left)",
    "F(bottom_left_corner & facing_up)",
    "F(facing_up & on_edge)",
    "F(facing_left & on_edge)",
)


def run_trial(index: int, scheme: str, seed: int, args: argparse.Namespace) -> dict:
    """Trains one trial (unless finished) and returns its record."""
    from noisybolt.runs import TrainConfig, resolve, train

    out = Path(args.out) / scheme / f"d{index}" / f"seed{seed}"
    summary = out / "summary.json"
    if not summary.exists():
        if out.exists():  # an unfinished trial: start it again
            import shutil

            shutil.rmtree(out)
        settings: dict = {
            "bolt.specs": [DETOURS[index]],
            "frames": args.frames,
            "seed": seed,
            "progress_bar": False,
        }
        if scheme in args.arms:
            settings.update(args.arms[scheme])
        elif scheme != "default":
            settings["bolt.reward"] = scheme
        config = resolve(TrainConfig.build(settings))
        train(config, out, argv=[sys.executable, *sys.argv], log=lambda _: None)
    data = json.loads(summary.read_text())
    final = data["final"]
    return {
        "spec": DETOURS[index],
        "scheme": scheme,
        "seed": seed,
        "compliance": float(next(iter(final["compliance"].values()))),
        "goal_rate": float(final["goal_rate"]),
        "env_return": float(final["env_return_mean"]),
        "frames_to_comply": data.get("frames_to_comply"),
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--schemes", default="default,compliance")
    parser.add_argument("--seeds", type=int, default=1)
    parser.add_argument("--first-seed", type=int, default=0)
    parser.add_argument("--frames", type=int, default=60_000)
    parser.add_argument("--only", type=int, nargs="*", default=None, help="detour indices")
    parser.add_argument("--out", default="runs/liveness_detours")
    parser.add_argument(
        "--arm",
        action="append",
        default=[],
        metavar="NAME:PATH=VALUE[,PATH=VALUE]",
        help="a named set of config settings, then usable in --schemes (e.g. "
        "annealed:bolt.constraint.anneal=0.5,bolt.constraint.start=0)",
    )
    args = parser.parse_args(argv)
    import yaml

    args.arms = {}
    for text in args.arm:
        name, _, pairs = text.partition(":")
        try:
            args.arms[name] = {
                path: yaml.safe_load(value)
                for path, value in (pair.split("=", 1) for pair in pairs.split(","))
            }
        except ValueError:
            parser.error(f"--arm takes NAME:PATH=VALUE[,PATH=VALUE], got {text!r}")
    schemes = [s.strip() for s in args.schemes.split(",") if s.strip()]
    indices = args.only if args.only is not None else range(len(DETOURS))
    seeds = range(args.first_seed, args.first_seed + args.seeds)
    records = [run_trial(i, s, seed, args) for seed in seeds for i in indices for s in schemes]
    print(f"| spec | seed | {' | '.join(schemes)} |")
    print(f"|---|---:|{'---|' * len(schemes)}")
    cells = {(r["spec"], r["seed"], r["scheme"]): r for r in records}
    for i in indices:
        for seed in seeds:
            row = [cells[(DETOURS[i], seed, s)] for s in schemes]
            text = [
                f"{r['compliance']:.0%} / {r['goal_rate']:.0%}"
                + (f" ({r['frames_to_comply'] / 1000:.0f}k)" if r["frames_to_comply"] else "")
                for r in row
            ]
            print(f"| `{DETOURS[i]}` | {seed} | {' | '.join(text)} |")
    for s in schemes:
        kept = [r for r in records if r["scheme"] == s]
        good = sum(r["compliance"] >= 0.95 and r["goal_rate"] >= 0.9 for r in kept)
        print(f"{s}: complied (>= 95 %) and reached the goal (>= 90 %) in {good}/{len(kept)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
