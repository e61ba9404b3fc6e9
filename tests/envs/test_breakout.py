"""Breakout world: RAM wall layout vs the rendered frame, preprocessing, seeding, bolt view."""

from __future__ import annotations

from pathlib import Path

import ale_py
import gymnasium as gym
import numpy as np
import pytest
from gymnasium.vector import AutoresetMode
from gymnasium.wrappers import AtariPreprocessing, FrameStackObservation

from noisybolt.envs import breakout
from noisybolt.envs.breakout import (
    BRICK_COLUMNS,
    BRICK_ROWS,
    BreakoutWorld,
    brick_box,
    bricks_present,
    left_columns_clear,
    make_breakout_world,
    set_bricks,
)
from noisybolt.errors import ConfigError, UnknownFluentError, UnknownNameError
from noisybolt.perception.dataset import SupportsCollectionStates, collect_samples
from noisybolt.perception.protocols import BoltObservable

ROM = ale_py.roms.get_rom_path("breakout") or Path("ale-py ships no Breakout ROM")


@pytest.fixture(scope="module")
def settled_ale() -> tuple[ale_py.ALEInterface, ale_py.ALEState]:
    """A console past the game's own wall drawing, ball not yet served."""
    ale_py.ALEInterface.setLoggerMode(ale_py.LoggerMode.Error)
    ale = ale_py.ALEInterface()
    ale.setInt("random_seed", 0)
    ale.setFloat("repeat_action_probability", 0.0)
    ale.loadROM(ROM)
    ale.reset_game()
    for _ in range(40):
        ale.act(ale_py.Action.NOOP)
    return ale, ale.cloneState()


def _frame_bricks(frame: np.ndarray) -> np.ndarray:
    """bool [6, 18]: which brick boxes of an RGB frame hold any coloured pixel."""
    shown = np.zeros((BRICK_ROWS, BRICK_COLUMNS), dtype=bool)
    for row in range(BRICK_ROWS):
        for column in range(BRICK_COLUMNS):
            ys, xs = brick_box(row, column)
            shown[row, column] = frame[ys, xs].any()
    return shown


def _show(ale: ale_py.ALEInterface, state: ale_py.ALEState, wall: np.ndarray) -> np.ndarray:
    ale.restoreState(state)
    set_bricks(ale, wall)
    ale.act(ale_py.Action.NOOP)  # the frame shows RAM from the next frame on
    return ale.getScreenRGB()


def test_full_wall_at_start(settled_ale):
    ale, state = settled_ale
    ale.restoreState(state)
    assert bricks_present(ale.getRAM()).all()
    assert _frame_bricks(ale.getScreenRGB()).all()


def test_every_brick_bit_map_matches_the_frame(settled_ale):
    """Each brick's RAM bits, and only they, draw that brick (108 bricks, both ways)."""
    ale, state = settled_ale
    full = np.ones((BRICK_ROWS, BRICK_COLUMNS), dtype=bool)
    for row in range(BRICK_ROWS):
        for column in range(BRICK_COLUMNS):
            one_gone = full.copy()
            one_gone[row, column] = False
            frame = _show(ale, state, one_gone)
            np.testing.assert_array_equal(_frame_bricks(frame), one_gone)
            np.testing.assert_array_equal(bricks_present(ale.getRAM()), one_gone)


def test_random_walls_match_the_frame(settled_ale):
    ale, state = settled_ale
    rng = np.random.default_rng(0)
    for keep in (0.1, 0.5, 0.9):
        wall = rng.random((BRICK_ROWS, BRICK_COLUMNS)) < keep
        frame = _show(ale, state, wall)
        np.testing.assert_array_equal(_frame_bricks(frame), wall)
        np.testing.assert_array_equal(bricks_present(ale.getRAM()), wall)


@pytest.mark.parametrize("left_columns", [1, 2, 3])
def test_left_column_fluent_follows_the_pixels(settled_ale, left_columns):
    """Clearing the left column(s) in RAM makes their pixels vanish and the fluent true;
    any single brick put back shows up and makes it false."""
    ale, state = settled_ale
    x_end = 8 + 8 * left_columns
    wall = np.ones((BRICK_ROWS, BRICK_COLUMNS), dtype=bool)
    wall[:, :left_columns] = False
    frame = _show(ale, state, wall)
    assert not frame[57:93, 8:x_end].any()
    assert frame[57:93, x_end : x_end + 8].any()
    assert left_columns_clear(ale.getRAM(), left_columns)
    for row in range(BRICK_ROWS):
        back = wall.copy()
        back[row, left_columns - 1] = True
        frame = _show(ale, state, back)
        assert frame[57:93, 8:x_end].any()
        assert not left_columns_clear(ale.getRAM(), left_columns)


