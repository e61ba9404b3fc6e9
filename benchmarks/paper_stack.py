"""The paper's own stack, rebuilt as the paper describes it: torch-ac, rl-starter-files'
model with the DFA state after the convolutions, and the bolt as a per-environment wrapper.

What "Perfect Observability is a Myth" (Verma et al.) says it ran, written the plain way
its authors would have, not optimised -- the anchor of ``vs_paper_stack.py``:

* the learners: torch-ac 1.4.0's ``PPOAlgo`` and ``A2CAlgo`` with rl-starter-files'
  defaults (16 environments, 15 of them in worker processes; PPO 128 frames per
  environment and update, 4 epochs, batch 256; A2C 5 frames, RMSprop alpha 0.99; both lr
  1e-3, gamma 0.99, GAE 0.95, entropy 0.01, value 0.5, gradient norm 0.5), on the agent's
  7x7 egocentric MiniGrid view;
* the model: rl-starter-files' ``ACModel`` (no memory, no text: 2x2 convolutions of 16,
  32 and 64 channels with a max-pool, 64-unit tanh actor and critic), with "the DFA state
  appended after the convolutional layers" (Sec. 3): the one-hot DFA state concatenated
  to the image embedding before the dense layers;
* the bolt: :class:`PaperBolt`, a Gymnasium wrapper around *one* environment that runs
  Algorithm 1 step by step in Python: the spec's DFA as dicts (a transition table keyed by
  ``(state, truth values)`` and each edge's symbols, read once from noisybolt's LTLf
  compiler), the classifier called on that environment's camera image every step, and
  the paper's rewards (+1 per step whose DFA state is accepting, 0.5 off per symbol of
  the edge taken whose probability lies in ``[0.5, 0.9]``). Each torch-ac worker process
  steps its environment and its bolt, classifier included.

The bolt sees what noisybolt's bolt sees: the same gridworld's camera with the same noise
(``GridworldEnv(noise=...)``'s ``info["bolt_image"]``) and the same trained classifier
(``detector.predict`` on a batch of one image). Its episode timing is noisybolt's: the
DFA reads the first observation at reset and that transition's reward is paid with the
first step (tests/agents/test_paper_stack.py checks it pays the same rewards and reaches
the same DFA states as noisybolt's bolt on the same trajectory).
"""

from __future__ import annotations

import itertools
import multiprocessing
import os
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import gymnasium as gym
import numpy as np
import torch
from torch import nn

EVAL_EVERY = 2048  # torch-ac's PPO update with rl-starter-files' defaults: 16 x 128 frames
EVAL_EPISODES = 20
SOLVED = 0.95
TRUTH, HIGH = 0.5, 0.9  # eq. 1: true from 0.5 on, low confidence up to 0.9
TERMINAL_REWARD, LOW_CONFIDENCE_COST = 1.0, 0.5  # the paper's rewards (Table 1)
PROCS = 16  # rl-starter-files' --procs
#: rl-starter-files' ``--frames-per-proc`` default per algorithm.
FRAMES_PER_PROC = {"ppo": 128, "a2c": 5}


# ---------------------------------------------------------------------- clocks
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


def cpu_seconds(pid: int) -> float:
    """User + system CPU seconds of a live process so far (Linux ``/proc``; 0 elsewhere)."""
    try:
        with open(f"/proc/{pid}/stat") as handle:
            fields = handle.read().rsplit(")", 1)[1].split()
    except OSError:
        return 0.0
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


# ---------------------------------------------------------------------- Algorithm 1
@dataclass
class PlainDFA:
    """A spec's DFA as the paper's code would hold it: Python dicts.

    Attributes:
        fluents: the fluents the DFA reads, in the order of the truth tuples.
        initial: the initial state.
        accepting: the accepting states.
        delta: ``(state, truth tuple) -> next state``.
        symbols: ``(state, next state) -> the fluents the edge's guard names``.
    """

    fluents: tuple[str, ...]
    initial: int
    accepting: set[int]
    delta: dict[tuple[int, tuple[bool, ...]], int] = field(default_factory=dict)
    symbols: dict[tuple[int, int], tuple[str, ...]] = field(default_factory=dict)

    @property
    def n_states(self) -> int:
        return 1 + max(q for q, _ in self.delta)


