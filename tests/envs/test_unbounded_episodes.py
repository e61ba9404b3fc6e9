"""A user's env without a time limit gets one: a policy that never ends an episode (a
loop by a wall) stalled the final evaluation for good; its episodes are now cut, with a
warning saying how to choose the limit."""

from __future__ import annotations

import json
import warnings
from collections.abc import Callable
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

from noisybolt.cli import main
from noisybolt.envs import make_world, registry
from noisybolt.errors import UnboundedEpisodesWarning

WORLD = """
import gymnasium as gym
import numpy as np
import noisybolt


class Corridor(gym.Env):
    # Never terminates: the agent walks a corridor of 5 cells for ever.
    observation_space = gym.spaces.Discrete(5)
    action_space = gym.spaces.Discrete(2)

    def reset(self, *, seed=None, options=None):
        super().reset(seed=seed)
        self.cell = 0
        return self.cell, {}

    def step(self, action):
        self.cell = min(4, max(0, self.cell + (1 if action else -1)))
        return self.cell, 0.0, False, False, {}


def lamp(env):
    return np.full((4, 4, 3), 50 * env.unwrapped.cell, dtype=np.uint8)


def make():
    fluents = {"end": lambda e: e.cell == 4}
    return noisybolt.FluentLabels(Corridor(), fluents=fluents, camera=lamp, return_bounds=(0, 0))


def make_limited():
    return gym.wrappers.TimeLimit(make(), max_episode_steps=7)


class SelfLimited(Corridor):
    # Cuts its own episodes, as MiniGrid's levels do (registered without a limit).
    max_steps = 9


def make_self_limited():
    fluents = {"end": lambda e: e.cell == 4}
    return noisybolt.FluentLabels(SelfLimited(), fluents=fluents, camera=lamp)
"""


@pytest.fixture(autouse=True)
def _forget_the_warnings(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(registry, "_UNBOUNDED_WARNED", set())


def test_an_env_without_time_limit_is_cut_and_said_once(
    world_module: Callable[[str, str], str], monkeypatch: pytest.MonkeyPatch
) -> None:
    world_module("corridor", WORLD)
    monkeypatch.setattr(registry, "DEFAULT_MAX_EPISODE_STEPS", 20)
    with pytest.warns(UnboundedEpisodesWarning, match="cut at 20 steps") as caught:
        world = make_world("corridor:make", num_envs=2, seed=0)
    assert len(caught) == 1 or all(str(w.message) == str(caught[0].message) for w in caught)
    world.reset(seed=0)
    ends = [world.step(np.array([1, 0]))[3] for _ in range(20)]
    assert not any(e.any() for e in ends[:19]) and ends[19].tolist() == [True, True]
    with warnings.catch_warnings():  # a limit of the user's own is kept, and nothing said
        warnings.simplefilter("error", UnboundedEpisodesWarning)
        limited = make_world("corridor:make_limited", num_envs=1, seed=0)
    limited.reset(seed=0)
    assert [bool(limited.step(np.array([1]))[3][0]) for _ in range(7)] == [False] * 6 + [True]
    with warnings.catch_warnings():  # said once a process, however often it is built
        warnings.simplefilter("error", UnboundedEpisodesWarning)
        make_world("corridor:make", num_envs=1, seed=0)


def test_an_env_that_states_its_own_max_steps_is_taken_at_its_word(
    world_module: Callable[[str, str], str],
) -> None:
    world_module("corridor", WORLD)
    with warnings.catch_warnings():
        warnings.simplefilter("error", UnboundedEpisodesWarning)
        make_world("corridor:make_self_limited", num_envs=1, seed=0)


def test_training_in_a_world_that_never_ends_an_episode_finishes(
    tmp_path: Path, world_module: Callable[[str, str], str], monkeypatch: pytest.MonkeyPatch
) -> None:
    world_module("corridor", WORLD)
    monkeypatch.setattr(registry, "DEFAULT_MAX_EPISODE_STEPS", 30)
    argv = ["train", "--world", "corridor:make", "--spec", "F(end)", "--detector", "oracle"]
    argv += ["--algo", "dqn", "--frames", "256", "--eval-freq", "0", "--eval-episodes", "2"]
    argv += ["--hp", "learning_starts=128"]  # a budget that lets DQN learn (issue 46)
    with pytest.warns(UnboundedEpisodesWarning):
        assert main([*argv, "--no-progress", "--out", str(tmp_path / "run")]) == 0
    summary = json.loads((tmp_path / "run" / "summary.json").read_text())
    assert summary["final"]["length_mean"] <= 30


def test_gym_make_keeps_the_registered_limit() -> None:
    env = gym.make("FrozenLake-v1")
    assert registry._has_time_limit(env)
    assert not registry._has_time_limit(env.unwrapped)
