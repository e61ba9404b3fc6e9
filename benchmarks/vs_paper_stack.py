"""noisybolt against the paper's own stack, bolted both, side by side on Table 1's rows.

Two learners per row of the paper's Table 1 (default ``G(on_edge)`` with PPO and A2C,
``!F(top_right_corner)`` with A2C), each watched by a restraining bolt through the same
noisy camera (regional smudge, the paper's case 4) and the same trained CNN classifier,
paid the paper's rewards (+1 per accepting step, 0.5 off per low-confidence fluent), in
interleaved rounds in one process, so that whatever else runs on the machine hits both
alike:

  paper's stack  torch-ac 1.4.0's PPO or A2C with rl-starter-files' model and defaults
                 (16 environments, 15 in worker processes), the DFA state one-hot after
                 the convolutions, and the bolt as a plain per-environment Gymnasium
                 wrapper running Algorithm 1 step by step (``paper_stack.py``, which says
                 what exactly; tested to pay what noisybolt's bolt pays);
  noisybolt      the row as ``noisybolt reproduce table1`` trains it: Stable-Baselines3
                 with ``configs/hyperparams/gridworld.yaml`` (8 environments, schedules,
                 reward normalisation), the vectorised world and the batched bolt
                 (``make_env``/``make_model`` of :mod:`noisybolt.runs`).

Each run trains until an evaluation (every 2,048 frames, 20 episodes on environments of
its own, actions sampled as rl-starter-files' ``evaluate.py`` does) has >= 95 % of its
episodes reach the goal *and* comply with the spec, judged from the world's ground truth,
or its frame budget (the row's Table 1 budget, or ``--frames``) is spent. Reported per
learner: training frames/s and time to that evaluation, with the evaluations' own time
left out (the clocks stop while evaluating), by two clocks: the wall clock, and CPU time
(the main process's, plus for torch-ac its worker processes'). On a quiet machine the wall
clock is the comparison that matters (torch-ac spreads over every core, noisybolt trains
in one process); on a shared one it measures how much of the machine the scheduler gave
each side, so the last two lines use the wall clock only with ``--clock wall`` (default:
CPU). One torch thread in every process (FACTS.md: PPO ran 9x slower with 2 threads on 2
cores). Medians over rounds; the ratios are of the medians, per row, and the last two
lines the worst row's (lowest frames/s ratio, highest time-to-solve ratio). Where the
paper's stack does not solve a row within the budget in some round, its time there is
at least its whole training time, so the time-to-solve ratio is an upper bound, printed
``<= X`` (:func:`solve_ratio`).

    pip install 'noisybolt[bench]'   # torch-ac 1.4.0 (or: pip install torch-ac==1.4.0)
    .venv/bin/python benchmarks/vs_paper_stack.py [--rows edge-ppo edge-a2c avoid_top_right-a2c]
        [--rounds 3] [--frames N] [--procs 16] [--clock cpu]
"""

from __future__ import annotations

import argparse
import contextlib
import importlib.util
import os
import statistics
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

import torch
from stable_baselines3.common.callbacks import BaseCallback, CallbackList

sys.path.insert(0, str(Path(__file__).resolve().parent))  # its sibling, when loaded by path
from paper_stack import (
    EVAL_EPISODES,
    EVAL_EVERY,
    PROCS,
    SOLVED,
    Outcome,
    StarterACModel,
    Stopwatch,
    run_paper_stack,
)

__all__ = ["INSTALL", "Outcome", "StarterACModel", "Stopwatch", "main", "run_noisybolt"]

INSTALL = (
    "torch-ac is not installed; this benchmark runs the paper's stack beside noisybolt: "
    "pip install 'noisybolt[bench]' (or pip install torch-ac==1.4.0)"
)
#: Table 1's rows measured by default: the issue's three.
DEFAULT_ROWS = ("edge-ppo", "edge-a2c", "avoid_top_right-a2c")
CLOCKS = ("wall", "cpu")
UNSOLVED = "n/a (noisybolt did not solve in every round)"


# ---------------------------------------------------------------------- noisybolt side
def row_config(row: str, seed: int, *, bolted: bool = True, n_envs: int | None = None) -> Any:
    """The run config of a Table 1 row as ``reproduce table1`` builds it (its settings
    of :func:`~noisybolt.experiments.table1_rows.table1_sweep`); unbolted: the same
    learner and world with the bolt paying nothing (and an oracle, no classifier)."""
    from noisybolt.experiments.table1_rows import select_rows
    from noisybolt.runs.config import TrainConfig
    from noisybolt.runs.resolution import resolve

    (table_row,) = select_rows([row])
    settings: dict[str, Any] = {
        "progress_bar": False,
        "world.name": "gridworld",
        "world.kwargs.noise": "regional",
        "bolt.reward": "paper",
        "bolt.specs": [table_row.spec],
        "algorithm.name": table_row.algo,
        "detector.kind": "classifier" if bolted else "oracle",
        # The schedules as the row's own budget sets them, whatever this run trains.
        "frames": table_row.frames(),
        "seed": seed,
    }
    if not bolted:
        settings["bolt.bolted"] = False
    if n_envs is not None:
        settings["world.n_envs"] = n_envs
    return resolve(TrainConfig.build(settings))


