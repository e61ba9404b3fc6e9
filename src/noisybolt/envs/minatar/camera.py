"""The bolt's camera on MinAtar Breakout: the board drawn in colour, and the camera's noise.

MinAtar has no screen of its own: its state is the board, bool ``[10, 10, 4]``. The bolt's
camera draws it (:func:`render_boards`): each cell a ``tile_size`` square of one colour
(:data:`PALETTE`: black floor, red bricks, a grey trail, a blue paddle), the ball a white
square in the middle of its cell with the cell's own colour around it (MinAtar lets the
ball pass into a brick's cell when it hits two bricks in a row, and a ball drawn over the
whole cell would hide that brick from the bolt), then adds its own seeded noise, each
game's from its own generator (:func:`noisy_images`); the noise is given as on ALE Breakout
(:func:`~noisybolt.envs.breakout.camera.resolve_noise`: a
:mod:`noisybolt.perception.noise` spec, model or callable), e.g.
``"gaussian:sigma=40+occlusion:count=1,size=0.25"`` for grain and a grey patch that can
hide the left column.

Example:
    >>> boards = np.zeros((2, 10, 10, 4), bool)
    >>> boards[:, 9, 4, 0] = True  # the paddle
    >>> images = render_boards(boards, tile_size=4)
    >>> images.shape, images[0, 36, 16].tolist(), images[0, 0, 0].tolist()
    ((2, 40, 40, 3), [66, 114, 228], [0, 0, 0])
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from noisybolt.envs.breakout.camera import NoiseFn
from noisybolt.envs.minatar.board import BOARD_SIDE, CHANNELS
from noisybolt.perception.noise import NoiseModel

__all__ = ["PALETTE", "noisy_images", "render_boards"]

#: The colour of what is in a cell (an empty cell is black). A cell is drawn in the colour
#: of the last of trail, paddle and brick it holds; the ball is drawn over the middle of
#: its cell only (see the module docs).
PALETTE: dict[str, tuple[int, int, int]] = {
    "trail": (110, 110, 110),
    "paddle": (66, 114, 228),
    "brick": (200, 72, 72),
    "ball": (255, 255, 255),
}
_CELLS = ("trail", "paddle", "brick")  # drawn over the whole cell, later over earlier
_ORDER = tuple(CHANNELS.index(name) for name in _CELLS)  # their board channels
_COLOURS = np.array([(0, 0, 0), *(PALETTE[name] for name in _CELLS)], np.uint8)
_BALL = CHANNELS.index("ball")


def render_boards(boards: np.ndarray, tile_size: int) -> np.ndarray:
    """uint8 ``[n, 10 * tile_size, 10 * tile_size, 3]``: boards ``[n, 10, 10, 4]`` drawn
    as :data:`PALETTE` says, each cell a ``tile_size`` square."""
    boards = np.asarray(boards, dtype=bool)
    if boards.ndim != 4 or boards.shape[1:] != (BOARD_SIDE, BOARD_SIDE, len(CHANNELS)):
        raise ValueError(f"boards must be bool [n, 10, 10, 4], got {boards.shape}")
    colour = np.zeros(boards.shape[:3], np.intp)  # [n, 10, 10]: index into _COLOURS
    for index, channel in enumerate(_ORDER, start=1):
        colour[boards[..., channel]] = index
    cells = _COLOURS[colour]  # [n, 10, 10, 3]
    images = np.repeat(np.repeat(cells, tile_size, axis=1), tile_size, axis=2)
    ball = np.repeat(np.repeat(boards[..., _BALL], tile_size, axis=1), tile_size, axis=2)
    margin = tile_size // 4  # of 4 pixels: the middle 2x2; of 1 to 3: all of them
    middle = np.zeros((tile_size, tile_size), bool)
    middle[margin : tile_size - margin, margin : tile_size - margin] = True
    images[ball & np.tile(middle, (BOARD_SIDE, BOARD_SIDE))] = PALETTE["ball"]
    return images


def noisy_images(
    images: np.ndarray, noise: NoiseFn | None, rngs: Sequence[np.random.Generator]
) -> np.ndarray:
    """``images`` (uint8 ``[n, H, W, 3]``) with the camera's ``noise``, image ``j``'s from
    ``rngs[j]`` (so a game looks the same whatever else is captured with it); a noise
    model draws them in one batch (``apply_each``).

    Raises:
        ValueError: a noise that does not keep uint8 images of the same shape.
    """
    if noise is None:
        return images
    owner = getattr(noise, "__self__", None)
    if isinstance(owner, NoiseModel):
        out = np.asarray(owner.apply_each(images, list(rngs)))
    else:
        out = np.concatenate(
            [np.asarray(noise(images[j : j + 1], rng)) for j, rng in enumerate(rngs)]
        )
    if out.dtype != np.uint8 or out.shape != images.shape:
        raise ValueError(
            f"the camera noise returned {out.dtype} {out.shape}; it must keep uint8 images "
            "of the same shape"
        )
    return out
