"""Frames per second of PPO training on the gridworld, with and without the bolt.

Measured in one run, interleaved, so the machine's noise hits every variant alike:

  (a) the bare world (the agent sees only its image; no bolt at all),
  (b) the bolt with the oracle detector (ground truth as probabilities),
  (c) the bolt with the trained noisy classifier (regional noise, the paper's case 4),
  (c0) with ``--old-bolt``: (c) as the learner was built before issue 16's fourth pass
       (SB3's own ``MultiInputPolicy``, which one-hot encodes the DFA states spec by spec,
       and per-step ``info`` records on the learner's envs): what those two changes bought,
       measured in the same run.

Prints frames/s (by the wall clock and per CPU second of the process) and the ratios
(b)/(a), (c)/(a), and (c) against the paper's own stack
(torch-ac + rl-starter-files: 1.1-1.7k frames/s unbolted on this kind of machine).

    .venv/bin/python benchmarks/training_throughput.py [--frames 20000] [--rounds 3] [--n-envs 8]
        [--chunk 2048]   # variants take turns every 2,048 frames within each round
        [--profile]      # with --chunk: CPU time in the bolt's, camera's, SB3's functions
        [--old-bolt]     # also (c0), see above
"""

from __future__ import annotations

import argparse
import os
import statistics
import time
from typing import Any, NamedTuple

import gymnasium as gym
import torch
from stable_baselines3 import PPO
from stable_baselines3.common.vec_env import VecEnv, VecEnvWrapper, VecMonitor, VecNormalize

from noisybolt.agents.extractor import BoltFeaturesExtractor
from noisybolt.agents.hyperparams import META_KEYS, WORLD_KEYS, load_hyperparams
from noisybolt.agents.policies import BoltActorCriticPolicy
from noisybolt.envs import SB3VecEnv, make_world
from noisybolt.runs import DetectorConfig
from noisybolt.runs.detectors import make_detector
from noisybolt.runs.specs import resolve_spec
from noisybolt.wrappers import BoltVecEnv

PAPER_STACK_FPS = (1100, 1700)


class ImageOnly(VecEnvWrapper):
    """The bare world's observation as ``Dict{"image"}`` so every variant has one network."""

    def __init__(self, venv: VecEnv) -> None:
        space = gym.spaces.Dict({"image": venv.observation_space})
        super().__init__(venv, observation_space=space)

    def reset(self) -> Any:
        return {"image": self.venv.reset()}

    def step_wait(self) -> Any:
        obs, rewards, dones, infos = self.venv.step_wait()
        for info in infos:
            if "terminal_observation" in info:
                info["terminal_observation"] = {"image": info["terminal_observation"]}
        return {"image": obs}, rewards, dones, infos


#: The variant that builds (c) as it was before issue 16's fourth pass.
OLD_BOLT = "classifier-old"


def build(variant: str, n_envs: int, seed: int) -> VecEnv:
    old = variant == OLD_BOLT
    variant = "classifier" if old else variant
    noise = "regional" if variant == "classifier" else "none"
    world = make_world("gridworld", num_envs=n_envs, seed=seed, noise=noise)
    venv = VecMonitor(SB3VecEnv(world))  # type: ignore[arg-type]
    if variant == "bare":
        return VecNormalize(ImageOnly(venv), norm_obs=False, norm_reward=True)
    detector = make_detector(
        DetectorConfig(kind=variant),
        world="gridworld",
        world_kwargs={"noise": noise},
        fluent_names=world.fluent_names,
        camera_spec=world.camera_spec,
        progress=False,
    )
    # As `noisybolt train` builds the learner's envs: without the per-step records.
    bolted = BoltVecEnv(venv, [resolve_spec("edge")], detector, world=world, info_records=old)
    return VecNormalize(bolted, norm_obs=False, norm_reward=True)


