"""MinAtar Breakout (``minatar-breakout``): the world plays as MinAtar's own ``Environment``
from the same seed, its fluents and camera read the board as written down, it meets the
batched ``info`` contract, refuses bad input by name, and a bolt trains on it."""

from __future__ import annotations

import doctest
import importlib
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from noisybolt.bolt import Spec
from noisybolt.cli import main
from noisybolt.envs import SB3VecEnv, make_single_world, make_world
from noisybolt.envs.minatar import (
    BRICK_CHANNEL,
    FLUENT_NAMES,
    PALETTE,
    MinAtarBreakoutConfig,
    MinAtarBreakoutEnv,
    MinAtarBreakoutWorld,
    game_seeds,
    make_minatar_breakout_world,
    minatar_fluents,
    noisy_images,
    render_boards,
)
from noisybolt.errors import (
    ConfigError,
    MissingDependencyError,
    StaleInfoError,
    UnknownFluentError,
    UnknownNameError,
    UnseenFluentWarning,
)
from noisybolt.perception.dataset import SupportsCollectionStates, collect_samples
from noisybolt.perception.detectors import OracleDetector
from noisybolt.perception.noise import make_noise
from noisybolt.perception.protocols import BoltObservable
from noisybolt.wrappers import BoltVecEnv

minatar = pytest.importorskip("minatar")

MODULES = [
    "noisybolt.envs.minatar",
    "noisybolt.envs.minatar.adapter",
    "noisybolt.envs.minatar.board",
    "noisybolt.envs.minatar.camera",
    "noisybolt.envs.minatar.config",
    "noisybolt.envs.minatar.factories",
    "noisybolt.envs.minatar.world",
]


def _reference(seed: int, n: int, **settings: float) -> list[minatar.Environment]:
    """MinAtar's own games, seeded as the world seeds its games."""
    games = []
    for game_seed in game_seeds(seed, n):
        game = minatar.Environment("breakout", **settings)
        game.seed(game_seed)
        game.reset()
        games.append(game)
    return games


@pytest.mark.parametrize("sticky", [0.1, 0.0])
def test_plays_as_minatar_environment_from_the_same_seed(sticky: float) -> None:
    """Same boards, rewards, ends (and last boards before each reset) over many episodes;
    episodes cut at 8 steps end as truncations, the reference reset at the same step."""
    n, limit = 4, 8
    world = MinAtarBreakoutWorld(num_envs=n, seed=11, sticky_action_prob=sticky)
    short = MinAtarBreakoutWorld(
        MinAtarBreakoutConfig(num_envs=n, sticky_action_prob=sticky, max_episode_steps=limit)
    )
    for env in (world, short):
        obs, info = env.reset(seed=11)
        np.testing.assert_array_equal(obs, np.stack([g.state() for g in _reference(11, n)]))
    references = {"world": _reference(11, n, sticky_action_prob=sticky)}
    references["short"] = _reference(11, n, sticky_action_prob=sticky)
    steps = np.zeros(n, int)
    minimal = references["world"][0].minimal_action_set()
    rng = np.random.default_rng(0)
    ended = {"world": 0, "short": 0}
    truncations = 0
    for _ in range(600):
        actions = rng.integers(0, 3, size=n)
        steps += 1
        for name, env in (("world", world), ("short", short)):
            obs, rewards, terminated, truncated, info = env.step(actions)
            for i, game in enumerate(references[name]):
                reward, terminal = game.act(minimal[actions[i]])
                assert rewards[i] == reward
                assert terminated[i] == terminal
                cut = name == "short" and not terminal and steps[i] >= limit
                assert truncated[i] == cut
                if terminal or cut:
                    np.testing.assert_array_equal(info["final_obs"][i], game.state())
                    final = np.asarray(info["final_info"]["true_fluents"])[i]
                    np.testing.assert_array_equal(final, minatar_fluents(game.state()[None])[0])
                    game.reset()
                    ended[name] += 1
                    truncations += int(cut)
                np.testing.assert_array_equal(obs[i], game.state())
        steps[np.asarray(terminated) | np.asarray(truncated)] = 0
    assert ended["world"] > 100 and ended["short"] > ended["world"] and truncations > 50


