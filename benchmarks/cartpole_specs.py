"""Specs drawn at random over a world nobody here wrote, learned with the built-in defaults.

The gridworld suite (``benchmarks/spec_suite.py``) measures specs nobody tuned for on our
own world. This measures them on Gymnasium's CartPole, labelled as a user would
(``examples/cartpole.py``: the cart far left or right, the pole leaning left or right), or
on any other labelled world (``--world examples.acrobot:make_acrobot``: specs drawn over
its own fluents),
with the noisy ``synthetic`` detector: Dwyer et al.'s patterns and scopes
(:func:`noisybolt.experiments.spec_families.pattern_formula`) over those fluents, a third
of them conjunctions of two, drawn by ``--suite-seed``; a spec its DFA accepts from the
start for good (nothing to learn) or can never accept is drawn again.

For each seed: one unbolted run that tracks every spec (what an agent that balances the
pole does anyway), then one bolted run per spec, PPO with the defaults a user's world gets
(``noisybolt/configs/hyperparams/_default.yaml``) and the default compliance scheme.
Compliance is judged from ground truth in the final evaluation. A spec is *constraining*
where the unbolted agent complies in under 95 % of its episodes, and *followed* where the
bolted one complies in at least 95 %. Prints a row per spec and a summary line; writes
``records.json``, ``suite.json`` and ``suite.md`` under ``--out``. A rerun skips trials
already finished (their ``summary.json``).

    .venv/bin/python benchmarks/cartpole_specs.py --specs 12 --suite-seed 0 --workers 2 \
        --out runs/cartpole_specs

``--warm-start F``: the bolt is put on an agent that already plays instead: per spec, an
unbolted run of ``F`` frames that tracks that spec (``<spec>/seed<k>-pretrain``), then the
bolted run starts from it (``--init-from``) for the remaining ``--frames - F``, so every
bolted agent has seen as many frames as one trained from scratch.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import sys
import time
from collections.abc import Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
WORLD = "examples.cartpole:make_cart"  # importable from the repository's root
FLUENTS = ("far_left", "far_right", "leaning_left", "leaning_right")


def world_fluents(world: str) -> tuple[str, ...]:
    """The fluents ``world`` (a factory path) labels, in its order."""
    from noisybolt.envs import make_single_world

    env = make_single_world(world)
    try:
        return tuple(env.get_wrapper_attr("fluent_names"))
    finally:
        env.close()


def draw_specs(
    n_specs: int, seed: int, *, conjunction_share: float = 0.34, fluents: Sequence[str] = FLUENTS
) -> list[dict]:
    """``n_specs`` distinct specs (``name``, ``formula``, ``family``) over ``fluents``."""
    from noisybolt.experiments.spec_families import PATTERNS, SCOPES, pattern_formula
    from noisybolt.logic import compile_ltlf

    rng = np.random.default_rng(seed)

    def one() -> tuple[str, str]:
        pattern, scope = str(rng.choice(PATTERNS)), str(rng.choice(SCOPES))
        p, s, r = (str(f) for f in rng.choice(list(fluents), size=3, replace=False))
        return f"{pattern}-{scope}", pattern_formula(pattern, scope, p, s, r)

    specs: list[dict] = []
    seen: set[str] = set()
    for _ in range(5000):
        if len(specs) == n_specs:
            break
        family, formula = one()
        if rng.random() < conjunction_share:
            other, second = one()
            family, formula = f"{family}+{other}", f"({formula}) & ({second})"
        if formula in seen:
            continue
        seen.add(formula)
        dfa = compile_ltlf(formula, list(fluents))
        start = dfa.initial_state
        if dfa.accepting_sinks[start] or not _can_accept(dfa):
            continue
        specs.append({"name": f"w{len(specs):02d}-{family}", "formula": formula, "family": family})
    return specs


def _can_accept(dfa: Any) -> bool:
    from noisybolt.logic import distance_to_acceptance

    return bool(distance_to_acceptance(dfa)[dfa.initial_state] >= 0)


def trial_config(
    specs: Sequence[dict],
    seed: int,
    args: argparse.Namespace,
    *,
    bolted: bool,
    frames: int | None = None,
    init_from: Path | None = None,
) -> Any:
    from noisybolt.agents.hyperparams import parse_overrides
    from noisybolt.cli.train import config_assignments
    from noisybolt.runs import DetectorConfig, TrainConfig

    config = TrainConfig.create(
        world=args.world,
        specs=[{"formula": s["formula"], "name": s["name"]} for s in specs],
        algo="ppo",
        detector=DetectorConfig(kind=args.detector),
        frames=frames or args.frames,
        seed=seed,
        eval_freq=args.eval_freq,
        eval_episodes=args.eval_episodes,
        checkpoint_freq=0,
        bolted=bolted,
        progress_bar=False,
        overrides=parse_overrides(args.hp),
    )
    changes = config_assignments(("--set", item) for item in args.set)
    if init_from:
        changes["algorithm.init_from"] = str(init_from)
    return config.override(changes) if changes else config


def run_trial(
    specs: Sequence[dict], seed: int, args: argparse.Namespace, out: Path, bolted: bool
) -> dict:
    """Trains one run (unless finished) and returns its final evaluation; with
    ``args.warm_start`` a bolted run starts from an unbolted one of those frames."""
    import torch

    from noisybolt.runs import train

    torch.set_num_threads(1)
    sys.path.insert(0, str(ROOT))  # the world's module, in a fresh worker
    summary = out / "summary.json"
    if not summary.exists():
        if out.exists():  # an unfinished trial: start it again
            shutil.rmtree(out)
        source, frames = None, None
        if bolted and args.warm_start:
            source = out.with_name(f"{out.name}-pretrain")
            if not (source / "summary.json").exists():
                if source.exists():
                    shutil.rmtree(source)
                config = trial_config(specs, seed, args, bolted=False, frames=args.warm_start)
                train(config, source, argv=[sys.executable, *sys.argv], log=lambda _: None)
            frames = args.frames - args.warm_start
        config = trial_config(specs, seed, args, bolted=bolted, frames=frames, init_from=source)
        train(config, out, argv=[sys.executable, *sys.argv], log=lambda _: None)
    final = json.loads(summary.read_text())["final"]
    return {
        "compliance": {k: float(v) for k, v in final["compliance"].items()},
        "false_acceptance": {k: float(v) for k, v in (final.get("false_acceptance") or {}).items()},
        "env_return": float(final["env_return_mean"]),
        "goal_rate": final.get("goal_rate"),  # None: a world without a goal (CartPole)
    }


def summarise(specs: Sequence[dict], records: dict[str, Any], seeds: int) -> list[str]:
    """The table (a row per spec, every seed) and the summary lines."""
    lines = [
        "| spec | formula | unbolted compliance | bolted compliance | bolted return | "
        "unbolted return | bolt fooled |",
        "|---|---|---:|---:|---:|---:|---:|",
    ]
    constraining = followed = shown = 0
    returns: list[float] = []
    base_returns: list[float] = []
    free_followed: list[float] = []  # bolted returns where the unbolted agent complies
    for spec in specs:
        name = spec["name"]
        rows = [
            (records[f"unbolted/seed{k}"], records.get(f"{name}/seed{k}")) for k in range(seeds)
        ]
        if any(bolted is None for _, bolted in rows):
            continue
        free = [base["compliance"][name] for base, _ in rows]
        held = [bolted["compliance"][name] for _, bolted in rows]
        fooled = [bolted["false_acceptance"].get(name, 0.0) for _, bolted in rows]
        returns += [bolted["env_return"] for _, bolted in rows]
        base_returns += [base["env_return"] for base, _ in rows]
        shown += 1
        if min(free) < 0.95:
            constraining += 1
            followed += min(held) >= 0.95
        else:
            free_followed += [bolted["env_return"] for _, bolted in rows]
        pct = lambda xs: ", ".join(f"{x:.0%}" for x in xs)  # noqa: E731
        bolted_returns = ", ".join(f"{bolted['env_return']:.0f}" for _, bolted in rows)
        if rows[0][1].get("goal_rate") is not None:  # a world with a goal: how often reached
            bolted_returns += (
                " (goal " + ", ".join(f"{bolted['goal_rate']:.0%}" for _, bolted in rows) + ")"
            )
        free_returns = ", ".join(f"{base['env_return']:.0f}" for base, _ in rows)
        lines.append(
            f"| {name} | `{spec['formula']}` | {pct(free)} | {pct(held)} | {bolted_returns} | "
            f"{free_returns} | {pct(fooled)} |"
        )
    lines.append("")
    lines.append(
        f"constraining specs (unbolted compliance < 95 % in some seed): {constraining} of "
        f"{shown}; followed by the bolted agent (>= 95 % in every seed): "
        f"{followed}/{constraining}; mean return bolted {np.mean(returns):.0f}, unbolted "
        f"{np.mean(base_returns):.0f}"
    )
    if free_followed:
        lines.append(
            f"on the {shown - constraining} specs the unbolted agent follows anyway, the bolted "
            f"agent's mean return: {np.mean(free_followed):.0f} (nothing to give up for them)"
        )
    return lines


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--specs", type=int, default=12, help="specs to draw")
    parser.add_argument("--suite-seed", type=int, default=0)
    parser.add_argument(
        "--world",
        default=WORLD,
        help="the world, a factory path importable from the repository's root (default: "
        "CartPole, examples/cartpole.py); specs are drawn over its fluents",
    )
    parser.add_argument("--seeds", type=int, default=1)
    parser.add_argument("--frames", type=int, default=100_000)
    parser.add_argument("--eval-freq", type=int, default=25_000)
    parser.add_argument("--eval-episodes", type=int, default=20)
    parser.add_argument("--detector", default="synthetic")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument(
        "--warm-start",
        type=int,
        default=0,
        metavar="F",
        help="bolt an agent first trained unbolted for F of the --frames (0: from scratch)",
    )
    parser.add_argument(
        "--hp",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="a hyperparameter for every run, as noisybolt train --hp (repeatable)",
    )
    parser.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="PATH=VALUE",
        help="a setting of every run's config, as noisybolt train --set (repeatable), e.g. "
        "bolt.reward_scale=110",
    )
    parser.add_argument("--out", default="runs/cartpole_specs")
    args = parser.parse_args(argv)
    if not 0 <= args.warm_start < args.frames:
        parser.error("--warm-start must be at least 0 and below --frames")

    sys.path.insert(0, str(ROOT))
    started = time.perf_counter()
    fluents = world_fluents(args.world)  # CartPole: FLUENTS, in that order
    specs = draw_specs(args.specs, args.suite_seed, fluents=fluents)
    root = Path(args.out)
    root.mkdir(parents=True, exist_ok=True)
    (root / "suite.json").write_text(json.dumps(specs, indent=1) + "\n", encoding="utf-8")
    jobs: list[tuple[str, list[dict], int, bool]] = []
    for seed in range(args.seeds):
        jobs.append((f"unbolted/seed{seed}", specs, seed, False))
        jobs += [(f"{s['name']}/seed{seed}", [s], seed, True) for s in specs]
    print(
        f"{len(specs)} specs, {args.seeds} seeds: {len(jobs)} runs, {args.workers} workers",
        flush=True,
    )
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    records: dict[str, Any] = {}
    with ProcessPoolExecutor(max_workers=args.workers) as pool:
        futures = {
            pool.submit(run_trial, chosen, seed, args, root / key, bolted): key
            for key, chosen, seed, bolted in jobs
        }
        for done in as_completed(futures):
            key = futures[done]
            records[key] = done.result()
            shown = {k: f"{v:.0%}" for k, v in records[key]["compliance"].items()}
            brief = shown if len(shown) < 3 else "(every spec)"
            print(f"[{len(records)}/{len(jobs)}] {key}: compliance {brief}, "
                  f"return {records[key]['env_return']:.0f}", flush=True)  # fmt: skip
    text = "\n".join(summarise(specs, records, args.seeds))
    (root / "records.json").write_text(json.dumps(records, indent=1) + "\n", encoding="utf-8")
    (root / "suite.md").write_text(text + "\n", encoding="utf-8")
    print(text)
    print(f"wall time {time.perf_counter() - started:.0f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
