"""Frames per second on Breakout, in one run: the stepping stack and the agent network.

Two questions, measured interleaved (round after round, so the machine's noise hits every
variant alike), everything seeded:

1. **Stepping** (agent steps/s of 8 games, random actions, no learning):

   - ``world-stack``: :class:`noisybolt.envs.breakout.BreakoutWorld`, the ALE driven
     directly (what training uses): frame skip 4 with the last two frames max-pooled,
     grey, 84x84 ``INTER_AREA``, a stack of 4, 1-30 no-ops, sticky actions 0.25;
   - ``world-stack+camera``: the same, plus the bolt's colour camera every step (84x84
     colour, Gaussian grain sigma 50), which a bolted run always pays;
   - ``world-ram``: the same world with ``obs_mode="ram"`` (no grey frames at all);
   - ``envpool-stack``: envpool's Atari ``Breakout-v5`` with the same preprocessing
     (``num_threads`` 1 and 2, synchronous: ``batch_size == num_envs``), when envpool
     imports here. It has no bolt camera (its observation is the agent's stack only;
     ``info["ram"]`` gives the RAM, so a camera would mean a second render through it)
     and it resets on the step *after* an episode ends, where noisybolt's worlds and SB3
     reset on the same step.

2. **Training** (PPO frames/s, 8 games, the built-in hyperparameters of each world, bolt
   on with the ``left_column_milestones`` specs):

   - ``image``: the image agent of ``configs/hyperparams/breakout.yaml`` (2013 DQN
     convolutions, 256 shared units, 256 each for policy and value);
   - ``ram``: the RAM agent of ``configs/hyperparams/breakout-ram.yaml`` (128 bytes ->
     256 units, 256 each for policy and value);

   each with the oracle detector (the agent's cost alone) and with the bolt's CNN
   classifier on the noisy camera (``+classifier``: untrained weights of the on-the-fly
   classifier's architecture, which cost what trained ones cost), as a real run pays;
   ``@bfloat16``: the same agent with ``algorithm.precision`` bfloat16 (its features
   extractor under autocast; measured where this CPU computes bfloat16 natively).

    .venv/bin/python benchmarks/breakout_network.py [--frames 4096] [--steps 2000] \
        [--rounds 3] [--trainers image+classifier,image+classifier@bfloat16] [--steppers ...]

envpool is not a dependency. envpool 1.2.5 registers every family it ships when imported
and fails without its MuJoCo assets (hundreds of MB more); this benchmark then imports its
Atari registration alone. To include it, install it somewhere (``pip install --target
DIR envpool envpool-assets dm-env optree --no-deps``) and put ``DIR`` on ``PYTHONPATH``.
"""

from __future__ import annotations

import argparse
import importlib
import statistics
import sys
import time
import types
from collections.abc import Callable
from typing import Any, NamedTuple

import numpy as np
import torch
from stable_baselines3 import PPO
from stable_baselines3.common.vec_env import VecMonitor

from noisybolt.agents.extractor import BoltFeaturesExtractor
from noisybolt.agents.hyperparams import META_KEYS, WORLD_KEYS, load_hyperparams
from noisybolt.envs import SB3VecEnv, make_world
from noisybolt.envs.breakout import BreakoutWorld
from noisybolt.perception.classifier import ClassifierDetector
from noisybolt.perception.detectors import OracleDetector
from noisybolt.runs.detectors import classifier_architecture
from noisybolt.runs.models import compute_dtype, set_precision
from noisybolt.runs.specs import expand_specs, resolve_spec
from noisybolt.wrappers import BoltVecEnv

N_ENVS = 8
NOISE = "gaussian:sigma=50"  # the bolt camera of the December 2026 Breakout runs


def _envpool() -> Any | None:
    """envpool with its Atari registration, or None when it is not importable here."""
    try:
        return importlib.import_module("envpool")
    except ImportError:
        return None
    except Exception:  # 1.2.5 fails on missing MuJoCo assets at import
        for name in [m for m in sys.modules if m == "envpool" or m.startswith("envpool.")]:
            del sys.modules[name]
    # Import the package without its all-families entry point, then Atari's registration.
    sys.modules["envpool.entry"] = types.ModuleType("envpool.entry")
    try:
        envpool = importlib.import_module("envpool")
        importlib.import_module("envpool.atari.registration")
    except Exception:  # anything else: leave it out, say so
        return None
    return envpool


def _stepper(kind: str, seed: int) -> Callable[[int], None]:
    """A function stepping ``kind`` ``n`` times with random actions (reset done)."""
    rng = np.random.default_rng(seed)
    if kind.startswith("envpool"):
        envpool = _envpool()
        assert envpool is not None
        env = envpool.make(
            "Breakout-v5",
            env_type="gymnasium",
            num_envs=N_ENVS,
            batch_size=N_ENVS,
            num_threads=int(kind.rsplit("-", 1)[1].removesuffix("t")),
            seed=seed,
            episodic_life=False,
            reward_clip=False,
            repeat_action_probability=0.25,
            noop_max=30,
            stack_num=4,
            img_height=84,
            img_width=84,
            gray_scale=True,
        )
        env.reset()

        def step_envpool(n: int) -> None:
            for _ in range(n):
                env.step(rng.integers(0, 4, N_ENVS))

        return step_envpool
    camera = kind == "world-stack+camera"
    world = BreakoutWorld(
        num_envs=N_ENVS, seed=seed, noise=NOISE, obs_mode="ram" if kind == "world-ram" else "stack"
    )
    world.reset(seed=seed)

    def step_world(n: int) -> None:
        for _ in range(n):
            world.step(rng.integers(0, 4, N_ENVS))
            if camera:
                world.bolt_images()

    return step_world


