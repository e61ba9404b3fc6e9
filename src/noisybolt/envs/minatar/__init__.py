"""MinAtar Breakout as a vectorised world for the restraining bolt.

MinAtar (Young & Tian 2019; the ``minatar`` package, an optional dependency:
``pip install "noisybolt[minatar]"``) plays Atari's games on a 10x10 grid, at a size a CPU
learns in minutes to hours. The world is :class:`MinAtarBreakoutWorld`
(:mod:`~noisybolt.envs.minatar.world`): ``num_envs`` of MinAtar's own Breakout games stepped
together behind Gymnasium's vector API, the agent on MinAtar's board, the bolt on a drawn,
noisy picture of it (:mod:`~noisybolt.envs.minatar.camera`) with ground-truth fluents read
from the board (:mod:`~noisybolt.envs.minatar.board`). Its settings are one
:class:`MinAtarBreakoutConfig` (:mod:`~noisybolt.envs.minatar.config`);
:mod:`~noisybolt.envs.minatar.factories` holds the registry's factory
(``"minatar-breakout"``), and :class:`MinAtarBreakoutEnv`
(:mod:`~noisybolt.envs.minatar.adapter`) is one game as a plain Gymnasium env. Importing
this package does not import ``minatar``.

Example:
    >>> import numpy as np
    >>> world = make_minatar_breakout_world(num_envs=2, seed=0, noise="gaussian:sigma=40")
    >>> obs, info = world.reset(seed=0)
    >>> obs.shape, np.asarray(info["bolt_image"]).shape, world.fluent_names[0]
    ((2, 10, 10, 4), (2, 40, 40, 3), 'brick_clear_left')
    >>> world.close()
"""

from noisybolt.envs.minatar.adapter import RENDER_TILE, MinAtarBreakoutEnv
from noisybolt.envs.minatar.board import (
    BOARD_SIDE,
    BRICK_CHANNEL,
    BRICK_COLUMNS,
    BRICK_ROWS,
    CHANNELS,
    FLUENT_NAMES,
    LEFT_ROW_FLUENTS,
    WALL_BRICKS,
    bricks_present,
    minatar_fluents,
)
from noisybolt.envs.minatar.camera import PALETTE, noisy_images, render_boards
from noisybolt.envs.minatar.config import GAMES, MinAtarBreakoutConfig
from noisybolt.envs.minatar.factories import make_minatar_breakout_world
from noisybolt.envs.minatar.world import (
    WORLD_NAME,
    MinAtarBreakoutWorld,
    game_seeds,
    load_minatar,
)

__all__ = [
    "BOARD_SIDE",
    "BRICK_CHANNEL",
    "BRICK_COLUMNS",
    "BRICK_ROWS",
    "CHANNELS",
    "FLUENT_NAMES",
    "GAMES",
    "LEFT_ROW_FLUENTS",
    "PALETTE",
    "RENDER_TILE",
    "WALL_BRICKS",
    "WORLD_NAME",
    "MinAtarBreakoutConfig",
    "MinAtarBreakoutEnv",
    "MinAtarBreakoutWorld",
    "bricks_present",
    "game_seeds",
    "load_minatar",
    "make_minatar_breakout_world",
    "minatar_fluents",
    "noisy_images",
    "render_boards",
]
