"""The bolt's camera on MinAtar Breakout: the board drawn in colour, and the camera's noise.

MinAtar has no screen of its own: its state is the board, bool ``[10, 10, 4]``. The bolt's
camera draws it (:func:`render_boards`): each cell a ``tile_size`` square of one colour
(:data:`PALETTE`: black floor, red bricks, a white ball with a grey trail, a blue paddle),
then adds its own seeded noise, each game's from its own generator
(:func:`noisy_images`); the noise is given as on ALE Breakout
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

#: The colour of a cell by what is in it (an empty cell is black); where several things
#: share a cell, the later one in this order is drawn: the ball over its trail and a brick.
PALETTE: dict[str, tuple[int, int, int]] = {
    "trail": (110, 110, 110),
    "paddle": (66, 114, 228),
    "brick": (200, 72, 72),
    "ball": (255, 255, 255),
}
_ORDER = tuple(CHANNELS.index(name) for name in PALETTE)  # board channel of each colour
_COLOURS = np.array([(0, 0, 0), *PALETTE.values()], np.uint8)  # [1 + colours, 3]


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
    return np.repeat(np.repeat(cells, tile_size, axis=1), tile_size, axis=2)


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