def test_truncation_at_the_episode_limit() -> None:
    """A game that never ends by itself (a paddle under the ball) is cut at the limit."""
    world = MinAtarBreakoutWorld(num_envs=1, seed=0, max_episode_steps=30, sticky_action_prob=0)
    world.reset(seed=0)
    game = world._games[0].env  # MinAtar's game: follow the ball with the paddle
    for step in range(30):
        target = game.ball_x + (1 if game.ball_dir in (1, 2) else -1)
        action = 0 if target == game.pos else (1 if target < game.pos else 2)
        _, _, terminated, truncated, info = world.step(np.array([action]))
        assert not terminated[0]
        assert truncated[0] == (step == 29)
    assert info["_final_info"].tolist() == [True]


def test_a_shard_plays_its_games_of_the_whole_world_and_workers_play_them_alike() -> None:
    from noisybolt.envs.worker_world import WorkerWorld

    settings = {"seed": 9, "noise": "gaussian:sigma=20"}
    whole = MinAtarBreakoutWorld(num_envs=3, **settings)
    part = MinAtarBreakoutWorld(num_envs=2, shard=(1, 3), **settings)
    workers = WorkerWorld("minatar-breakout", num_envs=3, workers=2, **settings)
    try:
        obs, info = whole.reset(seed=9)
        ours, our_info = part.reset(seed=9)
        theirs, their_info = workers.reset(seed=9)
        assert np.array_equal(obs[1:], ours) and np.array_equal(obs, theirs)
        # Each read as a worker reads it (a camera draws its noise when it is read).
        image = np.asarray(info["bolt_image"])
        assert np.array_equal(image[1:], np.asarray(our_info["bolt_image"]))
        assert np.array_equal(image, np.asarray(their_info["bolt_image"]))
        rng = np.random.default_rng(1)
        for _ in range(60):
            actions = rng.integers(0, 3, 3)
            obs, rewards, terminated, _, info = whole.step(actions)
            ours, our_rewards, _, _, our_info = part.step(actions[1:])
            theirs, _, their_terminated, _, their_info = workers.step(actions)
            assert np.array_equal(obs[1:], ours) and np.array_equal(rewards[1:], our_rewards)
            assert np.array_equal(obs, theirs) and np.array_equal(terminated, their_terminated)
            for key in ("bolt_image", "true_fluents"):
                assert np.array_equal(np.asarray(info[key])[1:], np.asarray(our_info[key]))
                assert np.array_equal(np.asarray(info[key]), np.asarray(their_info[key]))
            assert ("final_info" in info) == ("final_info" in their_info)
            if "final_info" in info:  # read too, as the workers read it
                final, their_final = info["final_info"], their_info["final_info"]
                for key in ("bolt_image", "true_fluents"):
                    ended = np.asarray(final[f"_{key}"])
                    mine, theirs_ = np.asarray(final[key]), np.asarray(their_final[key])
                    assert np.array_equal(mine[ended], theirs_[ended])
                if "final_info" in our_info:
                    np.asarray(our_info["final_info"]["bolt_image"])
    finally:
        workers.close()
    with pytest.raises(ConfigError, match="shard"):
        MinAtarBreakoutWorld(num_envs=2, shard=(2, 3))


