"""MinAtar Breakout's board: where the wall lives, and the bolt's fluents read from it.

MinAtar's Breakout (Young & Tian 2019) is played on a 10x10 grid whose state is a bool
``[10, 10, 4]`` array, one channel each for the paddle, the ball, the ball's trail (where
it was one step before) and the bricks (:data:`CHANNELS`). The wall is 3 rows of 10
bricks, grid rows 1 to 3 (:data:`BRICK_ROWS`); a brick the ball hits is gone, and when
every brick is gone a new wall of 30 is put up the next time the ball reaches the
paddle's row. The fluents, all read from the brick channel of a board
(:func:`minatar_fluents`):

* ``brick_clear_left``: the three bricks of the leftmost column are gone (the paper's
  Breakout fluent, as on ALE Breakout);
* ``left_gone_row0`` .. ``left_gone_row2``: that brick row's (0 = top) leftmost brick is
  gone: the milestones on the way to ``brick_clear_left``, named as on ALE Breakout so
  that the built-in specs ``left_row0`` .. ``left_row2`` read them;
* ``half_wall_gone``: at least half of the wall's 30 bricks are gone, for an ordering
  spec that only steering satisfies, e.g. ``!half_wall_gone U brick_clear_left`` (the left
  column cleared before half the wall is gone).

A new wall brings every brick back, and with it every fluent to false; by then every
``F`` spec over them has long been accepted.

Example:
    >>> boards = np.zeros((1, 10, 10, 4), bool)
    >>> boards[0, 1:4, :, BRICK_CHANNEL] = True  # a whole wall
    >>> boards[0, 1:4, 0, BRICK_CHANNEL] = False  # but for the left column
    >>> minatar_fluents(boards).astype(int).tolist()  # FLUENT_NAMES' order
    [[1, 1, 1, 1, 0]]
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "BOARD_SIDE",
    "BRICK_CHANNEL",
    "BRICK_COLUMNS",
    "BRICK_ROWS",
    "CHANNELS",
    "FLUENT_NAMES",
    "LEFT_ROW_FLUENTS",
    "WALL_BRICKS",
    "bricks_present",
    "minatar_fluents",
]

#: Side of MinAtar's square grid.
BOARD_SIDE = 10
#: MinAtar Breakout's state channels, in their order in the board's last axis.
CHANNELS: tuple[str, ...] = ("paddle", "ball", "trail", "brick")
BRICK_CHANNEL = CHANNELS.index("brick")
#: The grid rows that hold the wall, top first.
BRICK_ROWS: tuple[int, ...] = (1, 2, 3)
BRICK_COLUMNS = BOARD_SIDE
#: Bricks in a whole wall.
WALL_BRICKS = len(BRICK_ROWS) * BRICK_COLUMNS

#: ``left_gone_row{r}``: the wall's row ``r`` (0 = top) has lost its leftmost brick.
LEFT_ROW_FLUENTS: tuple[str, ...] = tuple(f"left_gone_row{r}" for r in range(len(BRICK_ROWS)))
#: Every MinAtar Breakout fluent, in the column order of :func:`minatar_fluents`.
FLUENT_NAMES: tuple[str, ...] = ("brick_clear_left", *LEFT_ROW_FLUENTS, "half_wall_gone")


def bricks_present(boards: np.ndarray) -> np.ndarray:
    """bool ``[..., 3, 10]``: which bricks of the wall stand, for boards ``[..., 10, 10, 4]``.

    Example:
        >>> board = np.zeros((10, 10, 4), bool)
        >>> board[2, 5, BRICK_CHANNEL] = True
        >>> np.argwhere(bricks_present(board)).tolist()
        [[1, 5]]
    """
    boards = np.asarray(boards)
    if boards.shape[-3:] != (BOARD_SIDE, BOARD_SIDE, len(CHANNELS)):
        raise ValueError(
            f"a MinAtar Breakout board is [..., {BOARD_SIDE}, {BOARD_SIDE}, {len(CHANNELS)}], "
            f"got {boards.shape}"
        )
    return boards[..., BRICK_ROWS[0] : BRICK_ROWS[-1] + 1, :, BRICK_CHANNEL].astype(bool)


def minatar_fluents(boards: np.ndarray) -> np.ndarray:
    """bool ``[n, 5]``: every fluent of :data:`FLUENT_NAMES` for boards ``[n, 10, 10, 4]``."""
    present = bricks_present(boards)  # [n, rows, columns]
    left_gone = ~present[..., :, 0]  # [n, rows]
    gone = WALL_BRICKS - present.sum(axis=(-1, -2))  # [n]
    clear = np.asarray(left_gone.all(axis=-1))  # [n]
    half = np.asarray(2 * gone >= WALL_BRICKS)  # [n]
    return np.concatenate([clear[..., None], left_gone, half[..., None]], axis=-1)
