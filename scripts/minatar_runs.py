"""MinAtar Breakout runs across sessions (issue 48): the plan, started, kept, resumed, summarised.

The plan (:data:`PLAN`, ``plan`` prints every command): on ``minatar-breakout`` with the
bolt's noisy camera (:data:`NOISE`: grain and a grey patch that can hide the left column),
the on-the-fly classifier and belief tracking, 3 seeds each of

* ``ppo-clear`` and ``dqn-clear``: the paper's spec ``F(brick_clear_left)``
  (``clear_left_column``) with its milestones (``left_row0`` .. ``left_row2``, one per
  brick of the left column), bolted;
* ``ppo-order``: the ordering spec ``left_first`` = ``!half_wall_gone U brick_clear_left``
  (the left column cleared before half the wall is gone) beside the paper's spec and the
  milestones, bolted;
* ``ppo-control`` and ``dqn-control``: unbolted controls carrying every spec above, so that
  their evaluations measure both specs' rates without the bolt (the controls serve both).

Runs live in ``runs/minatar/<name>`` (gitignored); what a resume needs is kept in
``results/minatar/<name>`` as ``scripts/breakout_runs.py`` keeps Breakout's (its ``keep``,
``restore``, ``resume``, ``stop``, pointed at ``results/minatar``), and ``summary`` writes
``results/minatar/summary.json``.

    .venv/bin/python scripts/minatar_runs.py plan                 # the commands
    .venv/bin/python scripts/minatar_runs.py start ppo-clear-bolted-seed0 ...  # nice 19
    .venv/bin/python scripts/minatar_runs.py keep ppo-clear-bolted-seed0 ...
    .venv/bin/python scripts/minatar_runs.py resume ppo-clear-bolted-seed0 ...
    .venv/bin/python scripts/minatar_runs.py stop                 # each saves, exits
    .venv/bin/python scripts/minatar_runs.py summary

``summary.json`` is a list with one entry per run and spec it was evaluated on (a control
gives one for each), from the run's last evaluation: ``run``, ``spec`` (``clear_left_column``
or ``left_first``), ``algo``, ``seed``, ``bolted``, ``frames``, ``games`` (episodes of that
evaluation), ``column_cleared_share`` (share of games whose left column was cleared,
ground truth), ``spec_share`` (share of games that satisfied ``spec``, ground truth),
``score_mean`` and ``score_std`` (game score), ``bolt_false_acceptance`` (share of games
whose DFA for ``spec``, run on what the bolt perceived, accepted while the truth did not;
null for a control), ``camera`` and ``tracking``.
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import shlex
import sys
from dataclasses import dataclass
from pathlib import Path
from types import ModuleType
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "results" / "minatar"
RUNS = ROOT / "runs" / "minatar"
PIDS = RUNS / "minatar.pids"

WORLD = "minatar-breakout"
#: The bolt camera's noise: grain, and a grey patch a quarter of the picture wide.
NOISE = "gaussian:sigma=40+occlusion:count=1,size=0.25"
SEEDS = (0, 1, 2)
FRAMES = "5m"
EVAL = ["--eval-freq", "250k", "--eval-episodes", "64", "--checkpoint-freq", "250k"]
CLEAR = "clear_left_column"
MILESTONES = ("left_row0", "left_row1", "left_row2")
ORDER_NAME = "left_first"
ORDER = "!half_wall_gone U brick_clear_left"


@dataclass(frozen=True)
class Run:
    """One planned run: its algorithm, the specs its bolt pays for, and its seed."""

    algo: str
    kind: str  # "clear", "order" or "control"
    seed: int

    @property
    def bolted(self) -> bool:
        return self.kind != "control"

    @property
    def name(self) -> str:
        tag = "unbolted" if self.kind == "control" else "bolted"
        return f"{self.algo}-{self.kind}-{tag}-seed{self.seed}"

    def specs(self) -> list[str]:
        """The ``--spec`` arguments: the paper's spec and its milestones, and the ordering
        spec for ``order`` runs and for the controls (which pay for none of them)."""
        out = ["--spec", CLEAR]
        for milestone in MILESTONES:
            out += ["--spec", milestone]
        if self.kind in ("order", "control"):
            out += ["--spec", ORDER, "--spec-set", f"name={ORDER_NAME}"]
        return out

    def train_args(self) -> list[str]:
        """``noisybolt train``'s arguments, all but ``--out``."""
        args = ["--world", WORLD, "--algo", self.algo, *self.specs()]
        # The scheme named: the plan was made under compliance, DQN's scheme still, and
        # PPO's default now being constrained would make the two learners' runs differ in
        # more than the learner.
        args += ["--reward", "compliance"]
        args += ["--detector", "classifier", "--noise", NOISE, "--tracking", "belief"]
        if not self.bolted:
            args.append("--unbolted")
        return [*args, "--frames", FRAMES, *EVAL, "--seed", str(self.seed)]


