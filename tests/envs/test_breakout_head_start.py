"""Breakout's start-state curriculum (``left_head_start``) and ``world.train_kwargs``,
which gives it to the learner's games only."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from noisybolt.envs.breakout import (
    BRICK_ROWS,
    FLUENT_NAMES,
    BreakoutWorld,
    bricks_present,
    make_breakout_world,
)
from noisybolt.errors import ConfigError
from noisybolt.perception.detectors import OracleDetector
from noisybolt.runs.config import TrainConfig
from noisybolt.runs.environments import make_env
from noisybolt.runs.legacy import LEGACY_DEFAULTS


def _world(**settings: Any) -> BreakoutWorld:
    return make_breakout_world(num_envs=6, seed=5, obs_mode="ram", fire_on_reset=True, **settings)


def _gone_from_bottom(wall: np.ndarray) -> int:
    """How many bricks of the leftmost column are gone, checking they are the bottom ones."""
    column = wall[:, 0]
    gone = int((~column).sum())
    assert column[: BRICK_ROWS - gone].all() and not column[BRICK_ROWS - gone :].any()
    return gone


def test_every_game_starts_with_the_columns_bottom_bricks_gone_and_the_top_one_standing() -> None:
    world = _world(left_head_start=1.0)
    seen = set()
    for seed in range(4):
        world.reset(seed=seed)
        walls = bricks_present(world.rams())
        for wall in walls:
            seen.add(_gone_from_bottom(wall))
            assert wall[:, 1:].all()  # the rest of the wall as the game sets it up
        # The bolt's view agrees: row r's fluent is true where its brick is gone.
        truth = world.true_fluents()
        names = list(FLUENT_NAMES)
        for r in range(BRICK_ROWS):
            assert np.array_equal(truth[:, names.index(f"left_gone_row{r}")], ~walls[:, r, 0])
        assert not truth[:, names.index("brick_clear_left")].any()
    assert seen <= set(range(1, BRICK_ROWS)) and len(seen) >= 3
    world.close()


def test_a_game_that_ends_starts_again_with_a_head_start() -> None:
    world = _world(left_head_start=1.0, max_episode_frames=100)
    world.reset(seed=0)
    ended = False
    for _ in range(40):  # 100 emulator frames: truncated within 25 agent steps
        _, _, terminated, truncated, _ = world.step(np.zeros(6, dtype=np.int64))
        ended |= bool((terminated | truncated).any())
    assert ended
    for wall in bricks_present(world.rams()):
        assert 1 <= _gone_from_bottom(wall) < BRICK_ROWS
    world.close()


def test_without_it_the_games_are_the_ones_they_were() -> None:
    # 0 spends no random draw: the same no-ops, the same games, frame for frame.
    plain, zero = _world(), _world(left_head_start=0.0)
    obs_a, _ = plain.reset(seed=3)
    obs_b, _ = zero.reset(seed=3)
    assert np.array_equal(obs_a, obs_b) and bricks_present(zero.rams()).all()
    rng = np.random.default_rng(0)
    for _ in range(60):
        actions = rng.integers(0, 4, size=6)
        a, b = plain.step(actions), zero.step(actions)
        assert np.array_equal(a[0], b[0]) and np.array_equal(a[1], b[1])
    plain.close()
    zero.close()


def test_a_shard_plays_the_same_head_starts_as_the_whole_world() -> None:
    whole = make_breakout_world(num_envs=4, seed=2, obs_mode="ram", left_head_start=0.5)
    part = make_breakout_world(
        num_envs=2, seed=2, obs_mode="ram", left_head_start=0.5, shard=(2, 4)
    )
    whole.reset(seed=2)
    part.reset(seed=2)
    assert np.array_equal(whole.rams()[2:], part.rams())
    whole.close()
    part.close()


@pytest.mark.parametrize("value", [-0.1, 1.5])
def test_a_share_outside_0_1_is_refused(value: float) -> None:
    with pytest.raises(ConfigError, match="left_head_start must be in"):
        _world(left_head_start=value)


def _config(**more: Any) -> TrainConfig:
    return TrainConfig.build(
        {
            "world.name": "breakout-ram",
            "world.n_envs": 4,
            "bolt.specs": ["left_column_milestones"],
            "bolt.reward": "paper",
            "detector.kind": "oracle",
            **more,
        }
    )


def test_train_kwargs_reach_the_learners_games_and_not_the_evaluations() -> None:
    config = _config(**{"world.train_kwargs": {"left_head_start": 1.0}})
    assert config.learner_world_settings["left_head_start"] == 1.0
    assert "left_head_start" not in config.world_settings
    detector = OracleDetector(FLUENT_NAMES)
    learner = make_env(config, detector, training=True)
    evaluation = make_env(config, detector, training=False, n_envs=4)
    try:
        learner.reset()
        evaluation.reset()
        # SB3's wrappers hand attribute reads down to the bolt, which holds the world.
        learner_walls = bricks_present(learner.world.rams())
        evaluation_walls = bricks_present(evaluation.world.rams())
        assert (~learner_walls[:, :, 0]).any(axis=1).all()  # every learner game had one
        assert evaluation_walls.all()
    finally:
        learner.close()
        evaluation.close()


def test_a_run_saved_before_train_kwargs_loads_without_them() -> None:
    assert LEGACY_DEFAULTS["world.train_kwargs"] == {}
    data = _config().to_dict()
    del data["world"]["train_kwargs"]
    assert TrainConfig.from_dict(data).world_config.train_kwargs == {}
