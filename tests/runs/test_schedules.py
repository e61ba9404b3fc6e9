"""Schedules fixed in frames: DQN's epsilon falls over the same frames whatever the budget."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest
from hypothesis import given
from hypothesis import strategies as st

from noisybolt.agents.hyperparams import frame_schedules, load_hyperparams
from noisybolt.errors import ConfigError
from noisybolt.runs.resolution import resolve


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


def _config(algo: str, frames: int, overrides: dict[str, object], checkpoint_freq: int = 0) -> Any:
    from noisybolt.runs import DetectorConfig, TrainConfig

    return resolve(
        TrainConfig.create(
            specs=["edge"],
            algo=algo,
            detector=DetectorConfig(kind="oracle"),
            frames=frames,
            eval_freq=0,
            eval_episodes=2,
            checkpoint_freq=checkpoint_freq,
            progress_bar=False,
            keep_best=False,  # model.zip: the last model, whose rate the tests read
            overrides=overrides,
        )
    )


def _train(
    tmp_path: Path, algo: str, frames: int, overrides: dict[str, object], name: str = ""
) -> Path:
    from noisybolt.runs import train

    run = tmp_path / f"{algo}-{frames}{name}"
    train(_config(algo, frames, overrides), run, log=lambda _: None)
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

    # (almost) no updates: a budget must leave DQN a step to learn from (issue 46)
    overrides = {"exploration_frames": 3000, "learning_starts": budget - 1}
    model = DQN.load(_train(tmp_path, "dqn", budget, overrides), device="cpu")
    assert model.exploration_fraction == pytest.approx(fraction)


# Learning rate and clip range: moved over the run's frames (callbacks.LinearSchedule).


@given(
    start=st.floats(0.0, 1.0),
    end=st.floats(0.0, 1.0),
    frames=st.integers(1, 10**7),
    a=st.integers(0, 10**7),
    b=st.integers(0, 10**7),
)
def test_a_schedule_is_linear_inside_its_frames_and_flat_after(
    start: float, end: float, frames: int, a: int, b: int
) -> None:
    from noisybolt.runs.callbacks import LinearSchedule

    schedule = LinearSchedule("learning_rate", start, end, frames)
    low, high = min(start, end), max(start, end)
    assert low - 1e-12 <= schedule.value(a) <= high + 1e-12
    if a + b <= 2 * frames and a <= frames and b <= frames:  # the midpoint of a line
        mid = (a + b) / 2
        expected = start + (end - start) * mid / frames
        assert (schedule.value(a) + schedule.value(b)) / 2 == pytest.approx(expected, abs=1e-9)
    assert schedule.value(frames + a) == pytest.approx(end)


def test_the_schedules_a_run_asks_for_start_from_sb3s_defaults() -> None:
    from noisybolt.runs.callbacks import linear_schedules

    found = linear_schedules(
        {"learning_rate_final": 0.0, "clip_range_final": 0.1, "clip_range_frames": 400},
        algo="ppo",
        frames=1000,
    )
    # SB3's PPO: learning_rate 3e-4, clip_range 0.2.
    assert [(s.name, s.start, s.end, s.frames) for s in found] == [
        ("learning_rate", 3e-4, 0.0, 1000),
        ("clip_range", 0.2, 0.1, 400),
    ]
    assert found[1].value(200) == pytest.approx(0.15)
    assert linear_schedules({"learning_rate": 1e-3}, algo="dqn", frames=10) == []


def test_learning_rate_and_clip_range_reach_the_model_and_its_optimiser(tmp_path: Path) -> None:
    from stable_baselines3 import PPO

    # 8 envs x 64 steps: the last rollout of 2048 frames starts at 1536, when the rate
    # is 1e-3 * (1 - 1536 / 2048) = 2.5e-4 and the clip range 0.2 + (0.1 - 0.2) * 0.75.
    overrides = {
        "n_steps": 64,
        "learning_rate": 1e-3,
        "learning_rate_final": 0.0,
        "clip_range": 0.2,
        "clip_range_final": 0.1,
    }
    model = PPO.load(_train(tmp_path, "ppo", 2048, overrides), device="cpu")
    assert model.learning_rate == pytest.approx(2.5e-4)
    assert model.policy.optimizer.param_groups[0]["lr"] == pytest.approx(2.5e-4)
    assert model.clip_range(1.0) == pytest.approx(0.125)  # whatever SB3's progress says
    unscheduled = PPO.load(
        _train(tmp_path, "ppo", 2048, {"n_steps": 64}, "-constant"), device="cpu"
    )
    constant = load_hyperparams("gridworld", "ppo")["learning_rate"]
    assert unscheduled.policy.optimizer.param_groups[0]["lr"] == pytest.approx(constant)


def test_dqn_learning_rate_moves_every_train_freq(tmp_path: Path) -> None:
    from stable_baselines3 import DQN

    # One env, train_freq 4: the last rollout of 512 frames starts at 508, when the rate
    # is 1e-3 + (1e-4 - 1e-3) * 508 / 512.
    overrides = {
        "n_envs": 1,
        "train_freq": 4,
        "learning_starts": 256,
        "learning_rate": 1e-3,
        "learning_rate_final": 1e-4,
    }
    model = DQN.load(_train(tmp_path, "dqn", 512, overrides), device="cpu")
    expected = 1e-3 + (1e-4 - 1e-3) * 508 / 512
    assert model.learning_rate == pytest.approx(expected)
    assert model.policy.optimizer.param_groups[0]["lr"] == pytest.approx(expected)


def test_a_resumed_run_continues_the_schedule_in_frames(tmp_path: Path) -> None:
    from stable_baselines3 import PPO

    from noisybolt.runs import train

    overrides = {
        "n_steps": 64,
        "learning_rate": 1e-3,
        "learning_rate_final": 0.0,
        "learning_rate_frames": 2048,
    }
    config = _config("ppo", 1024, overrides, checkpoint_freq=512)
    run = tmp_path / "run"
    train(config, run, log=lambda _: None)
    first = PPO.load(run / "model.zip", device="cpu").learning_rate  # rollout at 512
    train(config.override({"frames": 2048}), run, resume=True, log=lambda _: None)
    # SB3's own schedule would restart at the resumed learn() call's fraction; this one
    # goes on from the run's frames: the last rollout starts at 1536 of 2048.
    assert first == pytest.approx(1e-3 * (1 - 512 / 2048))
    assert PPO.load(run / "model.zip", device="cpu").learning_rate == pytest.approx(2.5e-4)


def test_the_rl_zoos_lin_schedules_read_as_start_and_final() -> None:
    from noisybolt.agents.hyperparams import parse_overrides, zoo_schedules

    params = load_hyperparams(
        "gridworld", "ppo", parse_overrides(["learning_rate=lin_2.5e-4", "clip_range=lin_0.1"])
    )
    assert params["learning_rate"] == pytest.approx(2.5e-4)
    assert params["learning_rate_final"] == 0.0
    assert (params["clip_range"], params["clip_range_final"]) == (pytest.approx(0.1), 0.0)
    assert zoo_schedules({"learning_rate": 3e-4}) == {"learning_rate": 3e-4}


@pytest.mark.parametrize(
    ("params", "message"),
    [
        ({"learning_rate": "lin_x"}, "a linear schedule is lin_<start>"),
        ({"ent_coef": "lin_0.01"}, "only learning_rate and clip_range"),
        (
            {"learning_rate": "lin_1e-3", "learning_rate_final": 1e-4},
            "learning_rate_final both set",
        ),
    ],
)
def test_bad_zoo_schedules_are_named_errors(params: dict[str, object], message: str) -> None:
    from noisybolt.agents.hyperparams import zoo_schedules

    with pytest.raises(ConfigError, match=message):
        zoo_schedules(params)


@pytest.mark.parametrize(
    ("algo", "overrides", "message"),
    [
        ("a2c", {"clip_range_final": 0.0}, "clip_range_final: A2C has no clip range"),
        ("dqn", {"ent_coef_final": 0.0}, "ent_coef_final: DQN has no entropy bonus"),
        ("ppo", {"learning_rate_frames": 100}, "learning_rate_frames=100 without"),
        ("ppo", {"learning_rate_final": -1.0}, "learning_rate_final=-1.0 is out of range"),
        ("ppo", {"clip_range_frames": 0, "clip_range_final": 0.0}, "clip_range_frames"),
    ],
)
def test_bad_schedules_are_refused_by_the_config(
    algo: str, overrides: dict[str, object], message: str
) -> None:
    from noisybolt.runs import DetectorConfig, TrainConfig

    with pytest.raises(ConfigError, match=message):
        resolve(
            TrainConfig.create(
                specs=["edge"],
                algo=algo,
                detector=DetectorConfig(kind="oracle"),
                frames=1024,
                overrides=overrides,
            )
        )


def test_a_config_written_by_hand_with_a_zoo_schedule_says_how_to_write_it() -> None:
    from noisybolt.agents.hyperparams import check_hyperparameter_values

    with pytest.raises(ConfigError, match="learning_rate_final=<end>"):
        check_hyperparameter_values("ppo", {"learning_rate": "lin_1e-3"})