def row_setup(row: str, *, bolted: bool = True) -> Any:
    """The row's bolt (specs' DFAs and the detector: the cached classifier, trained
    here if missing), built once per row before any clock starts."""
    from noisybolt.runs.environments import prepare_bolt

    return prepare_bolt(row_config(row, 0, bolted=bolted), seed=0, log=lambda _: None)


class _EvaluateEvery(BaseCallback):
    """Evaluates every ``EVAL_EVERY`` frames with the clock stopped; stops when solved."""

    def __init__(self, clock: Stopwatch, score: Callable[[], float]) -> None:
        super().__init__()
        self.clock, self.score = clock, score
        self.solved: tuple[int, float, float] | None = None
        self._next = EVAL_EVERY

    def _on_training_start(self) -> None:
        self.clock.start()

    def _on_training_end(self) -> None:
        if self.solved is None:
            self.clock.stop()

    def _on_step(self) -> bool:
        if self.num_timesteps < self._next:
            return True
        self._next += EVAL_EVERY
        self.clock.stop()
        if self.score() >= SOLVED:
            self.solved = (self.num_timesteps, self.clock.total, self.clock.cpu)
            return False
        self.clock.start()
        return True


def _unchecked() -> Any:
    """``train``'s context for ``learn()`` (torch distributions without argument checks)."""
    from noisybolt.runs import training

    return getattr(training, "_unchecked_distributions", contextlib.nullcontext)()


def run_noisybolt(
    bolted: bool,
    seed: int,
    budget: int,
    n_envs: int | None = None,
    *,
    row: str = "edge-ppo",
    setup: Any = None,
) -> Outcome:
    """noisybolt on a Table 1 ``row`` (bolted, or with a bolt that pays nothing) until
    solved or ``budget`` frames, on ``n_envs`` environments (default: the tuned 8)."""
    from noisybolt.runs.callbacks import linear_schedules
    from noisybolt.runs.environments import make_env
    from noisybolt.runs.evaluation import evaluate_bolted_policy
    from noisybolt.runs.models import make_model

    config = row_config(row, seed, bolted=bolted, n_envs=n_envs)
    setup = setup or row_setup(row, bolted=bolted)
    built = {"dfas": setup.dfas, "letters": setup.letters, "belief": setup.belief}
    env = make_env(config, setup.detector, training=True, **built)
    eval_env = make_env(config, setup.detector, training=False, **built)
    model = make_model(config, env)
    spec_names = [s.name for s in config.spec_objects()]

    def score() -> float:
        result = evaluate_bolted_policy(
            lambda obs: model.predict(obs, deterministic=False)[0],
            eval_env,
            n_episodes=EVAL_EPISODES,
            spec_names=spec_names,
        )
        return float((result.success_rate if bolted else result.goal_rate) or 0.0)

    clock = Stopwatch()
    evaluate = _EvaluateEvery(clock, score)
    schedules = linear_schedules(
        config.algorithm.hyperparams, algo=config.algorithm.name, frames=config.frames
    )
    with _unchecked():
        model.learn(budget, callback=CallbackList([*schedules, evaluate]))
    env.close()
    eval_env.close()
    return Outcome(
        model.num_timesteps, clock.total, clock.cpu, *(evaluate.solved or (None, None, None))
    )


# ---------------------------------------------------------------------- report
def _median(values: list[float | None]) -> float | None:
    known = [v for v in values if v is not None]
    return statistics.median(known) if len(known) == len(values) and known else None


def solve_ratio(
    ours: list[Outcome], theirs: list[Outcome], clock: str
) -> tuple[float, bool] | None:
    """noisybolt's median time to solve over the paper stack's: ``(ratio, bound)``.

    Where the paper's stack did not solve in some rounds, its time there is at least its
    whole training time, and the median of those lower bounds bounds its median from
    below: the ratio is then an upper bound (``bound`` True). None where noisybolt did not
    solve in every round (no bound in the direction of the target)."""
    mine = _median([o.to_solve(clock) for o in ours])
    if mine is None:
        return None
    seconds = [o.to_solve(clock) for o in theirs]
    at_least = [
        s if s is not None else (o.cpu_seconds if clock == "cpu" else o.seconds)
        for s, o in zip(seconds, theirs, strict=True)
    ]
    return mine / statistics.median(at_least), None in seconds


def _ratio(value: tuple[float, bool] | None) -> str:
    if value is None:
        return UNSOLVED
    return f"{'<= ' if value[1] else ''}{value[0]:.2f}"


def _fmt(value: float | None, spec: str) -> str:
    return "unsolved" if value is None else format(value, spec)


def _line(outcome: Outcome) -> str:
    return (
        f"{outcome.fps('wall'):>7,.0f} frames/s wall, {outcome.fps('cpu'):>7,.0f} per CPU s; "
        f"solved at {_fmt(outcome.solved_frames, ',')} frames, "
        f"{_fmt(outcome.solved_seconds, '.1f')} s wall, "
        f"{_fmt(outcome.solved_cpu_seconds, '.1f')} CPU s"
    )


