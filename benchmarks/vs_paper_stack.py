"""noisybolt against the paper's own stack (torch-ac + rl-starter-files), side by side.

Three learners on the same 6x6 gridworld (start (1,1) facing east, goal (4,4), -1.5 per
step, +100 at the goal, 144-step limit), in interleaved rounds in one process, so that
whatever else runs on the machine hits every side alike:

  torch-ac   torch-ac 1.4.0's PPO with a model written after rl-starter-files' default
             ``ACModel`` (no memory, no text: 2x2 convolutions of 16, 32 and 64 channels
             with a max-pool, then 64-unit tanh actor and critic) and its default PPO
             settings (16 environments in 15 worker processes + the main one, 128 frames
             each per update, 4 epochs, batch 256, lr 1e-3, gamma 0.99, GAE 0.95, entropy
             0.01, clip 0.2), on the agent's 7x7 egocentric view as MiniGrid gives it;
             unbolted, as the paper's agent was trained on it.
  (a)        noisybolt PPO (Stable-Baselines3, ``configs/hyperparams/gridworld.yaml``) on
             the vectorised world, unbolted.
  (c)        the same with the restraining bolt watching through the noisy camera
             (regional smudge, the paper's case 4) and the trained CNN classifier, spec
             ``G(on_edge)`` under the paper's reward.

Each run trains until an evaluation (every 2,048 frames, 20 episodes, actions sampled as
rl-starter-files' ``evaluate.py`` does) has >= 95 % of its episodes reach the goal -- and,
for (c), comply with the spec, judged from ground truth -- or its frame budget is spent.
Reported per learner: training frames/s and time to that evaluation, with the
evaluations' own time left out (the clocks stop while evaluating), by two clocks: the
wall clock, and CPU time (the main process's, plus for torch-ac its worker processes').
On a quiet machine the wall clock is the comparison that matters (torch-ac spreads over
every core, noisybolt trains in one process); on a shared one it measures how much of the
machine the scheduler gave each side, and 16 processes get more of a busy machine than
one does, so the last two lines use CPU time unless ``--clock wall``. One torch thread on
every side (FACTS.md: PPO ran 9x slower with 2 threads on 2 cores). Medians over rounds;
the ratios are of the medians.

    pip install 'noisybolt[bench]'   # torch-ac 1.4.0 (or: pip install torch-ac==1.4.0)
    .venv/bin/python benchmarks/vs_paper_stack.py [--rounds 3] [--frames 100000] [--clock cpu]
"""

from __future__ import annotations

import argparse
import importlib.util
import multiprocessing
import os
import statistics
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import gymnasium as gym
import numpy as np
import torch
from stable_baselines3 import PPO
from stable_baselines3.common.callbacks import BaseCallback
from stable_baselines3.common.vec_env import VecEnv, VecEnvWrapper, VecMonitor, VecNormalize
from torch import nn

EVAL_EVERY = 2048  # torch-ac's update with rl-starter-files' defaults: 16 x 128 frames
EVAL_EPISODES = 20
SOLVED = 0.95
INSTALL = (
    "torch-ac is not installed; this benchmark runs the paper's stack beside noisybolt: "
    "pip install 'noisybolt[bench]' (or pip install torch-ac==1.4.0)"
)


@dataclass
class Outcome:
    """One learner's run: training frames, wall and CPU seconds (evaluations excluded),
    and the frames and seconds at its first solved evaluation (None if never)."""

    frames: int
    seconds: float
    cpu_seconds: float
    solved_frames: int | None = None
    solved_seconds: float | None = None
    solved_cpu_seconds: float | None = None

    def fps(self, clock: str) -> float:
        return self.frames / (self.cpu_seconds if clock == "cpu" else self.seconds)

    def to_solve(self, clock: str) -> float | None:
        return self.solved_cpu_seconds if clock == "cpu" else self.solved_seconds


class Stopwatch:
    """Training time, wall and this process's CPU, with evaluations left out."""

    def __init__(self) -> None:
        self.total = self.cpu = 0.0
        self._since: tuple[float, float] | None = None

    def start(self) -> None:
        self._since = (time.perf_counter(), time.process_time())

    def stop(self) -> None:
        assert self._since is not None
        self.total += time.perf_counter() - self._since[0]
        self.cpu += time.process_time() - self._since[1]
        self._since = None


def _cpu_seconds(pid: int) -> float:
    """User + system CPU seconds of a live process so far (Linux ``/proc``; 0 elsewhere)."""
    try:
        with open(f"/proc/{pid}/stat") as handle:
            fields = handle.read().rsplit(")", 1)[1].split()
    except OSError:
        return 0.0
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


