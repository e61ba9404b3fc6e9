"""Spec: the formula, its rewards and its reward timing."""

from __future__ import annotations

import dataclasses

import pytest

from noisybolt.bolt import REWARD_TIMINGS, Spec
from noisybolt.errors import ConfigError


def test_defaults_and_name() -> None:
    spec = Spec("F(e & t)", terminal_reward=10, low_confidence_cost=2)
    assert spec.reward_timing == "every_step"
    assert spec.name == "F(e & t)"
    assert spec.terminal_reward == 10.0 and isinstance(spec.terminal_reward, float)
    named = Spec("G(e)", terminal_reward=-1.0, low_confidence_cost=0.0, name="stay_on_edge")
    assert named.name == "stay_on_edge"


def test_every_timing_is_accepted() -> None:
    assert set(REWARD_TIMINGS) == {"every_step", "on_entry", "episode_end", "on_change"}
    for timing in REWARD_TIMINGS:
        assert Spec("G(e)", terminal_reward=1, low_confidence_cost=1, reward_timing=timing)


def test_spec_is_frozen_and_keyword_only() -> None:
    spec = Spec("G(e)", terminal_reward=1, low_confidence_cost=1)
    with pytest.raises(dataclasses.FrozenInstanceError):
        spec.terminal_reward = 2.0  # type: ignore[misc]
    with pytest.raises(TypeError):
        Spec("G(e)", 1.0, 1.0)  # type: ignore[misc]


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"formula": ""}, "non-empty"),
        ({"formula": "   "}, "non-empty"),
        ({"formula": None}, "non-empty"),
        ({"terminal_reward": float("nan")}, "terminal_reward must be finite"),
        ({"terminal_reward": float("inf")}, "terminal_reward must be finite"),
        ({"terminal_reward": "10"}, "terminal_reward must be a number"),
        ({"low_confidence_cost": float("-inf")}, "low_confidence_cost must be finite"),
        ({"low_confidence_cost": -1.0}, "must be >= 0"),
        ({"low_confidence_cost": True}, "must be a number"),
        ({"reward_timing": "at_the_end"}, "not one of"),
        ({"name": 3}, "name must be a string"),
    ],
)
def test_invalid_specs_raise_config_error(kwargs: dict, message: str) -> None:
    args = {"formula": "F(t)", "terminal_reward": 1.0, "low_confidence_cost": 0.5} | kwargs
    formula = args.pop("formula")
    with pytest.raises(ConfigError, match=message):
        Spec(formula, **args)
