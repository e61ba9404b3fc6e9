"""Schedules fixed in frames: DQN's epsilon falls over the same frames whatever the budget."""

from __future__ import annotations

from pathlib import Path

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


def _train(tmp_path: Path, algo: str, frames: int, overrides: dict[str, object]) -> Path:
    from noisybolt.agents.training import DetectorConfig, TrainConfig, train

    config = TrainConfig.create(
        specs=["edge"],
        algo=algo,
        detector=DetectorConfig(kind="oracle"),
        frames=frames,
        eval_freq=0,
        eval_episodes=2,
        checkpoint_freq=0,
        progress_bar=False,
        overrides=overrides,
    )
    run = tmp_path / f"{algo}-{frames}"
    train(config, run, log=lambda _: None)
    return run / "model.zip"


def test_the_entropy_schedule_runs_over_its_own_frames_not_the_budget(tmp_path: Path) -> None:
    from stable_baselines3 import PPO

    # 8 envs x 64 steps: the last rollout of 2048 frames starts at 1536, when a schedule
    # over 3072 frames is at 0.05 + (0.01 - 0.05) * 1536 / 3072 = 0.03 (over the budget,
    # as without ent_coef_frames, it would be 0.02).
    overrides = {"n_steps": 64, "ent_coef": 0.05, "ent_coef_final": 0.01}
    fixed = _train(tmp_path, "ppo", 2048, {**overrides, "ent_coef_frames": 3072})
    assert PPO.load(fixed, device="cpu").ent_coef == pytest.approx(0.03)


@pytest.mark.parametrize(("budget", "fraction"), [(512, 1.0), (6000, 0.5)])
def test_dqn_explores_over_exploration_frames_whatever_the_budget(
    tmp_path: Path, budget: int, fraction: float
) -> None:
    from stable_baselines3 import DQN

    overrides = {"exploration_frames": 3000, "learning_starts": 100_000}  # no updates
    model = DQN.load(_train(tmp_path, "dqn", budget, overrides), device="cpu")
    assert model.exploration_fraction == pytest.approx(fraction)