def test_fluents_by_hand() -> None:
    boards = np.zeros((5, 10, 10, 4), bool)
    boards[:, 1:4, :, BRICK_CHANNEL] = True  # 0: a whole wall
    boards[1, 3, 0, BRICK_CHANNEL] = False  # 1: the bottom-left brick gone
    boards[2, 1:4, 0, BRICK_CHANNEL] = False  # 2: the left column gone (3 of 30)
    boards[3, 1:4, 5:, BRICK_CHANNEL] = False  # 3: the right half gone (15), left standing
    boards[4, 1:4, :5, BRICK_CHANNEL] = False  # 4: the left half gone
    boards[:, 9, 4, 0] = boards[:, 5, 5, 1] = True  # a paddle and a ball change nothing
    assert FLUENT_NAMES == (
        "brick_clear_left",
        "left_gone_row0",
        "left_gone_row1",
        "left_gone_row2",
        "half_wall_gone",
    )
    assert minatar_fluents(boards).astype(int).tolist() == [
        [0, 0, 0, 0, 0],
        [0, 0, 0, 1, 0],
        [1, 1, 1, 1, 0],
        [0, 0, 0, 0, 1],
        [1, 1, 1, 1, 1],
    ]
    boards[0, 1:4, :, BRICK_CHANNEL] = False
    boards[0, 1, 1:, BRICK_CHANNEL] = True  # 9 standing in the top row ...
    boards[0, 2, 3:, BRICK_CHANNEL] = True  # ... and 7 below: 14 of 30 gone, not yet half
    assert int(boards[0, 1:4, :, BRICK_CHANNEL].sum()) == 16
    assert minatar_fluents(boards[:1]).astype(int).tolist() == [[1, 1, 1, 1, 0]]
    boards[0, 2, 9, BRICK_CHANNEL] = False  # the 15th brick gone
    assert minatar_fluents(boards[:1]).astype(int).tolist() == [[1, 1, 1, 1, 1]]


def test_the_camera_draws_each_cell_in_its_colour() -> None:
    board = np.zeros((1, 10, 10, 4), bool)
    board[0, 9, 2, 0] = True  # paddle
    board[0, 6, 7, 1] = True  # ball ...
    board[0, 7, 8, 2] = True  # ... and its trail
    board[0, 1, 3, BRICK_CHANNEL] = board[0, 1, 3, 1] = True  # a ball inside a brick's cell
    image = render_boards(board, tile_size=4)[0]
    assert image.shape == (40, 40, 3)

    def cell(row: int, column: int) -> np.ndarray:
        return image[4 * row : 4 * row + 4, 4 * column : 4 * column + 4]

    assert (cell(9, 2) == PALETTE["paddle"]).all() and (cell(7, 8) == PALETTE["trail"]).all()
    ball, ball_in_brick = cell(6, 7), cell(1, 3)
    assert (ball[1:3, 1:3] == PALETTE["ball"]).all() and (ball_in_brick[1:3, 1:3] == 255).all()
    ring = np.ones((4, 4), bool)
    ring[1:3, 1:3] = False
    assert not ball[ring].any()  # the ball's cell is otherwise empty ...
    assert (ball_in_brick[ring] == PALETTE["brick"]).all()  # ... or shows the brick
    drawn = np.zeros((10, 10), bool)
    drawn[[9, 6, 7, 1], [2, 7, 8, 3]] = True
    cells = image.reshape(10, 4, 10, 4, 3).transpose(0, 2, 1, 3, 4)
    assert not cells[~drawn].any()  # the rest is black
    assert (render_boards(board, tile_size=1)[0, 6, 7] == PALETTE["ball"]).all()


def test_bolt_view_meets_the_protocol_and_noise_is_seeded() -> None:
    world = make_minatar_breakout_world(num_envs=3, seed=0, tile_size=5)
    assert isinstance(world, BoltObservable) and isinstance(world, SupportsCollectionStates)
    _, info = world.reset(seed=0)
    assert world.camera_spec.shape == (50, 50, 3) and world.camera_spec.noise == {"name": "none"}
    np.testing.assert_array_equal(info["bolt_image"], render_boards(world.boards(), 5))
    assert info["_bolt_image"].all() and info["_true_fluents"].all()
    assert not np.asarray(info["true_fluents"]).any()  # a whole wall
    runs = []
    for _ in range(2):
        noisy = make_minatar_breakout_world(num_envs=2, seed=4, noise="gaussian:sigma=40")
        noisy.reset(seed=4)
        images = []
        for step in range(40):
            _, _, terminated, truncated, info = noisy.step(np.array([step % 3, 2]))
            images.append(np.asarray(info["bolt_image"]))
            if (terminated | truncated).any():
                images.append(np.asarray(info["final_info"]["bolt_image"]))
        runs.append(np.stack(images))
    np.testing.assert_array_equal(*runs)
    clean = render_boards(noisy.boards(), 4).astype(int)
    assert 20 < (np.asarray(noisy.bolt_images()) - clean).std() < 45  # clipped at black
    assert noisy.camera_spec.noise["sigma"] == 40


