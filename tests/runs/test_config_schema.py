"""The run config schema: nested frozen sections, strict loading that names the key's
path, overrides by path typed from the dataclasses, and the JSON round trip."""

from __future__ import annotations

import dataclasses
import json
from typing import Any

import pytest

from noisybolt.errors import ConfigError, UnknownNameError
from noisybolt.runs.config import (
    AlgorithmConfig,
    BoltConfig,
    EvaluationConfig,
    FrozenDict,
    TrainConfig,
    WorldConfig,
    override_paths,
    schema_paths,
    value_from_text,
)
from noisybolt.runs.legacy import FLAT_PATHS, SCHEMA_VERSION, nested_config


@pytest.fixture(scope="module")
def config() -> TrainConfig:
    return TrainConfig.build(
        {"bolt.specs": ["edge"], "bolt.reward": "paper", "detector.kind": "oracle"}
    )


def test_config_json_is_nested_with_its_schema_version(config: TrainConfig) -> None:
    data = config.to_dict()
    assert data["schema"] == SCHEMA_VERSION == 2
    assert set(data) == {
        "schema", "seed", "frames", "checkpoint_freq", "progress_bar",
        "world", "bolt", "detector", "algorithm", "evaluation",
    }  # fmt: skip
    assert data["world"] == {
        "name": "gridworld", "kwargs": {}, "train_kwargs": {}, "n_envs": 8,
        "fire_on_reset": False, "clip_reward": False, "life_loss_terminal": False, "workers": 0,
        "overlap": False,
    }  # fmt: skip
    assert data["bolt"]["tracking"] == "threshold" and data["bolt"]["reward"] == "paper"
    assert data["algorithm"]["name"] == "ppo" and "n_envs" not in data["algorithm"]["hyperparams"]
    assert data["evaluation"]["freq"] == 10_000 and data["detector"]["kind"] == "oracle"


@pytest.mark.parametrize(
    "overrides",
    [
        {},
        {"bolt.tracking": "belief", "bolt.confidence": 0.95},
        {"algorithm.name": "dqn", "evaluation.deterministic": True, "world.n_envs": 2},
        {"bolt.reward": "compliance", "bolt.reward_scale": 12.5, "bolt.shaping": False},
        {"world.kwargs.noise": "regional", "detector.kind": "synthetic", "seed": 7},
    ],
)
def test_json_to_config_to_json_round_trips(overrides: dict[str, Any]) -> None:
    config = TrainConfig.build(
        {"bolt.specs": ["edge"], "bolt.reward": "paper", "detector.kind": "oracle", **overrides}
    )
    text = json.dumps(config.to_dict())
    again = TrainConfig.from_dict(json.loads(text))
    assert again == config
    assert json.dumps(again.to_dict()) == text
    assert nested_config(json.loads(text)) == json.loads(text)


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"bolt": {"trackin": "belief"}}, r"unknown config key bolt\.trackin; known in bolt"),
        ({"colour": 1}, r"unknown config key colour; known: \["),
        ({"detector": {"colour": 1}}, r"unknown config key detector\.colour"),
        ({"world": {"size": 6}}, r"unknown config key world\.size"),
        ({"bolt": {"tracking": 3}}, r"config key bolt\.tracking must be a string, got 3"),
        ({"evaluation": {"episodes": "many"}}, r"evaluation\.episodes must be an integer"),
        ({"evaluation": {"keep_best": 1}}, r"evaluation\.keep_best must be true or false"),
        ({"bolt": {"reward_scale": "big"}}, r"bolt\.reward_scale must be a number or null"),
        ({"world": {"kwargs": ["noise"]}}, r"config key world\.kwargs must be a mapping"),
        ({"bolt": {"specs": ["edge"]}}, r"config key bolt\.specs\[0\] must be a mapping"),
        ({"detector": {"low_confidence": "on_edge"}}, r"detector\.low_confidence must be a list"),
        ({"frames": 1.5}, r"config key frames must be an integer, got 1\.5"),
        ({"seed": True}, r"config key seed must be an integer, got True"),
        ({"bolt": "paper"}, r"config key bolt must be a mapping, got 'paper'"),
        ({"algorithm": {"hyperparams": {"gama": 0.9}}}, r"algorithm\.hyperparams\.gama"),
        ({"algorithm": {"hyperparams": {"gamma": 2}}}, r"gamma=2 is out of range"),
        ({"algorithm": {"hyperparams": {"n_envs": 2}}}, r"set world\.n_envs"),
        ({"world": {"n_envs": 0}}, r"world\.n_envs must be an integer >= 1, got 0"),
        ({"evaluation": {"freq": -1}}, r"evaluation\.freq must be an integer >= 0"),
        ({"schema": 3}, r"config schema 3: this noisybolt reads schema 2"),
    ],
)
def test_strict_loading_refuses_by_path(
    config: TrainConfig, change: dict[str, Any], message: str
) -> None:
    data = config.to_dict()
    for key, value in change.items():
        if isinstance(value, dict) and isinstance(data.get(key), dict):
            data[key] = {**data[key], **value}
        else:
            data[key] = value
    with pytest.raises(ConfigError, match=message):
        TrainConfig.from_dict(data)


