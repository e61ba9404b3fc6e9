"""Atari Breakout as a vectorised world for the restraining bolt (see
:mod:`noisybolt.envs.breakout.world`).

Example:
    >>> world = make_breakout_world(num_envs=1, seed=0)
    >>> world.fluent_names[0]
    'brick_clear_left'
"""

from noisybolt.envs.breakout.world import (
    BRICK_BITS,
    BRICK_COLUMNS,
    BRICK_ROWS,
    FLUENT_NAMES,
    LEFT_ROW_FLUENTS,
    MAX_BRICKS,
    MAX_SCORE,
    OBS_MODES,
    BreakoutEnv,
    BreakoutWorld,
    NoiseFn,
    area_resize_84,
    breakout_fluents,
    brick_box,
    bricks_present,
    left_columns_clear,
    make_breakout_ram_env,
    make_breakout_ram_world,
    make_breakout_world,
    resolve_noise,
    set_bricks,
)

__all__ = [
    "BRICK_BITS",
    "BRICK_COLUMNS",
    "BRICK_ROWS",
    "FLUENT_NAMES",
    "LEFT_ROW_FLUENTS",
    "MAX_BRICKS",
    "MAX_SCORE",
    "OBS_MODES",
    "BreakoutEnv",
    "BreakoutWorld",
    "NoiseFn",
    "area_resize_84",
    "breakout_fluents",
    "brick_box",
    "bricks_present",
    "left_columns_clear",
    "make_breakout_ram_env",
    "make_breakout_ram_world",
    "make_breakout_world",
    "resolve_noise",
    "set_bricks",
]
