"""The vectorised gridworld: step for step identical to MiniGrid envs; vector and SB3 APIs."""

from __future__ import annotations

import inspect

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.vector import AutoresetMode

import noisybolt.envs  # noqa: F401  (registers the Gymnasium ids)
from noisybolt.envs import SB3VecEnv, known_worlds, make_world
from noisybolt.envs.gridworld import GRIDWORLD_FLUENTS, GridworldEnv
from noisybolt.envs.gridworld_vec import VectorGridworld
from noisybolt.errors import (
    BackendUnavailableError,
    ConfigError,
    UnknownFluentError,
    UnknownNameError,
)
from noisybolt.perception.dataset import SupportsCollectionStates
from noisybolt.perception.protocols import BoltObservable

# Forward-heavy random play reaches the goal often; a short limit truncates often too.
ACTION_PROBS = [0.2, 0.2, 0.5, 0.1]


def minigrid_batch_step(
    envs: list[GridworldEnv], actions: np.ndarray, *, frames: bool = False
) -> dict[str, list]:
    """Step separate MiniGrid envs with SB3/Gymnasium same-step autoreset."""
    keys = ("obs", "rew", "term", "trunc", "final", "fluents", "frames")
    out: dict[str, list] = {k: [] for k in keys}
    for env, action in zip(envs, actions, strict=True):
        obs, reward, terminated, truncated, _ = env.step(int(action))
        out["final"].append(obs if terminated or truncated else None)
        out["fluents"].append(env.true_fluents())
        if frames:  # the state reached, before any reset, drawn by MiniGrid
            out["frames"].append(env.clean_bolt_image())
        if terminated or truncated:
            obs, _ = env.reset()
        out["obs"].append(obs)
        out["rew"].append(reward)
        out["term"].append(terminated)
        out["trunc"].append(truncated)
    return out


@pytest.mark.parametrize(
    ("obs_mode", "steps", "max_steps", "size", "heading"),
    [
        ("grid", 1500, 40, 6, "east"),
        ("view", 1500, 40, 6, "east"),
        ("rgb", 400, 25, 6, "east"),
        ("view", 600, 60, 7, "east"),
        ("view", 800, 40, 6, "south"),
    ],
)
def test_vectorised_form_is_identical_to_minigrid_envs(
    obs_mode: str, steps: int, max_steps: int, size: int, heading: str
) -> None:
    n = 6
    kwargs = {
        "obs_mode": obs_mode,
        "max_steps": max_steps,
        "size": size,
        "obs_tile_size": 4,
        "start_heading": heading,
    }
    envs = [GridworldEnv(**kwargs) for _ in range(n)]
    world = VectorGridworld(n, **kwargs)
    ref = np.stack([env.reset(seed=i)[0] for i, env in enumerate(envs)])
    obs, _ = world.reset(seed=0)
    assert np.array_equal(obs, ref)
    rng = np.random.default_rng(size)
    goals = truncations = 0
    for _ in range(steps):
        actions = rng.choice(4, size=n, p=ACTION_PROBS)
        want = minigrid_batch_step(envs, actions)
        obs, rewards, terminated, truncated, infos = world.step(actions)
        assert np.array_equal(obs, np.stack(want["obs"]))
        assert np.array_equal(rewards, want["rew"]) and rewards.dtype == np.float64
        assert np.array_equal(terminated, want["term"])
        assert np.array_equal(truncated, want["trunc"])
        assert np.array_equal(world.final_true_fluents(), np.stack(want["fluents"]))
        assert np.array_equal(world.true_fluents(), np.stack([e.true_fluents() for e in envs]))
        for i, final in enumerate(want["final"]):
            if final is None:
                assert "final_obs" not in infos or infos["final_obs"][i] is None
            else:
                assert infos["_final_obs"][i] and np.array_equal(infos["final_obs"][i], final)
        goals += int(terminated.sum())
        truncations += int(truncated.sum())
    assert goals >= 10 and truncations >= 10  # both endings were exercised