# ---------------------------------------------------------------------- torch-ac side
def _init_linear(module: nn.Module) -> None:
    # rl-starter-files' initialisation: unit-norm rows of normal weights, zero bias.
    if isinstance(module, nn.Linear):
        module.weight.data.normal_(0, 1)
        module.weight.data *= 1 / torch.sqrt(module.weight.data.pow(2).sum(1, keepdim=True))
        if module.bias is not None:
            module.bias.data.fill_(0)


class StarterACModel(nn.Module):
    """rl-starter-files' default actor-critic (no memory, no text), written from its
    description: for a 7x7x3 view, 64 image features."""

    recurrent = False

    def __init__(self, view_shape: tuple[int, ...], n_actions: int) -> None:
        super().__init__()
        self.image_conv = nn.Sequential(
            nn.Conv2d(3, 16, (2, 2)),
            nn.ReLU(),
            nn.MaxPool2d((2, 2)),
            nn.Conv2d(16, 32, (2, 2)),
            nn.ReLU(),
            nn.Conv2d(32, 64, (2, 2)),
            nn.ReLU(),
        )
        n, m = view_shape[0], view_shape[1]
        features = ((n - 1) // 2 - 2) * ((m - 1) // 2 - 2) * 64
        self.actor = nn.Sequential(nn.Linear(features, 64), nn.Tanh(), nn.Linear(64, n_actions))
        self.critic = nn.Sequential(nn.Linear(features, 64), nn.Tanh(), nn.Linear(64, 1))
        self.apply(_init_linear)

    def forward(self, obs: Any) -> tuple[torch.distributions.Categorical, torch.Tensor]:
        x = obs.image.permute(0, 3, 1, 2)  # [n, H, W, C] -> [n, C, H, W]
        x = self.image_conv(x).reshape(x.shape[0], -1)
        dist = torch.distributions.Categorical(logits=nn.functional.log_softmax(self.actor(x), 1))
        return dist, self.critic(x).squeeze(1)


def _view_env(seed: int) -> gym.Env[Any, Any]:
    from noisybolt.envs.gridworld import GridworldEnv

    env = GridworldEnv(obs_mode="view", bolt_labels=False)
    env.reset(seed=seed)
    return env


def _preprocess(obss: Any, device: Any = None) -> Any:
    from torch_ac import DictList

    return DictList({"image": torch.tensor(np.array(obss), device=device, dtype=torch.float)})


def _sampled_goal_rate(act: Callable[[np.ndarray], np.ndarray], seed: int) -> float:
    """Share of ``EVAL_EPISODES`` single-env episodes of the view world reaching the goal."""
    env = _view_env(seed)
    goals = 0
    for episode in range(EVAL_EPISODES):
        obs, _ = env.reset(seed=seed + episode)
        while True:
            obs, _, terminated, truncated, _ = env.step(int(act(obs[None])[0]))
            if terminated or truncated:
                goals += int(terminated)
                break
    return goals / EVAL_EPISODES


def run_torch_ac(seed: int, budget: int) -> Outcome:
    """torch-ac PPO with rl-starter-files' defaults until solved or ``budget`` frames."""
    import torch_ac

    torch.manual_seed(seed)
    np.random.seed(seed)  # noqa: NPY002 (torch-ac and rl-starter-files seed the globals)
    before = set(multiprocessing.active_children())
    envs = [_view_env(seed * 1000 + i) for i in range(16)]
    model = StarterACModel(envs[0].observation_space.shape, int(envs[0].action_space.n))
    algo = torch_ac.PPOAlgo(
        envs, model, torch.device("cpu"), num_frames_per_proc=128, discount=0.99, lr=0.001,
        gae_lambda=0.95, entropy_coef=0.01, value_loss_coef=0.5, max_grad_norm=0.5,
        recurrence=1, adam_eps=1e-8, clip_eps=0.2, epochs=4, batch_size=256,
        preprocess_obss=_preprocess,
    )  # fmt: skip
    workers = set(multiprocessing.active_children()) - before

    def act(obs: np.ndarray) -> np.ndarray:
        with torch.no_grad():
            dist, _ = model(_preprocess(obs))
        return dist.sample().numpy()

    clock, frames, solved = Stopwatch(), 0, False
    # The workers step their environments while the main process waits on them: their
    # CPU time is torch-ac's too (they idle during evaluations).
    worker_cpu = -sum(_cpu_seconds(p.pid) for p in workers if p.pid is not None)
    try:
        while frames < budget:
            clock.start()
            exps, _ = algo.collect_experiences()
            algo.update_parameters(exps)
            clock.stop()
            frames += int(exps.action.shape[0])
            if _sampled_goal_rate(act, 10_000 + seed) >= SOLVED:
                solved = True
                break
        worker_cpu += sum(_cpu_seconds(p.pid) for p in workers if p.pid is not None)
    finally:
        for process in workers:  # torch-ac's ParallelEnv leaves its workers running
            process.terminate()
            process.join()
    cpu = clock.cpu + worker_cpu
    outcome = Outcome(frames, clock.total, cpu)
    if solved:
        outcome.solved_frames, outcome.solved_seconds, outcome.solved_cpu_seconds = (
            frames,
            clock.total,
            cpu,
        )
    return outcome


# ---------------------------------------------------------------------- noisybolt side
class ImageOnly(VecEnvWrapper):
    """The bare world's observation as ``Dict{"image"}``: the agent network of (c)."""

    def __init__(self, venv: VecEnv) -> None:
        super().__init__(venv, observation_space=gym.spaces.Dict({"image": venv.observation_space}))

    def reset(self) -> Any:
        return {"image": self.venv.reset()}

    def step_wait(self) -> Any:
        obs, rewards, dones, infos = self.venv.step_wait()
        for info in infos:
            if "terminal_observation" in info:
                info["terminal_observation"] = {"image": info["terminal_observation"]}
        return {"image": obs}, rewards, dones, infos


def _noisybolt_env(bolted: bool, n_envs: int, seed: int, *, training: bool) -> VecEnv:
    from noisybolt.bolt import RewardScheme
    from noisybolt.envs import SB3VecEnv, make_world
    from noisybolt.runs import DetectorConfig
    from noisybolt.runs.detectors import make_detector
    from noisybolt.runs.specs import resolve_spec
    from noisybolt.wrappers import BoltVecEnv

    noise = "regional" if bolted else "none"
    world = make_world("gridworld", num_envs=n_envs, seed=seed, noise=noise)
    venv = VecMonitor(SB3VecEnv(world))  # type: ignore[arg-type]
    if not bolted:
        return ImageOnly(venv)
    detector = make_detector(
        DetectorConfig(kind="classifier"),
        world="gridworld",
        world_kwargs={"noise": noise},
        fluent_names=world.fluent_names,
        camera_spec=world.camera_spec,
        progress=False,
    )
    spec = RewardScheme("paper").apply(resolve_spec("edge"))
    # As `noisybolt train` builds them: the learner's envs without the per-step records.
    return BoltVecEnv(venv, [spec], detector, world=world, info_records=not training)


def _bare_goal_rate(model: PPO, env: VecEnv) -> float:
    """Share of ``EVAL_EPISODES`` episodes (spread over the envs) reaching the goal."""
    targets = np.array([(EVAL_EPISODES + i) // env.num_envs for i in range(env.num_envs)])
    counts, goals = np.zeros_like(targets), 0
    obs = env.reset()
    while (counts < targets).any():
        obs, _, dones, infos = env.step(model.predict(obs, deterministic=False)[0])
        for i in np.flatnonzero(dones):
            if counts[i] < targets[i]:
                counts[i] += 1
                goals += int(bool(infos[i].get("is_success")))
    return goals / EVAL_EPISODES


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


def run_noisybolt(bolted: bool, seed: int, budget: int, n_envs: int | None = None) -> Outcome:
    """noisybolt PPO, (a) unbolted or (c) with the classifier bolt, until solved; on
    ``n_envs`` environments (default: the tuned setting, 8)."""
    from noisybolt.agents.extractor import BoltFeaturesExtractor
    from noisybolt.agents.hyperparams import META_KEYS, WORLD_KEYS, load_hyperparams
    from noisybolt.agents.policies import BoltActorCriticPolicy
    from noisybolt.runs.evaluation import evaluate_bolted_policy

    params = load_hyperparams("gridworld", "ppo")
    env = VecNormalize(
        _noisybolt_env(bolted, n_envs or int(params["n_envs"]), seed, training=True),
        norm_obs=False,
        norm_reward=True,
    )
    eval_env = _noisybolt_env(bolted, 4, seed + 10_000, training=False)
    kwargs = {k: v for k, v in params.items() if k not in META_KEYS | WORLD_KEYS}
    policy_kwargs = dict(kwargs.pop("policy_kwargs"))
    policy_kwargs["features_extractor_class"] = BoltFeaturesExtractor
    model = PPO(
        BoltActorCriticPolicy, env, policy_kwargs=policy_kwargs, seed=seed, device="cpu", **kwargs
    )

    def score() -> float:
        if not bolted:
            return _bare_goal_rate(model, eval_env)
        result = evaluate_bolted_policy(
            lambda obs: model.predict(obs, deterministic=False)[0],
            eval_env,
            n_episodes=EVAL_EPISODES,
            spec_names=["edge"],
        )
        return float(result.success_rate)

    clock = Stopwatch()
    callback = _EvaluateEvery(clock, score)
    model.learn(budget, callback=callback)
    return Outcome(
        model.num_timesteps, clock.total, clock.cpu, *(callback.solved or (None, None, None))
    )


# ---------------------------------------------------------------------- report
LABELS = {
    "torch-ac": "torch-ac PPO, rl-starter-files model (unbolted)",
    "bare": "(a) noisybolt PPO, unbolted",
    "classifier": "(c) noisybolt PPO, noisy classifier bolt",
    "classifier-16": "(c) the same on 16 envs, torch-ac's count",
}
#: torch-ac's environments with rl-starter-files' defaults; the ``classifier-16`` row runs
#: noisybolt's bolted learner on as many (its other settings as tuned: 32 frames per env
#: and update, so 512 frames per update against torch-ac's 2,048).
TORCH_AC_ENVS = 16


CLOCKS = ("wall", "cpu")


def _median(values: list[float | None]) -> float | None:
    known = [v for v in values if v is not None]
    return statistics.median(known) if len(known) == len(values) and known else None


def _fmt(value: float | None, spec: str) -> str:
    return "unsolved" if value is None else format(value, spec)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--frames", type=int, default=100_000, help="budget per run")
    parser.add_argument(
        "--clock",
        choices=("cpu", "wall"),
        default="cpu",
        help="the clock of the last two lines (default cpu: fair on a shared machine)",
    )
    args = parser.parse_args(argv)
    if importlib.util.find_spec("torch_ac") is None:
        print(INSTALL, file=sys.stderr)
        return 2
    torch.set_num_threads(1)
    _noisybolt_env(
        True, 1, 0, training=False
    )  # train (or load) the bolt's classifier before any clock
    runs: dict[str, list[Outcome]] = {name: [] for name in LABELS}
    for r in range(args.rounds):
        for name in LABELS:
            if name == "torch-ac":
                outcome = run_torch_ac(r, args.frames)
            else:
                outcome = run_noisybolt(
                    name != "bare",
                    r,
                    args.frames,
                    TORCH_AC_ENVS if name == "classifier-16" else None,
                )
            runs[name].append(outcome)
            print(
                f"round {r} {name:<10} {outcome.fps('wall'):>7,.0f} frames/s wall, "
                f"{outcome.fps('cpu'):>7,.0f} per CPU s; solved at "
                f"{_fmt(outcome.solved_frames, ',')} frames, "
                f"{_fmt(outcome.solved_seconds, '.1f')} s wall, "
                f"{_fmt(outcome.solved_cpu_seconds, '.1f')} CPU s",
                flush=True,
            )
    print(
        f"\n6x6 gridworld, {args.rounds} interleaved rounds (medians), budget {args.frames:,} "
        f"frames, evaluation every {EVAL_EVERY:,} frames ({EVAL_EPISODES} sampled episodes, "
        f"solved at >= {SOLVED:.0%} at the goal, complying too for (c)), 1 torch thread, "
        f"load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} CPUs at the end"
    )
    print(
        f"{'learner':<48} {'frames/s':>9} {'per CPU s':>10} {'frames to solve':>16} "
        f"{'s to solve':>11} {'CPU s':>7}"
    )
    fps, solve = {}, {}
    for name, label in LABELS.items():
        fps[name] = {c: statistics.median(o.fps(c) for o in runs[name]) for c in CLOCKS}
        solve[name] = {c: _median([o.to_solve(c) for o in runs[name]]) for c in CLOCKS}
        frames = _median([o.solved_frames for o in runs[name]])
        print(
            f"{label:<48} {fps[name]['wall']:>9,.0f} {fps[name]['cpu']:>10,.0f} "
            f"{_fmt(frames, ',.0f'):>16} {_fmt(solve[name]['wall'], '.1f'):>11} "
            f"{_fmt(solve[name]['cpu'], '.1f'):>7}"
        )

    def ratios(name: str, clock: str) -> tuple[float, str]:
        base, ours = solve["torch-ac"][clock], solve[name][clock]
        solve_ratio = "n/a (a side did not solve in every round)"
        if base is not None and ours is not None:
            solve_ratio = f"{ours / base:.2f}"
        return fps[name][clock] / fps["torch-ac"][clock], solve_ratio

    # The verdict's clock last; its last two lines are (c) with each stack's own defaults.
    for clock in (*(c for c in CLOCKS if c != args.clock), args.clock):
        print(f"by the {clock} clock:")
        same_fps, same_solve = ratios("classifier-16", clock)
        print(
            f"  (c) on {TORCH_AC_ENVS} envs as torch-ac / torch-ac: fps ratio {same_fps:.2f}, "
            f"time-to-solve ratio {same_solve}"
        )
        ratio, solve_ratio = ratios("classifier", clock)
        print(f"fps ratio (noisybolt classifier bolt / torch-ac unbolted): {ratio:.2f}")
        print(f"time-to-solve ratio (noisybolt classifier bolt / torch-ac unbolted): {solve_ratio}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