def test_leftmost_column_is_bits_6_7_of_bytes_30_to_35(settled_ale):
    """The formula quoted in FACTS.md agrees with the brick map on random walls."""
    ale, state = settled_ale
    rng = np.random.default_rng(1)
    for _ in range(40):
        wall = rng.random((BRICK_ROWS, BRICK_COLUMNS)) < 0.5
        wall[:, 0] &= rng.random() < 0.5  # often a cleared left column
        ale.restoreState(state)
        set_bricks(ale, wall)
        ram = ale.getRAM()
        formula = all(ram[30 + i] & 0xC0 == 0 for i in range(6))
        assert bool(left_columns_clear(ram, 1)) == formula == (not wall[:, 0].any())


def test_game_redraws_the_wall_in_its_first_frames():
    """Why collection waits: pokes in the first 36 frames after reset_game are undone."""
    ale_py.ALEInterface.setLoggerMode(ale_py.LoggerMode.Error)
    ale = ale_py.ALEInterface()
    ale.loadROM(ROM)
    wall = np.zeros((BRICK_ROWS, BRICK_COLUMNS), dtype=bool)
    wall[0, 9] = True
    for frames, undone in ((30, True), (36, True), (37, False)):
        ale.reset_game()
        for _ in range(frames):
            ale.act(ale_py.Action.NOOP)
        set_bricks(ale, wall)
        for _ in range(40):
            ale.act(ale_py.Action.NOOP)
        assert bricks_present(ale.getRAM()).all() == undone


def test_same_observations_as_gymnasium_atari_preprocessing():
    """With sticky actions and no-ops off both are deterministic and must agree exactly,
    same-step autoreset and final observations included."""
    gym.register_envs(ale_py)

    def make() -> gym.Env:
        env = gym.make("ALE/Breakout-v5", frameskip=1, repeat_action_probability=0.0)
        return FrameStackObservation(AtariPreprocessing(env, frame_skip=4, noop_max=0), 4)

    reference = gym.vector.SyncVectorEnv([make, make], autoreset_mode=AutoresetMode.SAME_STEP)
    world = BreakoutWorld(num_envs=2, seed=0, noop_max=0, repeat_action_probability=0.0)
    assert world.metadata["autoreset_mode"] == AutoresetMode.SAME_STEP
    obs_ref, _ = reference.reset(seed=0)
    obs, _ = world.reset(seed=0)
    np.testing.assert_array_equal(obs, obs_ref)
    rng = np.random.default_rng(0)
    ended = 0
    for _ in range(1200):
        actions = rng.integers(0, 4, size=2)
        expected = reference.step(actions)
        got = world.step(actions)
        for want, have in zip(expected[:4], got[:4], strict=True):
            np.testing.assert_array_equal(np.asarray(have), np.asarray(want))
        done = got[2] | got[3]
        np.testing.assert_array_equal(world.dones, done)
        if done.any():
            ended += int(done.sum())
            np.testing.assert_array_equal(got[4]["_final_obs"], expected[4]["_final_obs"])
            for i in np.flatnonzero(done):
                np.testing.assert_array_equal(got[4]["final_obs"][i], expected[4]["final_obs"][i])
    assert ended >= 1  # autoreset was exercised
    reference.close()


def test_final_bolt_view_is_the_state_reached_before_autoreset():
    """A game truncated after 10 steps: its final view is a twin's (untruncated) view."""
    settings = {"num_envs": 2, "seed": 0, "noop_max": 0, "repeat_action_probability": 0.0}
    short = BreakoutWorld(max_episode_frames=40, **settings)
    twin = BreakoutWorld(**settings)
    short.reset(seed=0)
    twin.reset(seed=0)
    fresh = short.bolt_images()
    rng = np.random.default_rng(0)
    for step in range(10):
        actions = rng.integers(0, 4, size=2)
        _, _, terminated, truncated, infos = short.step(actions)
        twin.step(actions)
        if step < 9:
            assert not (truncated.any() or terminated.any())
            np.testing.assert_array_equal(short.final_bolt_images(), short.bolt_images())
    assert truncated.all() and "final_obs" in infos
    np.testing.assert_array_equal(short.final_bolt_images(), twin.bolt_images())
    np.testing.assert_array_equal(short.final_true_fluents(), twin.true_fluents())
    np.testing.assert_array_equal(short.bolt_images(), fresh)  # the new episode's view


