"""How often a noisy Breakout bolt pays for bricks that are still there.

An ``F(x)`` spec's DFA never leaves its accepting sink, so a single frame in which the
classifier says ``x`` (p >= 0.5) while it is false is enough for the bolt to pay a
milestone that never happened. Over a game of thousands of frames, a per-frame false
positive rate that looks negligible on a balanced validation set is not.

For each camera noise, with the classifier ``noisybolt train --noise NOISE`` would use
(cached, or trained on the fly with the same recipe), a uniformly random agent plays
Breakout (FIRE after reset and lost lives) under the bolt with ``left_column_milestones``:

- per fluent: the per-frame false-positive rate (p >= 0.5 while false, over the frames
  in which it is false) and the low-band share (0.5 <= p <= 0.9, over all frames);
- per spec: the false acceptances (:attr:`EvalResult.false_acceptance`): the share of
  episodes whose bolt DFA ended accepting while the true trace did not.

    .venv/bin/python benchmarks/breakout_false_acceptance.py [--episodes 32] \
        [--noise none --noise gaussian:sigma=50 ...]

A trained agent plays longer games than a random one; to measure a trained policy under
any camera: ``noisybolt evaluate RUN --stochastic --noise NOISE`` (its table has the
false acceptances per spec).
"""

from __future__ import annotations

import argparse
from typing import Any

import numpy as np
import torch
from stable_baselines3.common.vec_env import VecEnv, VecEnvWrapper, VecMonitor

from noisybolt.envs import SB3VecEnv, make_world
from noisybolt.runs import DetectorConfig
from noisybolt.runs.detectors import make_detector
from noisybolt.runs.evaluation import evaluate_bolted_policy
from noisybolt.runs.specs import expand_specs, resolve_spec
from noisybolt.wrappers import BoltVecEnv

DEFAULT_NOISES = ("none", "gaussian:sigma=50", "gaussian:sigma=40+occlusion:count=2,size=0.25")


class FrameCounter(VecEnvWrapper):
    """Counts, per fluent, false positives and low-band readings on every bolted step
    (from the step's ``fluent_probs`` and ``true_fluents`` infos)."""

    def __init__(self, venv: VecEnv, n_fluents: int) -> None:
        super().__init__(venv)
        self.false_positive = np.zeros(n_fluents)
        self.negative = np.zeros(n_fluents)
        self.low = np.zeros(n_fluents)
        self.frames = 0

    def reset(self) -> Any:
        return self.venv.reset()

    def step_wait(self) -> Any:
        obs, rewards, dones, infos = self.venv.step_wait()
        probs = np.stack([info["fluent_probs"] for info in infos])
        truth = np.stack([info["true_fluents"] for info in infos]).astype(bool)
        self.false_positive += ((probs >= 0.5) & ~truth).sum(axis=0)
        self.negative += (~truth).sum(axis=0)
        self.low += ((probs >= 0.5) & (probs <= 0.9)).sum(axis=0)
        self.frames += len(probs)
        return obs, rewards, dones, infos


def measure(noise: str, episodes: int, n_envs: int, seed: int) -> None:
    world = make_world("breakout", num_envs=n_envs, seed=seed, noise=noise, fire_on_reset=True)
    detector = make_detector(
        DetectorConfig(kind="classifier"),
        world="breakout",
        world_kwargs={"noise": noise, "fire_on_reset": True},
        fluent_names=world.fluent_names,
        camera_spec=world.camera_spec,
        progress=False,
        log=lambda _: None,
    )
    names = expand_specs(["left_column_milestones"])
    bolted = BoltVecEnv(
        VecMonitor(SB3VecEnv(world)),  # type: ignore[arg-type]
        [resolve_spec(name) for name in names],
        detector,
        world=world,
    )
    counter = FrameCounter(bolted, len(world.fluent_names))
    rng = np.random.default_rng(seed)
    result = evaluate_bolted_policy(
        lambda obs: rng.integers(0, 4, size=n_envs),
        counter,
        n_episodes=episodes,
        spec_names=names,
    )
    print(
        f"\nnoise {noise}: {result.n_episodes} random-play episodes, "
        f"{result.length_mean:.0f} steps on average, {counter.frames:,} frames"
    )
    print(f"{'fluent':<18} {'false positives / negative frame':>33} {'low-band frames':>16}")
    for i, name in enumerate(world.fluent_names):
        rate = counter.false_positive[i] / max(counter.negative[i], 1)
        print(f"{name:<18} {rate:>33.2e} {counter.low[i] / counter.frames:>16.2%}")
    print(f"{'spec':<18} {'episodes falsely accepted':>33}")
    for name in names:
        print(f"{name:<18} {result.false_acceptance[name]:>33.0%}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--noise", action="append", help="repeatable; default: three noises")
    parser.add_argument("--episodes", type=int, default=32)
    parser.add_argument("--n-envs", type=int, default=8)
    parser.add_argument("--seed", type=int, default=123)
    args = parser.parse_args()
    torch.set_num_threads(1)
    for noise in args.noise or DEFAULT_NOISES:
        measure(noise, args.episodes, args.n_envs, args.seed)


if __name__ == "__main__":
    main()
