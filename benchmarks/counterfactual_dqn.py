"""DQN with and without counterfactual experience on the spec suite's detour specs.

The suite of ``benchmarks/spec_suite.py`` (the same generated specs, classifier bolt on
the smudged camera, built-in DQN hyperparameters, the default ``compliance`` scheme),
restricted to the specs whose compliant route is a detour (the world's shortest route
breaks them). Each (spec, seed) trains twice: plain DQN, and DQN whose replay buffer also
stores every transition relabelled from the other DFA states
(``algorithm.counterfactual``, :mod:`noisybolt.agents.counterfactual`). Runs are
evaluated every ``--eval-freq`` frames and stop at the first evaluation that complies
and reaches the goal (``evaluation.stop_after=1``): what is measured is N_frames
(``frames_to_comply``), a trial that never gets there counting at its budget.

Resumable: a trial whose ``summary.json`` exists is read, not trained again.

    .venv/bin/python benchmarks/counterfactual_dqn.py --seeds 1 --arms plain,counterfactual

``--set PATH=VALUE`` sets a config path in both arms (``--set bolt.shaping=false``: the
compliance scheme without its progress shaping, where the bolt pays only on acceptance).
"""

from __future__ import annotations

import argparse
import json
import shutil
import statistics
import sys
import time
from pathlib import Path
from typing import Any

import yaml

sys.path.insert(0, str(Path(__file__).resolve().parent))

import spec_suite  # the suite's trial config, beside this file

ARMS = {"plain": {}, "counterfactual": {"algorithm.counterfactual": True}}


def run_trial(spec: Any, seed: int, arm: str, args: argparse.Namespace) -> dict[str, Any]:
    """Trains one trial (unless finished) and returns its record."""
    import torch

    from noisybolt.runs import train

    torch.set_num_threads(1)
    out = Path(args.out) / arm / spec.name / f"seed{seed}"
    summary = out / "summary.json"
    started = time.perf_counter()
    if not summary.exists():
        if out.exists():  # an unfinished trial: start it again
            shutil.rmtree(out)
        config = spec_suite.trial_config(spec, "dqn", seed, "compliance", args)
        config = config.override({"evaluation.stop_after": 1, **args.settings, **ARMS[arm]})
        train(config, out, argv=[sys.executable, *sys.argv], log=lambda _: None)
    data = json.loads(summary.read_text())
    final = data["final"]
    return {
        "spec": spec.name,
        "seed": seed,
        "arm": arm,
        "frames_to_comply": data["frames_to_comply"],
        "frames": data["frames"],
        "compliance": float(next(iter(final["compliance"].values()))),
        "goal_rate": float(final["goal_rate"]),
        "seconds": round(time.perf_counter() - started, 1),
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seeds", type=int, default=1)
    parser.add_argument("--first-seed", type=int, default=0)
    parser.add_argument("--arms", default="plain,counterfactual")
    parser.add_argument("--only", nargs="*", default=None, help="spec names to run")
    parser.add_argument("--dqn-frames", type=int, default=30_000)
    parser.add_argument("--eval-freq", type=int, default=1_000)
    parser.add_argument("--eval-episodes", type=int, default=20)
    parser.add_argument("--noise", default="regional")
    parser.add_argument("--detector", default="classifier")
    parser.add_argument("--suite-seed", type=int, default=0)
    parser.add_argument("--out", default="runs/counterfactual_dqn")
    parser.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="PATH=VALUE",
        help="a config path for both arms (e.g. bolt.shaping=false); repeat for several",
    )
    args = parser.parse_args(argv)
    args.settings = {}
    for text in args.set:
        path, sep, value = text.partition("=")
        if not sep:
            parser.error(f"--set takes PATH=VALUE, got {text!r}")
        args.settings[path] = yaml.safe_load(value)
    args.frames = args.dqn_frames  # trial_config reads both budgets

    from noisybolt.experiments.spec_families import generate_spec_suite

    suite = [s for s in generate_spec_suite(n_specs=24, seed=args.suite_seed)]
    detours = [s for s in suite if not s.shortest_complies]
    if args.only:
        detours = [s for s in detours if s.name in set(args.only)]
    arms = [a.strip() for a in args.arms.split(",") if a.strip()]
    records = []
    seeds = range(args.first_seed, args.first_seed + args.seeds)
    for seed in seeds:
        for spec in detours:
            for arm in arms:
                record = run_trial(spec, seed, arm, args)
                records.append(record)
                print(json.dumps(record), flush=True)
    print(f"| spec | {' | '.join(f'N_frames, {arm}' for arm in arms)} |")
    print(f"|---|{'---:|' * len(arms)}")
    cells = {(r["spec"], r["seed"], r["arm"]): r for r in records}
    for seed in seeds:
        for spec in detours:
            row = [cells[(spec.name, seed, arm)] for arm in arms]
            text = [
                f"{r['frames_to_comply'] / 1000:.0f}k" if r["frames_to_comply"] else
                f"> {r['frames'] / 1000:.0f}k"
                for r in row
            ]  # fmt: skip
            print(f"| {spec.name} (seed {seed}) | {' | '.join(text)} |")
    by_arm: dict[str, list[float]] = {arm: [] for arm in arms}
    for r in records:
        by_arm[r["arm"]].append(r["frames_to_comply"] or r["frames"])
    for arm, frames in by_arm.items():
        print(f"{arm}: N_frames mean {statistics.mean(frames) / 1000:.2f}k over {len(frames)}")
    if len(arms) == 2 and all(by_arm.values()):
        ratio = statistics.mean(by_arm[arms[1]]) / statistics.mean(by_arm[arms[0]])
        print(f"ratio {arms[1]} / {arms[0]}: {ratio:.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
