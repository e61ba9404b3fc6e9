"""``scripts/breakout_walls.py``: the wall at a game's end, read from a RAM agent's last
observation."""

from __future__ import annotations

from collections.abc import Callable
from types import ModuleType

import numpy as np
import pytest

from noisybolt.envs import make_world
from noisybolt.envs.breakout import BRICK_COLUMNS, BRICK_ROWS


@pytest.fixture
def script(load_script: Callable[..., ModuleType]) -> ModuleType:
    return load_script("scripts/breakout_walls.py")


@pytest.mark.parametrize("obs_mode", ["ram", "ram_bits"])
def test_the_ram_is_read_back_from_either_observation(script: ModuleType, obs_mode: str) -> None:
    world = make_world("breakout-ram", num_envs=2, seed=3, obs_mode=obs_mode)
    try:
        obs, _ = world.reset(seed=3)
        for _ in range(30):
            obs, *_ = world.step(np.array([1, 3]))
        rams = world.rams()
        for i in range(2):
            assert np.array_equal(script.ram_of(obs[i]), rams[i])
    finally:
        world.close()
    with pytest.raises(SystemExit, match="only breakout-ram runs"):
        script.ram_of(np.zeros((84, 84, 3)))


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