def test_bolt_camera_draws_what_minigrid_draws_along_episodes() -> None:
    n = 4
    envs = [GridworldEnv(max_steps=30, camera_tile_size=6) for _ in range(n)]
    world = VectorGridworld(n, max_steps=30, camera_tile_size=6)
    for env in envs:
        env.reset(seed=0)
    world.reset(seed=0)
    rng = np.random.default_rng(1)
    ended = 0
    for _ in range(200):
        actions = rng.choice(4, size=n, p=ACTION_PROBS)
        want = minigrid_batch_step(envs, actions, frames=True)
        world.step(actions)
        assert np.array_equal(world.bolt_images(), np.stack([e.clean_bolt_image() for e in envs]))
        assert np.array_equal(world.final_bolt_images(), np.stack(want["frames"]))
        ended += sum(f is not None for f in want["final"])
    assert ended >= 5


def test_terminal_frame_shows_the_agent_on_the_goal() -> None:
    world = VectorGridworld(1, camera_tile_size=8)
    world.reset(seed=0)
    for a in [2, 2, 2, 1, 2, 2]:
        world.step(np.array([a]))
    _, _, terminated, _, _ = world.step(np.array([2]))
    assert terminated[0]
    env = GridworldEnv()
    env.reset(seed=0)
    for a in [2, 2, 2, 1, 2, 2, 2]:
        env.step(a)
    assert np.array_equal(world.final_bolt_images()[0], env.clean_bolt_image())
    assert world.final_true_fluents()[0].tolist() == env.true_fluents().tolist()
    assert [v.tolist() for v in world.agent_state] == [[1], [1], [0]]  # already reset
    assert not np.array_equal(world.final_bolt_images(), world.bolt_images())


def test_meets_the_protocols_and_the_gymnasium_vector_api() -> None:
    world = VectorGridworld(5, obs_mode="view")
    assert isinstance(world, BoltObservable) and isinstance(world, gym.vector.VectorEnv)
    assert isinstance(world, SupportsCollectionStates)
    assert world.metadata["autoreset_mode"] is AutoresetMode.SAME_STEP
    assert world.single_observation_space.shape == (7, 7, 3)
    assert world.observation_space.shape == (5, 7, 7, 3)
    assert world.action_space == gym.spaces.MultiDiscrete([4] * 5)
    obs, infos = world.reset(seed=1)
    assert world.observation_space.contains(obs)
    assert set(infos) == {
        "bolt_image", "_bolt_image", "true_fluents", "_true_fluents", "grid_position",
        "_grid_position",
    }  # fmt: skip
    assert world.true_fluents().dtype == bool and world.true_fluents().shape == (5, 7)
    assert world.fluent_names == GRIDWORLD_FLUENTS
    vec = gym.make_vec("noisybolt/Gridworld-6x6-v0", num_envs=3)
    assert isinstance(vec, VectorGridworld) and vec.num_envs == 3


def test_bolt_images_are_noisy_cached_and_seeded() -> None:
    def frames(seed: int) -> list[np.ndarray]:
        world = VectorGridworld(3, noise="gaussian:sigma=30", seed=seed)
        out = [world.bolt_images()]
        assert world.bolt_images() is out[0]  # one draw per step
        for _ in range(3):
            world.step(np.array([2, 1, 2]))
            out.append(world.bolt_images())
        return out

    a, b, c = frames(0), frames(0), frames(1)
    assert all(np.array_equal(x, y) for x, y in zip(a, b, strict=True))
    assert not np.array_equal(a[1], c[1])
    world = VectorGridworld(3, noise="gaussian:sigma=30", seed=0)
    assert not np.array_equal(world.bolt_images(), world.clean_bolt_images())
    assert world.camera_spec.noise == {"name": "gaussian", "sigma": 30.0}
    world.reset(seed=0)  # re-seeding reproduces the first frame
    assert np.array_equal(world.bolt_images(), a[0])


