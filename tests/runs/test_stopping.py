"""Stop when solved: training ends after exactly k consecutive qualifying evaluations."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import pytest
import torch
from hypothesis import given, settings
from hypothesis import strategies as st
from stable_baselines3 import A2C
from stable_baselines3.common.callbacks import EvalCallback
from stable_baselines3.common.monitor import Monitor

from noisybolt.errors import ConfigError
from noisybolt.runs.stopping import StopWhenSolved, trailing_streak


class ScriptedReturns(gym.Env[np.ndarray, int]):
    """One-step episodes whose reward is the next of ``returns`` (then 0): each SB3
    evaluation of one episode scores exactly the next scripted value."""

    observation_space = gym.spaces.Box(0.0, 1.0, (1,), np.float32)
    action_space = gym.spaces.Discrete(2)

    def __init__(self, returns: list[float]) -> None:
        self.returns = list(returns)
        self.episodes = 0

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        super().reset(seed=seed)
        return np.zeros(1, np.float32), {}

    def step(self, action: int) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        reward = self.returns[self.episodes] if self.episodes < len(self.returns) else 0.0
        self.episodes += 1
        return np.zeros(1, np.float32), float(reward), True, False, {}


def _train_until_stopped(returns: list[float], *, consecutive: int, every: int = 5) -> Any:
    torch.set_num_threads(1)
    scripted = ScriptedReturns(returns)
    stop = StopWhenSolved(threshold=1.0, consecutive=consecutive)
    evaluation = EvalCallback(
        Monitor(scripted), eval_freq=every, n_eval_episodes=1, callback_after_eval=stop, verbose=0
    )
    model = A2C("MlpPolicy", ScriptedReturns([]), n_steps=every, seed=0, device="cpu")
    model.learn(10_000, callback=evaluation)
    return model, stop, scripted


def test_stops_after_exactly_k_qualifying_evaluations_in_a_row() -> None:
    # Evaluations score 0, 1, 0, 1, 1, 1, ...: the third in a row at 1.0 is the 6th.
    model, stop, scripted = _train_until_stopped([0, 1, 0, 1, 1, 1, 1, 1], consecutive=3)
    assert stop.evaluations == 6
    assert scripted.episodes == 6  # no evaluation after the stopping one
    assert model.num_timesteps == 6 * 5  # stopped at the 6th evaluation's step
    assert stop.stopped_at == 30
    assert stop.streak == 3


def test_one_evaluation_below_the_threshold_restarts_the_count() -> None:
    model, stop, _ = _train_until_stopped([1, 1, 0.99, 1, 1], consecutive=2)
    assert stop.evaluations == 2
    assert model.num_timesteps == 10
    model, stop, _ = _train_until_stopped([1, 0.99, 1, 0.5, 1, 1], consecutive=2)
    assert stop.evaluations == 6
    assert model.num_timesteps == 30


def test_never_solved_trains_the_whole_budget() -> None:
    torch.set_num_threads(1)
    stop = StopWhenSolved(threshold=1.0, consecutive=1)
    evaluation = EvalCallback(
        Monitor(ScriptedReturns([0.5] * 100)),
        eval_freq=5,
        n_eval_episodes=1,
        callback_after_eval=stop,
    )
    model = A2C("MlpPolicy", ScriptedReturns([]), n_steps=5, seed=0, device="cpu")
    model.learn(50, callback=evaluation)
    assert model.num_timesteps == 50
    assert stop.evaluations == 10
    assert stop.stopped_at is None


@settings(max_examples=200, deadline=None)
@given(
    scores=st.lists(st.sampled_from([0.0, 0.9, 0.95, 1.0]), max_size=30),
    k=st.integers(1, 4),
)
def test_record_stops_at_the_first_window_of_k_qualifying_scores(
    scores: list[float], k: int
) -> None:
    expected = next(
        (i for i in range(k - 1, len(scores)) if all(s >= 0.95 for s in scores[i - k + 1 : i + 1])),
        None,
    )
    stop = StopWhenSolved(threshold=0.95, consecutive=k)
    stopped = None
    for i, score in enumerate(scores):
        if not stop.record(score, frames=1000 * (i + 1)):
            stopped = i
            break
    assert stopped == expected
    assert stop.stopped_at == (None if expected is None else 1000 * (expected + 1))


def test_no_streak_stops_training_before_not_before() -> None:
    # Three solved evaluations by 3k frames, but the exploration runs to 4k: the streak
    # goes on counting and the first solved evaluation from 4k on stops.
    stop = StopWhenSolved(threshold=0.95, consecutive=3, not_before=4000)
    assert [stop.record(1.0, frames=f) for f in (1000, 2000, 3000)] == [True] * 3
    assert stop.streak == 3 and stop.stopped_at is None
    assert stop.record(1.0, frames=4000) is False
    assert stop.stopped_at == 4000
    # A miss after not_before restarts the count as ever.
    late = StopWhenSolved(threshold=0.95, consecutive=2, not_before=2000)
    assert [late.record(s, frames=f) for s, f in ((1, 1000), (0, 2000), (1, 3000))] == [True] * 3
    assert late.record(1.0, frames=4000) is False


def test_a_resumed_streak_counts_towards_k() -> None:
    stop = StopWhenSolved(threshold=0.95, consecutive=3, streak=trailing_streak([1, 0, 1, 1], 0.95))
    assert stop.streak == 2
    assert stop.record(1.0, frames=5) is False
    assert stop.evaluations == 1


def test_bad_settings_and_a_missing_parent_are_named_errors() -> None:
    with pytest.raises(ConfigError, match="consecutive must be >= 1"):
        StopWhenSolved(threshold=1.0, consecutive=0)
    with pytest.raises(ConfigError, match="streak must be >= 0"):
        StopWhenSolved(threshold=1.0, streak=-1)
    with pytest.raises(ConfigError, match="callback_after_eval"):
        StopWhenSolved(threshold=1.0)._on_step()


def test_docstring_examples_run() -> None:
    import doctest

    from noisybolt.runs import stopping

    result = doctest.testmod(stopping)
    assert result.attempted > 0 and result.failed == 0


# ---------------------------------------------------------------------- train(stop_after=k)
def _scripted_success(monkeypatch: pytest.MonkeyPatch, rates: list[float]) -> list[int]:
    """Makes every periodic evaluation of ``train`` report the next scripted success rate
    (the episodes themselves still run); returns the list of evaluated frame counts."""
    import dataclasses

    from noisybolt.runs import callbacks

    real = callbacks.evaluate_bolted_policy
    seen: list[int] = []

    def scripted(*args: Any, **kwargs: Any) -> Any:
        result = real(*args, **kwargs)
        rate = rates[len(seen)] if len(seen) < len(rates) else 0.0
        seen.append(len(seen))
        return dataclasses.replace(result, success_rate=rate)

    monkeypatch.setattr(callbacks, "evaluate_bolted_policy", scripted)
    return seen


def _stopping_config(**kwargs: Any) -> Any:
    from noisybolt.runs import DetectorConfig, TrainConfig

    settings: dict[str, Any] = {
        "specs": ["edge"],
        "detector": DetectorConfig(kind="oracle"),
        "frames": 20 * 512,
        "eval_freq": 512,
        "eval_episodes": 2,
        "checkpoint_freq": 0,
        "progress_bar": False,
        "overrides": {"n_steps": 64},  # 8 envs x 64 = one update per evaluation
        "stop_after": 3,
    }
    settings.update(kwargs)
    return TrainConfig.create(**settings)


def test_train_stops_after_exactly_k_solved_evaluations(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import json

    from noisybolt.runs import train

    seen = _scripted_success(monkeypatch, [0.0, 1.0, 0.95, 0.5, 1.0, 0.96, 1.0, 1.0])
    result = train(_stopping_config(), tmp_path / "run", log=lambda _: None)
    # Evaluations 5, 6 and 7 (at 2560, 3072, 3584 frames) are the first three in a row.
    assert len(seen) == 7
    assert result.frames == 7 * 512
    assert [r["frames"] for r in result.history] == [512 * i for i in range(1, 8)]
    summary = json.loads((tmp_path / "run" / "summary.json").read_text())
    assert summary["stopped_at"] == 7 * 512 and summary["frames"] == 7 * 512
    assert summary["frames_to_comply"] == 2 * 512  # N_frames: the first solved evaluation


def test_train_does_not_stop_while_the_entropy_bonus_still_falls(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from noisybolt.runs import train

    # A2C with its entropy bonus falling over the first 2,048 frames: every evaluation is
    # solved, but the first three (512-1,536) come before the schedule ends.
    seen = _scripted_success(monkeypatch, [1.0] * 20)
    config = _stopping_config(
        algo="a2c", overrides={"n_steps": 64, "ent_coef_final": 0.0, "ent_coef_frames": 2048}
    )
    result = train(config, tmp_path / "run", log=lambda _: None)
    assert len(seen) == 4 and result.frames == 4 * 512


def test_train_without_the_rule_trains_its_whole_budget(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from noisybolt.runs import train

    seen = _scripted_success(monkeypatch, [1.0] * 10)
    result = train(
        _stopping_config(stop_after=0, frames=4 * 512), tmp_path / "run", log=lambda _: None
    )
    assert result.frames == 4 * 512 and len(seen) == 4


def test_stop_after_needs_periodic_evaluations() -> None:
    with pytest.raises(ConfigError, match="eval_freq > 0"):
        _stopping_config(eval_freq=0)
    with pytest.raises(ConfigError, match="give stop_after >= 0"):
        _stopping_config(stop_after=-1)
