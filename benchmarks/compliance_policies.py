"""The policies ``compliance_estimates.py`` plays: scripted, trained, and mixtures of them.

Every policy here is driven by :func:`compliance_estimates.record` through one protocol
(:class:`Policy`): ``start`` when the world resets, ``act`` on each step's observations,
``seen`` with what the bolt's detector read after the step (the ended games' last frames
and the new games' first ones). A scripted policy reads the world's own state (the grid
position, Breakout's RAM); a trained one reads the observation its agent was trained on,
with its bolt's DFA states tracked on the same detector outputs the estimate reads, as a
deployed bolt would feed them to it.

- :class:`RoutePolicy`: per episode a route drawn from a mixture of waypoint routes
  (the gridworld, FrozenLake), with ``eps``-random actions.
- :class:`PaddlePolicy`: Breakout's paddle follows the ball with an offset (per episode
  drawn from a mixture; negative: the ball is sent towards the left wall, where the
  fluents' bricks are), with ``eps``-random actions.
- :class:`TrainedPolicy`: a run trained with ``noisybolt.runs.train`` (PPO, bolted or
  not), its actions sampled; with several runs and weights, per episode one of them (a
  mixture of a bolted and an unbolted agent).

:func:`trained_grid_runs` trains the gridworld's two agents once (cached under the
benchmark's work folder, never under ``results/``).
"""

from __future__ import annotations

import sys
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any, Protocol

import numpy as np

from noisybolt.errors import ConfigError

#: The gridworld's trained agents: the bolted one asked to pass the bottom-left corner on
#: its way to the goal, the unbolted control trained on the world's reward alone (seeds 50
#: and 51 took the top-right route). Synthetic detector while training (cheap); seeded.
#: About 30 s each on one core.
GRID_AGENT_SPEC = "F(bottom_left_corner)"
GRID_AGENT_FRAMES = 40_000

# Breakout's RAM bytes (the console's, as ``breakout-ram`` observes them scaled to [0, 1]).
_PADDLE_X, _BALL_X, _BALL_Y = 72, 99, 101
# The paddle's RAM x and the ball's differ by about this much when the ball meets its middle
# (tried by eye: at 8, ``track`` knocks out the left column's bottom brick in 76 % of games
# cut at 3,000 frames, a random paddle in 34 %).
_PADDLE_CENTRE = 8
BREAKOUT_NOOP, BREAKOUT_FIRE, BREAKOUT_RIGHT, BREAKOUT_LEFT = 0, 1, 2, 3


class Policy(Protocol):
    """What :func:`compliance_estimates.record` drives."""

    def start(self, probs: np.ndarray) -> None:
        """Every env's episode starts; ``probs`` float ``[n_envs, n_fluents]``: the
        detector's reading of its first frame."""

    def act(self, obs: Any, info: Mapping[str, Any], truth: np.ndarray) -> np.ndarray:
        """Actions ``[n_envs]`` for the world's observations and info now."""

    def seen(self, last: np.ndarray, first: np.ndarray, ended: np.ndarray) -> None:
        """After a step: ``last`` the detector's reading of each env's frame (of its last
        frame where its episode ended), ``first`` the new episodes' first frames (rows of
        ``ended``, the envs whose episode ended)."""


def _mixture(mixture: Mapping[str, float]) -> tuple[list[str], np.ndarray]:
    names = list(mixture)
    weights = np.array([mixture[n] for n in names], dtype=np.float64)
    if not len(names) or (weights < 0).any() or weights.sum() <= 0:
        raise ConfigError(f"a mixture needs non-negative weights summing above 0, got {mixture}")
    return names, weights / weights.sum()