def report(runs: dict[tuple[str, str], list[Outcome]], *, clock: str = "cpu") -> list[str]:
    """The table of medians per row and learner, then the ratios per row by each clock,
    ``clock``'s last; the last two lines are the worst row's by ``clock``. ``runs`` maps
    ``(row, "paper" or "noisybolt")`` to that learner's outcomes, one per round."""
    lines = [
        f"{'row':<20} {'learner':<15} {'frames/s':>9} {'per CPU s':>10} "
        f"{'frames to solve':>16} {'s to solve':>11} {'CPU s':>7}"
    ]
    fps: dict[tuple[str, str], dict[str, float]] = {}
    for key, outcomes in runs.items():
        fps[key] = {c: statistics.median(o.fps(c) for o in outcomes) for c in CLOCKS}
        solve = {c: _median([o.to_solve(c) for o in outcomes]) for c in CLOCKS}
        frames = _median([o.solved_frames for o in outcomes])
        learner = "paper's stack" if key[1] == "paper" else "noisybolt"
        lines.append(
            f"{key[0]:<20} {learner:<15} {fps[key]['wall']:>9,.0f} {fps[key]['cpu']:>10,.0f} "
            f"{_fmt(frames, ',.0f'):>16} {_fmt(solve['wall'], '.1f'):>11} "
            f"{_fmt(solve['cpu'], '.1f'):>7}"
        )
    rows = list(dict.fromkeys(name for name, _ in runs))
    what = "noisybolt / paper's stack, bolted both"
    for by in (*(c for c in CLOCKS if c != clock), clock):
        lines.append(f"by the {by} clock:")
        fps_ratios: list[float] = []
        solve_ratios: list[tuple[float, bool] | None] = []
        for name in rows:
            ours, theirs = (name, "noisybolt"), (name, "paper")
            fps_ratios.append(fps[ours][by] / fps[theirs][by])
            solve_ratios.append(solve_ratio(runs[ours], runs[theirs], by))
            lines.append(
                f"  {name}: fps ratio {fps_ratios[-1]:.2f}, time-to-solve ratio "
                f"{_ratio(solve_ratios[-1])}"
            )
        known = [v for v in solve_ratios if v is not None]
        # The worst row's ratio, or a bound on it where some row's is a bound.
        worst = (
            (max(v[0] for v in known), any(v[1] for v in known))
            if len(known) == len(solve_ratios)
            else None
        )
        lines.append(f"fps ratio ({what}, worst row): {min(fps_ratios):.2f}")
        lines.append(f"time-to-solve ratio ({what}, worst row): {_ratio(worst)}")
    return lines


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rows", nargs="+", default=list(DEFAULT_ROWS), help="Table 1 rows")
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument(
        "--frames", type=int, default=None, help="budget per run (default: the row's Table 1)"
    )
    parser.add_argument(
        "--procs", type=int, default=PROCS, help="the paper stack's environments (16)"
    )
    parser.add_argument(
        "--clock",
        choices=CLOCKS,
        default="cpu",
        help="the clock of the last two lines (default cpu: fair on a shared machine)",
    )
    args = parser.parse_args(argv)
    if importlib.util.find_spec("torch_ac") is None:
        print(INSTALL, file=sys.stderr)
        return 2
    from noisybolt.experiments.table1_rows import select_rows
    from noisybolt.runs.specs import PAPER_SPECS

    torch.set_num_threads(1)
    rows = {r.name: r for r in select_rows(args.rows)}
    setups = {name: row_setup(name) for name in rows}  # the classifier before any clock
    runs: dict[tuple[str, str], list[Outcome]] = {}
    for r in range(args.rounds):
        for name, row in rows.items():
            budget = args.frames or row.frames()
            formula = PAPER_SPECS[row.spec]
            for side in ("paper", "noisybolt"):
                if side == "paper":
                    outcome = run_paper_stack(
                        row.algo, formula, setups[name].detector, r, budget, procs=args.procs
                    )
                else:
                    outcome = run_noisybolt(True, r, budget, row=name, setup=setups[name])
                runs.setdefault((name, side), []).append(outcome)
                print(f"round {r} {name:<20} {side:<9} {_line(outcome)}", flush=True)
    print(
        f"\n6x6 gridworld, regional camera noise, classifier bolt, paper rewards; "
        f"{args.rounds} interleaved rounds (medians), budget "
        f"{'per row as Table 1' if args.frames is None else f'{args.frames:,} frames'}, "
        f"evaluation every {EVAL_EVERY:,} frames ({EVAL_EPISODES} sampled episodes, solved at "
        f">= {SOLVED:.0%} at the goal and complying), paper's stack on {args.procs} envs, "
        f"1 torch thread per process, load average {os.getloadavg()[0]:.1f} on "
        f"{os.cpu_count()} CPUs at the end"
    )
    for line in report(runs, clock=args.clock):
        print(line)
    return 0


if __name__ == "__main__":
    sys.exit(main())
