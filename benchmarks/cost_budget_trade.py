"""Does a cost budget trade as promised? The constrained scheme at several budgets ``d`` on
a world whose episodes differ in what a violation is worth (``budget_worlds:toll``).

Each (d, algorithm, seed) is trained with the built-in defaults but ``--cost-limit d``
(synthetic detector), and its models are judged from the world's ground truth over many
sampled episodes: the violation rate against ``d`` (the target: within 5 points), and the
return against the best any policy can do under that budget
(:func:`budget_worlds.best_under_budget`) and against the other budgets (the target: it
rises as ``d`` grows). Both the last model and the model ``train`` keeps are judged. The
unbolted control of each seed is trained too. Finished trials are skipped on a rerun.

    cd benchmarks && ../.venv/bin/python cost_budget_trade.py --budgets 0.1,0.3 --seeds 3
"""

from __future__ import annotations

import argparse
import itertools
import json
import os
import statistics
import sys
from pathlib import Path
from typing import Any

HERE = Path(__file__).resolve().parent
WORLD = "budget_worlds:toll"
SPEC = "G(!toll)"


def run_trial(d: float | None, algo: str, seed: int, args: Any) -> dict:
    """Trains one trial (unless finished) and returns its record; ``d`` None: unbolted."""
    import torch

    from noisybolt.runs import DetectorConfig, TrainConfig, train

    torch.set_num_threads(1)
    os.chdir(HERE)  # the factory path resolves from this folder
    label = "unbolted" if d is None else f"d{d:g}"
    out = Path(args.out).resolve() / algo / label / f"seed{seed}"
    if not (out / "summary.json").exists():
        settings: dict[str, Any] = {} if d is None else {"bolt.constraint.cost_limit": d}
        config = TrainConfig.create(
            world=WORLD,
            specs=[SPEC],
            algo=algo,
            bolted=d is not None,
            detector=DetectorConfig(kind="synthetic"),
            frames=args.frames,
            seed=seed,
            eval_episodes=args.eval_episodes,
            checkpoint_freq=0,
            progress_bar=False,
            **settings,
        )
        if out.exists():
            import shutil

            shutil.rmtree(out)
        train(config, out, argv=[sys.executable, *sys.argv], log=lambda _: None)
    metrics = json.loads((out / "metrics.json").read_text())
    summary = json.loads((out / "summary.json").read_text())
    last = metrics[-1]  # the last periodic evaluation: the last model
    kept = summary["final"]  # the model train wrote (the best evaluated one)
    return {
        "d": d,
        "algo": algo,
        "seed": seed,
        "last": _judged(last),
        "kept": _judged(kept),
        "frames": summary["frames"],
    }


def _judged(result: dict) -> dict:
    return {
        "violation": 1.0 - float(next(iter(result["compliance"].values()))),
        "return": float(result["env_return_mean"]),
        "episodes": int(result["n_episodes"]),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--budgets", default="0.1,0.3", help="comma-separated cost limits")
    parser.add_argument("--algos", default="ppo")
    parser.add_argument("--seeds", type=int, default=3)
    parser.add_argument("--frames", type=int, default=150_000)
    parser.add_argument("--eval-episodes", type=int, default=1000)
    parser.add_argument("--out", default=str(HERE.parent / "runs" / "cost_budget_trade"))
    args = parser.parse_args()
    sys.path.insert(0, str(HERE))
    from budget_worlds import best_under_budget

    budgets = [float(d) for d in args.budgets.split(",")]
    rows = []
    for algo in args.algos.split(","):
        for seed in range(args.seeds):
            control = run_trial(None, algo, seed, args)
            for d in budgets:
                r = run_trial(d, algo, seed, args)
                rows.append((r, control))
                print(json.dumps({**r, "control": control["last"]}), flush=True)
    print()
    print(
        "| algo | d | seed | last model: violation / return | kept model: violation / return |"
        " best under d | control: violation / return |"
    )
    print("|---|---:|---:|---|---|---:|---|")
    met = 0
    for r, control in rows:
        last, kept = r["last"], r["kept"]
        met += abs(last["violation"] - r["d"]) <= 0.05
        print(
            f"| {r['algo'].upper()} | {r['d']:g} | {r['seed']} "
            f"| {last['violation']:.1%} / {last['return']:.3f} "
            f"| {kept['violation']:.1%} / {kept['return']:.3f} "
            f"| {best_under_budget(r['d']):.3f} "
            f"| {control['last']['violation']:.1%} / {control['last']['return']:.3f} |"
        )
    means = {
        d: statistics.mean(r["last"]["return"] for r, _ in rows if r["d"] == d) for d in budgets
    }
    rising = all(means[a] < means[b] for a, b in itertools.pairwise(budgets))
    print()
    print(
        f"cost budget trade: {met}/{len(rows)} last models within 5 points of d; mean return "
        + ", ".join(f"d={d:g}: {means[d]:.3f}" for d in budgets)
        + f" ({'rising' if rising else 'not rising'} with d)"
    )


if __name__ == "__main__":
    main()
