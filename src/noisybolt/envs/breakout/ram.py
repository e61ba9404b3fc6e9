"""Breakout's console RAM: where the wall lives, and the bolt's fluents read from it.

* fluent ``brick_clear_left``: every brick of the leftmost ``left_columns`` brick
  column(s) is gone, read from RAM (:func:`bricks_present`, :func:`left_columns_clear`);
* fluents ``left_gone_row0`` .. ``left_gone_row5``: the brick of that row (0 = top) in
  the leftmost column is gone: the milestones on the way to ``brick_clear_left``, so that
  a bolt can reward progress the agent can actually make (``F(brick_clear_left)`` alone
  pays nothing until the whole column is gone, which random play never achieves).

RAM layout of the wall (verified by poking every bit with ``ale.setRAM`` and diffing the
rendered frame; ``tests/envs/test_breakout.py`` re-checks it brick by brick). Bytes 0-35
hold the wall (OCAtari's Breakout reads ``ram[0:36]``; the AtariARI map of Anand et al.
2019 lists only bytes 0-29 and so misses the leftmost column). They form six groups of six
bytes, one byte per brick row, the row's byte at ``group_base + 5 - row`` (row 0 is the
top, red row at y 57-62; row 5 the bottom, blue row at y 87-92; 6 pixels per row). Each
brick is 8 pixels wide and owns two bits, one per 4-pixel playfield cell; the columns,
left to right (x = 8 + 8 * column), are in :data:`BRICK_BITS`. The leftmost column is
bits 6-7 of bytes 30-35, so it is clear iff ``ram[30 + i] & 0xC0 == 0`` for i in 0..5.
Caveat: during the first 36 frames after ``reset_game`` the game is still setting up
the wall and overwrites any pokes (measured: pokes at frame 36 are undone, at frame 37
they stay); :meth:`~noisybolt.envs.breakout.world.BreakoutWorld.sample_collection_states`
waits for that.

Example:
    >>> ram = np.zeros(128, np.uint8)
    >>> ram[30:36] = 0xC0  # the leftmost column standing
    >>> int(bricks_present(ram).sum()), brick_box(0, 0)
    (6, (slice(57, 63, None), slice(8, 16, None)))
"""

from __future__ import annotations

import ale_py
import numpy as np

from noisybolt.errors import ConfigError

__all__ = [
    "BRICK_BITS",
    "BRICK_COLUMNS",
    "BRICK_ROWS",
    "FLUENT_NAMES",
    "LEFT_ROW_FLUENTS",
    "MAX_BRICKS",
    "MAX_SCORE",
    "RAM_SIZE",
    "breakout_fluents",
    "brick_box",
    "bricks_present",
    "left_columns_clear",
    "set_bricks",
]

#: The most points a game of Breakout can score: two walls of 432 (see return_bounds).
MAX_SCORE = 864.0
#: The bricks of a game: two walls of 6 rows of 18 (see clipped_return_bounds).
MAX_BRICKS = 216

BRICK_ROWS = 6
#: ``left_gone_row{r}``: the leftmost column's brick of row ``r`` (0 = top) is gone.
LEFT_ROW_FLUENTS: tuple[str, ...] = tuple(f"left_gone_row{r}" for r in range(BRICK_ROWS))
#: Every Breakout fluent, in the column order of :func:`breakout_fluents`.
FLUENT_NAMES: tuple[str, ...] = ("brick_clear_left", *LEFT_ROW_FLUENTS)
BRICK_COLUMNS = 18
RAM_SIZE = 128

#: ``(byte group base, bit mask)`` of each brick column, left to right; a brick of row
#: ``r`` (0 = top) lives in ``ram[base + 5 - r] & mask``. Measured, see the module doc.
BRICK_BITS: tuple[tuple[int, int], ...] = (
    (30, 0xC0),
    (24, 0xC0), (24, 0x30), (24, 0x0C), (24, 0x03),
    (18, 0x03), (18, 0x0C), (18, 0x30), (18, 0xC0),
    (12, 0x30), (12, 0xC0),
    (6, 0xC0), (6, 0x30), (6, 0x0C), (6, 0x03),
    (0, 0x03), (0, 0x0C), (0, 0x30),
)  # fmt: skip