class RoutePolicy:
    """Per episode, a route drawn from a mixture; greedy moves to its next waypoint, or a
    uniformly random action with probability ``eps`` (seeded). Reads ``grid_position``
    (and, where ``turning``, the heading from the true ``facing_*`` fluents)."""

    def __init__(
        self,
        routes: Mapping[str, list[tuple[int, int]]],
        mixture: Mapping[str, float],
        eps: float,
        *,
        n_envs: int,
        n_actions: int,
        turning: bool,
        seed: int,
        fluents: Sequence[str] = (),
    ) -> None:
        self._names, self._weights = _mixture(mixture)
        self._routes = routes
        self._eps = eps
        self._n_actions = n_actions
        self._turning = turning
        self._heading = [
            list(fluents).index(f)
            for f in ("facing_right", "facing_down", "facing_left", "facing_up")
            if turning
        ]
        self._rng = np.random.default_rng(seed)
        self._route: list[list[tuple[int, int]]] = [[] for _ in range(n_envs)]
        self._next = np.zeros(n_envs, dtype=int)
        for i in range(n_envs):
            self.restart(i)

    def restart(self, i: int) -> None:
        """A new episode in env ``i``: a new route."""
        self._route[i] = self._routes[self._rng.choice(self._names, p=self._weights)]
        self._next[i] = 0

    def start(self, probs: np.ndarray) -> None:
        del probs  # routes are drawn per episode, not read from the camera

    def seen(self, last: np.ndarray, first: np.ndarray, ended: np.ndarray) -> None:
        for i in ended.tolist():
            self.restart(i)

    def act(self, obs: Any, info: Mapping[str, Any], truth: np.ndarray) -> np.ndarray:
        positions = np.asarray(info["grid_position"])
        headings = np.argmax(truth[:, self._heading], axis=1) if self._turning else None
        actions = np.zeros(len(positions), dtype=np.int64)
        for i, (x, y) in enumerate(positions.tolist()):
            route = self._route[i]
            while self._next[i] < len(route) - 1 and route[self._next[i]] == (x, y):
                self._next[i] += 1
            if self._rng.random() < self._eps:
                actions[i] = self._rng.integers(self._n_actions)
                continue
            tx, ty = route[self._next[i]]
            # E, S, W, N as the gridworld's headings
            want = (0 if tx > x else 2) if tx != x else (1 if ty > y else 3)
            if headings is not None:
                turn = (want - int(headings[i])) % 4
                actions[i] = 2 if turn == 0 else (1 if turn == 1 else 0)
            else:  # FrozenLake: 0 left, 1 down, 2 right, 3 up
                actions[i] = {0: 2, 1: 1, 2: 0, 3: 3}[want]
        return actions


class PaddlePolicy:
    """Breakout (``breakout-ram``): the paddle follows the ball's x plus an offset drawn per
    episode from a mixture (``{offset: weight}``; RAM x units, the paddle about 16 wide:
    -6 meets the ball with the paddle's right part, sending it left), FIRE when no ball is
    in play; a uniformly random action with probability ``eps`` (seeded)."""

    def __init__(self, mixture: Mapping[int, float], eps: float, *, n_envs: int, seed: int) -> None:
        names, self._weights = _mixture({str(k): v for k, v in mixture.items()})
        self._offsets = np.array([int(n) for n in names])
        self._eps = eps
        self._rng = np.random.default_rng(seed)
        self._offset = self._rng.choice(self._offsets, size=n_envs, p=self._weights)

    def start(self, probs: np.ndarray) -> None:
        del probs

    def seen(self, last: np.ndarray, first: np.ndarray, ended: np.ndarray) -> None:
        self._offset[ended] = self._rng.choice(self._offsets, size=ended.size, p=self._weights)

    def act(self, obs: Any, info: Mapping[str, Any], truth: np.ndarray) -> np.ndarray:
        ram = np.rint(np.asarray(obs, dtype=np.float64) * 255).astype(np.int64)
        paddle, ball_x, ball_y = ram[:, _PADDLE_X], ram[:, _BALL_X], ram[:, _BALL_Y]
        target = ball_x - _PADDLE_CENTRE + self._offset
        actions = np.where(target > paddle + 2, BREAKOUT_RIGHT, BREAKOUT_LEFT)
        actions = np.where(np.abs(target - paddle) <= 2, BREAKOUT_NOOP, actions)
        actions = np.where(ball_y == 0, BREAKOUT_FIRE, actions)  # no ball in play
        explore = self._rng.random(len(actions)) < self._eps
        return np.where(explore, self._rng.integers(4, size=len(actions)), actions)


