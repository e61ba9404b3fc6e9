"""Frames per second by the wall clock of real Breakout RAM PPO runs: world in process
against the world in worker processes (``world.workers``, optionally with overlapped
rollouts, ``world.overlap``), interleaved in one run.

Each variant is the command of the RAM runs in ``results/breakout/README.md`` (PPO, the
RAM agent, the ``left_column_milestones`` specs, the bolt's CNN classifier on the noisy
camera, Gaussian grain sigma 50, an evaluation of 8 episodes and a checkpoint every
``--eval-freq`` frames), run as its own ``noisybolt train`` process, with
``--set world.workers=N`` for the worker variants (a variant ``No``: N workers and
``--set world.overlap=true``). The classifier is trained (or read
from the cache) by a first short run, outside the clock.

Per run it reports: frames/s over the whole process (start-up, the evaluations, the final
one and the checkpoints included); frames/s between the first and the last checkpoint
(the steady state of a long run, its evaluations and checkpoints included); the CPU
seconds of the training process and of its worker processes (psutil, sampled); the load
average. The variants take turns (round after round), so the machine's other load hits
them alike.

    .venv/bin/python benchmarks/breakout_workers.py [--frames 100k] [--rounds 2] \
        [--variants 0,2,2o] [--out runs/h17-bench]

``--stepping N`` measures the world alone instead: 8 games of ``breakout-ram`` with the
bolt's noisy camera read every step, N steps of seeded random actions, in process against
2 workers and against 2 threads (two shards of 4 games, each stepped in its own thread of
this process), twice each interleaved in this process: CPU ms per frame of this process
and of the workers, and wall ms per frame.
"""

from __future__ import annotations

import argparse
import contextlib
import os
import re
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any, NamedTuple

import psutil

COMMAND = [
    "train", "--world", "breakout-ram", "--spec", "left_column_milestones", "--reward",
    "paper", "--algo", "ppo", "--detector", "classifier", "--noise", "gaussian:sigma=50",
    "--eval-episodes", "8", "--seed", "0", "--no-progress",
]  # fmt: skip


class Run(NamedTuple):
    """One training process's figures."""

    variant: str  # worker count, "o" appended for overlapped rollouts
    frames: int
    wall_s: float
    steady_fps: float  # between the first and the last checkpoint
    main_cpu_s: float
    worker_cpu_s: float
    load: float  # 1-minute load average at the end

    @property
    def fps(self) -> float:
        """Frames per second over the whole process."""
        return self.frames / self.wall_s


def _noisybolt() -> list[str]:
    exe = Path(sys.executable).with_name("noisybolt")
    return [str(exe)] if exe.exists() else [sys.executable, "-m", "noisybolt.cli"]


