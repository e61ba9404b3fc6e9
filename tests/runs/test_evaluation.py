"""Evaluation: summaries by hand, goal from ``is_success``, compliance from ground truth."""

from __future__ import annotations

import numpy as np
import pytest

from noisybolt.envs import SB3VecEnv, VectorGridworld
from noisybolt.envs.gridworld import GridAction
from noisybolt.perception.detectors import OracleDetector
from noisybolt.runs.evaluation import EpisodeRecord, evaluate_bolted_policy, summarise
from noisybolt.runs.specs import resolve_spec
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


def test_false_acceptance_by_hand() -> None:
    episodes = [
        # bolt accepted spec a, truth did not: a false acceptance of a
        EpisodeRecord(1.0, 1.0, 5, True, (False, True), bolt_accepting=(True, True)),
        # the bolt missed what happened (b): not a false acceptance
        EpisodeRecord(1.0, 0.0, 5, True, (True, True), bolt_accepting=(True, False)),
        EpisodeRecord(1.0, 0.0, 5, True, (False, False), bolt_accepting=(False, False)),
        EpisodeRecord(1.0, 1.0, 5, True, (False, True), bolt_accepting=(True, True)),
    ]
    assert summarise(episodes, ["a", "b"]).false_acceptance == pytest.approx({"a": 0.5, "b": 0.0})
    # Records without the bolt's view (older runs) give no figure rather than a wrong one.
    assert summarise([EpisodeRecord(1.0, 0.0, 5, True, (True,))], ["a"]).false_acceptance == {}


class _SeesTheCornerEverywhere(OracleDetector):
    """A detector whose only fluent it lies about is the top-right corner: always seen."""

    def predict(self, images: np.ndarray, *, truth: np.ndarray | None = None) -> np.ndarray:
        probs = super().predict(images, truth=truth)
        probs[:, list(self.fluent_names).index("top_right_corner")] = 1.0
        return probs


def test_a_bolt_that_sees_what_is_not_there_is_counted_as_falsely_accepting() -> None:
    # The agent never moves, so F(top_right_corner) is never true; the lying detector
    # moves the bolt's DFA to its accepting sink on the first observation.
    world = VectorGridworld(num_envs=1, max_steps=5, seed=0)
    spec = {"formula": "F(top_right_corner)", "name": "visit"}
    honest = BoltVecEnv(SB3VecEnv(world), [resolve_spec(spec)], OracleDetector(world.fluent_names))

    def wait(obs: object) -> np.ndarray:
        return np.array([GridAction.NOOP])

    truthful = evaluate_bolted_policy(wait, honest, n_episodes=2, spec_names=["visit"])
    assert truthful.compliance == {"visit": 0.0}
    assert truthful.false_acceptance == {"visit": 0.0}
    world = VectorGridworld(num_envs=1, max_steps=5, seed=0)
    lying = BoltVecEnv(
        SB3VecEnv(world), [resolve_spec(spec)], _SeesTheCornerEverywhere(world.fluent_names)
    )
    fooled = evaluate_bolted_policy(wait, lying, n_episodes=2, spec_names=["visit"])
    assert fooled.compliance == {"visit": 0.0}
    assert fooled.false_acceptance == {"visit": 1.0}
    assert fooled.bolt_return_mean > 0  # and it paid for it