# byte index and mask of every brick, as [rows, columns] arrays for vectorised reads.
_BRICK_BYTE = np.array(
    [[base + 5 - row for base, _ in BRICK_BITS] for row in range(BRICK_ROWS)], dtype=np.intp
)
_BRICK_MASK = np.array(
    [[mask for _, mask in BRICK_BITS] for _ in range(BRICK_ROWS)], dtype=np.uint8
)


def brick_box(row: int, column: int) -> tuple[slice, slice]:
    """``(y slice, x slice)`` of a brick in the 210x160 frame."""
    if not (0 <= row < BRICK_ROWS and 0 <= column < BRICK_COLUMNS):
        raise ValueError(f"no brick at row {row}, column {column}")
    return slice(57 + 6 * row, 63 + 6 * row), slice(8 + 8 * column, 16 + 8 * column)


def bricks_present(ram: np.ndarray) -> np.ndarray:
    """bool ``[..., 6, 18]``: which bricks are (at least partly) standing.

    Args:
        ram: uint8 ``[..., 128]`` Breakout RAM (one or a batch of consoles).
    """
    ram = np.asarray(ram)
    return (ram[..., _BRICK_BYTE] & _BRICK_MASK) != 0


def left_columns_clear(ram: np.ndarray, left_columns: int = 1) -> np.ndarray:
    """bool ``[...]``: every brick of the leftmost ``left_columns`` columns is gone.

    Example:
        >>> ram = np.zeros(128, np.uint8)
        >>> ram[30:36] = 0xC0  # the leftmost column standing
        >>> bool(left_columns_clear(ram)), bool(left_columns_clear(ram & 0x3F))
        (False, True)
    """
    if not 1 <= left_columns <= BRICK_COLUMNS:
        raise ConfigError(f"left_columns must be in 1..{BRICK_COLUMNS}, got {left_columns}")
    return np.asarray(~bricks_present(ram)[..., :left_columns].any(axis=(-1, -2)))


def breakout_fluents(ram: np.ndarray, left_columns: int = 1) -> np.ndarray:
    """bool ``[n, 7]``: every fluent of :data:`FLUENT_NAMES` for RAMs ``[n, 128]``.

    Example:
        >>> ram = np.zeros((1, 128), np.uint8)
        >>> ram[0, 30:36] = 0xC0  # the leftmost column standing ...
        >>> ram[0, 30 + 5 - 4] = 0  # ... but for its brick in row 4
        >>> breakout_fluents(ram).astype(int).tolist()
        [[0, 0, 0, 0, 0, 1, 0]]
    """
    gone = ~bricks_present(ram)[..., :, 0]  # [n, rows]: the leftmost column
    return np.concatenate([left_columns_clear(ram, left_columns)[..., None], gone], axis=-1)


def set_bricks(ale: ale_py.ALEInterface, present: np.ndarray) -> None:
    """Writes a whole wall (bool ``[6, 18]``) into a console's RAM.

    The frame shows it from the next emulated frame on; during the first 36 frames of a
    game the game's own wall set-up overwrites it.
    """
    present = np.asarray(present, dtype=bool)
    if present.shape != (BRICK_ROWS, BRICK_COLUMNS):
        raise ValueError(f"a wall is bool [{BRICK_ROWS}, {BRICK_COLUMNS}], got {present.shape}")
    ram = ale.getRAM()
    values = {int(b): int(ram[b]) for b in np.unique(_BRICK_BYTE)}
    for (row, column), mask in np.ndenumerate(_BRICK_MASK):
        byte = int(_BRICK_BYTE[row, column])
        values[byte] = (
            (values[byte] | int(mask))
            if present[row, column]
            else (values[byte] & ~int(mask) & 0xFF)
        )
    for byte, value in values.items():
        if value != ram[byte]:
            ale.setRAM(byte, value)
