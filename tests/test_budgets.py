"""A budget a user sets is kept or refused with the arithmetic (issue 46): the run of
``noisybolt train --spec edge --n-envs 100000 --frames 1k`` trained past 3,200,000 frames
before it was stopped, one PPO rollout being ``n_envs x n_steps`` frames."""

from __future__ import annotations

import json
import warnings
from pathlib import Path

import pytest

from noisybolt.cli import main
from noisybolt.errors import ConfigError, NoEvaluationWarning
from noisybolt.runs.config import TrainConfig

BASE = {"bolt.specs": ["edge"], "bolt.reward": "paper", "detector.kind": "oracle"}


def test_the_issues_command_is_refused_with_the_arithmetic_before_anything_is_written(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "run"
    argv = ["train", "--spec", "edge", "--n-envs", "100000", "--frames", "1k"]
    assert main([*argv, "--reward", "paper", "--detector", "oracle", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    # The gridworld's PPO takes 32 steps per environment a rollout.
    assert "frames 1,000 is less than one PPO rollout" in err
    assert "100000 x 32 = 3,200,000 frames" in err and "--n-envs 1000 or less" in err
    assert not out.exists()


@pytest.mark.parametrize(
    ("settings", "message"),
    [
        ({"frames": 255}, r"8 x 32 = 256 frames.*--frames 256 or more.*--hp n_steps=31"),
        ({"frames": 39, "algorithm.name": "a2c"}, r"A2C rollout.*8 x 5 = 40 frames"),
        ({"frames": 200, "algorithm.name": "dqn"}, r"learning_starts 200 >= frames 200"),
    ],
)
def test_a_budget_that_cannot_be_kept_is_refused(settings: dict[str, object], message: str) -> None:
    config = TrainConfig.build({**BASE, **settings})
    with pytest.raises(ConfigError, match=message):
        config.check_budget()


@pytest.mark.parametrize(
    "settings",
    [
        {"frames": 256},  # exactly one rollout
        {"frames": 40, "algorithm.name": "a2c"},
        {"frames": 201, "algorithm.name": "dqn"},
    ],
)
def test_a_budget_of_one_rollout_or_update_is_kept(settings: dict[str, object]) -> None:
    TrainConfig.build({**BASE, **settings}).check_budget()


def test_the_python_door_refuses_before_anything_is_written(tmp_path: Path) -> None:
    from noisybolt.runs import train

    config = TrainConfig.build({**BASE, "frames": 100})
    with pytest.raises(ConfigError, match="rollout"):
        train(config, tmp_path / "run", log=lambda _: None)
    assert not (tmp_path / "run").exists()


def test_an_evaluation_never_reached_is_warned_of_only_when_chosen() -> None:
    with pytest.warns(NoEvaluationWarning, match="evaluation.freq 5,000 > frames 4,096"):
        TrainConfig.build({**BASE, "frames": 4096, "evaluation.freq": 5000})
    with warnings.catch_warnings():
        warnings.simplefilter("error", NoEvaluationWarning)
        TrainConfig.build({**BASE, "frames": 4096})  # the default freq: not the user's word


def test_a_saved_run_outside_the_rule_still_loads(tmp_path: Path) -> None:
    # Saved before the rule (or by hand): evaluating and reading it are not refused.
    saved = TrainConfig.build({**BASE, "frames": 64}).to_dict()
    config = TrainConfig.from_dict(json.loads(json.dumps(saved)))
    assert config.frames == 64


def test_every_committed_config_keeps_its_budget() -> None:
    # The rule breaks no kept run: each results/**/config.json would be started again.
    root = Path(__file__).resolve().parents[1] / "results"
    paths = sorted(root.rglob("config.json"))
    assert paths
    for path in paths:
        TrainConfig.from_dict(json.loads(path.read_text())).check_budget()
