from __future__ import annotations

import pytest

from noisybolt.agents import load_hyperparams, parse_overrides
from noisybolt.agents.hyperparams import algorithm_class, known_hyperparameters
from noisybolt.errors import ConfigError, UnknownNameError


@pytest.mark.parametrize("world", ["gridworld", "breakout"])
@pytest.mark.parametrize("algo", ["ppo", "a2c", "dqn"])
def test_builtin_hyperparameters_are_valid_sb3_arguments(world: str, algo: str) -> None:
    params = load_hyperparams(world, algo)
    assert params["n_envs"] >= 1
    assert set(params) <= known_hyperparameters(algo)


def test_overrides_replace_and_reach_into_nested_mappings() -> None:
    params = load_hyperparams(
        "gridworld",
        "ppo",
        parse_overrides(["n_epochs=2", "policy_kwargs.net_arch=[32, 16]", "learning_rate=1e-3"]),
    )
    assert params["n_epochs"] == 2
    assert params["policy_kwargs"]["net_arch"] == [32, 16]
    assert params["policy_kwargs"]["normalize_images"] is False  # untouched sibling kept
    assert params["learning_rate"] == pytest.approx(1e-3)


def test_overrides_do_not_leak_into_the_builtin_table() -> None:
    load_hyperparams("gridworld", "ppo", {"policy_kwargs.net_arch": [1]})
    assert load_hyperparams("gridworld", "ppo")["policy_kwargs"]["net_arch"] == [64, 64]


def test_unknown_hyperparameter_lists_known_ones() -> None:
    with pytest.raises(ConfigError, match=r"unknown hyperparameter 'n_epoch'.*n_epochs"):
        load_hyperparams("gridworld", "ppo", {"n_epoch": 3})


def test_dqn_refuses_ppo_only_keys() -> None:
    with pytest.raises(ConfigError, match="clip_range"):
        load_hyperparams("gridworld", "dqn", {"clip_range": 0.1})


def test_unknown_algorithm_and_world_are_named_errors() -> None:
    with pytest.raises(UnknownNameError, match=r"known algorithms: \['a2c', 'dqn', 'ppo'\]"):
        algorithm_class("sac")
    with pytest.raises(UnknownNameError, match=r"unknown world 'pong'.*module:function"):
        load_hyperparams("pong", "ppo")


@pytest.mark.parametrize("bad", ["n_epochs", "=3", "x: [1"])
def test_malformed_override_is_refused(bad: str) -> None:
    with pytest.raises(ConfigError):
        parse_overrides([bad])


def test_dqn_on_continuous_actions_is_refused_with_the_algorithms_that_take_them() -> None:
    from types import SimpleNamespace

    import numpy as np
    from gymnasium import spaces

    from noisybolt.runs.config import TrainConfig
    from noisybolt.runs.models import make_model

    config = TrainConfig.create(specs=["edge"], algo="dqn", reward="paper")
    env = SimpleNamespace(action_space=spaces.Box(-1.0, 1.0, (1,), np.float32))
    with pytest.raises(ConfigError, match=r"DQN takes only Discrete actions.*--algo ppo or a2c"):
        make_model(config, env)  # type: ignore[arg-type]
