"""Worlds nobody tuned for, trained with the built-in defaults: the world suite.

Each world of ``unseen_worlds.WORLDS`` (Gymnasium envs noisybolt was not written for,
labelled as a user would label them, no return bounds declared unless said) is trained
with ``noisybolt.runs.training.train`` exactly as ``noisybolt train --world
unseen_worlds:NAME --spec S`` trains it: the fallback hyperparameters
(``configs/hyperparams/_default.yaml``), the default ``compliance`` reward scheme, a
synthetic noisy detector (``--detector``; the classifier works too, slower), the model
of the best shaped evaluation kept. Each (world, spec, algorithm, seed) is trained bolted,
and each (world, algorithm, seed) once unbolted as the control: what the world's own
reward teaches. Compliance is judged from ground truth. Prints one table: per world and
spec, compliance and goal rate of the bolted agent against the unbolted one.

Trials run in ``--workers`` processes (from this folder, where the factories live);
finished trials are skipped on a rerun (their ``summary.json``), so a stopped suite
resumes. Every trial's config and command are in its run directory.

    cd benchmarks && ../.venv/bin/python world_suite.py --algos ppo --seeds 1 --workers 2
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import time
from collections import defaultdict
from collections.abc import Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path
from typing import Any

HERE = Path(__file__).resolve().parent


def _name(world: str) -> str:
    return world.split(":")[1]


def run_trial(world: str, spec: str | None, algo: str, seed: int, args: Any) -> dict | None:
    """Trains one trial (unless finished) and returns its record (None: collecting only)."""
    import torch

    from noisybolt.agents.hyperparams import parse_overrides
    from noisybolt.runs import DetectorConfig, TrainConfig, train
    from noisybolt.runs.legacy import nested_config

    torch.set_num_threads(1)
    os.chdir(HERE)  # factory paths resolve from the folder holding unseen_worlds.py
    label = "unbolted" if spec is None else f"spec{WORLD_SPECS[world].index(spec)}"
    out = Path(args.out).resolve() / _name(world) / algo / label / f"seed{seed}"
    summary = out / "summary.json"
    if not summary.exists() and args.collect:
        return None
    if not summary.exists():
        if out.exists():  # an unfinished trial: start it again
            import shutil

            shutil.rmtree(out)
        config = TrainConfig.create(
            world=world,
            # The unbolted control carries the first spec only to measure it from the truth.
            specs=[spec or WORLD_SPECS[world][0]],
            algo=algo,
            bolted=spec is not None,
            detector=DetectorConfig(kind=args.detector),
            frames=args.frames or WORLD_FRAMES.get(world, 100_000),
            seed=seed,
            eval_freq=args.eval_freq,
            eval_episodes=args.eval_episodes,
            checkpoint_freq=0,
            eval_deterministic=algo == "dqn",
            keep_best=True,
            progress_bar=False,
            overrides=parse_overrides(args.hp),
            **settings_from(args.set),
        )
        train(config, out, argv=[sys.executable, *sys.argv], log=lambda _: None)
    data = json.loads(summary.read_text())
    final = data["final"]
    config = nested_config(json.loads((out / "config.json").read_text()))  # older: flat
    return {
        "world": _name(world),
        "spec": spec,
        "algo": algo,
        "seed": seed,
        "bolted": spec is not None,
        "compliance": float(next(iter(final["compliance"].values()))),
        # None for a world without a goal (CartPole): the table says "-"
        "goal_rate": None if final["goal_rate"] is None else float(final["goal_rate"]),
        "env_return": float(final["env_return_mean"]),
        "frames_to_comply": data.get("frames_to_comply"),
        "frames": data["frames"],
        "reward_scale": config["bolt"]["reward_scale"],
    }


WORLD_SPECS: dict[str, tuple[str, ...]] = {}
#: Each world's budget (``unseen_worlds.FRAMES``), unless ``--frames`` gives one for all.
WORLD_FRAMES: dict[str, int] = {}


def settings_from(texts: Sequence[str]) -> dict[str, Any]:
    """``--set PATH=VALUE`` as the schema paths and values ``TrainConfig.create`` takes."""
    from noisybolt.runs.config import value_from_text

    settings: dict[str, Any] = {}
    for text in texts:
        path, sep, value = text.partition("=")
        if not sep:
            raise SystemExit(f"--set takes PATH=VALUE, got {text!r}")
        settings[path] = value_from_text(path, value)
    return settings


def _load_worlds() -> None:
    sys.path.insert(0, str(HERE))
    from unseen_worlds import FRAMES, WORLDS

    WORLD_SPECS.update(WORLDS)
    WORLD_FRAMES.update(FRAMES)


def summarise(records: Sequence[dict], threshold: float) -> list[str]:
    """One row per (world, spec, algorithm): bolted against the unbolted control."""
    by_key: dict[tuple[str, str | None, str], list[dict]] = defaultdict(list)
    for r in records:
        by_key[(r["world"], r["spec"], r["algo"])].append(r)
    lines = [
        "| world | spec | algo | seeds | followed | compliance | goal | return | scale |"
        " unbolted compliance | unbolted goal | unbolted return |",
        "|---|---|---|---:|---|---:|---:|---:|---:|---:|---:|---:|",
    ]
    followed_total = total = 0
    for (world, spec, algo), rows in sorted(by_key.items(), key=lambda kv: str(kv[0])):
        if spec is None:
            continue
        control = by_key.get((world, None, algo), [])
        followed = all(r["compliance"] >= threshold for r in rows)
        followed_total += followed
        total += 1
        # The control is measured against the world's first spec only.
        first = WORLD_SPECS.get(f"unseen_worlds:{world}", (None,))[0] == spec
        lines.append(
            f"| {world} | `{spec}` | {algo.upper()} | {len(rows)} | {'yes' if followed else 'no'} "
            f"| {_pct(r['compliance'] for r in rows)} | {_pct(r['goal_rate'] for r in rows)} "
            f"| {_num(r['env_return'] for r in rows)} | {_num(r['reward_scale'] for r in rows)} "
            f"| {_pct(r['compliance'] for r in control) if first else '-'} "
            f"| {_pct(r['goal_rate'] for r in control)} "
            f"| {_num(r['env_return'] for r in control)} |"
        )
    kept, counted, per_world = task_kept(records, threshold)
    lines += [
        "",
        f"world suite: {followed_total}/{total} (world, spec, algorithm) followed in every seed "
        f"(>= {threshold:.0%} compliance from ground truth)",
        "",
        "| world | trials whose control does the task | bolted: complied and kept the task |",
        "|---|---:|---:|",
        *(f"| {w} | {n} | {k} |" for w, (k, n) in sorted(per_world.items())),
        "",
        f"task kept: {kept}/{counted} trials (control reaches the goal in >= 90 % of "
        f"episodes, or the task is a return) comply >= {threshold:.0%} and reach the goal in "
        ">= 90 % (returns: >= 90 % of the control's, above the world's floor)",
    ]
    return lines


#: The least return of the worlds whose task is a return (their declared bounds):
#: "the control's return kept" is measured above it.
RETURN_FLOOR = {"cartpole": 0.0, "acrobot": -500.0}


def task_kept(
    records: Sequence[dict], threshold: float
) -> tuple[int, int, dict[str, tuple[int, int]]]:
    """Each bolted trial against the unbolted control of its own world, algorithm and seed:
    counted where the control does the task (goal in >= 90 % of episodes; every control of a
    return world), kept where the bolted agent complies (``threshold``) and reaches the goal
    in >= 90 % (a return world: >= 90 % of the control's return above the world's floor).
    Returns ``(kept, counted, {world: (kept, counted)})``."""
    controls = {(r["world"], r["algo"], r["seed"]): r for r in records if not r["bolted"]}
    kept = counted = 0
    per_world: dict[str, tuple[int, int]] = {}
    for r in records:
        control = controls.get((r["world"], r["algo"], r["seed"]))
        if not r["bolted"] or control is None:
            continue
        if control["goal_rate"] is None:
            floor = RETURN_FLOOR.get(r["world"], 0.0)
            done = r["env_return"] - floor >= 0.9 * (control["env_return"] - floor)
        elif control["goal_rate"] >= 0.9:
            done = r["goal_rate"] is not None and r["goal_rate"] >= 0.9
        else:
            continue
        ok = done and r["compliance"] >= threshold
        kept, counted = kept + ok, counted + 1
        k, n = per_world.get(r["world"], (0, 0))
        per_world[r["world"]] = (k + ok, n + 1)
    return kept, counted, per_world


def _pct(values: Any) -> str:
    v = [float(x) for x in values if x is not None]
    return f"{statistics.mean(v):.0%}" if v else "-"


def _num(values: Any) -> str:
    v = [float(x) for x in values if x is not None]
    return f"{statistics.mean(v):.1f}" if v else "-"


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--worlds", nargs="*", default=None, help="world names (default: all)")
    parser.add_argument("--algos", default="ppo")
    parser.add_argument("--seeds", type=int, default=1)
    parser.add_argument(
        "--frames", type=int, default=0, help="frames per trial (default: each world's own)"
    )
    parser.add_argument("--eval-freq", type=int, default=10_000)
    parser.add_argument("--eval-episodes", type=int, default=20)
    parser.add_argument("--detector", default="synthetic")
    parser.add_argument("--threshold", type=float, default=0.95)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument(
        "--hp",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="a hyperparameter for every trial, as noisybolt train --hp (repeatable)",
    )
    parser.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="PATH=VALUE",
        help="a setting for every trial, as noisybolt train --set (bolt.reward=constrained)",
    )
    parser.add_argument("--out", default=str(HERE.parent / "runs" / "world_suite"))
    parser.add_argument("--collect", action="store_true", help="tabulate finished trials only")
    args = parser.parse_args(argv)
    _load_worlds()
    worlds = [w for w in WORLD_SPECS if args.worlds is None or _name(w) in args.worlds]
    trials = [
        (world, spec, algo, seed)
        for algo in args.algos.split(",")
        for seed in range(args.seeds)
        for world in worlds
        for spec in (None, *WORLD_SPECS[world])
    ]
    print(f"{len(trials)} trials, {args.workers} workers", flush=True)
    start = time.perf_counter()
    records: list[dict] = []
    with ProcessPoolExecutor(max_workers=args.workers, initializer=_load_worlds) as pool:
        futures = {pool.submit(run_trial, *t, args): t for t in trials}
        for i, future in enumerate(as_completed(futures), 1):
            world, spec, algo, seed = futures[future]
            try:
                record = future.result()
            except Exception as exc:  # one failed trial must not lose the others
                print(f"[{i}/{len(trials)}] {world} {spec} {algo} seed {seed}: FAILED {exc!r}")
                continue
            if record is None:
                continue
            records.append(record)
            print(
                f"[{i}/{len(trials)}] {_name(world)} {spec or 'unbolted'} {algo} seed {seed}: "
                f"compliance {record['compliance']:.0%}, goal {_pct([record['goal_rate']])}, "
                f"return {record['env_return']:.1f}, scale {record['reward_scale']}",
                flush=True,
            )
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    (out / "records.json").write_text(json.dumps(records, indent=1))
    table = summarise(records, args.threshold)
    (out / "suite.md").write_text("\n".join(table) + "\n")
    print("\n".join(table))
    print(f"wall time {time.perf_counter() - start:.0f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