class TrainedPolicy:
    """Trained agents, their actions sampled; per episode one of them drawn with
    ``weights`` (one agent: that agent throughout).

    An agent is a model (``predict(obs, deterministic=False)``, as Stable-Baselines3's)
    and its bolt: it observes ``{"image": the world's observation, "dfa": its bolt's DFA
    states}``, the bolt (the run's specs and settings, threshold tracking) driven here by
    the detector outputs :func:`compliance_estimates.record` reads, as a deployed bolt
    feeds its agent. An unbolted run's agent has a bolt too: it saw the DFA states while
    training, but was paid nothing for them. :meth:`from_runs` loads runs' agents.
    """

    def __init__(
        self, agents: Sequence[tuple[Any, Any]], weights: Sequence[float], *, seed: int
    ) -> None:
        if len(agents) != len(weights):
            raise ConfigError(f"{len(agents)} agents but {len(weights)} weights")
        _, self._weights = _mixture({str(i): w for i, w in enumerate(weights)})
        self._models = [model for model, _ in agents]
        self._bolts = [bolt for _, bolt in agents]
        self._rng = np.random.default_rng(seed)
        self.playing = self._rng.choice(len(agents), size=self._bolts[0].n_envs, p=self._weights)

    @classmethod
    def from_runs(
        cls,
        runs: Sequence[Path],
        weights: Sequence[float],
        *,
        fluents: Sequence[str],
        n_envs: int,
        seed: int,
    ) -> TrainedPolicy:
        """The final models of runs trained by ``noisybolt.runs.train`` (threshold
        tracking), each with a bolt of its run's specs and settings over ``fluents``."""
        import torch

        from noisybolt.bolt import RestrainingBolt
        from noisybolt.runs.config import TrainConfig
        from noisybolt.runs.run_evaluation import load_run_model
        from noisybolt.runs.rundir import RunDirectory

        agents = []
        for path in runs:
            run = RunDirectory(path)
            config = TrainConfig.from_dict(run.read_config())
            if config.bolt.tracking != "threshold":
                raise ConfigError(
                    f"{path} tracks its bolt by {config.bolt.tracking!r}: only threshold "
                    "tracking is replayed here; train the agent with --tracking threshold"
                )
            bolt = RestrainingBolt(
                config.spec_objects(), fluents, settings=config.bolt.settings, n_envs=n_envs
            )
            agents.append((load_run_model(run, config), bolt))
        torch.manual_seed(seed)  # the sampled actions
        return cls(agents, weights, seed=seed)

    def start(self, probs: np.ndarray) -> None:
        for bolt in self._bolts:
            bolt.reset(probs)

    def seen(self, last: np.ndarray, first: np.ndarray, ended: np.ndarray) -> None:
        done = np.zeros(len(last), dtype=bool)
        done[ended] = True
        full = np.zeros_like(last)
        full[ended] = first
        for bolt in self._bolts:
            bolt.step(last, done=done)
            if ended.size:  # as the batched bolt restarts its ended games
                bolt.reset(full, env_mask=done)
        self.playing[ended] = self._rng.choice(len(self._models), size=ended.size, p=self._weights)

    def act(self, obs: Any, info: Mapping[str, Any], truth: np.ndarray) -> np.ndarray:
        actions = np.zeros(len(truth), dtype=np.int64)
        for k, (model, bolt) in enumerate(zip(self._models, self._bolts, strict=True)):
            rows = self.playing == k
            if rows.any():
                seen = {"image": np.asarray(obs)[rows], "dfa": bolt.states[rows].copy()}
                actions[rows] = np.asarray(model.predict(seen, deterministic=False)[0])
        return actions


def trained_grid_runs(work: Path, seed: int) -> dict[str, Path]:
    """The gridworld's bolted and unbolted PPO agents (:data:`GRID_AGENT_SPEC`,
    :data:`GRID_AGENT_FRAMES` frames, synthetic detector, seed ``seed``), trained into
    ``work`` unless a finished run is there already."""
    import shutil

    from noisybolt.runs import DetectorConfig, TrainConfig, train

    runs = {}
    for label, bolted in (("bolted", True), ("unbolted", False)):
        out = work / f"gridworld-ppo-{label}-seed{seed}"
        if not (out / "summary.json").exists():
            if out.exists():  # an unfinished run: start it again
                shutil.rmtree(out)
            print(f"  training the gridworld's {label} PPO agent into {out}", file=sys.stderr)
            config = TrainConfig.create(
                world="gridworld",
                specs=[GRID_AGENT_SPEC],
                algo="ppo",
                bolted=bolted,
                detector=DetectorConfig(kind="synthetic"),
                frames=GRID_AGENT_FRAMES,
                seed=seed,
                eval_freq=10_000,
                eval_episodes=16,
                checkpoint_freq=0,
                keep_best=True,
                progress_bar=False,
            )
            train(config, out, argv=[sys.executable, *sys.argv], log=lambda _: None)
        runs[label] = out
    return runs