def plain_dfa(formula: str, fluents: Sequence[str]) -> PlainDFA:
    """Compiles ``formula`` with noisybolt's compiler and copies its DFA into dicts."""
    from noisybolt.logic import compile_ltlf

    dfa = compile_ltlf(formula, tuple(fluents))
    table = PlainDFA(
        tuple(dfa.fluents),
        int(dfa.initial_state),
        {int(q) for q in np.flatnonzero(dfa.accepting)},
    )
    for q in range(dfa.n_states):
        for truth in itertools.product((False, True), repeat=len(dfa.fluents)):
            letter = sum(1 << i for i, true in enumerate(truth) if true)
            table.delta[(q, truth)] = int(dfa.next_state[q, letter])
    for edge in dfa.iter_edges():
        table.symbols[(edge.src, edge.dst)] = tuple(edge.support)
    return table


def algorithm_1(dfa: PlainDFA, q: int, probs: dict[str, float]) -> tuple[float, int]:
    """Algorithm 1 of the paper, as printed: ``(reward, next state)``.

    The truth of each fluent is ``C(f) >= 0.5`` (eq. 1: the low band starts at 0.5); the
    edge that truth assignment takes out of ``q`` is followed; each symbol of that edge
    with ``0.5 <= C <= 0.9`` costs the low-confidence cost; an accepting next state pays
    the terminal reward.
    """
    truth = tuple(probs[f] >= TRUTH for f in dfa.fluents)
    q_next = dfa.delta[(q, truth)]
    reward = 0.0
    for symbol in dfa.symbols[(q, q_next)]:
        if TRUTH <= probs[symbol] <= HIGH:
            reward -= LOW_CONFIDENCE_COST
    if q_next in dfa.accepting:
        reward += TERMINAL_REWARD
    return reward, q_next


class PaperBolt(gym.Wrapper):
    """The restraining bolt around one gridworld, as the paper's code would have it.

    Each reset and step it takes the camera image from ``info["bolt_image"]``, asks the
    classifier for every fluent's probability, and moves the DFA by :func:`algorithm_1`.
    The observation is ``{"image": the env's, "dfa": the one-hot DFA state}``; the reward
    the env's plus the bolt's (the reset transition's reward is added to the first step's).
    """

    def __init__(self, env: gym.Env[Any, Any], formula: str, detector: Any) -> None:
        super().__init__(env)
        self.detector = detector
        self.fluent_names = tuple(env.unwrapped.fluent_names)  # type: ignore[attr-defined]
        self.dfa = plain_dfa(formula, self.fluent_names)
        self.q = self.dfa.initial
        self.pending = 0.0
        self.observation_space = gym.spaces.Dict(
            {
                "image": env.observation_space,
                "dfa": gym.spaces.Box(0.0, 1.0, (self.dfa.n_states,), np.float32),
            }
        )

    def _probs(self, info: dict[str, Any]) -> dict[str, float]:
        probs = self.detector.predict(info["bolt_image"][None])[0]
        return {name: float(p) for name, p in zip(self.fluent_names, probs, strict=True)}

    def _observation(self, image: Any) -> dict[str, Any]:
        one_hot = np.zeros(self.dfa.n_states, dtype=np.float32)
        one_hot[self.q] = 1.0
        return {"image": image, "dfa": one_hot}

    def reset(self, **kwargs: Any) -> tuple[dict[str, Any], dict[str, Any]]:
        if torch.get_num_threads() != 1:  # a worker process: one torch thread, as every side
            torch.set_num_threads(1)
        obs, info = self.env.reset(**kwargs)
        self.pending, self.q = algorithm_1(self.dfa, self.dfa.initial, self._probs(info))
        info["dfa_state"] = self.q
        return self._observation(obs), info

    def step(self, action: Any) -> tuple[dict[str, Any], float, bool, bool, dict[str, Any]]:
        obs, reward, terminated, truncated, info = self.env.step(action)
        bolt_reward, self.q = algorithm_1(self.dfa, self.q, self._probs(info))
        bolt_reward += self.pending
        self.pending = 0.0
        info["bolt_reward"], info["dfa_state"] = bolt_reward, self.q
        return self._observation(obs), float(reward) + bolt_reward, terminated, truncated, info


