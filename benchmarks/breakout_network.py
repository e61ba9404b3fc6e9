"""Frames per second of PPO on Breakout with three agent networks, in one run.

The agent network is most of a Breakout training step on a CPU (cProfile: backward 37 %,
forward convolutions 14 %, dense layers 7 %; the ALE 7 %), so its size sets the frames per
hour. Measured here, interleaved so the machine's noise hits every variant alike, with
the bolt on (oracle detector, so the classifier's constant cost does not blur the
ratios), the built-in Breakout PPO hyperparameters otherwise:

  (a) ``nature-separate``: Nature DQN convolutions, separate 512-unit policy and value
      layers (``net_arch: [512]``; the Breakout setting until December 2026),
  (b) ``nature-shared``: Nature DQN convolutions, one shared 512-unit layer, linear
      heads (SB3's ``CnnPolicy`` and the RL Zoo's Atari PPO),
  (c) ``atari2013``: the 2013 DQN's two convolutions and one shared 256-unit layer, then
      a 256-unit layer each for policy and value, where the DFA states meet the image
      features through a non-linearity (the Breakout setting since December 2026).

    .venv/bin/python benchmarks/breakout_network.py [--frames 4096] [--rounds 3]
"""

from __future__ import annotations

import argparse
import statistics
import time
from typing import Any

import torch
from stable_baselines3 import PPO
from stable_baselines3.common.vec_env import VecMonitor

from noisybolt.agents.extractor import BoltFeaturesExtractor
from noisybolt.agents.hyperparams import META_KEYS, load_hyperparams
from noisybolt.agents.specs import expand_specs, resolve_spec
from noisybolt.envs import SB3VecEnv, make_world
from noisybolt.perception.detectors import OracleDetector
from noisybolt.wrappers import BoltVecEnv

#: name -> (extractor settings, policy net_arch)
VARIANTS: dict[str, tuple[dict[str, Any], list[int]]] = {
    "nature-separate": ({"cnn": "nature"}, [512]),
    "nature-shared": ({"cnn": "nature", "image_features": 512}, []),
    "atari2013": ({"cnn": "atari2013", "image_features": 256}, [256]),
}


def fps(variant: str, frames: int, seed: int) -> float:
    params = load_hyperparams("breakout", "ppo")
    world = make_world("breakout", num_envs=int(params["n_envs"]), seed=seed, fire_on_reset=True)
    specs = [resolve_spec(name) for name in expand_specs(["left_column_milestones"])]
    env = BoltVecEnv(
        VecMonitor(SB3VecEnv(world)),  # type: ignore[arg-type]
        specs,
        OracleDetector(world.fluent_names),
        world=world,
    )
    extractor, net_arch = VARIANTS[variant]
    kwargs = {k: v for k, v in params.items() if k not in META_KEYS}
    kwargs.pop("policy_kwargs", None)
    policy_kwargs = {
        "features_extractor_class": BoltFeaturesExtractor,
        "features_extractor_kwargs": extractor,
        "net_arch": net_arch,
    }
    model = PPO(
        "MultiInputPolicy", env, policy_kwargs=policy_kwargs, seed=seed, device="cpu", **kwargs
    )
    start = time.perf_counter()
    model.learn(frames)
    return model.num_timesteps / (time.perf_counter() - start)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=4096)
    parser.add_argument("--rounds", type=int, default=3)
    args = parser.parse_args()
    torch.set_num_threads(1)
    results: dict[str, list[float]] = {v: [] for v in VARIANTS}
    for r in range(args.rounds):
        for v in VARIANTS:
            results[v].append(fps(v, args.frames, seed=r))
    med = {v: statistics.median(results[v]) for v in VARIANTS}
    base = med["nature-separate"]
    print(
        f"PPO on Breakout, 8 envs, bolt with the oracle detector, {args.frames} frames x "
        f"{args.rounds} rounds (median), 1 torch thread"
    )
    print(f"{'network':<20} {'frames/s':>9}  {'vs (a)':>7}")
    for v in VARIANTS:
        print(f"{v:<20} {med[v]:>9,.0f}  {med[v] / base:>7.2f}")
    print("all rounds:", {v: [round(x) for x in results[v]] for v in VARIANTS})


if __name__ == "__main__":
    main()