def test_seeded_runs_repeat_with_sticky_actions_noops_and_noise():
    def noise(images: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        return (images ^ rng.integers(0, 8, images.shape, dtype=np.uint8)).astype(np.uint8)

    runs = []
    for _ in range(2):
        world = make_breakout_world(num_envs=2, seed=7, noise=noise)
        world.reset(seed=7)
        rng = np.random.default_rng(3)
        trace = []
        for _ in range(30):
            obs, reward, *_ = world.step(rng.integers(0, 4, size=2))
            trace += [obs, reward, world.bolt_images(), world.true_fluents()]
        runs.append(trace)
    for a, b in zip(*runs, strict=True):
        np.testing.assert_array_equal(a, b)


def test_bolt_view_meets_the_protocol():
    world = make_breakout_world(num_envs=3, seed=0, camera_size=64)
    assert isinstance(world, BoltObservable)
    assert isinstance(world, SupportsCollectionStates)
    world.reset(seed=0)
    images = world.bolt_images()
    assert images.dtype == np.uint8 and images.shape == (3, 64, 64, 3)
    np.testing.assert_array_equal(images, world.bolt_images())  # cached until the next step
    truth = world.true_fluents()
    assert world.fluent_names == breakout.FLUENT_NAMES
    assert world.fluent_names[1:] == tuple(f"left_gone_row{r}" for r in range(6))
    assert truth.dtype == np.bool_ and truth.shape == (3, 7)
    assert not truth.any()  # a full wall
    assert world.camera_spec.shape == (64, 64, 3)
    assert world.camera_spec.extra["fluents"] == {
        "brick_clear_left": {"left_columns": 1},
        **{f"left_gone_row{r}": {} for r in range(6)},
    }
    one = make_breakout_world(num_envs=1, fluents=["brick_clear_left"], left_columns=2)
    assert one.camera_spec.extra["fluents"] == {"brick_clear_left": {"left_columns": 2}}


def test_collection_states_give_both_values_and_true_labels():
    world = make_breakout_world(num_envs=4, seed=0)
    world.reset(seed=0)
    rng = np.random.default_rng(0)
    labels = []
    for _ in range(10):
        world.sample_collection_states(rng)
        truth = world.true_fluents()
        frames = world.frames()
        shown = ~frames[:, 57:93, 8:16].any(axis=(1, 2, 3))  # left column empty
        np.testing.assert_array_equal(truth[:, 0], shown)
        for row in range(6):  # each brick of the left column, from the picture
            ys, xs = brick_box(row, 0)
            np.testing.assert_array_equal(truth[:, 1 + row], ~frames[:, ys, xs].any(axis=(1, 2, 3)))
        labels.append(truth)
    frac = np.mean(labels, axis=(0, 1))
    assert 0.25 < frac[0] < 0.75
    assert ((frac[1:] > 0.5) & (frac[1:] < 0.95)).all()  # gone: half the walls, and more


def test_a_subset_of_fluents_in_any_order():
    world = make_breakout_world(num_envs=2, seed=0, fluents=["left_gone_row5", "brick_clear_left"])
    world.reset(seed=0)
    world.sample_collection_states(np.random.default_rng(3))
    full = make_breakout_world(num_envs=2, seed=0)
    assert world.fluent_names == ("left_gone_row5", "brick_clear_left")
    np.testing.assert_array_equal(
        world.true_fluents(), breakout.breakout_fluents(world.rams())[:, [6, 0]]
    )
    assert full.true_fluents().shape == (2, 7)


def test_collect_samples_from_breakout_is_balanced():
    world = make_breakout_world(num_envs=4, seed=0, camera_size=32)
    data = collect_samples(world, num_samples=48, seed=0)
    assert len(data) == 48
    assert data.images.shape == (48, 32, 32, 3)
    assert 16 <= data.positives["brick_clear_left"] <= 32


def test_bad_settings_are_refused():
    with pytest.raises(ConfigError, match="left_columns"):
        BreakoutWorld(num_envs=1, left_columns=0)
    with pytest.raises(ConfigError, match="left_columns"):
        left_columns_clear(np.zeros(128, np.uint8), 19)
    with pytest.raises(ConfigError, match="noise"):
        BreakoutWorld(num_envs=1, noise=42)
    with pytest.raises(UnknownFluentError, match="left_gone_row0"):
        BreakoutWorld(num_envs=1, fluents=["left_gone_row6"])
    with pytest.raises(UnknownNameError, match="gaussian"):
        BreakoutWorld(num_envs=1, noise="pink")
    world = BreakoutWorld(num_envs=1, noise=lambda images, rng: images[:, :10])
    world.reset(seed=0)
    with pytest.raises(ValueError, match="noise"):
        world.bolt_images()
    with pytest.raises(ValueError, match="actions"):
        world.step(np.array([4]))


def test_camera_noise_from_the_noise_registry():
    clean = make_breakout_world(num_envs=2, seed=0)
    noisy = make_breakout_world(num_envs=2, seed=0, noise="gaussian:sigma=12")
    assert clean.camera_spec.noise == {"name": "none"}
    assert noisy.camera_spec.noise["name"] == "gaussian"
    assert noisy.camera_spec.noise["sigma"] == 12
    clean.reset(seed=0)
    noisy.reset(seed=0)
    difference = noisy.bolt_images().astype(int) - clean.bolt_images()
    assert 8 < difference.std() < 16
    again = make_breakout_world(num_envs=2, seed=0, noise={"name": "gaussian", "sigma": 12})
    again.reset(seed=0)
    np.testing.assert_array_equal(again.bolt_images(), noisy.bolt_images())


def test_public_api():
    for name in breakout.__all__:
        assert hasattr(breakout, name)


@pytest.mark.slow
def test_a_classifier_learns_brick_clear_left_from_the_colour_frame():
    from noisybolt.perception.metrics import build_report
    from noisybolt.perception.training import TrainingConfig, train_classifier

    data = collect_samples(make_breakout_world(num_envs=16, seed=0), num_samples=1500, seed=0)
    result = train_classifier(data, training=TrainingConfig(epochs=12, seed=0), progress=False)
    test = collect_samples(make_breakout_world(num_envs=16, seed=1), num_samples=600, seed=1)
    report = build_report(
        result.detector.predict(test.images), test.labels, fluent_names=test.fluent_names
    )
    assert report["brick_clear_left"].accuracy > 0.98
    assert report["brick_clear_left"].auroc > 0.99


def test_single_game_env_is_the_world_of_one_and_shows_the_end() -> None:
    settings = {"seed": 5, "noise": "gaussian:sigma=8", "max_episode_frames": 120}
    env = breakout.BreakoutEnv(**settings)
    world = make_breakout_world(num_envs=1, **settings)
    obs, first = env.reset(seed=5)
    want, _ = world.reset(seed=5)
    np.testing.assert_array_equal(obs, want[0])
    # The bolt's labels come in info (the camera draws its noise once per step).
    np.testing.assert_array_equal(first["bolt_image"], world.bolt_images()[0])
    np.testing.assert_array_equal(first["true_fluents"], world.true_fluents()[0])
    rng = np.random.default_rng(0)
    for _ in range(200):
        action = int(rng.integers(0, 4))
        obs, reward, terminated, truncated, labels = env.step(action)
        w_obs, w_reward, w_term, w_trunc, info = world.step(np.array([action]))
        assert (reward, terminated, truncated) == (w_reward[0], w_term[0], w_trunc[0])
        if terminated or truncated:  # the game's last state, not the next game's first
            np.testing.assert_array_equal(obs, info["final_obs"][0])
            np.testing.assert_array_equal(labels["bolt_image"], world.final_bolt_images()[0])
            np.testing.assert_array_equal(labels["true_fluents"], world.final_true_fluents()[0])
            assert not np.array_equal(env.render(), world.frames()[0])
            break
        np.testing.assert_array_equal(obs, w_obs[0])
        np.testing.assert_array_equal(labels["bolt_image"], world.bolt_images()[0])
        np.testing.assert_array_equal(labels["true_fluents"], world.true_fluents()[0])
        np.testing.assert_array_equal(env.render(), world.frames()[0])
    else:
        pytest.fail("120 emulator frames should truncate the game within 200 steps")
    with pytest.raises(RuntimeError, match="reset"):
        env.step(0)
    env.reset()
    env.step(0)
    with pytest.raises(ConfigError, match="render_mode"):
        breakout.BreakoutEnv(render_mode="human")


def test_single_game_env_passes_gymnasium_checks() -> None:
    from gymnasium.utils.env_checker import check_env

    check_env(breakout.BreakoutEnv(seed=0), skip_render_check=True)