def test_fluent_selection_and_collection_states() -> None:
    world = VectorGridworld(64, fluents=("bottom_left_corner", "facing_up"))
    world.sample_collection_states(np.random.default_rng(0))
    x, y, d = world.agent_state
    assert set(zip(x.tolist(), y.tolist(), strict=True)) <= {
        (i, j) for i in range(1, 5) for j in range(1, 5)
    }
    truth = world.true_fluents()
    assert np.array_equal(truth[:, 0], (x == 1) & (y == 4))
    assert np.array_equal(truth[:, 1], d == 3)
    world.set_agent_state([1] * 64, [4] * 64, [3] * 64)
    assert world.true_fluents().all()
    with pytest.raises(ConfigError, match="floor"):
        world.set_agent_state([0] * 64, [4] * 64, [3] * 64)


def test_step_refuses_bad_actions() -> None:
    world = VectorGridworld(2)
    with pytest.raises(ValueError, match="shape"):
        world.step(np.array([1, 2, 3]))
    for bad in (np.array([0, 4]), np.array([-1, 0]), np.array([3, 255], dtype=np.uint8)):
        with pytest.raises(ValueError, match=r"\[0, 4\)"):
            world.step(bad)
    world.step(np.array([3, 0], dtype=np.uint8))  # unsigned actions in range are fine


# -------------------------------------------------------------------------- SB3


def test_sb3_vec_env_follows_sb3_conventions() -> None:
    venv = SB3VecEnv(VectorGridworld(2, max_steps=3, obs_mode="grid"))
    venv.seed(0)
    obs = venv.reset()
    assert isinstance(obs, np.ndarray) and obs.shape == (2, 6, 6, 3)
    for _ in range(2):
        obs, rewards, dones, infos = venv.step(np.array([3, 3]))
        assert not dones.any() and rewards.dtype == np.float32
    obs, rewards, dones, infos = venv.step(np.array([3, 2]))
    assert dones.tolist() == [True, True]
    assert all(info["TimeLimit.truncated"] for info in infos)
    assert infos[1]["terminal_observation"][2, 1, 0] == 10  # agent moved to (2, 1) ...
    assert obs[1, 1, 1, 0] == 10  # ... and the returned observation is the new episode's
    # The world's own batched info, kept for the batched bolt (SB3's dicts hold SB3's keys).
    assert np.asarray(venv.batched_info["bolt_image"]).shape == (2, 48, 48, 3)
    assert venv.batched_info["_final_info"].tolist() == [True, True]
    assert "bolt_image" not in infos[0]
    assert venv.get_attr("fluent_names") == [GRIDWORLD_FLUENTS] * 2
    assert venv.env_is_wrapped(gym.Wrapper) == [False, False]


def test_sb3_goal_step_is_not_marked_truncated() -> None:
    venv = SB3VecEnv(VectorGridworld(1))
    venv.reset()
    for a in [2, 2, 2, 1, 2, 2]:
        venv.step(np.array([a]))
    _, rewards, dones, infos = venv.step(np.array([2]))
    assert dones[0] and rewards[0] == pytest.approx(98.5)
    assert infos[0]["TimeLimit.truncated"] is False and "terminal_observation" in infos[0]


def test_sb3_refuses_next_step_autoreset() -> None:
    class NextStep(VectorGridworld):
        metadata = {"autoreset_mode": AutoresetMode.NEXT_STEP}  # noqa: RUF012

    with pytest.raises(ConfigError, match="SAME_STEP"):
        SB3VecEnv(NextStep(1))


def test_sb3_ppo_runs_on_the_vectorised_world() -> None:
    from stable_baselines3 import PPO

    venv = SB3VecEnv(VectorGridworld(4, obs_mode="grid"))
    model = PPO("MlpPolicy", venv, n_steps=16, batch_size=32, n_epochs=1, seed=0, device="cpu")
    model.learn(total_timesteps=64)
    assert model.num_timesteps == 64


# --------------------------------------------------------------------- registry


def test_make_world_builds_the_gridworld() -> None:
    world = make_world("gridworld", num_envs=3, seed=0, noise="salt_pepper", obs_mode="rgb")
    assert isinstance(world, VectorGridworld) and world.num_envs == 3
    assert world.config.obs_mode == "rgb" and world.camera_spec.noise["name"] == "salt_pepper"
    assert make_world("gridworld", size=8).camera_spec.shape == (64, 64, 3)
    assert known_worlds() == ("breakout", "breakout-ram", "gridworld", "minatar-breakout")


