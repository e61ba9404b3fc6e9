"""The gridworld's step before and after a change, in one process: one A/B you can trust
on a loaded machine.

Loads ``envs/gridworld_vec.py`` and ``envs/sb3.py`` of an older source tree (``--before``,
e.g. a ``git worktree`` of the commit before the change) as modules of their own, beside
this tree's, and times both, interleaved (``--rounds`` turns of ``--steps`` steps each,
the order alternating), plus the older one a second time as an A/A control: what the
machine's noise alone does to a ratio. Figures are the lower quartile of the rounds
(a loaded machine only ever adds time). The older modules must import against this
tree's package (true when the change kept ``envs/gridworld.py``'s names).

Cases: the bare world step, the step plus the bolt's labels read as the batched bolt reads
them (``info["bolt_image"]`` and ``info["true_fluents"]`` if the world puts them in
``info``, else the older ``bolt_images()`` and ``true_fluents()``), and the step through
SB3's ``VecEnv`` API; 8 and 64 rooms, ``grid`` observations, clean camera.

    git worktree add --detach /tmp/nb_before <commit before the change>
    .venv/bin/python benchmarks/world_step_before_after.py --before /tmp/nb_before
"""

from __future__ import annotations

import argparse
import importlib.util
import itertools
import statistics
import sys
import timeit
from collections.abc import Callable
from pathlib import Path
from types import ModuleType
from typing import Any

import numpy as np

from noisybolt.envs import gridworld_vec, sb3


def load(name: str, path: Path) -> ModuleType:
    spec = importlib.util.spec_from_file_location(name, path)
    if spec is None or spec.loader is None:
        raise SystemExit(f"cannot load {path}")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def world_case(gv: Any, n: int, *, read_labels: bool) -> Callable[[], None]:
    world = gv.VectorGridworld(n, obs_mode="grid", seed=0)
    _, first = world.reset(seed=0)
    actions = np.random.default_rng(0).integers(0, 4, (1024, n))
    turn = itertools.cycle(range(1024))
    in_info = "bolt_image" in first

    def work() -> None:
        info = world.step(actions[next(turn)])[4]
        if read_labels and in_info:
            np.asarray(info["bolt_image"])
            np.asarray(info["true_fluents"])
        elif read_labels:
            world.bolt_images()
            world.true_fluents()

    return work


def sb3_case(gv: Any, adapter: Any, n: int) -> Callable[[], None]:
    venv = adapter.SB3VecEnv(gv.VectorGridworld(n, obs_mode="grid"))
    venv.reset()
    actions = np.random.default_rng(0).integers(0, 4, (1024, n))
    turn = itertools.cycle(range(1024))
    return lambda: venv.step(actions[next(turn)])


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--before", type=Path, required=True, help="the older source tree")
    parser.add_argument("--rounds", type=int, default=60)
    parser.add_argument("--steps", type=int, default=200, help="steps per round")
    options = parser.parse_args(argv)
    envs = options.before / "src" / "noisybolt" / "envs"
    old_gv = load("before_gridworld_vec", envs / "gridworld_vec.py")
    old_sb3 = load("before_sb3", envs / "sb3.py")
    print(
        f"# {options.rounds} interleaved rounds of {options.steps} steps; lower quartile, "
        f"us per vector step; before: {options.before}"
    )
    print(f"{'case':44s}  {'before':>8}  {'A/A':>8}  {'after':>8}  {'time after/before':>18}")
    for n in (8, 64):
        cases: list[tuple[str, Callable[[Any, Any], Callable[[], None]]]] = [
            (f"VectorGridworld, {n} envs", lambda g, s, n=n: world_case(g, n, read_labels=False)),
            (
                f"VectorGridworld + labels read, {n} envs",
                lambda g, s, n=n: world_case(g, n, read_labels=True),
            ),
            (f"SB3VecEnv(VectorGridworld), {n} envs", lambda g, s, n=n: sb3_case(g, s, n)),
        ]
        for label, make in cases:
            runs = {
                "before": make(old_gv, old_sb3),
                "A/A": make(old_gv, old_sb3),
                "after": make(gridworld_vec, sb3),
            }
            for work in runs.values():  # warm-up: first allocations, caches
                timeit.timeit(work, number=options.steps)
            times: dict[str, list[float]] = {k: [] for k in runs}
            for r in range(options.rounds):
                for k in list(runs) if r % 2 == 0 else list(runs)[::-1]:
                    times[k].append(timeit.timeit(runs[k], number=options.steps) / options.steps)
            q = {
                k: statistics.quantiles(v, n=4, method="inclusive")[0] * 1e6
                for k, v in times.items()
            }
            print(
                f"{label:44s}  {q['before']:8.1f}  {q['A/A']:8.1f}  {q['after']:8.1f}  "
                f"{q['after'] / q['before']:18.2f}"
            )
    return 0


if __name__ == "__main__":
    sys.exit(main())
