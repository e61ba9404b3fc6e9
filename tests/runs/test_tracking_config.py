"""Belief tracking through a run: TrainConfig's tracking and confidence, the envs built from
it, and ``noisybolt train --tracking``."""

from __future__ import annotations

import json
from pathlib import Path

import gymnasium as gym
import pytest

from noisybolt.cli import main
from noisybolt.envs import make_world
from noisybolt.errors import ConfidenceLevelError, UnknownNameError
from noisybolt.perception.detectors import OracleDetector
from noisybolt.runs.config import DetectorConfig, TrainConfig
from noisybolt.runs.environments import make_env
from noisybolt.runs.resolution import resolve


def _config(**kwargs: object) -> TrainConfig:
    return resolve(
        TrainConfig.create(
            world="gridworld",
            specs=["edge"],
            detector=DetectorConfig(kind="oracle"),
            frames=64,
            progress_bar=False,
            **kwargs,  # type: ignore[arg-type]
        )
    )


def test_threshold_is_the_default_and_belief_settings_follow_the_config() -> None:
    assert _config().tracking == "threshold" and _config().belief_settings is None
    config = _config(tracking="belief", confidence=0.95)
    settings = config.belief_settings
    assert settings is not None and settings.confidence == 0.95
    assert TrainConfig.from_dict(json.loads(json.dumps(config.to_dict()))) == config


def test_bad_tracking_settings_are_refused_by_name() -> None:
    with pytest.raises(UnknownNameError):
        _config(tracking="bayes")
    with pytest.raises(ConfidenceLevelError):
        _config(tracking="belief", confidence=1.0)


@pytest.mark.parametrize("tracking", ["threshold", "belief"])
def test_the_runs_envs_carry_the_tracking(tracking: str) -> None:
    config = _config(tracking=tracking)
    fluents = make_world("gridworld", num_envs=1, seed=0).fluent_names
    env = make_env(config, OracleDetector(fluents), training=False, n_envs=2)
    space = env.observation_space
    assert isinstance(space, gym.spaces.Dict)
    expected = gym.spaces.Box if tracking == "belief" else gym.spaces.MultiDiscrete
    assert isinstance(space["dfa"], expected)


def test_cli_trains_under_belief_tracking(tmp_path: Path) -> None:
    out = tmp_path / "run"
    code = main(
        [
            "train",
            "--spec",
            "edge",
            "--detector",
            "oracle",
            "--tracking",
            "belief",
            "--confidence",
            "0.95",
            "--frames",
            "64",
            "--eval-freq",
            "0",
            "--checkpoint-freq",
            "0",
            "--eval-episodes",
            "1",
            "--n-envs",
            "2",
            "--no-progress",
            "--out",
            str(out),
        ]
    )
    assert code == 0
    saved = json.loads((out / "config.json").read_text())
    assert saved["bolt"]["tracking"] == "belief" and saved["bolt"]["confidence"] == 0.95