class Rate(NamedTuple):
    """Frames per second of wall-clock time and per second of this process's CPU time
    (all its threads): on a shared machine the second is what the variant would make
    with a core to itself, the first what it made here."""

    wall: float
    cpu: float


def _rate(frames: int, wall: float, cpu: float) -> Rate:
    return Rate(frames / wall, frames / cpu)


def stepping_fps(kind: str, steps: int, seed: int) -> Rate:
    """Agent steps per second (all games together) of ``steps`` batched steps."""
    step = _stepper(kind, seed)
    start, cpu = time.perf_counter(), time.process_time()
    step(steps)
    return _rate(steps * N_ENVS, time.perf_counter() - start, time.process_time() - cpu)


def training_fps(variant: str, frames: int, seed: int) -> Rate:
    """PPO frames per second of ``frames`` frames (model built before the clock starts)."""
    variant, _, precision = variant.partition("@")
    agent, _, detector_kind = variant.partition("+")
    world_name = "breakout-ram" if agent == "ram" else "breakout"
    params = load_hyperparams(world_name, "ppo")
    world = make_world(
        world_name, num_envs=int(params["n_envs"]), seed=seed, noise=NOISE, fire_on_reset=True
    )
    specs = [resolve_spec(name) for name in expand_specs(["left_column_milestones"])]
    detector: Any
    if detector_kind == "classifier":
        torch.manual_seed(seed)
        detector = ClassifierDetector.untrained(
            fluent_names=world.fluent_names,
            camera_spec=world.camera_spec,
            config=classifier_architecture(world.camera_spec),
        )
    else:
        detector = OracleDetector(world.fluent_names)
    env = BoltVecEnv(
        VecMonitor(SB3VecEnv(world)),  # type: ignore[arg-type]
        specs,
        detector,
        world=world,
    )
    extractor = {k: params[k] for k in ("cnn", "image_features") if k in params}
    kwargs = {k: v for k, v in params.items() if k not in META_KEYS | WORLD_KEYS}
    policy_kwargs = {
        **kwargs.pop("policy_kwargs", {}),
        "features_extractor_class": BoltFeaturesExtractor,
        "features_extractor_kwargs": extractor,
    }
    model = PPO(
        "MultiInputPolicy", env, policy_kwargs=policy_kwargs, seed=seed, device="cpu", **kwargs
    )
    set_precision(model, compute_dtype(precision or "float32", "cpu"))
    start, cpu = time.perf_counter(), time.process_time()
    model.learn(frames)
    return _rate(model.num_timesteps, time.perf_counter() - start, time.process_time() - cpu)


def main() -> None:
    parser = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    parser.add_argument("--frames", type=int, default=4096, help="PPO frames per variant")
    parser.add_argument("--steps", type=int, default=2000, help="batched steps per stepper")
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument(
        "--trainers",
        default="image,image+classifier,image+classifier@bfloat16,ram,ram+classifier",
        help="PPO variants, comma-separated (AGENT[+classifier][@bfloat16])",
    )
    parser.add_argument(
        "--steppers",
        default="world-stack,world-stack+camera,world-ram,envpool",
        help="stepping variants, comma-separated ('' for none)",
    )
    args = parser.parse_args()
    torch.set_num_threads(1)
    steppers = [k for k in args.steppers.split(",") if k and k != "envpool"]
    if "envpool" in args.steppers.split(","):
        if _envpool() is not None:
            steppers += ["envpool-stack-1t", "envpool-stack-2t"]
        else:
            print("envpool: not importable here, left out (see the module docstring)")
    trainers = [k for k in args.trainers.split(",") if k]
    if "image+classifier" not in trainers:
        trainers.insert(0, "image+classifier")  # the base of the ratios
    stepping: dict[str, list[Rate]] = {k: [] for k in steppers}
    training: dict[str, list[Rate]] = {k: [] for k in trainers}
    for r in range(args.rounds):
        for kind in steppers:
            stepping[kind].append(stepping_fps(kind, args.steps, seed=r))
        for variant in trainers:
            training[variant].append(training_fps(variant, args.frames, seed=r))
    print(
        f"Breakout, {N_ENVS} games, {args.rounds} rounds (median), 1 torch thread; stepping "
        f"{args.steps} batched steps, PPO {args.frames} frames"
    )
    for title, table, base in (
        ("stepping", stepping, "world-stack"),
        ("training (PPO)", training, "image+classifier"),
    ):
        if base not in table:
            continue
        wall = {k: statistics.median(r.wall for r in v) for k, v in table.items()}
        cpu = {k: statistics.median(r.cpu for r in v) for k, v in table.items()}
        print(f"\n{title:<20} {'frames/s':>9} {'per CPU s':>10}  {'vs ' + base + ' (CPU)':>28}")
        for k in table:
            print(f"{k:<20} {wall[k]:>9,.0f} {cpu[k]:>10,.0f}  {cpu[k] / cpu[base]:>28.2f}")
        print("all rounds (wall):", {k: [round(r.wall) for r in v] for k, v in table.items()})
    for agent in (a for a in trainers if a.endswith(("+classifier", "@bfloat16"))):
        rate = statistics.median(r.cpu for r in training[agent])
        print(
            f"10M frames of {agent} at {rate:,.0f} frames per CPU second: "
            f"{1e7 / rate / 3600:.1f} h with a core to itself"
        )


if __name__ == "__main__":
    main()
