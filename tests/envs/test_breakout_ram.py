"""Breakout with the agent on the RAM (``obs_mode="ram"``, world ``breakout-ram``).

The RAM agent must play the very game the image agent plays and be watched by the very
same bolt: only the agent's observation differs. The main check compares a RAM world with
an image world from the same seed, step for step.
"""

from __future__ import annotations

import cv2
import gymnasium as gym
import numpy as np
import pytest
import torch

from noisybolt.agents.extractor import BoltFeaturesExtractor
from noisybolt.agents.hyperparams import load_hyperparams
from noisybolt.envs.breakout import (
    OBS_MODES,
    BreakoutWorld,
    area_resize_84,
    breakout_fluents,
    make_breakout_ram_world,
    make_breakout_world,
)
from noisybolt.envs.registry import make_single_world, make_world, world_display
from noisybolt.errors import ConfigError

SETTINGS = {
    "num_envs": 3,
    "seed": 11,
    "noise": "gaussian:sigma=20",
    "fire_on_reset": True,
    "max_episode_frames": 240,  # 60 agent steps: every game is cut a few times
}


def test_ram_world_plays_the_image_worlds_game_and_shows_the_bolt_the_same():
    ram = make_world("breakout-ram", **SETTINGS)
    image = make_world("breakout", **SETTINGS)
    assert isinstance(ram, BreakoutWorld) and ram.obs_mode == "ram"
    assert isinstance(image, BreakoutWorld) and image.obs_mode == "stack"
    obs, info = ram.reset(seed=11)
    _, image_info = image.reset(seed=11)
    np.testing.assert_array_equal(info["lives"], image_info["lives"])
    rng = np.random.default_rng(0)
    ended = 0
    for _ in range(150):
        # the RAM agent's observation is the console's RAM, bytes / 255
        np.testing.assert_array_equal(obs, ram.rams().astype(np.float32) / 255)
        assert obs.dtype == np.float32 and ram.single_observation_space.contains(obs[0])
        np.testing.assert_array_equal(ram.bolt_images(), image.bolt_images())
        np.testing.assert_array_equal(ram.true_fluents(), image.true_fluents())
        actions = rng.integers(0, 4, size=3)
        obs, rewards, terminated, truncated, info = ram.step(actions)
        _, want_rewards, want_terminated, want_truncated, want_info = image.step(actions)
        np.testing.assert_array_equal(rewards, want_rewards)
        np.testing.assert_array_equal(terminated, want_terminated)
        np.testing.assert_array_equal(truncated, want_truncated)
        np.testing.assert_array_equal(info["lives"], want_info["lives"])
        np.testing.assert_array_equal(ram.final_bolt_images(), image.final_bolt_images())
        np.testing.assert_array_equal(ram.final_true_fluents(), image.final_true_fluents())
        for i in np.flatnonzero(terminated | truncated):
            ended += 1
            # the ended game's last observation is its last RAM: the fluents read from it
            # are the ended game's, not the new game's full wall
            last = np.rint(info["final_obs"][i] * 255).astype(np.uint8)
            assert last.shape == (128,)
            np.testing.assert_array_equal(
                breakout_fluents(last[None])[0], ram.final_true_fluents()[i]
            )
            np.testing.assert_array_equal(info["final_obs"][i], last / np.float32(255))
            assert not np.array_equal(info["final_obs"][i], obs[i])  # obs: the new game's
    assert ended >= 3  # autoreset was exercised
    assert rewards.dtype == np.float64


def test_ram_bits_are_the_bytes_bits_most_significant_first():
    bytes_world = make_world("breakout-ram", **SETTINGS)
    bits_world = make_world("breakout-ram", **SETTINGS, obs_mode="ram_bits")
    assert bits_world.single_observation_space == gym.spaces.Box(0, 1, (1024,), np.uint8)
    obs, _ = bytes_world.reset(seed=11)
    bits, _ = bits_world.reset(seed=11)
    rng = np.random.default_rng(1)
    ended = 0
    for _ in range(150):
        assert bits.dtype == np.uint8 and bits_world.observation_space.contains(bits)
        rams = np.rint(obs * 255).astype(np.uint8)
        # the left column's bricks are the top two bits of bytes 30-35 (the module's map):
        # one input each, bits 8 * byte and 8 * byte + 1
        for byte in range(30, 36):
            np.testing.assert_array_equal(bits[:, 8 * byte], rams[:, byte] >> 7)
            np.testing.assert_array_equal(bits[:, 8 * byte + 1], (rams[:, byte] >> 6) & 1)
        for j in range(8):
            np.testing.assert_array_equal(bits[:, j::8], (rams >> (7 - j)) & 1)
        actions = rng.integers(0, 4, size=3)
        obs, rewards, terminated, truncated, info = bytes_world.step(actions)
        bits, bits_rewards, bits_terminated, _, bits_info = bits_world.step(actions)
        np.testing.assert_array_equal(rewards, bits_rewards)
        np.testing.assert_array_equal(terminated, bits_terminated)
        for i in np.flatnonzero(terminated | truncated):
            ended += 1
            last = np.rint(info["final_obs"][i] * 255).astype(np.uint8)
            np.testing.assert_array_equal(bits_info["final_obs"][i], np.unpackbits(last))
    assert ended >= 3


