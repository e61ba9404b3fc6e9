"""Schedules fixed in frames: DQN's epsilon falls over the same frames whatever the budget."""

from __future__ import annotations

import pytest

from noisybolt.agents.hyperparams import frame_schedules, load_hyperparams
from noisybolt.errors import ConfigError


@pytest.mark.parametrize(
    ("budget", "fraction"), [(30_000, 0.1), (60_000, 0.05), (300_000, 0.01), (2_000, 1.0)]
)
def test_exploration_frames_become_the_fraction_of_any_budget(budget: int, fraction: float) -> None:
    out = frame_schedules({"exploration_frames": 3000}, frames=budget)
    assert out == {"exploration_fraction": pytest.approx(fraction)}
    # What SB3 does with it: epsilon reaches its floor after fraction * budget frames.
    assert out["exploration_fraction"] * budget == pytest.approx(min(3000, budget))


def test_without_frame_schedules_nothing_changes() -> None:
    assert frame_schedules({"exploration_fraction": 0.2, "ent_coef": 0.01}, frames=10) == {}


@pytest.mark.parametrize(
    ("params", "message"),
    [
        ({"exploration_frames": 3000, "exploration_fraction": 0.1}, "both set"),
        ({"exploration_frames": 0}, "exploration_frames must be an integer >= 1"),
        ({"exploration_frames": 2.5}, "exploration_frames must be an integer >= 1"),
        ({"ent_coef_frames": -1}, "ent_coef_frames must be an integer >= 1"),
    ],
)
def test_bad_frame_schedules_are_named_errors(params: dict[str, object], message: str) -> None:
    with pytest.raises(ConfigError, match=message):
        frame_schedules(params, frames=30_000)


def test_the_frame_keys_are_known_hyperparameters() -> None:
    params = load_hyperparams(
        "gridworld", "a2c", {"ent_coef_frames": 40_000, "exploration_frames": None}
    )
    assert params["ent_coef_frames"] == 40_000
