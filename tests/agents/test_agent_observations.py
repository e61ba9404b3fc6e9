"""A world whose agent observation the agents cannot read (a Dict, a 2-D Box) is refused
up front, by name, with how to flatten it: SB3 would otherwise fail deep in the model's
constructor, in words that blame the hyperparameters."""

from __future__ import annotations

import warnings
from collections.abc import Callable
from pathlib import Path

import pytest

from noisybolt.cli import main
from noisybolt.errors import EstimatedBoundsWarning

WORLD = """
import gymnasium as gym
import numpy as np
import noisybolt


class Nested(gym.ObservationWrapper):
    def __init__(self, env):
        super().__init__(env)
        self.observation_space = {space}

    def observation(self, obs):
        return {value}


def make():
    lake = Nested(gym.make("FrozenLake-v1", is_slippery=False, render_mode="rgb_array"))
    fluents = {{"top": lambda e: e.unwrapped.s < 4}}
    return noisybolt.FluentLabels(lake, fluents=fluents, return_bounds=(0, 1))
"""
DICT = ('gym.spaces.Dict({"cell": env.observation_space})', '{"cell": obs}')
GRID = ("gym.spaces.Box(0, 1, (4, 4), np.float32)", "np.eye(4, dtype=np.float32)")


@pytest.mark.parametrize(("space", "shown"), [(DICT, "Dict('cell': Discrete(16))"), (GRID, "Box(")])
def test_an_unreadable_agent_observation_is_refused_before_training(
    space: tuple[str, str],
    shown: str,
    tmp_path: Path,
    world_module: Callable[[str, str], str],
    capsys: pytest.CaptureFixture[str],
) -> None:
    world_module("nestedlake", WORLD.format(space=space[0], value=space[1]))
    argv = ["train", "--world", "nestedlake:make", "--spec", "F(top)", "--detector", "oracle"]
    assert main([*argv, "--frames", "64", "--out", str(tmp_path / "run")]) == 2
    err = capsys.readouterr().err
    assert f"world 'nestedlake:make' gives the agent {shown}" in err
    assert "FlattenObservation" in err and "hyperparameters" not in err
    assert not (tmp_path / "run").exists()


CAR = """
import gymnasium as gym
import noisybolt


def make():
    car = gym.make("MountainCarContinuous-v0", render_mode="rgb_array")
    return noisybolt.FluentLabels(car, fluents={"right": lambda e: e.unwrapped.state[0] > 0})
"""


@pytest.mark.parametrize(
    ("extra", "said"),
    [
        (["--algo", "dqn", "--spec", "F(right)"], "DQN takes only Discrete actions"),
        (["--spec", "F(left)"], "uses fluent(s) ['left']"),
    ],
)
def test_what_cannot_run_is_refused_before_random_play_estimates_the_returns(
    extra: list[str],
    said: str,
    tmp_path: Path,
    world_module: Callable[[str, str], str],
    capsys: pytest.CaptureFixture[str],
) -> None:
    # The world declares no return bounds: the compliance scale would rest on 4,096 steps
    # of random play (and say so at length) before the run was found unable to start.
    world_module("car", CAR)
    argv = ["train", "--world", "car:make", "--detector", "oracle", *extra]
    with warnings.catch_warnings():
        warnings.simplefilter("error", EstimatedBoundsWarning)
        assert main([*argv, "--frames", "64", "--out", str(tmp_path / "run")]) == 2
    err = capsys.readouterr().err
    assert said in err and "declares no bounds" not in err
    assert not (tmp_path / "run").exists()