def paper_env(formula: str, detector: Any, seed: int, noise: str = "regional") -> PaperBolt:
    """One bolted gridworld of the paper's stack: the agent sees MiniGrid's 7x7 view, the
    bolt the top-down camera with ``noise``; seeded (the camera's noise too)."""
    from noisybolt.envs.gridworld import GridworldEnv

    env = PaperBolt(GridworldEnv(obs_mode="view", noise=noise), formula, detector)
    env.reset(seed=seed)
    return env


# ---------------------------------------------------------------------- the model
def import_torch_ac() -> Any:
    """``torch_ac``, imported where another start method is already set too.

    torch-ac sets the fork start method when imported (``torch_ac.utils.penv``), which
    raises where a process started before has fixed one (a test suite's pools): the method
    already set is kept then (its ``ParallelEnv`` works under any).
    """
    if "torch_ac" in sys.modules:
        return sys.modules["torch_ac"]
    set_method = multiprocessing.set_start_method

    def keep_the_set_one(method: str | None, force: bool = False) -> None:
        if force or multiprocessing.get_start_method(allow_none=True) is None:
            set_method(method, force)

    multiprocessing.set_start_method = keep_the_set_one
    try:
        import torch_ac
    finally:
        multiprocessing.set_start_method = set_method
    return torch_ac


def _init_linear(module: nn.Module) -> None:
    # rl-starter-files' initialisation: unit-norm rows of normal weights, zero bias.
    if isinstance(module, nn.Linear):
        module.weight.data.normal_(0, 1)
        module.weight.data *= 1 / torch.sqrt(module.weight.data.pow(2).sum(1, keepdim=True))
        if module.bias is not None:
            module.bias.data.fill_(0)