def train(variant: str, frames: int, eval_freq: int, out: Path) -> Run:
    """Runs one ``noisybolt train`` to ``frames`` frames and measures it."""
    workers, overlap = int(variant.removesuffix("o")), variant.endswith("o")
    argv = [
        *_noisybolt(),
        *COMMAND,
        "--frames", str(frames), "--eval-freq", str(eval_freq),
        "--checkpoint-freq", str(eval_freq // 4), "--out", str(out),
        "--set", f"world.workers={workers}",
        *(["--set", "world.overlap=true"] if overlap else []),
    ]  # fmt: skip
    cpu: dict[int, float] = {}
    seen: dict[int, float] = {}  # checkpoint frames -> when it appeared (only the latest stays)
    start = time.perf_counter()
    process = psutil.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    root = process.pid
    while process.poll() is None:
        try:
            for p in [process, *process.children(recursive=True)]:
                times = p.cpu_times()
                cpu[p.pid] = times.user + times.system
        except psutil.Error:
            pass
        for path in (out / "checkpoints").glob("step_*"):
            with contextlib.suppress(ValueError):
                seen.setdefault(int(path.name.removeprefix("step_")), time.perf_counter())
        time.sleep(0.25)
    wall = time.perf_counter() - start
    output = process.stdout.read() if process.stdout else ""
    if process.returncode != 0:
        raise RuntimeError(f"{' '.join(argv)} failed ({process.returncode}):\n{output[-3000:]}")
    trained = int(re.search(r"frames trained\s+([\d,]+)", output)[1].replace(",", ""))  # type: ignore[index]
    steps = sorted(seen.items())
    steady = (steps[-1][0] - steps[0][0]) / (steps[-1][1] - steps[0][1]) if len(steps) > 1 else 0
    main = cpu.pop(root, 0.0)
    return Run(variant, trained, wall, steady, main, sum(cpu.values()), os.getloadavg()[0])


def stepping(steps: int, rounds: int = 2) -> None:
    """The world alone, in process against 2 workers and against 2 threads (see the
    module docstring)."""
    from concurrent.futures import ThreadPoolExecutor

    import numpy as np

    from noisybolt.envs.breakout import BreakoutWorld
    from noisybolt.envs.worker_world import WorkerWorld

    settings: dict[str, Any] = {"noise": "gaussian:sigma=50", "fire_on_reset": True}
    inside = BreakoutWorld(num_envs=8, seed=0, obs_mode="ram", **settings)
    outside = WorkerWorld("breakout-ram", num_envs=8, workers=2, seed=0, **settings)
    halves = [
        BreakoutWorld(num_envs=4, seed=0, obs_mode="ram", shard=(first, 8), **settings)
        for first in (0, 4)
    ]
    pool = ThreadPoolExecutor(2)
    workers = [psutil.Process(pid) for pid in outside.pids if pid is not None]

    def worker_cpu() -> float:
        return sum(p.cpu_times().user + p.cpu_times().system for p in workers)

    def read(info: dict[str, Any]) -> None:
        np.asarray(info["bolt_image"]), np.asarray(info["true_fluents"])
        if "final_info" in info:
            np.asarray(info["final_info"]["bolt_image"])

    def step_half(world: BreakoutWorld, actions: np.ndarray) -> None:
        read(world.step(actions)[4])

    def threaded(actions: np.ndarray) -> None:
        # each shard stepped and its camera read in its own thread (the ALE releases the
        # GIL while it emulates; the world's Python and numpy glue does not)
        list(pool.map(step_half, halves, (actions[:4], actions[4:])))

    variants: dict[str, Any] = {
        "in process": (lambda a: read(inside.step(a)[4]), [inside]),
        "2 workers": (lambda a: read(outside.step(a)[4]), [outside]),
        "2 threads": (threaded, halves),
    }
    try:
        for _ in range(rounds):
            for name, (step, worlds) in variants.items():
                for world in worlds:
                    world.reset(seed=0)
                rng = np.random.default_rng(0)
                cpu, wall, other = time.process_time(), time.perf_counter(), worker_cpu()
                for _ in range(steps):
                    step(rng.integers(0, 4, 8))
                frames = 8 * steps
                print(
                    f"{name:>10}: CPU ms per frame {1e3 * (time.process_time() - cpu) / frames:.3f}"
                    f" here, {1e3 * (worker_cpu() - other) / frames:.3f} in workers; wall "
                    f"{1e3 * (time.perf_counter() - wall) / frames:.3f}; load "
                    f"{os.getloadavg()[0]:.2f}",
                    flush=True,
                )
    finally:
        pool.shutdown()
        outside.close()
        inside.close()
        for world in halves:
            world.close()


def main() -> None:
    parser = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    parser.add_argument("--frames", default="100k", help="frames per run (k/m suffixes)")
    parser.add_argument("--rounds", type=int, default=2)
    parser.add_argument(
        "--variants",
        default="0,2",
        help="worker counts (0: in process; 'o' appended: with world.overlap)",
    )
    parser.add_argument("--out", type=Path, help="keep the runs here (default: a temp dir)")
    parser.add_argument("--eval-freq", default="100k")
    parser.add_argument("--stepping", type=int, default=0, help="steps: the world alone")
    args = parser.parse_args()
    if args.stepping:
        stepping(args.stepping)
        return

    def count(text: str) -> int:
        text = text.lower()
        scale = {"k": 1_000, "m": 1_000_000}.get(text[-1], 1)
        return int(float(text.rstrip("km")) * scale)

    frames, eval_freq = count(args.frames), count(args.eval_freq)
    variants = [v.strip() for v in args.variants.split(",")]
    root = args.out or Path(tempfile.mkdtemp(prefix="breakout-workers-"))
    try:
        print("warming the classifier cache (a short run, not timed) ...", flush=True)
        train("0", 2048, 2048, root / "warm")
        runs: list[Run] = []
        for r in range(args.rounds):
            for variant in variants if r % 2 == 0 else reversed(variants):
                run = train(variant, frames, eval_freq, root / f"r{r}-w{variant}")
                runs.append(run)
                print(
                    f"round {r} workers={variant}: {run.frames:,} frames in {run.wall_s:.0f} s "
                    f"= {run.fps:.0f} frames/s (steady {run.steady_fps:.0f}); CPU s: main "
                    f"{run.main_cpu_s:.0f}, workers {run.worker_cpu_s:.0f}; load {run.load:.2f}",
                    flush=True,
                )
    finally:
        if args.out is None:
            shutil.rmtree(root, ignore_errors=True)
    print(f"\nBreakout RAM PPO + classifier bolt, {frames:,} frames per run, {args.rounds} rounds")
    print(
        f"{'workers':>8} {'frames/s':>9} {'steady':>7} {'main CPU/frame ms':>18} "
        f"{'workers CPU/frame ms':>21} {'10M frames':>11}"
    )
    for variant in variants:
        mine = [run for run in runs if run.variant == variant]
        fps = statistics.median(run.fps for run in mine)
        steady = statistics.median(run.steady_fps for run in mine)
        main_ms = statistics.median(1e3 * run.main_cpu_s / run.frames for run in mine)
        worker_ms = statistics.median(1e3 * run.worker_cpu_s / run.frames for run in mine)
        print(
            f"{variant:>8} {fps:>9.0f} {steady:>7.0f} {main_ms:>18.2f} {worker_ms:>21.2f} "
            f"{1e7 / steady / 3600 if steady else float('nan'):>9.1f} h"
        )
    print("(10M frames: the steady rate extrapolated; an extrapolation, not a measurement)")


if __name__ == "__main__":
    main()