def make_model(variant: str, seed: int, n_envs: int | None = None) -> PPO:
    """PPO with the gridworld's tuned hyperparameters on ``variant``'s environments."""
    params = load_hyperparams("gridworld", "ppo")
    env = build(variant, n_envs or int(params["n_envs"]), seed)
    kwargs = {k: v for k, v in params.items() if k not in META_KEYS | WORLD_KEYS}
    policy_kwargs = dict(kwargs.pop("policy_kwargs"))
    policy_kwargs["features_extractor_class"] = BoltFeaturesExtractor
    policy = "MultiInputPolicy" if variant == OLD_BOLT else BoltActorCriticPolicy
    return PPO(policy, env, policy_kwargs=policy_kwargs, seed=seed, device="cpu", **kwargs)


class Rate(NamedTuple):
    """Training frames per second of wall clock and per CPU second of this process."""

    wall: float
    cpu: float


#: What ``--profile`` times inside training: (owner, attribute, label). The world's own
#: step is under VecMonitor; the bolt's step_wait holds the detector and the camera.
PROFILED = (
    ("stable_baselines3.ppo.ppo:PPO", "train", "PPO.train"),
    ("stable_baselines3.common.on_policy_algorithm:OnPolicyAlgorithm", "collect_rollouts",
     "collect_rollouts"),
    ("stable_baselines3.common.vec_env.vec_monitor:VecMonitor", "step_wait", "world step"),
    ("noisybolt.wrappers.bolt_vec_env:BoltVecEnv", "step_wait", "BoltVecEnv.step_wait"),
    ("noisybolt.perception.classifier:ClassifierDetector", "predict", "classifier"),
    ("noisybolt.wrappers.bolt_vec_env:BoltVecEnv", "_labels", "camera (labels)"),
    ("noisybolt.perception.noise:RegionalDegradation", "apply", "regional noise"),
    ("noisybolt.bolt.restraining_bolt:RestrainingBolt", "step", "RestrainingBolt.step"),
    ("noisybolt.bolt.restraining_bolt:RestrainingBolt", "reset", "RestrainingBolt.reset"),
    ("noisybolt.wrappers.bolt_vec_env", "bolt_info", "info records"),
    ("noisybolt.wrappers._common:TruthTracker", "step", "truth tracking"),
    ("stable_baselines3.common.policies", "preprocess_obs", "SB3 preprocess_obs"),
    ("noisybolt.agents.extractor:BoltFeaturesExtractor", "preprocess", "policy preprocess"),
    ("stable_baselines3.common.buffers:DictRolloutBuffer", "add", "rollout buffer add"),
)  # fmt: skip


class Timers:
    """CPU time (this thread's clock) spent in :data:`PROFILED`, while installed."""

    def __init__(self) -> None:
        self.seconds: dict[str, float] = {}
        self._undo: list[tuple[Any, str, Any]] = []

    def install(self) -> None:
        import importlib

        for target, name, label in PROFILED:
            module, _, cls = target.partition(":")
            owner: Any = importlib.import_module(module)
            if cls:
                owner = getattr(owner, cls)
            original = owner.__dict__[name] if cls else getattr(owner, name)
            self._undo.append((owner, name, original))
            setattr(owner, name, self._timed(original, label))

    def _timed(self, function: Any, label: str) -> Any:
        def timed(*args: Any, **kwargs: Any) -> Any:
            start = time.thread_time()
            try:
                return function(*args, **kwargs)
            finally:
                self.seconds[label] = self.seconds.get(label, 0.0) + time.thread_time() - start

        return timed

    def uninstall(self) -> None:
        for owner, name, original in reversed(self._undo):
            setattr(owner, name, original)
        self._undo.clear()


def fps(variant: str, frames: int, seed: int, n_envs: int | None = None) -> Rate:
    model = make_model(variant, seed, n_envs)
    start, cpu = time.perf_counter(), time.process_time()
    model.learn(frames)
    return Rate(
        model.num_timesteps / (time.perf_counter() - start),
        model.num_timesteps / (time.process_time() - cpu),
    )