def test_make_world_bad_input() -> None:
    with pytest.raises(UnknownNameError, match="gridworld, minatar-breakout") as info:
        make_world("pong")
    assert info.value.name == "pong"
    assert info.value.known == ("breakout", "breakout-ram", "gridworld", "minatar-breakout")
    with pytest.raises(ConfigError, match="colour"):
        make_world("gridworld", colour="blue")
    with pytest.raises(UnknownNameError, match="gaussian"):
        make_world("gridworld", noise="fog")
    with pytest.raises(ConfigError, match="sigma"):
        make_world("gridworld", noise={"name": "gaussian", "sigma": -1})
    with pytest.raises(UnknownFluentError):
        make_world("gridworld", fluents=["in_lava"])
    with pytest.raises(ConfigError, match="num_envs"):
        make_world("gridworld", num_envs=0)


def test_a_world_whose_module_is_missing_says_so() -> None:
    from noisybolt.envs import registry

    registry.register_world("ghost", "noisybolt.envs.no_such_world:make", overwrite=True)
    try:
        with pytest.raises(BackendUnavailableError, match="no_such_world"):
            make_world("ghost")
    finally:
        registry._WORLDS.pop("ghost")
    with pytest.raises(ConfigError, match="already registered"):
        registry.register_world("gridworld", VectorGridworld)


def test_breakout_entry_point_resolves_to_its_factory() -> None:
    pytest.importorskip("ale_py")
    from noisybolt.envs import registry

    factory = registry._resolve("breakout")
    parameters = set(inspect.signature(factory).parameters)
    assert {"num_envs", "seed", "noise", "obs_mode"} <= parameters


def test_rgb_array_render_through_both_apis() -> None:
    world = VectorGridworld(2, render_mode="rgb_array")
    world.reset(seed=0)
    frames = world.render()
    assert frames is not None and len(frames) == 2 and frames[0].shape == (192, 192, 3)
    env = GridworldEnv()
    env.reset(seed=0)
    assert np.array_equal(frames[0], env.get_frame(highlight=False, tile_size=32))
    assert [f.shape for f in SB3VecEnv(world).get_images()] == [(192, 192, 3)] * 2
    assert VectorGridworld(1).render() is None
    with pytest.raises(ConfigError, match="render_mode"):
        VectorGridworld(1, render_mode="human")


@pytest.mark.parametrize(
    "module",
    [
        "noisybolt.envs",
        "noisybolt.envs.gridworld",
        "noisybolt.envs.gridworld_vec",
        "noisybolt.envs.sb3",
        "noisybolt.envs.registry",
    ],
)
def test_public_api_is_documented_and_examples_run(module: str) -> None:
    import doctest
    import importlib
    import types

    mod = importlib.import_module(module)
    assert mod.__doc__
    for name in mod.__all__:
        obj = getattr(mod, name)
        if isinstance(obj, type | types.FunctionType):
            assert obj.__doc__, f"{module}.{name} has no docstring"
    result = doctest.testmod(mod, optionflags=doctest.ELLIPSIS)
    assert result.failed == 0
    # The package only re-exports (its modules hold the examples); every module has some.
    assert result.attempted > 0 or module == "noisybolt.envs", f"{module} has no examples"


@pytest.mark.parametrize(("heading", "after_forward"), [("east", (2, 1)), ("south", (1, 2))])
def test_start_heading_sets_where_the_first_step_goes(
    heading: str, after_forward: tuple[int, int]
) -> None:
    env = GridworldEnv(start_heading=heading)
    env.reset(seed=0)
    env.step(2)  # forward
    assert tuple(int(v) for v in env.agent_pos) == after_forward
    world = VectorGridworld(1, start_heading=heading)
    world.reset(seed=0)
    facing = dict(zip(world.fluent_names, world.true_fluents()[0], strict=True))
    assert facing["facing_down" if heading == "south" else "facing_right"]


def test_unknown_start_heading_lists_the_known_ones() -> None:
    with pytest.raises(UnknownNameError, match="east, south, west, north"):
        VectorGridworld(1, start_heading="up")
