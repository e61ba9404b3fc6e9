"""The tile compositor draws MiniGrid's pictures pixel for pixel, for whole batches."""

from __future__ import annotations

import doctest
import itertools

import numpy as np
import pytest

import noisybolt.perception.cameras as cameras
from noisybolt.envs.gridworld import GridworldCamera, GridworldEnv, room_compositor
from noisybolt.errors import ConfigError
from noisybolt.perception.cameras import TileCompositor


def every_state(size: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    states = list(itertools.product(range(1, size - 1), range(1, size - 1), range(4)))
    x, y, d = (np.array(v) for v in zip(*states, strict=True))
    return x, y, d


@pytest.mark.parametrize(("size", "tile_size"), [(6, 8), (6, 32), (5, 3), (7, 11)])
def test_camera_equals_minigrid_get_frame_in_every_state(size: int, tile_size: int) -> None:
    x, y, d = every_state(size)  # the goal cell included: terminal frames
    ours = GridworldCamera(size=size, tile_size=tile_size).render(x, y, d)
    env = GridworldEnv(size=size)
    env.reset(seed=0)
    for i in range(len(x)):
        env.agent_pos, env.agent_dir = (int(x[i]), int(y[i])), int(d[i])
        theirs = env.get_frame(highlight=False, tile_size=tile_size)
        assert np.array_equal(ours[i], theirs), (x[i], y[i], d[i])


def test_render_layouts_agrees_with_render_sprites() -> None:
    comp = room_compositor(6, 8)
    x, y, d = every_state(6)
    sprites = comp.render_sprites(np.where((x == 4) & (y == 4), 7, 3) + d, rows=y, cols=x)
    grid = np.array([[1, 1, 1, 1, 1, 1]] + [[1, 0, 0, 0, 0, 1]] * 4 + [[1] * 6])
    grid[4, 4] = 2  # the goal
    assert np.array_equal(comp.render_layouts(grid[None])[0], comp.background)
    many = np.repeat(grid[None], len(x), axis=0)
    many[np.arange(len(x)), y, x] = np.where((x == 4) & (y == 4), 7, 3) + d
    assert np.array_equal(comp.render_layouts(many), sprites)


def test_several_sprites_and_an_output_buffer() -> None:
    tiles = np.arange(3, dtype=np.uint8)[:, None, None, None] * np.ones((3, 2, 2, 1), np.uint8)
    comp = TileCompositor(tiles, layout=np.zeros((2, 2), dtype=int))
    out = np.full((1, 4, 4, 1), 99, dtype=np.uint8)
    got = comp.render_sprites(
        np.array([[1, 2]]), rows=np.array([[0, 1]]), cols=np.array([[1, 0]]), out=out
    )
    assert got is out
    assert got[0, :, :, 0].tolist() == [[0, 0, 1, 1], [0, 0, 1, 1], [2, 2, 0, 0], [2, 2, 0, 0]]
    assert comp.grid_shape == (2, 2) and comp.image_shape == (4, 4, 1)


@pytest.mark.slow  # a timing: the default suite asserts no speeds (benchmarks/ measure them)
def test_compositor_is_fast_enough_to_matter() -> None:
    # The benchmark measures it properly; here only a floor far below it (~1e6 frames/s).
    import time

    cam = GridworldCamera(size=6, tile_size=8)
    x, y, d = (np.full(64, v) for v in (1, 2, 3))
    start = time.perf_counter()
    for _ in range(50):
        cam.render(x, y, d)
    assert 50 * 64 / (time.perf_counter() - start) > 13_000


@pytest.mark.parametrize(
    ("tiles", "layout", "match"),
    [
        (np.zeros((2, 4, 4, 3), dtype=np.float32), np.zeros((2, 2), int), "uint8"),
        (np.zeros((4, 4, 3), dtype=np.uint8), np.zeros((2, 2), int), "uint8"),
        (np.zeros((2, 4, 4, 3), dtype=np.uint8), np.zeros(4, int), "layout"),
        (np.zeros((2, 4, 4, 3), dtype=np.uint8), np.full((2, 2), 2), "outside"),
    ],
)
def test_bad_atlas_or_layout(tiles: np.ndarray, layout: np.ndarray, match: str) -> None:
    with pytest.raises(ConfigError, match=match):
        TileCompositor(tiles, layout=layout)


def test_layouts_of_the_wrong_shape_are_refused() -> None:
    with pytest.raises(ConfigError, match="layouts"):
        room_compositor(6, 2).render_layouts(np.zeros((1, 5, 6), int))


def test_public_api_and_docstring_examples() -> None:
    assert cameras.__all__ == ["TileCompositor"]
    assert doctest.testmod(cameras).failed == 0
