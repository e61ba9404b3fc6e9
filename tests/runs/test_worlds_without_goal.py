"""A world that declares no goal (a FluentLabels env without ``success``, Breakout) gets
no goal rate, and its evaluations count compliance alone as success: before, every
episode of such a world counted as missing the goal, so its success rate, its N_frames and
stop-when-solved could never be reached whatever the agent learnt."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

from noisybolt.cli import main
from noisybolt.envs import make_world
from noisybolt.envs.labels import FluentLabels
from noisybolt.perception.protocols import goal_declared
from noisybolt.runs.evaluation import evaluate_bolted_policy
from noisybolt.wrappers import make_bolted_vec_env

FLUENTS = {"top": lambda lake: lake.s < 4, "at_goal": lambda lake: lake.s == 15}
# X(top): the second state still on the top row (random play: about 3 episodes in 4);
# F(top) holds from the start, so every episode complies with it.
SPECS = ["X(top)", "F(top)"]


def _lake(success: str | None) -> FluentLabels:
    env = gym.make("FrozenLake-v1", render_mode="rgb_array", is_slippery=False)
    return FluentLabels(env, fluents=FLUENTS, success=success)


@pytest.mark.parametrize("success", [None, "at_goal"])
def test_goal_rate_and_success_follow_whether_the_world_declares_a_goal(
    success: str | None,
) -> None:
    venv = make_bolted_vec_env(lambda: _lake(success), 4, SPECS, "oracle", seed=0)
    assert venv.declares_goal is (success is not None)  # read through the VecEnv wrappers
    rng = np.random.default_rng(0)
    result = evaluate_bolted_policy(
        lambda obs: rng.integers(4, size=4), venv, n_episodes=24, spec_names=SPECS
    )
    every = min(result.compliance.values())
    assert result.compliance["F(top)"] == 1.0 and 0.0 < every < 1.0  # random play leaves the top
    if success is None:
        assert result.goal_rate is None and all(e.goal is None for e in result.episodes)
        assert result.success_rate == pytest.approx(
            np.mean([all(e.compliant) for e in result.episodes])
        )
    else:
        assert result.goal_rate is not None
        goals = np.array([bool(e.goal) for e in result.episodes])
        complied = np.array([all(e.compliant) for e in result.episodes])
        assert result.success_rate == pytest.approx(float((goals & complied).mean()))


def test_the_shipped_worlds_say_whether_they_have_a_goal() -> None:
    assert goal_declared(make_world("gridworld", num_envs=1, seed=0))  # ends at the goal


WORLD = """
import gymnasium as gym
import noisybolt


def make():
    lake = gym.make("FrozenLake-v1", is_slippery=False, render_mode="rgb_array")
    fluents = {"top": lambda e: e.unwrapped.s < 4}
    return noisybolt.FluentLabels(lake, fluents=fluents, return_bounds=(0, 1))
"""


def test_a_run_in_a_world_without_goal_reports_no_goal_rate(
    tmp_path: Path, world_module: Callable[[str, str], str], capsys: pytest.CaptureFixture[str]
) -> None:
    world_module("nogoallake", WORLD)
    argv = ["train", "--world", "nogoallake:make", "--spec", "F(top)", "--detector", "oracle"]
    argv += ["--frames", "64", "--eval-freq", "0", "--eval-episodes", "2", "--no-progress"]
    argv += ["--hp", "n_steps=32"]  # one rollout of 2 x 32 within the 64 frames
    assert main([*argv, "--set", "world.n_envs=2", "--out", str(tmp_path / "run")]) == 0
    printed = capsys.readouterr().out
    assert "goal rate" not in printed and "goal and compliant" not in printed
    # F(top) holds from the start: every evaluation complies, so N_frames is reached
    assert "N_frames (first >= 95% compliant)" in printed and "not reached" not in printed
