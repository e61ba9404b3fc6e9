"""Specs nobody tuned for, learned with the built-in defaults: the spec-family suite.

Generates the suite (:func:`noisybolt.experiments.spec_families.generate_spec_suite`:
Dwyer et al.'s patterns over the gridworld's fluents, each with a compliant route to the
goal, fixed by ``--suite-seed``), trains every (spec, algorithm, seed, scheme) with
``noisybolt.runs.training.train`` and the built-in hyperparameters, the classifier bolt
on the regionally smudged camera, and judges compliance from ground truth. Prints, per
algorithm and scheme, per pattern family: specs followed (>= 95 % compliance in every
seed), goal rate, mean return against R^c_max, N_frames; then one summary line per
scheme and algorithm, and (with ``--no-shaping`` among the schemes) the N_frames ratio
of shaping to no shaping.

Trials run in ``--workers`` processes; each writes its run directory under ``--out``, and
a rerun skips trials already finished (their ``summary.json``), so a stopped suite
resumes. Every trial's config and command are in its run directory.

A suite outlives a session through ``--kept DIR`` (the committed copy is
``results/spec_suite/trials``): finished trials found there and missing under ``--out``
are put back before anything runs, and every finished trial's small files (summary,
metrics, config, command: no models) are copied there, so a new machine whose ``runs/``
is empty resumes where the last one stopped.

    .venv/bin/python benchmarks/spec_suite.py --algos ppo --seeds 1 --workers 2
    .venv/bin/python benchmarks/spec_suite.py                  # the whole suite (hours)
    .venv/bin/python benchmarks/spec_suite.py --seeds 3 --plan compliance:ppo,compliance:a2c,\
        compliance:dqn --out runs/spec_suite_final --kept results/spec_suite/trials
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import statistics
import sys
import time
from collections import defaultdict
from collections.abc import Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path
from typing import Any

SCHEMES = {
    "compliance": {"reward": "compliance"},
    # Compliance as a constraint: the compliance scheme's payments at a learned price
    # (noisybolt.bolt.constraint), PPO and A2C only.
    "constrained": {"reward": "constrained"},
    "no-shaping": {"reward": "compliance", "shaping": False},
    "paper": {"reward": "paper"},
    # The default scheme with belief tracking instead of Algorithm 1's threshold (base
    # rates estimated in each run, as `noisybolt train --tracking belief` does).
    "belief": {"reward": "compliance", "tracking": "belief"},
    # The default scheme with the world's rewards and the bolt's normalised apart
    # (`--hp normalize_reward=split`): the scale no longer puts complying first.
    "split": {"reward": "compliance", "overrides": {"normalize_reward": "split"}},
}


def trial_config(spec: Any, algo: str, seed: int, scheme: str, args: argparse.Namespace) -> Any:
    from noisybolt.runs import DetectorConfig, TrainConfig, resolve

    config = TrainConfig.create(
        world="gridworld",
        specs=[{"formula": spec.formula, "name": spec.name}],
        algo=algo,
        world_kwargs={"noise": args.noise},
        detector=DetectorConfig(kind=args.detector),
        frames=args.dqn_frames if algo == "dqn" else args.frames,
        seed=seed,
        eval_freq=args.eval_freq,
        eval_episodes=args.eval_episodes,
        checkpoint_freq=0,
        eval_deterministic=algo == "dqn",
        # The model of the best shaped-return evaluation (as the bolt sees it; never ground
        # truth), as reproduce table1 keeps: PPO's near-deterministic policies on the grid
        # sometimes fall into a loop for an evaluation or two late in a run.
        keep_best=True,
        progress_bar=False,
        **SCHEMES[scheme],
    )
    # What `noisybolt train` does: resolved (the compliance scale computed on the product,
    # under `constrained` too, whose classifier is prepared from this config).
    return resolve(config, log=lambda _: None)


def run_trial(
    spec: Any, algo: str, seed: int, scheme: str, args: argparse.Namespace
) -> dict | None:
    """Trains one trial (unless finished) and returns its record (None: not run, collecting)."""
    import torch

    from noisybolt.runs import train

    torch.set_num_threads(1)
    out = Path(args.out) / scheme / algo / spec.name / f"seed{seed}"
    summary = out / "summary.json"
    if not summary.exists() and args.collect:
        return None
    if not summary.exists():
        if out.exists():  # an unfinished trial: start it again
            import shutil

            shutil.rmtree(out)
        config = trial_config(spec, algo, seed, scheme, args)
        argv = [sys.executable, *sys.argv]
        train(config, out, argv=argv, log=lambda _: None)
    data = json.loads(summary.read_text())
    final = data["final"]
    return {
        "spec": spec.name,
        "family": spec.family,
        "algo": algo,
        "seed": seed,
        "scheme": scheme,
        "compliance": float(next(iter(final["compliance"].values()))),
        "goal_rate": float(final["goal_rate"]),
        "env_return": float(final["env_return_mean"]),
        "rc_max": spec.rc_max,
        "frames_to_comply": data["frames_to_comply"],
        "frames": data["frames"],
        # Episodes the bolt's noisy view accepted while the true trace did not.
        "falsely_accepted": float(next(iter((final.get("false_acceptance") or {0: 0.0}).values()))),
    }


#: What ``--kept`` keeps of a finished trial: enough to tabulate it and to see how it ran.
KEPT_FILES = ("summary.json", "metrics.json", "config.json", "command.txt")


def sync_kept(out: Path, kept: Path) -> tuple[int, int]:
    """Restores kept trials missing under ``out``, then keeps every finished trial of
    ``out`` in ``kept``; returns (restored, kept) counts. Files are copied whole to a
    temporary name and renamed, so an interrupted copy never looks finished."""
    restored = saved = 0
    for source, target in ((kept, out), (out, kept)):
        for summary in sorted(source.glob("*/*/*/seed*/summary.json")):
            trial = summary.parent.relative_to(source)
            if (target / trial / "summary.json").exists():
                continue
            (target / trial).mkdir(parents=True, exist_ok=True)
            # summary.json last: it is what marks the trial finished
            for name in sorted(KEPT_FILES, key=lambda n: n == "summary.json"):
                if (summary.parent / name).exists():
                    tmp = target / trial / f".{name}.tmp"
                    shutil.copyfile(summary.parent / name, tmp)
                    os.replace(tmp, target / trial / name)
            if source is kept:
                restored += 1
            else:
                saved += 1
    return restored, saved


def _family(name: str) -> str:
    """The pattern family of a suite entry (conjunctions count as their own family)."""
    return "conjunction" if "+" in name else name.split("/")[0]


def summarise(records: Sequence[dict], threshold: float) -> list[str]:
    """The per-family tables and the summary lines.

    "bolt fooled": specs where some seed's final evaluation had most episodes accepted by
    the bolt's noisy view while the true trace broke the spec (the agent complied in the
    bolt's eyes only).
    """
    lines: list[str] = []
    groups: dict[tuple[str, str], list[dict]] = defaultdict(list)
    for r in records:
        groups[(r["scheme"], r["algo"])].append(r)
    summary: list[str] = []
    by_group: dict[tuple[str, str], dict[str, list[dict]]] = {}
    for (scheme, algo), rows in sorted(groups.items()):
        by_spec: dict[str, list[dict]] = defaultdict(list)
        for r in rows:
            by_spec[r["spec"]].append(r)
        by_group[(scheme, algo)] = by_spec
        lines.append(f"\n## {algo.upper()}, scheme {scheme}")
        lines.append(
            "| family | specs | followed | goal rate | return - R^c_max | N_frames | bolt fooled |"
        )
        lines.append("|---|---:|---:|---:|---:|---:|---:|")
        fam_rows: dict[str, list[list[dict]]] = defaultdict(list)
        for spec_rows in by_spec.values():
            fam_rows[_family(spec_rows[0]["family"])].append(spec_rows)
        total = followed_total = 0
        gaps: list[float] = []
        goals: list[float] = []
        frames_all: list[float] = []
        for family, specs in sorted(fam_rows.items()):
            followed = [s for s in specs if all(r["compliance"] >= threshold for r in s)]
            goal = [statistics.mean(r["goal_rate"] for r in s) for s in followed]
            gap = [statistics.mean(r["env_return"] - r["rc_max"] for r in s) for s in followed]
            # A trial that never complied counts at its budget (a lower bound on its N_frames).
            frames = [
                statistics.mean(r["frames_to_comply"] or r["frames"] for r in s) for s in specs
            ]
            fooled = sum(any(r.get("falsely_accepted", 0) > 0.5 for r in s) for s in specs)
            total += len(specs)
            followed_total += len(followed)
            gaps += gap
            goals += goal
            frames_all += frames
            lines.append(
                f"| {family} | {len(specs)} | {len(followed)} | "
                f"{_mean(goal, pct=True)} | {_mean(gap)} | {_mean(frames, k=True)} | {fooled} |"
            )
        summary.append(
            f"suite [{scheme}] {algo.upper()}: {followed_total}/{total} specs followed in every "
            f"seed ({followed_total / max(total, 1):.0%}); goal rate on those "
            f"{_mean(goals, pct=True)}; return - R^c_max {_mean(gaps)}; "
            f"N_frames {_mean(frames_all, k=True)}"
        )
    # Schemes side by side on the specs both ran (the same seeds).
    for (scheme, algo), specs in sorted(by_group.items()):
        base = by_group.get(("compliance", algo))
        if scheme == "compliance" or base is None:
            continue
        common = sorted(set(specs) & set(base))
        if not common:
            continue
        ours, theirs = (_followed_and_frames(g, common, threshold) for g in (base, specs))
        summary.append(
            f"{algo.upper()} on the same {len(common)} specs: compliance {ours[0]}/"
            f"{len(common)} followed, N_frames {ours[1] / 1000:.1f}k; {scheme} "
            f"{theirs[0]}/{len(common)}, N_frames {theirs[1] / 1000:.1f}k; "
            f"N_frames ratio (compliance / {scheme}): {ours[1] / theirs[1]:.2f}"
        )
    return [*lines, "", *summary]


def _followed_and_frames(
    group: dict[str, list[dict]], names: Sequence[str], threshold: float
) -> tuple[int, float]:
    """Specs of ``names`` followed in every seed, and their mean N_frames (budget if never)."""
    followed = sum(all(r["compliance"] >= threshold for r in group[n]) for n in names)
    frames = statistics.mean(
        statistics.mean(r["frames_to_comply"] or r["frames"] for r in group[n]) for n in names
    )
    return followed, frames


def _mean(values: Sequence[float], *, pct: bool = False, k: bool = False) -> str:
    if not values:
        return "-"
    m = statistics.mean(values)
    if pct:
        return f"{m:.0%}"
    if k:
        return f"{m / 1000:.1f}k"
    return f"{m:+.2f}"


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--specs", type=int, default=24, help="suite size")
    parser.add_argument("--suite-seed", type=int, default=0)
    parser.add_argument("--only", nargs="*", default=None, help="spec names to run")
    parser.add_argument("--algos", default="ppo,a2c,dqn")
    parser.add_argument("--seeds", type=int, default=3)
    parser.add_argument("--schemes", default="compliance,paper")
    parser.add_argument(
        "--plan",
        default=None,
        help="scheme:algo pairs to run, in this order (e.g. compliance:ppo,paper:ppo), "
        "instead of every scheme with every algorithm",
    )
    parser.add_argument("--frames", type=int, default=60_000)
    parser.add_argument(
        "--dqn-frames",
        type=int,
        default=30_000,
        help="DQN's budget (as in reproduce table1: DQN learns the grid by 2-5k frames and a "
        "gradient step per frame makes it the slowest learner per frame)",
    )
    parser.add_argument("--eval-freq", type=int, default=5_000)
    parser.add_argument("--eval-episodes", type=int, default=20)
    parser.add_argument("--noise", default="regional")
    parser.add_argument("--detector", default="classifier")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--out", default="runs/spec_suite")
    parser.add_argument(
        "--kept",
        default=None,
        help="a folder that keeps finished trials across machines (see the module docstring)",
    )
    parser.add_argument(
        "--collect",
        action="store_true",
        help="train nothing: tabulate the trials already finished under --out",
    )
    args = parser.parse_args(argv)

    from noisybolt.experiments.spec_families import generate_spec_suite

    started = time.perf_counter()
    suite = generate_spec_suite(n_specs=args.specs, seed=args.suite_seed)
    if args.only:
        suite = tuple(s for s in suite if s.name in set(args.only))
    algos = [a.strip() for a in args.algos.split(",") if a.strip()]
    schemes = [s.strip() for s in args.schemes.split(",") if s.strip()]
    unknown = sorted(set(schemes) - set(SCHEMES))
    if unknown:
        parser.error(f"unknown scheme(s) {unknown}; known: {sorted(SCHEMES)}")
    root = Path(args.out)
    root.mkdir(parents=True, exist_ok=True)
    kept = Path(args.kept) if args.kept else None
    if kept is not None:
        restored, saved = sync_kept(root, kept)
        print(f"kept trials: {restored} restored into {root}, {saved} kept in {kept}")
    (root / "suite.json").write_text(
        json.dumps([s.__dict__ for s in suite], indent=1) + "\n", encoding="utf-8"
    )
    if (
        args.detector == "classifier" and not args.collect
    ):  # train the cached classifier once, not per worker
        from noisybolt.runs.environments import prepare_bolt

        prepare_bolt(trial_config(suite[0], algos[0], 0, schemes[0], args), seed=0)
    pairs = [(scheme, algo) for scheme in schemes for algo in algos]
    if args.plan:
        pairs = [tuple(p.strip().split(":", 1)) for p in args.plan.split(",")]  # type: ignore[misc]
    jobs = [
        (spec, algo, seed, scheme)
        for seed in range(args.seeds)
        for scheme, algo in pairs
        for spec in suite
    ]
    print(
        f"{len(suite)} specs x {len(pairs)} scheme/algorithm pairs x {args.seeds} seeds = "
        f"{len(jobs)} trials, {args.workers} workers",
        flush=True,
    )
    records = []
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    if args.collect:
        records = [r for job in jobs if (r := run_trial(*job, args)) is not None]
        print(f"{len(records)} of {len(jobs)} trials finished")
        jobs = []
    with ProcessPoolExecutor(max_workers=args.workers) as pool:
        futures = {pool.submit(run_trial, *job, args): job for job in jobs}
        for done in as_completed(futures):
            record = done.result()
            assert record is not None
            records.append(record)
            print(
                f"[{len(records)}/{len(jobs)}] {record['scheme']:<10} {record['algo']} "
                f"{record['spec']} seed {record['seed']}: compliance {record['compliance']:.0%}, "
                f"goal {record['goal_rate']:.0%}, N_frames {record['frames_to_comply']}",
                flush=True,
            )
            if kept is not None:
                sync_kept(root, kept)
    threshold = 0.95
    text = "\n".join(summarise(records, threshold))
    (root / "records.json").write_text(json.dumps(records, indent=1) + "\n", encoding="utf-8")
    (root / "suite.md").write_text(text + "\n", encoding="utf-8")
    print(text)
    print(f"wall time {time.perf_counter() - started:.0f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
