"""Atari Breakout as a vectorised world for the restraining bolt.

The world is :class:`BreakoutWorld` (:mod:`~noisybolt.envs.breakout.world`): ``num_envs``
ALE games stepped together behind Gymnasium's vector API, preprocessed for the agent as
``ALE/Breakout-v5`` with the standard Atari wrappers, and labelled for the bolt through
``infos``. Its settings are one :class:`BreakoutConfig`
(:mod:`~noisybolt.envs.breakout.config`). The bolt's fluents are read from the console's
RAM (:mod:`~noisybolt.envs.breakout.ram`, where the wall's layout is documented); its
camera is the colour frame resized, with seeded noise
(:mod:`~noisybolt.envs.breakout.camera`). :class:`BreakoutEnv`
(:mod:`~noisybolt.envs.breakout.adapter`) is one game as a plain Gymnasium env, and
:mod:`~noisybolt.envs.breakout.factories` holds the registry's factories (``"breakout"``,
``"breakout-ram"``).

Example:
    >>> import numpy as np
    >>> world = make_breakout_world(num_envs=2, seed=0)
    >>> obs, info = world.reset(seed=0)
    >>> obs.shape, np.asarray(info["bolt_image"]).shape, np.asarray(info["true_fluents"]).any()
    ((2, 4, 84, 84), (2, 84, 84, 3), np.False_)
    >>> world.close()
"""

from noisybolt.envs.breakout.adapter import BreakoutEnv
from noisybolt.envs.breakout.camera import NoiseFn, area_resize_84, resolve_noise
from noisybolt.envs.breakout.config import OBS_MODES, BreakoutConfig
from noisybolt.envs.breakout.factories import (
    make_breakout_ram_env,
    make_breakout_ram_world,
    make_breakout_world,
)
from noisybolt.envs.breakout.ram import (
    BRICK_BITS,
    BRICK_COLUMNS,
    BRICK_ROWS,
    FLUENT_NAMES,
    LEFT_ROW_FLUENTS,
    MAX_BRICKS,
    MAX_SCORE,
    breakout_fluents,
    brick_box,
    bricks_present,
    left_columns_clear,
    set_bricks,
)
from noisybolt.envs.breakout.world import BreakoutWorld

__all__ = [
    "BRICK_BITS",
    "BRICK_COLUMNS",
    "BRICK_ROWS",
    "FLUENT_NAMES",
    "LEFT_ROW_FLUENTS",
    "MAX_BRICKS",
    "MAX_SCORE",
    "OBS_MODES",
    "BreakoutConfig",
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