def test_obs_mode_is_a_setting_of_both_factories():
    assert OBS_MODES == ("stack", "ram", "ram_bits")
    via_setting = make_world("breakout", num_envs=1, seed=0, obs_mode="ram")
    assert via_setting.single_observation_space == gym.spaces.Box(0.0, 1.0, (128,), np.float32)
    stack = make_world("breakout-ram", num_envs=1, seed=0, obs_mode="stack")
    assert stack.single_observation_space.shape == (4, 84, 84)
    assert make_breakout_world(num_envs=1).obs_mode == "stack"
    with pytest.raises(ConfigError, match="obs_mode"):
        make_breakout_world(num_envs=1, obs_mode="pixels")
    with pytest.raises(ConfigError, match="obs_mode"):
        make_breakout_ram_world(num_envs=1, obs_mode="bytes")
    with pytest.raises(ConfigError, match="screen_sise"):
        make_world("breakout-ram", num_envs=1, screen_sise=84)


def test_collection_states_in_ram_mode_give_the_poked_wall():
    world = make_world("breakout-ram", num_envs=2, seed=0)
    world.reset(seed=0)
    world.sample_collection_states(np.random.default_rng(0))
    # the wall poked into RAM is what the fluents read (the agent's stack is not kept)
    np.testing.assert_array_equal(world.true_fluents(), breakout_fluents(world.rams()))


def test_single_game_of_breakout_ram_observes_the_ram():
    from gymnasium.utils.env_checker import check_env

    env = make_single_world("breakout-ram", seed=3)
    obs, info = env.reset(seed=3)
    assert obs.shape == (128,) and obs.dtype == np.float32
    assert info["bolt_image"].shape == (84, 84, 3)
    check_env(env, skip_render_check=True)
    assert world_display("breakout-ram") == world_display("breakout")


def test_ram_agent_network_is_a_dense_layer_beside_the_dfa_states():
    params = load_hyperparams("breakout-ram", "ppo")
    assert "cnn" not in params and params["image_features"] == 256
    assert params["policy_kwargs"] == {"net_arch": [256]}
    image_params = load_hyperparams("breakout", "ppo")
    # only the network differs from the image agent's settings
    same = {k: v for k, v in image_params.items() if k not in ("cnn",)}
    assert params == same
    space = gym.spaces.Dict(
        {
            "image": gym.spaces.Box(0.0, 1.0, (128,), np.float32),
            "dfa": gym.spaces.MultiDiscrete([2] * 7),
        }
    )
    body = BoltFeaturesExtractor(space, image_features=256)
    assert body.features_dim == 256 + 14
    features = body({"image": torch.ones(5, 128), "dfa": torch.zeros(5, 14)})
    assert features.shape == (5, 270)


def test_the_cameras_area_resize_is_opencvs_on_the_games_frames() -> None:
    world = make_world("breakout-ram", num_envs=4, seed=0)
    world.reset(seed=0)
    rng = np.random.default_rng(0)
    frames = []
    for _ in range(150):
        world.step(rng.integers(0, 4, size=4))
        frames.append(world.frames())
    world.close()
    frames_ = np.concatenate(frames)
    theirs = np.stack([cv2.resize(f, (84, 84), interpolation=cv2.INTER_AREA) for f in frames_])
    assert np.array_equal(area_resize_84(frames_), theirs)
    # Random pixels: an exact half may round the other way, one level apart at most.
    noise = rng.integers(0, 256, (64, 210, 160, 3), dtype=np.uint8)
    theirs = np.stack([cv2.resize(f, (84, 84), interpolation=cv2.INTER_AREA) for f in noise])
    diff = np.abs(area_resize_84(noise).astype(int) - theirs)
    assert diff.max() <= 1 and (diff > 0).mean() < 2e-3
    with pytest.raises(ValueError, match="210, 160, 3"):
        area_resize_84(noise[:, :200])
