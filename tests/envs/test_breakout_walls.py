"""``scripts/breakout_walls.py``: the wall at a game's end, read from the console's RAM as
each game ended (``BreakoutWorld.ended_rams``), for image and RAM players alike."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from types import ModuleType

import numpy as np
import pytest

from noisybolt.envs.breakout import (
    BRICK_COLUMNS,
    BRICK_ROWS,
    BreakoutWorld,
    breakout_fluents,
    bricks_present,
)
from noisybolt.runs import train
from noisybolt.runs.config import TrainConfig

#: Points per brick, top row first (Breakout's red, orange, yellow, green, aqua, blue).
ROW_POINTS = np.array([7, 7, 4, 4, 1, 1])


@pytest.fixture
def script(load_script: Callable[..., ModuleType]) -> ModuleType:
    return load_script("scripts/breakout_walls.py")


def test_the_ended_games_ram_is_the_twins_at_that_step() -> None:
    # Two worlds from one seed, one truncating its games after 40 emulator frames (10
    # steps): at the 10th step the short world's ended games' RAM is the twin's RAM then,
    # and its own RAM is a new game's.
    settings = {"num_envs": 2, "seed": 0, "noop_max": 0, "repeat_action_probability": 0.0}
    short = BreakoutWorld(max_episode_frames=40, **settings)
    twin = BreakoutWorld(**settings)
    try:
        short.reset(seed=0)
        twin.reset(seed=0)
        assert short.ended_rams() == {}
        rng = np.random.default_rng(0)
        for _ in range(10):
            actions = rng.integers(0, 4, size=2)
            short.step(actions)
            twin.step(actions)
        ended = short.ended_rams()
        assert sorted(ended) == [0, 1]
        for i in range(2):
            np.testing.assert_array_equal(ended[i], twin.rams()[i])
        np.testing.assert_array_equal(
            breakout_fluents(np.stack([ended[0], ended[1]])), short.final_true_fluents()
        )
        assert bricks_present(short.rams()).all()  # the new games' walls are whole
        ended[0][:] = 0  # a copy: the world keeps its own
        assert short.ended_rams()[0].any()
        short.step(np.zeros(2, dtype=int))
        assert short.ended_rams() == {}
    finally:
        short.close()
        twin.close()


@pytest.mark.filterwarnings("ignore::noisybolt.errors.UnseenFluentWarning")
def test_a_trained_image_run_s_walls_match_its_scores(script: ModuleType, tmp_path: Path) -> None:
    # A few hundred frames of the image agent, games cut at 100 steps: each game's wall as
    # read back must account for its score, brick by brick (7, 7, 4, 4, 1, 1 points per
    # row, top first; no game this short clears a wall).
    config = TrainConfig.build(
        {
            "world.name": "breakout",
            "world.n_envs": 2,
            "world.kwargs": {"max_episode_frames": 400},
            "bolt.specs": ["F(brick_clear_left)"],
            "bolt.reward": "paper",
            "detector.kind": "oracle",
            "frames": 64,
            "evaluation.freq": 0,
            "evaluation.episodes": 1,
            "progress_bar": False,
            "algorithm.hyperparams.n_steps": 16,
            "algorithm.hyperparams.batch_size": 32,
        }
    )
    out = tmp_path / "run"
    train(config, out, log=lambda _: None)
    games = script.final_walls(out, episodes=3, seed=0, stochastic=True)
    assert len(games) == 3
    for score, gone in games:
        assert gone.shape == (BRICK_ROWS, BRICK_COLUMNS) and gone.dtype == bool
        assert score == float(ROW_POINTS @ gone.sum(axis=1))
    assert script.report(games, lines=False).startswith("3 games, score ")
    flat = tmp_path / "gridworld"
    train(
        TrainConfig.build(
            {
                "frames": 64,
                "evaluation.freq": 0,
                "progress_bar": False,
                "detector.kind": "oracle",
                "bolt.specs": ["edge"],
                "algorithm.hyperparams.n_steps": 32,
                "world.n_envs": 2,  # one rollout of 2 x 32 within the budget
            }
        ),
        flat,
        log=lambda _: None,
    )
    with pytest.raises(SystemExit, match="only Breakout runs"):
        script.final_walls(flat, episodes=1, seed=0, stochastic=False)


def test_the_report_counts_rows_and_left_bricks_by_hand(script: ModuleType) -> None:
    first = np.zeros((BRICK_ROWS, BRICK_COLUMNS), dtype=bool)
    first[:, 0] = True  # the left column cleared, nothing else
    second = np.zeros_like(first)
    second[0, 5:14] = True  # half the top row, away from the left
    second[5, 0] = True  # and the bottom left brick
    text = script.report([(100.0, first), (50.0, second)], lines=True)
    lines = text.splitlines()
    assert lines[0] == "2 games, score 75.0 ± 25.0"
    # row 0: (1 + 9) of 36 bricks gone = 28 %; its left brick in 1 of 2 games
    assert lines[2] == "  0: 28% | 50%"
    assert lines[3] == "  1: 3% | 50%"  # 1 of 36
    assert lines[7] == "  5: 6% | 100%"  # 2 of 36
    assert lines[8] == (
        "games that took any brick of row 0: 100%, of row 1: 50%; cleared the column: 50%"
    )
    assert lines[-1] == "   50 | .....#########.... | .................. | .....#"
