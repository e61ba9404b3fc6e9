"""The gridworld's MiniGrid form: rules, rewards, observations, fluents, registration."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env
from minigrid.envs import EmptyEnv
from minigrid.wrappers import FullyObsWrapper

import noisybolt.envs
from noisybolt.envs.gridworld import (
    GRIDWORLD_FLUENTS,
    MINIGRID_ACTIONS,
    GridAction,
    GridworldConfig,
    GridworldEnv,
    bottom_left_region,
    fit_regional_default,
    gridworld_fluents,
)
from noisybolt.errors import ConfigError, UnknownFluentError, UnknownNameError
from noisybolt.perception.noise import DEFAULT_REGION, RegionalDegradation, make_noise

F, L, R, N = GridAction.FORWARD, GridAction.LEFT, GridAction.RIGHT, GridAction.NOOP
SHORTEST = [F, F, F, R, F, F, F]  # (1,1) east to (4,4): 7 actions


def run(env: GridworldEnv, actions: list[GridAction]) -> list[tuple]:
    return [env.step(a) for a in actions]


@pytest.mark.parametrize("obs_mode", ["grid", "view", "rgb"])
def test_passes_gymnasium_env_checker(obs_mode: str) -> None:
    check_env(GridworldEnv(obs_mode=obs_mode), skip_render_check=True)


def test_rgb_array_render_is_minigrids() -> None:
    env = gym.make("noisybolt/Gridworld-6x6-v0", render_mode="rgb_array")
    env.reset(seed=0)
    assert env.render().shape == (6 * 32, 6 * 32, 3)


def test_room_layout_start_and_goal() -> None:
    env = GridworldEnv()
    env.reset(seed=0)
    assert tuple(env.agent_pos) == (1, 1) and env.agent_dir == 0
    assert env.grid.get(4, 4).type == "goal"
    assert env.max_steps == 4 * 6 * 6 == 144
    assert env.action_space == gym.spaces.Discrete(4)


def test_shortest_episode_rewards_and_terminates() -> None:
    env = GridworldEnv()
    env.reset(seed=0)
    results = run(env, SHORTEST)
    rewards = [r for _, r, _, _, _ in results]
    assert rewards == [-1.5] * 6 + [100.0 - 1.5]
    assert [t for _, _, t, _, _ in results] == [False] * 6 + [True]
    assert sum(rewards) == pytest.approx(89.5)


def test_reward_parameters_replace_minigrids_reward() -> None:
    env = GridworldEnv(step_reward=-1.0, goal_reward=10.0)
    env.reset(seed=0)
    assert [r for _, r, _, _, _ in run(env, SHORTEST)][-2:] == [-1.0, 9.0]


def test_action_mapping_matches_minigrid() -> None:
    assert [int(a) for a in MINIGRID_ACTIONS] == [0, 1, 2, 6]
    env = GridworldEnv()
    env.reset(seed=0)
    env.step(L)
    assert env.agent_dir == 3
    env.step(R)
    env.step(R)
    assert env.agent_dir == 1
    env.step(N)
    assert (tuple(env.agent_pos), env.agent_dir) == ((1, 1), 1)
    env.step(F)
    assert tuple(env.agent_pos) == (1, 2)


def test_walls_block_forward() -> None:
    env = GridworldEnv()
    env.reset(seed=0)
    env.step(L)  # facing north, wall ahead
    _, reward, terminated, _, _ = env.step(F)
    assert tuple(env.agent_pos) == (1, 1) and reward == -1.5 and not terminated


def test_truncation_at_max_steps_and_both_flags_on_the_last_step() -> None:
    env = GridworldEnv(max_steps=3)
    env.reset(seed=0)
    assert [tr for *_, tr, _ in run(env, [N, N, N])] == [False, False, True]
    env = GridworldEnv(max_steps=7)
    env.reset(seed=0)
    *_, (_, _, terminated, truncated, _) = run(env, SHORTEST)
    assert terminated and truncated


def test_invalid_action_is_refused() -> None:
    env = GridworldEnv()
    env.reset(seed=0)
    with pytest.raises(ValueError, match="action"):
        env.step(4)


def test_grid_observation_is_minigrids_fully_observable_encoding() -> None:
    ours = GridworldEnv(obs_mode="grid")
    theirs = FullyObsWrapper(EmptyEnv(size=6))
    o1, _ = ours.reset(seed=0)
    o2, _ = theirs.reset(seed=0)
    assert np.array_equal(o1, o2["image"])
    rng = np.random.default_rng(0)
    for action in rng.integers(0, 3, size=40):  # the three actions both envs share
        o1, *_ = ours.step(int(action))
        o2, *_ = theirs.step(int(action))
        assert np.array_equal(o1, o2["image"])


def test_view_and_rgb_observations() -> None:
    env = GridworldEnv(obs_mode="view")
    obs, _ = env.reset(seed=0)
    assert obs.shape == (7, 7, 3) and np.array_equal(obs, env.gen_obs()["image"])
    env = GridworldEnv(obs_mode="rgb", obs_tile_size=5)
    obs, _ = env.reset(seed=0)
    assert obs.shape == (30, 30, 3)
    assert np.array_equal(obs, env.get_frame(highlight=False, tile_size=5))


def test_deterministic_under_a_seed_noise_included() -> None:
    def episode(seed: int) -> list[np.ndarray]:
        env = GridworldEnv(obs_mode="rgb", noise="gaussian:sigma=20")
        obs, _ = env.reset(seed=seed)
        out = [obs, env.bolt_image()]
        for a in [F, R, F, L, F]:
            out += [env.step(a)[0], env.bolt_image()]
        return out

    a, b, c = episode(3), episode(3), episode(4)
    assert all(np.array_equal(x, y) for x, y in zip(a, b, strict=True))
    assert not all(np.array_equal(x, y) for x, y in zip(a, c, strict=True))


def test_bolt_view_and_spec() -> None:
    env = GridworldEnv(camera_tile_size=4)
    env.reset(seed=0)
    assert env.bolt_image().shape == env.camera_spec.shape == (24, 24, 3)
    assert env.camera_spec.world == "gridworld" and env.camera_spec.noise == {"name": "none"}
    assert np.array_equal(env.bolt_image(), env.get_frame(highlight=False, tile_size=4))


# --------------------------------------------------------------------- fluents

HAND_PLACED = [
    # x, y, dir, expected true fluents
    (1, 1, 0, {"on_edge", "facing_right"}),
    (2, 2, 1, {"facing_down"}),
    (3, 2, 2, {"facing_left"}),
    (4, 1, 3, {"on_edge", "top_right_corner", "facing_up"}),
    (1, 4, 0, {"on_edge", "bottom_left_corner", "facing_right"}),
    (2, 4, 3, {"on_edge", "facing_up"}),
    (4, 3, 1, {"on_edge", "facing_down"}),
    (4, 4, 0, {"on_edge", "facing_right"}),
]


def test_fluents_on_hand_placed_states() -> None:
    x, y, d, expected = zip(*HAND_PLACED, strict=True)
    table = gridworld_fluents(np.array(x), np.array(y), np.array(d), size=6)
    assert table.dtype == bool and table.shape == (len(HAND_PLACED), 7)
    for row, want in zip(table, expected, strict=True):
        assert {n for n, v in zip(GRIDWORLD_FLUENTS, row, strict=True) if v} == want


def test_fluents_in_a_larger_room() -> None:
    table = gridworld_fluents(np.array([6, 1, 3]), np.array([1, 6, 3]), np.array([0, 0, 0]), size=8)
    assert table[:, :3].tolist() == [[True, True, False], [True, False, True], [False] * 3]


def test_single_env_fluents_follow_the_agent_and_selection() -> None:
    env = GridworldEnv(fluents=["facing_up", "on_edge"])
    env.reset(seed=0)
    assert env.fluent_names == ("facing_up", "on_edge")
    assert env.true_fluents().tolist() == [False, True]
    env.step(L)
    assert env.true_fluents().tolist() == [True, True]


# ------------------------------------------------------------------- bad input


@pytest.mark.parametrize(
    ("kwargs", "param"),
    [
        ({"size": 3}, "size"),
        ({"size": 6.5}, "size"),
        ({"max_steps": 0}, "max_steps"),
        ({"step_reward": float("nan")}, "step_reward"),
        ({"goal_reward": "lots"}, "goal_reward"),
        ({"obs_tile_size": 0}, "obs_tile_size"),
        ({"camera_tile_size": -2}, "camera_tile_size"),
    ],
)
def test_out_of_range_parameters_name_themselves(kwargs: dict, param: str) -> None:
    with pytest.raises(ConfigError, match=param):
        GridworldConfig(**kwargs)


def test_unknown_obs_mode_and_fluent_list_the_known_ones() -> None:
    with pytest.raises(UnknownNameError, match="grid, view, rgb") as info:
        GridworldEnv(obs_mode="pixels")
    assert info.value.known == ("grid", "view", "rgb")
    with pytest.raises(UnknownFluentError, match="on_edge") as err:
        GridworldEnv(fluents=["on_edge", "in_lava"])
    assert err.value.unknown == ("in_lava",) and err.value.known == GRIDWORLD_FLUENTS


# ------------------------------------------------------------- registration etc.


def test_gymnasium_ids_are_registered() -> None:
    assert set(noisybolt.envs.GYM_IDS) <= set(gym.registry)
    env = gym.make("noisybolt/Gridworld-v0", size=8, obs_mode="view")
    assert env.unwrapped.config.size == 8 and env.observation_space.shape == (7, 7, 3)
    noisybolt.envs.register_gym_envs()  # idempotent


def test_regional_default_box_follows_the_room_size() -> None:
    assert np.allclose(DEFAULT_REGION, bottom_left_region(6))
    fitted = fit_regional_default(make_noise(["gaussian", "regional"]), 8)
    regional = fitted.models[1]  # type: ignore[attr-defined]
    assert isinstance(regional, RegionalDegradation)
    assert np.allclose(regional.boxes, [[6 / 8, 1 / 8, 7 / 8, 6 / 8]])
    explicit = make_noise({"name": "regional", "boxes": [[0, 0, 0.5, 0.5]]})
    assert fit_regional_default(explicit, 8) is explicit