def test_overrides_by_path_equal_overrides_by_nested_mapping_and_by_flat_name(
    config: TrainConfig,
) -> None:
    dotted = config.override({"bolt.tracking": "belief", "evaluation.freq": 500})
    nested = config.override({"bolt": {"tracking": "belief"}, "evaluation": {"freq": 500}})
    flat = config.override(override_paths({"tracking": "belief", "eval_freq": 500}))
    assert dotted == nested == flat
    assert dotted.tracking == "belief" and dotted.eval_freq == 500
    # only what the paths name changes
    assert dataclasses.replace(dotted, bolt=config.bolt, evaluation=config.evaluation) == config


def test_override_types_from_the_dataclasses_and_refuses_unknown_paths(
    config: TrainConfig,
) -> None:
    with pytest.raises(ConfigError, match=r"unknown config key bolt\.trackin"):
        config.override({"bolt.trackin": "belief"})
    with pytest.raises(ConfigError, match=r"config key frames is not a mapping"):
        config.override({"frames.x": 1})
    with pytest.raises(ConfigError, match=r"config key evaluation\.freq must be an integer"):
        config.override({"evaluation.freq": "often"})
    with pytest.raises(UnknownNameError, match="unknown tracking mode 'beleif'"):
        config.override({"bolt.tracking": "beleif"})
    assert config.override({"bolt.thresholds.high": 0.95}).thresholds == {
        "truth": 0.5,
        "high": 0.95,
    }
    assert config.override({"bolt.specs": ["avoid_top_right"]}).specs[0]["name"] == (
        "avoid_top_right"
    )


def test_build_resolves_hyperparameters_and_moves_world_settings_to_the_world() -> None:
    breakout = TrainConfig.build(
        {"world.name": "breakout", "bolt.specs": ["clear_left_column"], "bolt.reward": "paper",
         "detector.kind": "oracle", "world.n_envs": 2,
         "algorithm.hyperparams.learning_rate": 1e-4}
    )  # fmt: skip
    world = breakout.world_config
    assert (world.fire_on_reset, world.clip_reward, world.life_loss_terminal) == (True,) * 3
    assert world.n_envs == 2  # the override beats the file's 8
    assert breakout.hyperparams["learning_rate"] == 1e-4
    assert breakout.hyperparams["n_steps"] == 128  # the rest from breakout.yaml
    assert not {"n_envs", "fire_on_reset", "clip_reward"} & set(breakout.hyperparams)
    assert breakout.world_settings == {"fire_on_reset": True}
    # a world setting given among the hyperparameters (the files' layout) reaches the world
    via_hp = TrainConfig.build(
        {"bolt.specs": ["edge"], "bolt.reward": "paper", "algorithm.hyperparams.n_envs": 3}
    )
    assert via_hp.n_envs == 3 and "n_envs" not in via_hp.hyperparams
    with pytest.raises(ConfigError, match="unknown hyperparameter 'gama'"):
        TrainConfig.build({"bolt.specs": ["edge"], "algorithm.hyperparams.gama": 0.9})


def test_create_with_flat_keywords_is_build_with_paths() -> None:
    flat = TrainConfig.create(
        specs=["edge"], algo="a2c", reward="paper", tracking="belief", eval_freq=500,
        n_envs=2, overrides={"gamma": 0.9}, world_kwargs={"noise": "regional"},
    )  # fmt: skip
    paths = TrainConfig.build(
        {"bolt.specs": ["edge"], "algorithm.name": "a2c", "bolt.reward": "paper",
         "bolt.tracking": "belief", "evaluation.freq": 500, "world.n_envs": 2,
         "algorithm.hyperparams.gamma": 0.9, "world.kwargs.noise": "regional"}
    )  # fmt: skip
    assert flat == paths


