"""A world's declared grid: the agent's cell in ``info`` and heat-maps of any grid world."""

from __future__ import annotations

from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import noisybolt
from noisybolt.envs.gridworld import GridworldEnv
from noisybolt.envs.layout import GridLayout
from noisybolt.errors import ConfigError
from noisybolt.perception.protocols import GRID_POSITION_KEY
from noisybolt.viz import record_episode, trajectory_heatmap, visit_counts


def _lake_cell(env: object) -> tuple[int, int]:
    s = int(env.s)  # type: ignore[attr-defined]
    return (s % 4, s // 4)


def _lake(grid: GridLayout | None) -> noisybolt.FluentLabels:
    env = gym.make("FrozenLake-v1", render_mode="rgb_array", is_slippery=False)
    return noisybolt.FluentLabels(env, fluents={"top_row": lambda e: e.s < 4}, grid=grid)


LAKE = GridLayout(width=4, height=4, position=_lake_cell, goal=(3, 3), start=(0, 0))


@pytest.mark.parametrize(
    ("kwargs", "needle"),
    [
        ({"width": 0}, "width must be a positive integer"),
        ({"height": True}, "height must be a positive integer"),
        ({"position": 3}, "position must be a function"),
        ({"goal": (4, 0)}, "the goal (4, 0) is outside the 4x4 grid"),
        ({"start": (0, -1)}, "the start (0, -1) is outside"),
        ({"marks": {"corner": (1, 2, 3)}}, "mark 'corner' must be an (x, y) cell"),
        ({"goal": (1.5, 2)}, "pair of integers"),
    ],
)
def test_a_malformed_layout_is_refused_by_name(kwargs: dict, needle: str) -> None:
    settings = {"width": 4, "height": 4, "position": _lake_cell, **kwargs}
    with pytest.raises(ConfigError, match=None) as caught:
        GridLayout(**settings)
    assert needle in str(caught.value)


def test_labelled_lake_reports_the_cell_each_step_as_its_state_says() -> None:
    env = _lake(LAKE)
    assert env.get_wrapper_attr("grid_layout") is LAKE
    _, info = env.reset(seed=0)
    cells = [info[GRID_POSITION_KEY]]
    for action in (1, 1, 2, 2):  # down, down, right, right: states 4, 8, 9, 10
        *_, info = env.step(action)
        cells.append(info[GRID_POSITION_KEY])
    assert cells == [(0, 0), (0, 1), (0, 2), (1, 2), (2, 2)]


def test_the_grid_leaves_the_wrapped_env_and_the_other_labels_as_they_were() -> None:
    plain, gridded = _lake(None), _lake(LAKE)
    _, a = plain.reset(seed=3)
    _, b = gridded.reset(seed=3)
    assert b[GRID_POSITION_KEY] == (0, 0)
    assert GRID_POSITION_KEY not in a
    for action in (2, 1, 1, 0, 3):
        ra = plain.step(action)
        rb = gridded.step(action)
        assert ra[:4] == rb[:4]
        assert np.array_equal(ra[4]["true_fluents"], rb[4]["true_fluents"])
        assert np.array_equal(ra[4]["bolt_image"], rb[4]["bolt_image"])
        assert set(rb[4]) - set(ra[4]) == {GRID_POSITION_KEY}


def test_a_position_outside_the_grid_is_caught_at_reset() -> None:
    wrong = GridLayout(width=2, height=2, position=_lake_cell)
    env = _lake(wrong)
    env.reset(seed=0)  # (0, 0) fits
    with pytest.raises(ConfigError, match=r"agent's cell.*\(2, 0\) is outside the 2x2 grid"):
        for _ in range(2):
            env.step(2)  # right, right: (2, 0)


def test_grid_must_be_a_layout() -> None:
    with pytest.raises(ConfigError, match=r"grid must be a noisybolt\.GridLayout"):
        _lake((4, 4))  # type: ignore[arg-type]


def test_gridworld_declares_its_room_and_reports_agent_pos() -> None:
    env = GridworldEnv(size=6)
    layout = env.grid_layout
    assert (layout.width, layout.height, layout.walls) == (6, 6, True)
    assert layout.goal == (4, 4) and layout.start == (1, 1)
    assert layout.marks == {"top-right": (4, 1), "bottom-left": (1, 4)}
    _, info = env.reset(seed=0)
    assert info[GRID_POSITION_KEY] == (1, 1)
    *_, info = env.step(2)  # forward, facing east
    assert info[GRID_POSITION_KEY] == (2, 1) == tuple(env.agent_pos)


def test_visit_counts_on_a_wide_grid_by_hand() -> None:
    wide = GridLayout(width=3, height=2, position=_lake_cell)
    episodes = [[(0, 0), (1, 0), (1, 0), (2, 1)], [(0, 0), (0, 1)]]
    assert visit_counts(episodes, size=wide).tolist() == [[2, 2, 0], [1, 0, 1]]
    assert visit_counts(episodes, size=wide, per_episode=True).tolist() == [[2, 1, 0], [1, 0, 1]]
    with pytest.raises(ConfigError, match=r"cell \(0, 2\) is outside a 3x2 room"):
        visit_counts([[(0, 2)]], size=wide)


def test_recorded_lake_episode_carries_the_declared_cells(tmp_path: Path) -> None:
    env = noisybolt.RestrainingBoltWrapper(_lake(LAKE), ["G(!top_row)"], "oracle")
    actions = iter([1, 1, 2, 2, 1, 2])  # down the left column, then along to the goal
    recording = record_episode(env, lambda obs: next(actions), seed=0)
    assert recording.positions is not None
    assert recording.positions.tolist() == [
        [0, 0], [0, 1], [0, 2], [1, 2], [2, 2], [2, 3], [3, 3]
    ]  # fmt: skip
    path = trajectory_heatmap(
        [recording.positions.tolist()], layout=LAKE, path=tmp_path / "lake.png", draw_paths=True
    )
    assert path.read_bytes()[:4] == b"\x89PNG"


def test_heatmap_takes_exactly_one_room(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="exactly one"):
        trajectory_heatmap([[(1, 1)]], size=6, layout=LAKE, path=tmp_path / "a.png")
    with pytest.raises(ConfigError, match="exactly one"):
        trajectory_heatmap([[(1, 1)]], path=tmp_path / "b.png")
    assert not (tmp_path / "a.png").exists() and not (tmp_path / "b.png").exists()