#: Every run of the plan, by name.
PLAN: dict[str, Run] = {
    run.name: run
    for run in (
        *(Run("ppo", "clear", s) for s in SEEDS),
        *(Run("dqn", "clear", s) for s in SEEDS),
        *(Run("ppo", "order", s) for s in SEEDS),
        *(Run("ppo", "control", s) for s in SEEDS),
        *(Run("dqn", "control", s) for s in SEEDS),
    )
}


def breakout_runs() -> ModuleType:
    """``scripts/breakout_runs.py`` pointed at ``results/minatar``: its keep, restore,
    resume and stop, which read their folders from its module globals."""
    path = ROOT / "scripts" / "breakout_runs.py"
    spec = importlib.util.spec_from_file_location("breakout_runs", path)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    module.RESULTS = RESULTS
    module.CLASSIFIERS = RESULTS / "classifiers"
    return module


def command(run: Run) -> str:
    """The command line of a planned run."""
    args = [*run.train_args(), "--out", str((RUNS / run.name).relative_to(ROOT))]
    return shlex.join(["noisybolt", "train", *args, "--no-progress"])


def summary_entries(run_dir: Path) -> list[dict[str, Any]]:
    """The ``summary.json`` entries of one run (none before its first evaluation)."""
    from noisybolt.runs.legacy import nested_config

    config = nested_config(json.loads((run_dir / "config.json").read_text()))
    path = run_dir / "metrics.json"
    metrics = json.loads(path.read_text()) if path.exists() else []
    if not metrics:
        return []
    last = max(metrics, key=lambda record: int(record["frames"]))
    rates = last.get("compliance") or {}
    false = last.get("false_acceptance") or {}
    bolted = bool(config["bolt"].get("bolted", True))
    noise = (config["world"].get("kwargs") or {}).get("noise")
    base = {
        "run": run_dir.name,
        "algo": config["algorithm"]["name"],
        "seed": int(config["seed"]),
        "bolted": bolted,
        "frames": int(last["frames"]),
        "games": int(last["n_episodes"]),
        "column_cleared_share": float(rates.get(CLEAR, 0.0)),
        "score_mean": float(last["env_return_mean"]),
        "score_std": float(last.get("env_return_std", 0.0)),
        "camera": "none" if noise is None else str(noise),
        "tracking": str(config["bolt"].get("tracking", "threshold")),
    }
    entries = []
    for spec in (CLEAR, ORDER_NAME):
        if spec not in rates:
            continue
        paid = {s.get("name") for s in config["bolt"].get("specs", [])}
        if bolted and spec == CLEAR and ORDER_NAME in paid:
            continue  # an ordering run is reported under its ordering spec
        entries.append(
            {
                **base,
                "spec": spec,
                "spec_share": float(rates[spec]),
                "bolt_false_acceptance": float(false[spec]) if bolted and spec in false else None,
            }
        )
    return entries


def summary(results: Path = RESULTS) -> list[dict[str, Any]]:
    """Every kept run's entries, written to ``results/minatar/summary.json``."""
    from noisybolt.io import atomic_write_json

    entries = [
        entry
        for run_dir in sorted(results.iterdir())
        if (run_dir / "config.json").exists()
        for entry in summary_entries(run_dir)
    ]
    entries.sort(key=lambda e: (e["spec"], e["algo"], not e["bolted"], e["seed"], e["run"]))
    atomic_write_json(results / "summary.json", entries)
    return entries


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)
    sub.add_parser("plan", help="print every planned run's command")
    for name, text in (
        ("start", "start planned runs in the background (nice 19)"),
        ("keep", "copy runs' resume files into results/minatar"),
        ("resume", "restore kept runs where needed and resume them in the background"),
    ):
        command_parser = sub.add_parser(name, help=text)
        command_parser.add_argument("names", nargs="+", choices=sorted(PLAN), metavar="RUN")
        if name != "keep":
            command_parser.add_argument(
                "--tree", type=Path, help="a checkout whose src/ the runs import"
            )
    sub.add_parser("stop", help="SIGTERM the started and resumed runs (each saves, exits)")
    sub.add_parser("summary", help="write results/minatar/summary.json")
    args = parser.parse_args(argv)
    if args.command == "plan":
        for run in PLAN.values():
            print(command(run))
        return
    if args.command == "summary":
        for entry in summary():
            print(json.dumps(entry))
        return
    tools = breakout_runs()
    if args.command == "stop":
        print(f"stopped {len(tools.stop(PIDS))} runs (each saved a checkpoint)")
    elif args.command == "start":
        for name in args.names:
            tools.start(name, PLAN[name].train_args(), RUNS, PIDS, tree=args.tree)
    elif args.command == "resume":
        for name in args.names:
            tools.resume(name, RUNS, PIDS, tree=args.tree)
    elif args.command == "keep":
        for name in args.names:
            tools.keep(RUNS / name)
        summary()


if __name__ == "__main__":
    sys.exit(main())