class StarterACModel(nn.Module):
    """rl-starter-files' default actor-critic (no memory, no text), written from its
    description: for a 7x7x3 view, 64 image features; with ``n_dfa_states``, the one-hot
    DFA state (``obs.dfa``) concatenated to them after the convolutions (the paper's
    change)."""

    recurrent = False

    def __init__(self, view_shape: tuple[int, ...], n_actions: int, n_dfa_states: int = 0) -> None:
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
        self.n_dfa_states = n_dfa_states
        features = ((n - 1) // 2 - 2) * ((m - 1) // 2 - 2) * 64 + n_dfa_states
        self.actor = nn.Sequential(nn.Linear(features, 64), nn.Tanh(), nn.Linear(64, n_actions))
        self.critic = nn.Sequential(nn.Linear(features, 64), nn.Tanh(), nn.Linear(64, 1))
        self.apply(_init_linear)

    def forward(self, obs: Any) -> tuple[torch.distributions.Categorical, torch.Tensor]:
        x = obs.image.permute(0, 3, 1, 2)  # [n, H, W, C] -> [n, C, H, W]
        x = self.image_conv(x).reshape(x.shape[0], -1)
        if self.n_dfa_states:
            x = torch.cat([x, obs.dfa], dim=1)
        dist = torch.distributions.Categorical(logits=nn.functional.log_softmax(self.actor(x), 1))
        return dist, self.critic(x).squeeze(1)


def preprocess(obss: Sequence[dict[str, Any]], device: Any = None) -> Any:
    """rl-starter-files' ``preprocess_obss`` for the bolted observation."""
    DictList = import_torch_ac().DictList
    image = torch.tensor(np.array([o["image"] for o in obss]), device=device, dtype=torch.float)
    dfa = torch.tensor(np.array([o["dfa"] for o in obss]), device=device, dtype=torch.float)
    return DictList({"image": image, "dfa": dfa})


# ---------------------------------------------------------------------- training
def success_rate(
    act: Callable[[list[dict[str, Any]]], np.ndarray], formula: str, detector: Any, seed: int
) -> float:
    """Share of ``EVAL_EPISODES`` episodes of one bolted env that reach the goal and
    comply; compliance from the ground truth (``info["true_fluents"]`` through the same
    DFA), never from what the bolt saw. Actions sampled, as rl-starter-files'
    ``evaluate.py`` does."""
    env = paper_env(formula, detector, seed)
    dfa, solved = env.dfa, 0
    names = env.fluent_names
    for episode in range(EVAL_EPISODES):
        obs, info = env.reset(seed=seed + episode)
        true_q = dfa.initial
        while True:
            truth = {n: float(t) for n, t in zip(names, info["true_fluents"], strict=True)}
            true_q = algorithm_1(dfa, true_q, truth)[1]
            obs, _, terminated, truncated, info = env.step(int(act([obs])[0]))
            if terminated or truncated:
                truth = {n: float(t) for n, t in zip(names, info["true_fluents"], strict=True)}
                true_q = algorithm_1(dfa, true_q, truth)[1]
                solved += int(terminated and true_q in dfa.accepting)
                break
    return solved / EVAL_EPISODES


def make_algo(algo: str, envs: list[Any], model: nn.Module) -> Any:
    """torch-ac's PPO or A2C with rl-starter-files' defaults (``scripts/train.py``)."""
    torch_ac = import_torch_ac()

    common = dict(
        num_frames_per_proc=FRAMES_PER_PROC[algo], discount=0.99, lr=0.001, gae_lambda=0.95,
        entropy_coef=0.01, value_loss_coef=0.5, max_grad_norm=0.5, recurrence=1,
        preprocess_obss=preprocess,
    )  # fmt: skip
    if algo == "ppo":
        return torch_ac.PPOAlgo(
            envs, model, torch.device("cpu"), adam_eps=1e-8, clip_eps=0.2, epochs=4,
            batch_size=256, **common,
        )  # fmt: skip
    return torch_ac.A2CAlgo(
        envs, model, torch.device("cpu"), rmsprop_alpha=0.99, rmsprop_eps=1e-8, **common
    )


def run_paper_stack(
    algo: str, formula: str, detector: Any, seed: int, budget: int, procs: int = PROCS
) -> Outcome:
    """The paper's stack on one Table 1 row until solved (an evaluation, every
    ``EVAL_EVERY`` frames, with >= 95 % of its episodes at the goal and complying) or
    ``budget`` frames. CPU time: the main process's plus its worker processes'."""
    torch.manual_seed(seed)
    np.random.seed(seed)  # noqa: NPY002 (torch-ac and rl-starter-files seed the globals)
    before = set(multiprocessing.active_children())
    envs = [paper_env(formula, detector, seed * 1000 + i) for i in range(procs)]
    image_shape = envs[0].env.observation_space.shape  # the agent's view: 7x7x3
    assert image_shape is not None
    n_actions = int(envs[0].action_space.n)  # type: ignore[attr-defined]
    model = StarterACModel(image_shape, n_actions, envs[0].dfa.n_states)
    learner = make_algo(algo, envs, model)
    workers = set(multiprocessing.active_children()) - before

    def act(obss: list[dict[str, Any]]) -> np.ndarray:
        with torch.no_grad():
            dist, _ = model(preprocess(obss))
        return dist.sample().numpy()

    clock, frames, solved, next_eval = Stopwatch(), 0, False, EVAL_EVERY
    # The workers step their environments and bolts while the main process waits on
    # them: their CPU time is the stack's too (they idle during evaluations).
    worker_cpu = -sum(cpu_seconds(p.pid) for p in workers if p.pid is not None)
    try:
        while frames < budget:
            clock.start()
            exps, _ = learner.collect_experiences()
            learner.update_parameters(exps)
            clock.stop()
            frames += int(exps.action.shape[0])
            if frames >= next_eval:
                next_eval += EVAL_EVERY
                if success_rate(act, formula, detector, 10_000 + seed) >= SOLVED:
                    solved = True
                    break
        worker_cpu += sum(cpu_seconds(p.pid) for p in workers if p.pid is not None)
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
