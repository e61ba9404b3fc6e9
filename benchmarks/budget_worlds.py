"""A world made to measure a cost budget's trade: breaking the spec pays a different amount
in every episode.

The constrained scheme promises that a cost budget ``d`` trades compliance for return:
the learner violates in about a ``d`` share of episodes, the ones where violating pays
most. That promise is only well posed where the episodes differ in what a violation is
worth. On a world with one start and one shortcut (the gridworld's two-corner detour,
FrozenLake's right column) every episode's choice is the same, so a policy that violates
in 10 % of episodes must toss a coin at the fork, and a policy-gradient learner's iterates
swing between complying always and never instead (measured: ``benchmarks/README.md``, "The
cost budget's trade on a world that pays for breaking the spec"). Here the saving is drawn
afresh each episode, so the best policy under a budget is a threshold on what the agent
sees, which a learner can represent and hold.

``toll``: each episode the world draws how much the toll road saves, ``s ~ U(0, 1)``, and
shows it to the agent (its one observation). Action 1 takes the toll road (return ``s``,
the fluent ``toll`` true), action 0 the free road (return 0); the episode ends. The spec
``G(!toll)`` asks never to take it. Under a budget ``d`` the best policy takes the toll
road exactly when ``s > 1 - d``: it violates in a ``d`` share of episodes and returns
``d - d**2 / 2`` on average (``d`` 0.1: 0.095; 0.3: 0.255); the unbolted optimum takes it
always (0.5). Its return bounds are declared, ``(0, 1)``, as a user who wrote it knows them.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np

from noisybolt import FluentLabels


class TollRoad(gym.Env):
    """One decision an episode: the toll road, worth a fresh ``U(0, 1)``, or the free road."""

    metadata = {"render_modes": []}  # noqa: RUF012 (gymnasium's layout)

    def __init__(self) -> None:
        self.observation_space = gym.spaces.Box(0.0, 1.0, shape=(1,), dtype=np.float32)
        self.action_space = gym.spaces.Discrete(2)
        self.saving = 0.0
        self.took_toll = False

    def reset(self, *, seed: int | None = None, options: dict | None = None) -> tuple[Any, dict]:
        super().reset(seed=seed)
        self.saving = float(self.np_random.uniform())
        self.took_toll = False
        return np.array([self.saving], np.float32), {}

    def step(self, action: Any) -> tuple[Any, float, bool, bool, dict]:
        self.took_toll = int(action) == 1
        reward = self.saving if self.took_toll else 0.0
        return np.array([self.saving], np.float32), reward, True, False, {}


def best_under_budget(d: float) -> float:
    """The mean return of the best policy that violates in at most a ``d`` share of
    episodes: the toll road exactly when the saving exceeds ``1 - d``.

    Example:
        >>> best_under_budget(0.1), best_under_budget(1.0)
        (0.095, 0.5)
    """
    d = min(max(float(d), 0.0), 1.0)
    return round(d - d * d / 2, 12)


def toll() -> FluentLabels:
    """The toll road as a user would label it: the fluent ``toll`` (the toll road taken),
    no camera (a detector reading the truth: oracle or synthetic), bounds declared."""
    return FluentLabels(
        TollRoad(),
        fluents={"toll": lambda e: bool(e.took_toll)},
        camera=False,
        return_bounds=(0.0, 1.0),
    )