def interleaved_fps(
    variants: tuple[str, ...],
    frames: int,
    seed: int,
    n_envs: int | None,
    chunk: int,
    timers: dict[str, Timers] | None = None,
) -> dict[str, Rate]:
    """Every variant's model trains ``chunk`` frames in turn until each has ``frames``:
    a load that comes and goes on a shared machine then hits every variant alike (whole
    runs one after another gave (c)/(a) from 0.50 to 0.75 on a busy machine)."""
    models = {v: make_model(v, seed, n_envs) for v in variants}
    seconds = dict.fromkeys(variants, 0.0)
    cpu = dict.fromkeys(variants, 0.0)
    done = 0
    while done < frames:
        for v, model in models.items():
            if timers is not None:
                timers[v].install()
            start, cpu_start = time.perf_counter(), time.process_time()
            model.learn(chunk, reset_num_timesteps=done == 0)
            seconds[v] += time.perf_counter() - start
            cpu[v] += time.process_time() - cpu_start
            if timers is not None:
                timers[v].uninstall()
        done += chunk
    return {
        v: Rate(models[v].num_timesteps / seconds[v], models[v].num_timesteps / cpu[v])
        for v in variants
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=20_000)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument(
        "--n-envs", type=int, default=None, help="default: the tuned PPO setting (8)"
    )
    parser.add_argument(
        "--chunk",
        type=int,
        default=0,
        help="interleave the variants every CHUNK frames within a round (0: whole runs)",
    )
    parser.add_argument(
        "--profile",
        action="store_true",
        help="with --chunk: also print each variant's CPU seconds in the bolt's, the "
        "camera's, the classifier's and SB3's functions (timers inside the real run)",
    )
    parser.add_argument(
        "--old-bolt",
        action="store_true",
        help="also (c0): (c) with SB3's own policy and per-step info records, as before",
    )
    args = parser.parse_args()
    if args.profile and not args.chunk:
        parser.error("--profile needs --chunk")
    torch.set_num_threads(1)
    # Train (or load) the classifier before timing anything.
    build("classifier", 1, 0)
    variants: tuple[str, ...] = ("bare", "oracle", "classifier")
    if args.old_bolt:
        variants += (OLD_BOLT,)
    results: dict[str, list[Rate]] = {v: [] for v in variants}
    timers = {v: Timers() for v in variants} if args.profile else None
    for r in range(args.rounds):
        if args.chunk:
            for v, value in interleaved_fps(
                variants, args.frames, r, args.n_envs, args.chunk, timers
            ).items():
                results[v].append(value)
            continue
        for v in variants:
            results[v].append(fps(v, args.frames, seed=r, n_envs=args.n_envs))
    wall = {v: statistics.median(x.wall for x in results[v]) for v in variants}
    cpu = {v: statistics.median(x.cpu for x in results[v]) for v in variants}
    print(
        f"PPO on the 6x6 gridworld, {args.n_envs or 8} envs, default hyperparameters, "
        f"{args.frames} frames x {args.rounds} rounds (median), 1 torch thread, "
        f"load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} CPUs at the end"
    )
    print(f"{'variant':<32} {'frames/s':>9}  {'vs (a)':>7}  {'per CPU s':>9}  {'vs (a)':>7}")
    labels = {
        "bare": "(a) bare world",
        "oracle": "(b) bolt, oracle detector",
        "classifier": "(c) bolt, noisy CNN classifier",
        OLD_BOLT: "(c0) (c) as before: SB3 policy",
    }
    for v in variants:
        print(
            f"{labels[v]:<32} {wall[v]:>9,.0f}  {wall[v] / wall['bare']:>7.2f}  "
            f"{cpu[v]:>9,.0f}  {cpu[v] / cpu['bare']:>7.2f}"
        )
    lo, hi = PAPER_STACK_FPS
    print(
        f"(c) vs the paper's stack ({lo}-{hi} fps, unbolted): "
        f"{wall['classifier'] / hi:.1f}x-{wall['classifier'] / lo:.1f}x"
    )
    print(
        "all rounds (wall, CPU):",
        {v: [(round(x.wall), round(x.cpu)) for x in results[v]] for v in variants},
    )
    if timers is not None:
        frames = args.frames * args.rounds
        print(f"CPU seconds per {frames:,} frames inside training (all rounds):")
        labels_seen = [label for _, _, label in PROFILED]
        print(f"{'':<24}" + "".join(f"{labels[v][:4]:>10}" for v in variants))
        for label in labels_seen:
            row = [timers[v].seconds.get(label, 0.0) for v in variants]
            print(f"{label:<24}" + "".join(f"{x:>10.3f}" for x in row))


if __name__ == "__main__":
    main()
