"""Evaluation: summaries by hand, goal from ``is_success``, compliance from ground truth."""

from __future__ import annotations

import numpy as np
import pytest

from noisybolt.agents.evaluation import EpisodeRecord, evaluate_bolted_policy, summarise
from noisybolt.agents.specs import resolve_spec
from noisybolt.envs import SB3VecEnv, VectorGridworld
from noisybolt.envs.gridworld import GridAction
from noisybolt.perception.detectors import OracleDetector
from noisybolt.wrappers import BoltVecEnv


def test_summary_by_hand() -> None:
    episodes = [
        EpisodeRecord(89.5, 8.0, 7, True, (True, False)),
        EpisodeRecord(88.0, 9.0, 8, True, (True, True)),
        EpisodeRecord(-216.0, 0.0, 144, False, (False, True)),
    ]
    result = summarise(episodes, ["a", "b"])
    assert result.env_return_mean == pytest.approx((89.5 + 88.0 - 216.0) / 3)
    assert result.env_return_std == pytest.approx(np.std([89.5, 88.0, -216.0]))
    assert result.length_mean == pytest.approx(53.0)
    assert result.goal_rate == pytest.approx(2 / 3)
    assert result.compliance == pytest.approx({"a": 2 / 3, "b": 2 / 3})
    assert result.success_rate == pytest.approx(1 / 3)  # only the second does both


def test_goal_comes_from_is_success_and_compliance_from_the_true_dfa() -> None:
    # Scripted policy: along the top wall through the top-right corner to the goal.
    world = VectorGridworld(num_envs=2, max_steps=20, seed=0)
    env = BoltVecEnv(
        SB3VecEnv(world), [resolve_spec("avoid_top_right")], OracleDetector(world.fluent_names)
    )
    script = [GridAction.FORWARD] * 3 + [GridAction.RIGHT] + [GridAction.FORWARD] * 3
    t = {"step": 0}

    def policy(obs: object) -> np.ndarray:
        action = script[t["step"] % len(script)]
        t["step"] += 1
        return np.array([action, GridAction.NOOP])  # env 1 waits until truncation

    result = evaluate_bolted_policy(policy, env, n_episodes=2, spec_names=["avoid"])
    by_goal = sorted(result.episodes, key=lambda e: e.goal)
    stuck, reached = by_goal
    assert reached.goal and reached.length == 7 and reached.env_return == pytest.approx(89.5)
    assert reached.compliant == (False,)  # went through the top-right corner
    assert not stuck.goal and stuck.length == 20 and stuck.compliant == (True,)