def test_final_info_holds_the_last_board_and_labels_expire() -> None:
    world = MinAtarBreakoutWorld(num_envs=2, seed=3)
    world.reset(seed=3)
    last = None
    for _ in range(200):
        _, _, terminated, truncated, info = world.step(np.zeros(2, np.int64))
        done = terminated | truncated
        if done.any():
            last = info
            break
    assert last is not None
    done_rows = np.flatnonzero(done)
    final = last["final_info"]
    assert final["_true_fluents"].tolist() == done.tolist()
    for i in done_rows:
        board = last["final_obs"][i].astype(bool)
        assert board[..., 1].sum() == 1  # the ball at its last cell
        np.testing.assert_array_equal(
            np.asarray(final["bolt_image"])[i], render_boards(board[None], 4)[0]
        )
    world.step(np.zeros(2, np.int64))
    np.asarray(last["bolt_image"])  # read before the step (the final view drew it): kept
    with pytest.raises(StaleInfoError):  # never read: gone with the world's next step
        np.asarray(last["true_fluents"])


def test_collection_states_give_both_values_and_true_labels() -> None:
    world = MinAtarBreakoutWorld(num_envs=8, seed=0)
    world.reset(seed=0)
    rng = np.random.default_rng(0)
    labels = []
    for _ in range(20):
        world.sample_collection_states(rng)
        truth = world.true_fluents()
        images = world.bolt_images()
        brick = np.array(PALETTE["brick"], np.uint8)
        left = (images[:, 4:16, 0:4] == brick).all(axis=-1)  # the left column's cells
        np.testing.assert_array_equal(truth[:, 0], ~left.any(axis=(1, 2)))
        np.testing.assert_array_equal(truth, minatar_fluents(world.boards()))
        labels.append(truth)
        world.step(rng.integers(0, 3, size=8))  # the games play on from there
    share = np.mean(labels, axis=(0, 1))
    assert (share > 0.25).all() and (share < 0.85).all()
    data = collect_samples(MinAtarBreakoutWorld(num_envs=4, seed=1), num_samples=64, seed=0)
    assert data.images.shape == (64, 40, 40, 3)
    assert 16 <= data.positives["brick_clear_left"] <= 48


def test_bad_input_is_refused_by_name() -> None:
    with pytest.raises(UnknownNameError, match="asterix") as unknown:
        make_world("minatar-breakout", game="asterix")
    assert unknown.value.known == ("breakout",)
    with pytest.raises(ConfigError, match="difficulty"):
        make_world("minatar-breakout", difficulty=2)
    with pytest.raises(ConfigError, match="obs_mode"):
        make_world("minatar-breakout", obs_mode="rgb")
    with pytest.raises(ConfigError, match="sticky_action_prob"):
        MinAtarBreakoutWorld(sticky_action_prob=1.5)
    with pytest.raises(ConfigError, match="noise"):
        MinAtarBreakoutWorld(noise=42)
    with pytest.raises(UnknownFluentError, match="half_wall_gone"):
        MinAtarBreakoutWorld(fluents=["left_gone_row5"])
    world = MinAtarBreakoutWorld(num_envs=1, seed=0)
    with pytest.raises(RuntimeError, match="reset"):
        world.step(np.array([0]))
    world.reset(seed=0)
    with pytest.raises(ValueError, match="actions"):
        world.step(np.array([3]))