def test_a_detector_kind_alone_is_that_detector_with_its_defaults() -> None:
    from noisybolt.errors import UnknownNameError
    from noisybolt.runs import DetectorConfig

    by_kind = TrainConfig.create(specs=["edge"], detector="synthetic")
    assert by_kind == TrainConfig.create(specs=["edge"], detector=DetectorConfig(kind="synthetic"))
    assert by_kind.detector.kind == "synthetic"
    with pytest.raises(UnknownNameError, match="unknown detector 'orakel'"):
        TrainConfig.create(specs=["edge"], detector="orakel")


def test_every_flat_name_reads_its_section_with_a_deprecation_warning(
    config: TrainConfig,
) -> None:
    assert set(FLAT_PATHS.values()) <= set(schema_paths())
    for name, path in FLAT_PATHS.items():
        section, key = path.split(".")
        holder = config.world_config if section == "world" else getattr(config, section)
        with pytest.warns(DeprecationWarning, match=rf"TrainConfig\.{name} is deprecated"):
            assert getattr(config, name) == getattr(holder, key), name
    with pytest.raises(AttributeError, match="no attribute 'tracker'"):
        config.tracker  # noqa: B018  # a name that is neither a field nor a flat name


def test_no_code_in_the_package_reads_a_flat_name() -> None:
    """The package reads settings by their schema paths only: a flat read from inside
    noisybolt is an error wherever the suite runs (pyproject's filterwarnings), and none
    is written in its source."""
    import pathlib
    import re

    import noisybolt

    flat = "|".join(FLAT_PATHS)
    pattern = re.compile(rf"\b(config|cfg|self\.config|run_config)\.({flat})\b(?!_)")
    root = pathlib.Path(noisybolt.__file__).parent
    found = [
        f"{path.relative_to(root)}:{number}: {line.strip()}"
        for path in sorted(root.rglob("*.py"))
        for number, line in enumerate(path.read_text().splitlines(), 1)
        if pattern.search(line) and "config.world_config" not in line
    ]
    assert found == []


def test_configs_are_frozen_through_and_through(config: TrainConfig) -> None:
    with pytest.raises(dataclasses.FrozenInstanceError):
        config.bolt.tracking = "belief"  # type: ignore[misc]
    with pytest.raises(TypeError, match="frozen"):
        config.algorithm.hyperparams["gamma"] = 0.5  # type: ignore[index]
    assert isinstance(config.bolt.thresholds, FrozenDict) and isinstance(config.bolt.specs, tuple)
    for section in (WorldConfig, BoltConfig, AlgorithmConfig, EvaluationConfig):
        assert section.__dataclass_params__.frozen  # type: ignore[attr-defined]


def test_values_from_the_command_line_take_the_settings_type() -> None:
    assert value_from_text("bolt.tracking", "belief") == "belief"
    assert value_from_text("world.kwargs.noise", "none") == "none"
    assert value_from_text("detector.path", "123") == "123"  # a string setting keeps text
    assert value_from_text("detector.path", "null") is None
    assert value_from_text("bolt.reward_scale", "null") is None
    assert value_from_text("evaluation.envs", "8") == 8
    assert value_from_text("evaluation.keep_best", "true") is True
    assert value_from_text("algorithm.hyperparams.learning_rate", "3e-4") == 3e-4
    assert value_from_text("algorithm.hyperparams.policy_kwargs.net_arch", "[32, 32]") == [32, 32]
    with pytest.raises(ConfigError, match=r"unknown config key evaluation\.env"):
        value_from_text("evaluation.env", "8")


def test_dqn_is_evaluated_greedily_unless_told_otherwise() -> None:
    # Sampling DQN's policy is SB3's epsilon-exploration; PPO and A2C sample by default.
    assert TrainConfig.create(specs=["edge"], algo="dqn").evaluation.deterministic is True
    assert TrainConfig.create(specs=["edge"], algo="a2c").evaluation.deterministic is False
    sampled = TrainConfig.create(specs=["edge"], algo="dqn", eval_deterministic=False)
    assert sampled.evaluation.deterministic is False
    saved = TrainConfig.from_dict(sampled.to_dict())  # a saved run keeps what it said
    assert saved.evaluation.deterministic is False
