"""The shipped vector worlds' batched ``info`` is the contract of
``noisybolt.perception.protocols``: what Gymnasium's ``SyncVectorEnv`` makes of their
single envs' infos, from the same seed, across autoresets; and the batched bolt reads it
and nothing else of the world."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.vector import AutoresetMode, SyncVectorEnv

from noisybolt.bolt import Spec
from noisybolt.envs import SB3VecEnv
from noisybolt.envs.breakout import BreakoutEnv, BreakoutWorld
from noisybolt.envs.deferred import DeferredArray
from noisybolt.envs.gridworld import GridworldEnv
from noisybolt.envs.gridworld_vec import VectorGridworld
from noisybolt.errors import StaleInfoError
from noisybolt.perception.detectors import OracleDetector
from noisybolt.wrappers import BoltVecEnv

LABELS = ("bolt_image", "true_fluents", "grid_position")


def _rows(value: Any, mask: np.ndarray) -> np.ndarray:
    """The masked rows of a batched info value as one array (SyncVectorEnv keeps tuples,
    and None in rows without them, in object arrays)."""
    array = np.asarray(value)[mask]
    if array.dtype == object:
        return np.stack([np.asarray(row) for row in array])
    return array


def _same_labels(ours: dict[str, Any], theirs: dict[str, Any], keys: tuple[str, ...]) -> None:
    """Every label key and mask of ``theirs`` is in ``ours``, equal in the rows it masks."""
    for key in keys:
        if key not in theirs:
            assert key not in ours
            continue
        mask = np.asarray(theirs[f"_{key}"])
        np.testing.assert_array_equal(np.asarray(ours[f"_{key}"]), mask, err_msg=key)
        np.testing.assert_array_equal(_rows(ours[key], mask), _rows(theirs[key], mask), err_msg=key)


def _compare(
    world: gym.vector.VectorEnv,
    single: Callable[[], gym.Env],
    actions: np.ndarray,
    keys: tuple[str, ...],
    *,
    seed: int,
) -> int:
    """Steps ``world`` and a same-step ``SyncVectorEnv`` of ``single`` envs alike; returns
    how many episodes ended."""
    sync = SyncVectorEnv([single] * world.num_envs, autoreset_mode=AutoresetMode.SAME_STEP)
    obs, info = world.reset(seed=seed)
    sync_obs, sync_info = sync.reset(seed=seed)
    np.testing.assert_array_equal(obs, sync_obs)
    _same_labels(info, sync_info, keys)
    ended = 0
    for action in actions:
        obs, rewards, terminated, truncated, info = world.step(action)
        sync_obs, sync_rewards, sync_term, sync_trunc, sync_info = sync.step(action)
        np.testing.assert_array_equal(obs, sync_obs)
        np.testing.assert_array_equal(rewards, sync_rewards)
        np.testing.assert_array_equal(terminated, sync_term)
        np.testing.assert_array_equal(truncated, sync_trunc)
        _same_labels(info, sync_info, keys)
        done = terminated | truncated
        assert ("final_info" in info) == bool(done.any())
        if done.any():
            np.testing.assert_array_equal(info["_final_info"], sync_info["_final_info"])
            _same_labels(info["final_info"], sync_info["final_info"], keys)
            ended += int(done.sum())
    sync.close()
    return ended


def test_vector_gridworld_info_is_the_stacked_info_of_its_single_envs() -> None:
    n, steps = 3, 40
    route = [2, 2, 2, 1, 2, 2, 2]  # east along the top, then south: the goal in 7 steps
    rng = np.random.default_rng(0)
    actions = rng.integers(0, 4, size=(steps, n))
    actions[:, 0] = [route[t % len(route)] for t in range(steps)]  # room 0 reaches the goal
    world = VectorGridworld(n, max_steps=9, obs_mode="grid", seed=3)
    ended = _compare(
        world, lambda: GridworldEnv(max_steps=9, obs_mode="grid"), actions, LABELS, seed=3
    )
    assert ended >= 2 * n  # goals (room 0) and time limits (the others)


def test_breakout_world_info_is_the_stacked_info_of_its_single_envs() -> None:
    # Sticky actions and no-ops off: every game is then the same whatever its seed.
    settings: dict[str, Any] = {
        "noop_max": 0,
        "repeat_action_probability": 0.0,
        "max_episode_frames": 120,
    }
    actions = np.random.default_rng(1).integers(0, 4, size=(70, 2))
    world = BreakoutWorld(num_envs=2, seed=0, **settings)
    ended = _compare(
        world,
        lambda: BreakoutEnv(**settings),
        actions,
        ("bolt_image", "true_fluents"),
        seed=0,
    )
    assert ended >= 2
    world.close()


def test_the_camera_runs_only_when_read_and_once_per_step() -> None:
    world = VectorGridworld(4, noise="gaussian:sigma=20", seed=0)
    _, info = world.reset(seed=0)
    untouched = world._noise_rng.bit_generator.state
    for _ in range(3):
        _, _, _, _, info = world.step(np.array([2, 2, 1, 0]))
    assert world._noise_rng.bit_generator.state == untouched  # nobody looked: no draws
    images = info["bolt_image"]
    assert isinstance(images, DeferredArray) and not images.computed
    first = np.asarray(images)
    assert images.computed and np.asarray(images) is first  # one camera call per step
    assert world.bolt_images() is first  # the method is a view of the info
    # The noise drawn is the noise a world that looked at every step draws at its first look.
    fresh = VectorGridworld(4, noise="gaussian:sigma=20", seed=0)
    fresh.reset(seed=0)
    for _ in range(3):
        fresh.step(np.array([2, 2, 1, 0]))
    np.testing.assert_array_equal(fresh.bolt_images(), first)


def test_an_info_value_read_after_the_world_moved_on_is_refused() -> None:
    world = VectorGridworld(2)
    _, old = world.reset(seed=0)
    seen = np.asarray(old["true_fluents"])  # read in time: kept
    world.step(np.array([2, 2]))
    np.testing.assert_array_equal(old["true_fluents"], seen)
    with pytest.raises(StaleInfoError, match="before the next step"):
        np.asarray(old["bolt_image"])


def test_the_batched_bolt_reads_info_and_no_world_method(monkeypatch: pytest.MonkeyPatch) -> None:
    def refused(*_: Any, **__: Any) -> Any:
        raise AssertionError("the bolt called a world method instead of reading info")

    for name in ("bolt_images", "true_fluents", "final_bolt_images", "final_true_fluents"):
        monkeypatch.setattr(VectorGridworld, name, refused)
    world = VectorGridworld(3, max_steps=4, seed=0)
    spec = Spec("G(!top_right_corner)", terminal_reward=1.0, low_confidence_cost=0.5)
    bolted = BoltVecEnv(SB3VecEnv(world), [spec], OracleDetector(world.fluent_names))
    bolted.reset()
    ended = 0
    for _ in range(9):  # every room's episode is cut at steps 4 and 8
        _, _, dones, infos = bolted.step(np.array([2, 1, 2]))
        ended += int(dones.sum())
    assert ended == 6 and infos[0]["true_fluents"].shape == (len(world.fluent_names),)