def test_a_bad_spec_game_or_option_is_refused_before_anything_is_written(
    tmp_path: Path,
) -> None:
    world = MinAtarBreakoutWorld(num_envs=2, seed=0)
    spec = Spec("F(left_gone_row5)")
    with pytest.raises(UnknownFluentError, match="left_gone_row5"):
        BoltVecEnv(SB3VecEnv(world), [spec], OracleDetector(world.fluent_names))
    out = tmp_path / "run"
    argv = ["train", "--world", "minatar-breakout", "--spec", "F(left_gone_row5)"]
    assert main([*argv, "--detector", "oracle", "--frames", "256", "--out", str(out)]) == 2
    assert not out.exists()
    argv = ["train", "--world", "minatar-breakout", "--spec", "clear_left_column"]
    argv += ["--detector", "oracle", "--frames", "256", "--out", str(out)]
    for setting in ("world.kwargs.game=asterix", "world.kwargs.difficulty=2"):
        assert main([*argv, "--set", setting]) == 2
        assert not out.exists()


def test_without_minatar_a_named_error_says_which_extra_to_install(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    for name in [m for m in sys.modules if m == "minatar" or m.startswith("minatar.")]:
        monkeypatch.delitem(sys.modules, name)
    monkeypatch.setitem(sys.modules, "minatar", None)  # import minatar: ImportError
    for build in (lambda: MinAtarBreakoutWorld(num_envs=1), lambda: make_world("minatar-breakout")):
        with pytest.raises(MissingDependencyError, match=r"noisybolt\[minatar\]") as error:
            build()
        assert (error.value.package, error.value.extra) == ("minatar", "minatar")
    out = tmp_path / "run"
    argv = ["train", "--world", "minatar-breakout", "--spec", "clear_left_column"]
    assert main([*argv, "--detector", "oracle", "--frames", "256", "--out", str(out)]) != 0
    assert not out.exists()


def test_importing_noisybolt_does_not_import_minatar() -> None:
    code = (
        "import sys, noisybolt, noisybolt.envs, noisybolt.envs.minatar; "
        "print('minatar' in sys.modules)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["False"]


@pytest.mark.parametrize("name", MODULES)
def test_docstring_examples_run_and_names_are_documented(name: str) -> None:
    module = importlib.import_module(name)
    assert module.__doc__
    for public in module.__all__:
        value = getattr(module, public)
        if callable(value):
            assert value.__doc__, f"{name}.{public} has no docstring"
    result = doctest.testmod(module, optionflags=doctest.ELLIPSIS)
    assert result.attempted > 0 and result.failed == 0


def test_single_game_env_is_the_world_of_one_and_shows_the_end() -> None:
    settings = {"seed": 5, "noise": "gaussian:sigma=20", "max_episode_steps": 40}
    env = MinAtarBreakoutEnv(**settings)
    world = make_minatar_breakout_world(num_envs=1, **settings)
    obs, first = env.reset(seed=5)
    want, info = world.reset(seed=5)
    np.testing.assert_array_equal(obs, want[0])
    np.testing.assert_array_equal(first["bolt_image"], np.asarray(info["bolt_image"])[0])
    rng = np.random.default_rng(0)
    for _ in range(50):
        action = int(rng.integers(0, 3))
        obs, reward, terminated, truncated, labels = env.step(action)
        w_obs, w_reward, w_term, w_trunc, info = world.step(np.array([action]))
        assert (reward, terminated, truncated) == (w_reward[0], w_term[0], w_trunc[0])
        if terminated or truncated:  # the game's last state, not the next game's first
            np.testing.assert_array_equal(obs, info["final_obs"][0])
            np.testing.assert_array_equal(labels["bolt_image"], world.final_bolt_images()[0])
            np.testing.assert_array_equal(labels["true_fluents"], world.final_true_fluents()[0])
            assert (env.render() == render_boards(obs[None].astype(bool), 16)[0]).all()
            break
        np.testing.assert_array_equal(obs, w_obs[0])
        np.testing.assert_array_equal(labels["bolt_image"], world.bolt_images()[0])
    else:
        pytest.fail("a random game should end within 40 steps")
    with pytest.raises(RuntimeError, match="reset"):
        env.step(0)
    with pytest.raises(ConfigError, match="render_mode"):
        MinAtarBreakoutEnv(render_mode="human")
    from gymnasium.utils.env_checker import check_env

    check_env(MinAtarBreakoutEnv(seed=0), skip_render_check=True)
    single = make_single_world("minatar-breakout", noise="gaussian:sigma=20", obs_mode=None)
    assert isinstance(single, MinAtarBreakoutEnv)


def test_a_short_bolted_training_runs_and_reports_the_specs(tmp_path: Path) -> None:
    """PPO on the paper's spec with its milestones and the ordering spec, a noisy camera
    and belief tracking, through the command line: a few thousand frames."""
    out = tmp_path / "run"
    argv = ["train", "--world", "minatar-breakout", "--algo", "ppo", "--seed", "0"]
    for spec in ("clear_left_column", "left_row0", "left_row1", "left_row2"):
        argv += ["--spec", spec]
    argv += ["--spec", "!half_wall_gone U brick_clear_left", "--spec-set", "name=left_first"]
    argv += ["--detector", "synthetic", "--noise", "gaussian:sigma=40", "--tracking", "belief"]
    argv += ["--frames", "3072", "--eval-freq", "0", "--eval-episodes", "4", "--no-progress"]
    with pytest.warns(UnseenFluentWarning, match="brick_clear_left"):  # random play
        assert main([*argv, "--out", str(out)]) == 0
    config = json.loads((out / "config.json").read_text())
    assert config["world"]["name"] == "minatar-breakout"
    metrics = json.loads((out / "metrics.json").read_text())
    assert set(metrics[-1]["compliance"]) >= {"clear_left_column", "left_first"}
    assert metrics[-1]["frames"] >= 3072


def test_a_classifier_learns_the_fluents_from_the_noisy_camera() -> None:
    """The classifier a run trains on the fly (its architecture for this camera) tells
    every fluent from the grainy picture, and one brick of the left column from another:
    the bottom two gone and the top one standing is not the column cleared (a classifier
    that averaged the wall's rows together took it for that, and a bolted agent was paid
    for it)."""
    from noisybolt.perception.metrics import build_report
    from noisybolt.perception.training import TrainingConfig, train_classifier
    from noisybolt.runs.detectors import classifier_architecture

    noise = "gaussian:sigma=40"
    world = MinAtarBreakoutWorld(num_envs=16, seed=0, noise=noise)
    architecture = classifier_architecture(world.camera_spec)
    assert (architecture.patch, architecture.pool) == (4, 10)
    train = collect_samples(world, num_samples=3000, seed=0)
    result = train_classifier(
        train, config=architecture, training=TrainingConfig(epochs=20, seed=0), progress=False
    )
    world = MinAtarBreakoutWorld(num_envs=16, seed=1, noise=noise)
    test = collect_samples(world, num_samples=600, seed=1)
    report = build_report(
        result.detector.predict(test.images), test.labels, fluent_names=test.fluent_names
    )
    for name in FLUENT_NAMES:
        assert report[name].auroc > 0.99, name
    rng = np.random.default_rng(0)
    boards = np.zeros((64, 10, 10, 4), bool)
    boards[:, 1:4, :, BRICK_CHANNEL] = True
    boards[:, 2:4, 0, BRICK_CHANNEL] = False  # the left column's bottom two bricks gone
    boards[np.arange(64), 9, rng.integers(0, 10, 64), 0] = True  # paddles
    boards[np.arange(64), rng.integers(4, 9, 64), rng.integers(0, 10, 64), 1] = True  # balls
    truth = minatar_fluents(boards)
    assert truth[0].tolist() == [False, False, True, True, False]
    images = noisy_images(render_boards(boards, 4), make_noise(noise).apply, [rng] * 64)
    seen = result.detector.predict(images) >= 0.5
    assert (seen == truth).mean(axis=0).min() >= 0.95
