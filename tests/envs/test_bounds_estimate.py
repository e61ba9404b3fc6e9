"""Return bounds estimated from random play, for worlds that declare none."""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.vector import AutoresetMode, SyncVectorEnv

from noisybolt.bolt.schemes import COMPLIANCE_MARGIN, compliance_scale
from noisybolt.envs.bounds import ESTIMATE_MARGIN, estimate_return_bounds
from noisybolt.errors import ConfigError


class ThreeSteps(gym.Env):
    """Every episode is three steps; action 1 pays ``pay``, action 0 pays nothing."""

    observation_space = gym.spaces.Discrete(1)
    action_space = gym.spaces.Discrete(2)

    def __init__(self, pay: float = 1.0, length: int = 3) -> None:
        self.pay, self.length, self.t = pay, length, 0

    def reset(self, *, seed: int | None = None, options: Any = None) -> tuple[int, dict]:
        super().reset(seed=seed)
        self.t = 0
        return 0, {}

    def step(self, action: Any) -> tuple[int, float, bool, bool, dict]:
        self.t += 1
        return 0, self.pay * float(action), self.t >= self.length, False, {}


class CostPerStep(ThreeSteps):
    """Every step pays ``-cost`` whatever the action (Acrobot's pattern, shorter)."""

    def __init__(self, cost: float = 1.0, length: int = 5) -> None:
        super().__init__(pay=0.0, length=length)
        self.cost = cost

    def step(self, action: Any) -> tuple[int, float, bool, bool, dict]:
        obs, _, terminated, truncated, info = super().step(action)
        return obs, -self.cost, terminated, truncated, info


def _world(n: int = 4, env: type[ThreeSteps] = ThreeSteps, **kwargs: Any) -> SyncVectorEnv:
    return SyncVectorEnv([lambda: env(**kwargs)] * n, autoreset_mode=AutoresetMode.SAME_STEP)


def test_bounds_from_the_episodes_random_play_ends_by_hand() -> None:
    estimate = estimate_return_bounds(_world(), steps=4000, seed=1)
    # 4 envs x 1,000 steps: 4 x 333 episodes of three fair coin flips, so returns 0 and 3
    # are both seen (each missed with probability (7/8)^1332).
    assert estimate.observed == (0.0, 3.0)
    assert estimate.episodes == 1332 and estimate.steps == 4000 and estimate.longest == 3
    assert estimate.bounds.low == 0.0
    assert estimate.bounds.high == pytest.approx(3.0 + ESTIMATE_MARGIN * 3.0)
    assert estimate.describe().endswith(
        "1332 random-play episodes (4000 steps; returns 0 to 3, longest 3 steps), "
        "raised to [0, 4.5]"
    )


def test_the_estimate_is_seeded() -> None:
    a = estimate_return_bounds(_world(pay=-2.0), steps=40, seed=5)
    b = estimate_return_bounds(_world(pay=-2.0), steps=40, seed=5)
    assert a == b
    assert a.bounds.low <= a.observed[0] <= a.observed[1] < a.bounds.high


def test_without_an_ended_episode_the_steps_played_stand_in() -> None:
    estimate = estimate_return_bounds(_world(n=2, length=10**6), steps=20, seed=0)
    assert estimate.episodes == 0 and estimate.longest == 10
    assert 0.0 <= estimate.observed[0] <= estimate.observed[1] <= 10.0


def test_a_world_whose_episodes_all_return_the_same_keeps_a_width_of_one_step() -> None:
    estimate = estimate_return_bounds(_world(pay=0.0), steps=40, seed=0)
    assert estimate.observed == (0.0, 0.0)
    assert estimate.bounds.width == 0.0  # compliance_scale then gives 1
    assert estimate.describe().endswith("it says nothing of the gap)")


@pytest.mark.parametrize("steps", [0, -3, 2.5, True])
def test_bad_budgets_are_refused(steps: Any) -> None:
    with pytest.raises(ConfigError, match="steps must be a positive integer"):
        estimate_return_bounds(_world(), steps=steps)


def test_a_non_finite_reward_is_refused() -> None:
    with pytest.raises(ConfigError, match="non-finite reward"):
        estimate_return_bounds(_world(pay=np.inf), steps=40)


def test_a_constant_cost_per_step_gives_a_width_of_the_longest_episode() -> None:
    # Every step pays -2 and every episode is 5 steps, so random play returns -10 every
    # time; an agent ending an episode after one step would return -2: the width is
    # 2 x (5 - 1) = 8, and the top is raised by the margin as for any estimate.
    estimate = estimate_return_bounds(_world(env=CostPerStep, cost=2.0), steps=40, seed=0)
    assert estimate.observed == (-10.0, -10.0) and estimate.longest == 5
    assert estimate.bounds.low == -10.0
    assert estimate.bounds.high == pytest.approx(-10.0 + (1 + ESTIMATE_MARGIN) * 8.0)
    assert compliance_scale(estimate.bounds) == pytest.approx(
        COMPLIANCE_MARGIN * (1 + ESTIMATE_MARGIN) * 8.0
    )
    assert "one step's reward times the longest episode" in estimate.describe()


def test_clipped_bounds_are_those_of_the_rewards_signs() -> None:
    # Each paying step pays 0.25: three of them return 0.75, clipped to their sign 3.
    plain = estimate_return_bounds(_world(pay=0.25), steps=4000, seed=1)
    clipped = estimate_return_bounds(_world(pay=0.25), steps=4000, seed=1, clipped=True)
    assert plain.observed == (0.0, 0.75) and clipped.observed == (0.0, 3.0)
    costs = estimate_return_bounds(_world(env=CostPerStep, cost=7.0), steps=400, clipped=True)
    assert costs.observed == (-5.0, -5.0)
