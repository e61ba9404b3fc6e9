"""Belief tracking against worlds whose fluents hold for a single frame.

Belief tracking assumes a fluent, once true, stays true ``min_dwell`` frames, and a rare
fluent's onset costs more than one frame's evidence can buy: a world that shows a fluent
for one frame (a FrozenLake cell passed through) is never credited, however good the
detector. The run's set-up says so, measured on the world's random play.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable
from typing import Any

import numpy as np
import pytest

from noisybolt.bolt import BeliefSettings
from noisybolt.bolt.belief import frames_to_believe
from noisybolt.errors import BriefFluentWarning
from noisybolt.runs import DetectorConfig, TrainConfig
from noisybolt.runs.environments import prepare_bolt
from noisybolt.runs.play import true_runs, warn_of_brief_runs
from noisybolt.runs.resolution import resolve

LAKE = """
import gymnasium as gym
import noisybolt

def make():
    env = gym.make("FrozenLake-v1", render_mode="rgb_array", is_slippery=False)
    fluents = {"second": lambda e: e.s == 1, "goal": lambda e: e.s == 15}
    return noisybolt.FluentLabels(env, fluents=fluents, success="goal", return_bounds=(0, 1))
"""


def test_true_runs_are_counted_whole_and_not_across_episodes() -> None:
    truth = np.array([1, 1, 0, 1, 0, 1, 1, 1, 1, 0, 1, 1], dtype=bool)
    last = np.array([0, 0, 0, 0, 0, 0, 1, 0, 0, 0, 0, 0], dtype=bool)
    lengths, at_end = true_runs(truth, last)
    # [1, 1] from an episode's start; [1]; [1, 1] to its episode's end; [1, 1] from the
    # next episode's start; the last run, still going when the frames stop, is not counted.
    assert lengths.tolist() == [2, 1, 2, 2]
    assert at_end.tolist() == [False, False, True, False]


def test_the_frames_a_perfect_detector_needs_follow_the_dwell_and_the_base_rate() -> None:
    # min_dwell 2: a truth of one frame is impossible a priori, so two are needed.
    assert frames_to_believe(BeliefSettings(base_rates=0.3), ["x"], "x")[0] == 2
    # min_dwell 1, a common fluent: one clear frame (odds 0.15 * e^7 against 1) is enough.
    n, single = frames_to_believe(BeliefSettings(base_rates=0.3, min_dwell=1), ["x"], "x")
    assert n == 1 and single >= 0.9
    # min_dwell 1, a rare one: its onset (0.5 * 0.01) costs more than a frame can buy.
    n, single = frames_to_believe(BeliefSettings(base_rates=0.01, min_dwell=1), ["x"], "x")
    assert n == 2 and single < 0.9
    # A visit that ends the episode is not refuted by later frames: one frame can do.
    n, _ = frames_to_believe(BeliefSettings(base_rates=0.3), ["x"], "x", after=0)
    assert n == 1
    # The fluent asked about is found by name among others (which stay false).
    settings = BeliefSettings(base_rates={"y": 0.01, "x": 0.3}, min_dwell=1)
    assert frames_to_believe(settings, ["y", "x"], "x")[0] == 1


def _warned(settings: BeliefSettings, runs: list[int], at_end: Any = None) -> list[str]:
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        warn_of_brief_runs(settings, ["x"], "x", np.array(runs), at_end)
    return [str(w.message) for w in caught if issubclass(w.category, BriefFluentWarning)]


def test_the_warning_counts_the_brief_visits_and_advises_what_would_credit_them() -> None:
    assert _warned(BeliefSettings(base_rates=0.3), [2, 5, 3]) == []
    [message] = _warned(BeliefSettings(base_rates=0.3), [1, 5, 1, 2])
    assert "in 2 of its 4 visits (the shortest 1)" in message
    assert "only after 2 frames of it in a row" in message
    assert "--min-dwell 1" in message
    # Rare: min_dwell 1 would not help, so the advice is threshold tracking.
    [message] = _warned(BeliefSettings(base_rates=0.01), [1, 3])
    assert "--tracking threshold" in message and "--min-dwell 1" not in message
    assert _warned(BeliefSettings(base_rates=0.01), []) == []
    # One frame as the episode ends: believed under a common fluent, not a rare one.
    assert _warned(BeliefSettings(base_rates=0.3), [1, 3], np.array([True, False])) == []
    [message] = _warned(BeliefSettings(base_rates=0.01), [1, 3], np.array([True, False]))
    assert "in 1 of its 2 visits (the shortest 1, 1 of them as the episode ended)" in message


def test_a_goal_true_only_as_the_episode_ends_is_seen_by_random_play(
    world_module: Callable[[str, str], str],
) -> None:
    # FrozenLake's goal ends the episode: it shows only in final_info. Random play's
    # letters (progress shaping) and the checks must see it, and belief tracking, which
    # cannot believe one frame of a rare fluent, says so of the goal's visits.
    from noisybolt.errors import UnseenFluentWarning

    world_module("brieflake", LAKE)
    oracle = DetectorConfig(kind="oracle")
    config = resolve(
        TrainConfig.create(
            world="brieflake:make", specs=["F(goal)"], detector=oracle, tracking="belief"
        )
    )
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        setup = prepare_bolt(config, seed=0, log=lambda _: None)
    assert setup.letters is not None and setup.letters[:, 1].any()  # the goal was seen
    assert not [w for w in caught if w.category is UnseenFluentWarning]
    brief = [str(w.message) for w in caught if w.category is BriefFluentWarning]
    assert len(brief) == 1 and brief[0].startswith("belief tracking: in random play, goal")
    assert "as the episode ended" in brief[0]


@pytest.mark.filterwarnings("ignore::noisybolt.errors.EstimatedBoundsWarning")
def test_a_run_on_a_world_of_one_frame_visits_is_warned_at_set_up(
    world_module: Callable[[str, str], str],
) -> None:
    world_module("brieflake", LAKE)
    oracle = DetectorConfig(kind="oracle")

    def set_up(**settings: object) -> list[str]:
        config = resolve(
            TrainConfig.create(
                world="brieflake:make", specs=["F(second)"], detector=oracle, **settings
            )
        )
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            prepare_bolt(config, seed=0, log=lambda _: None)
        return [str(w.message) for w in caught if issubclass(w.category, BriefFluentWarning)]

    # Random moves from the start cell step into cell 1 and out again at once most times.
    [message] = set_up(tracking="belief")
    assert message.startswith("belief tracking: in random play, second was true")
    assert "--min-dwell 1" in message
    assert set_up(tracking="belief", min_dwell=1) == []
    assert set_up(tracking="threshold") == []  # Algorithm 1 believes a single frame
