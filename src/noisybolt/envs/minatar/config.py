"""The settings of a MinAtar Breakout world, in one frozen :class:`MinAtarBreakoutConfig`.

:class:`~noisybolt.envs.minatar.world.MinAtarBreakoutWorld` is built from one (or from its
fields as keywords), and the registry's factory (:mod:`noisybolt.envs.minatar.factories`)
forwards one, so that the settings, their defaults and their checks are written here only.

Example:
    >>> MinAtarBreakoutConfig(num_envs=2, seed=0).camera_size
    40
    >>> MinAtarBreakoutConfig(game="asterix")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    noisybolt.errors.UnknownNameError: MinAtar game 'asterix' has no fluents here; ...
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from noisybolt.envs.minatar.board import BOARD_SIDE
from noisybolt.errors import ConfigError, UnknownNameError

__all__ = ["GAMES", "MinAtarBreakoutConfig"]

#: The MinAtar games noisybolt gives fluents to (MinAtar has five: asterix, breakout,
#: freeway, seaquest, space_invaders).
GAMES: tuple[str, ...] = ("breakout",)


@dataclass(frozen=True)
class MinAtarBreakoutConfig:
    """Everything that defines a MinAtar Breakout world: the games, the agent's view and the
    bolt's.

    Attributes:
        num_envs: number of games.
        seed: seeds the games (MinAtar's own generator per game: sticky actions and the
            ball's start) and the camera noise; the world's ``reset(seed=)`` re-seeds.
        noise: the bolt camera's noise (None: clean): a noise spec or model of
            :mod:`noisybolt.perception.noise` (e.g.
            ``"gaussian:sigma=40+occlusion:count=2,size=0.25"``, grain and two grey
            patches, as on ALE Breakout) or a callable ``noise(images, rng) -> images``.
        fluents: the bolt's fluents, in order (default: all of
            :data:`~noisybolt.envs.minatar.board.FLUENT_NAMES`).
        game: the MinAtar game; only ``"breakout"`` has fluents (:data:`GAMES`).
        sticky_action_prob: the chance that a game repeats its last action instead of the
            one chosen (MinAtar's default, 0.1).
        tile_size: pixels per board cell in the bolt's camera: its image is
            ``10 * tile_size`` squared (default 4: 40x40).
        max_episode_steps: steps after which an episode is truncated. MinAtar's Breakout
            refills its wall when it is cleared, so a player that never misses would play
            for ever.
        shard: ``(first, total)``: these ``num_envs`` games are games ``first`` ..
            ``first + num_envs - 1`` of a world of ``total`` games with this ``seed``, and
            play exactly as those do there (each game's generators are seeded from the
            seed and the game's index in the whole world). None: the whole world,
            ``(0, num_envs)`` (:attr:`games`). For
            :class:`~noisybolt.envs.worker_world.WorkerWorld`, which runs the shards in
            worker processes.

    Raises:
        UnknownNameError: a ``game`` outside :data:`GAMES`.
        ConfigError: an out-of-range setting (the message names it). The fluents and the
            noise are checked when the world is built.
    """

    num_envs: int = 8
    seed: int | None = None
    noise: Any = None
    fluents: Sequence[str] | None = None
    game: str = "breakout"
    sticky_action_prob: float = 0.1
    tile_size: int = 4
    max_episode_steps: int = 5_000
    shard: tuple[int, int] | None = None

    def __post_init__(self) -> None:
        if self.game not in GAMES:
            raise UnknownNameError(
                f"MinAtar game {self.game!r} has no fluents here; known: {', '.join(GAMES)}",
                name=str(self.game),
                known=GAMES,
            )
        if self.num_envs < 1:
            raise ConfigError(f"num_envs must be >= 1, got {self.num_envs}")
        if not 0.0 <= self.sticky_action_prob <= 1.0:
            raise ConfigError(
                f"sticky_action_prob must be in [0, 1], got {self.sticky_action_prob}"
            )
        if not 1 <= self.tile_size <= 16:
            raise ConfigError(f"tile_size must be in 1..16, got {self.tile_size}")
        if self.max_episode_steps < 1:
            raise ConfigError(f"max_episode_steps must be >= 1, got {self.max_episode_steps}")
        first, total = self.games
        if not (first >= 0 and first + self.num_envs <= total):
            raise ConfigError(
                f"shard (first game, games in all) must hold this world's {self.num_envs} "
                f"games, got {self.shard}"
            )

    @property
    def games(self) -> tuple[int, int]:
        """``(first, total)``: :attr:`shard`, or ``(0, num_envs)`` for the whole world."""
        shard = (0, self.num_envs) if self.shard is None else self.shard
        first, total = (int(v) for v in shard)
        return first, total

    @property
    def camera_size(self) -> int:
        """Side of the bolt's square colour image, in pixels."""
        return BOARD_SIDE * self.tile_size
