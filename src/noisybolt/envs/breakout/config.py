"""The settings of a Breakout world, in one frozen :class:`BreakoutConfig`.

:class:`~noisybolt.envs.breakout.world.BreakoutWorld` is built from one (or from its
fields as keywords), and the registry's factories
(:mod:`noisybolt.envs.breakout.factories`) forward one, so that the settings, their
defaults and their checks are written here only.

Example:
    >>> config = BreakoutConfig(num_envs=2, obs_mode="ram", shard=(2, 4))
    >>> config.obs_mode, config.games
    ('ram', (2, 4))
    >>> BreakoutConfig(left_head_start=2.0)
    Traceback (most recent call last):
    ...
    noisybolt.errors.ConfigError: left_head_start must be in [0, 1], got 2.0
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from noisybolt.envs.breakout.ram import BRICK_COLUMNS
from noisybolt.errors import ConfigError

__all__ = ["OBS_MODES", "BreakoutConfig"]

#: The agent's observations: ``stack`` (the preprocessed grey frames, for the convolutions),
#: ``ram`` (the console's 128 RAM bytes scaled to [0, 1], for a dense network) or
#: ``ram_bits`` (the same bytes as their 1,024 bits, 0 or 1: Breakout keeps its wall as bit
#: fields, one brick per bit, which a byte scaled to [0, 1] blurs into one number).
OBS_MODES: tuple[str, ...] = ("stack", "ram", "ram_bits")


@dataclass(frozen=True)
class BreakoutConfig:
    """Everything that defines a Breakout world: the games, the agent's view and the bolt's.

    Attributes:
        num_envs: number of games.
        seed: seeds the games (sticky actions, no-ops) and the camera noise; the world's
            ``reset(seed=)`` re-seeds.
        noise: the bolt camera's noise (None: clean): a noise spec or model of
            :mod:`noisybolt.perception.noise` (e.g. ``"gaussian:sigma=12"``) or a callable
            ``noise(images, rng) -> images``; see
            :func:`~noisybolt.envs.breakout.camera.resolve_noise`.
        obs_mode: the agent's observation, one of :data:`OBS_MODES`. ``ram`` and
            ``ram_bits`` skip the grey frames altogether (``frame_stack`` and
            ``screen_size`` are then unused); the bolt's camera, fluents and everything
            else are the same in all, so a RAM agent is watched by the same noisy camera
            and classifier as an image agent.
        left_columns: how many brick columns, from the left, ``brick_clear_left`` covers.
        fluents: the bolt's fluents, in order (default: all of
            :data:`~noisybolt.envs.breakout.ram.FLUENT_NAMES`).
        camera_size: side of the bolt's square colour image.
        frame_skip: frames per action.
        noop_max: a reset is followed by 1..``noop_max`` random no-ops (0: none).
        repeat_action_probability: sticky-action probability of the ALE.
        frame_stack: frames in the agent's observation.
        screen_size: side of the agent's square grayscale frames.
        max_episode_frames: emulator frames after which an episode is truncated.
        fire_on_reset: press FIRE (one agent step's frames) after every reset and every lost
            life, as SB3's ``FireResetEnv`` with ``EpisodicLifeEnv`` does: Breakout waits
            for FIRE to serve the ball, and an agent that has not learnt to press it
            wastes its episode until truncation. Off by default (plain ALE v5); the
            Breakout training settings turn it on (``configs/hyperparams/breakout.yaml``).
        left_head_start: the probability that a game starts with the bottom ``k`` bricks
            of the leftmost ``left_columns`` column(s) already gone, ``k`` uniform in
            1..5 (never the whole column), the rest of the wall as the game sets it up:
            a start-state curriculum for a learner (``world.train_kwargs``), so that
            the column's top bricks, which a player reaches only after the bottom ones,
            are met early and often. 0 (default): every game as the ALE starts it (and
            no random draw is spent on it). A missing brick scores nothing, and the
            bolt's fluents see it gone from the first frame: under threshold tracking a
            spec it satisfies is paid nothing for it (the compliance scheme pays no
            acceptance the first observation gives); belief tracking, which believes a
            fluent that comes on only after ``min_dwell`` frames and treats the first
            frame as such an onset, pays for it over the first steps, whatever the
            agent does (an offset to the return, not a gradient).
        shard: ``(first, total)``: these ``num_envs`` games are games ``first`` ..
            ``first + num_envs - 1`` of a world of ``total`` games with this ``seed``, and
            play exactly as those do there (each game's ALE, no-ops and camera noise are
            seeded from the seed and the game's index in the whole world). None: the whole
            world, ``(0, num_envs)`` (:attr:`games`). For
            :class:`~noisybolt.envs.worker_world.WorkerWorld`, which runs the shards in
            worker processes.

    Raises:
        ConfigError: for an unknown ``obs_mode`` or an out-of-range setting (the message
            names it). The fluents and the noise are checked when the world is built.
    """

    num_envs: int = 8
    seed: int | None = None
    noise: Any = None
    obs_mode: str = "stack"
    left_columns: int = 1
    fluents: Sequence[str] | None = None
    camera_size: int = 84
    frame_skip: int = 4
    noop_max: int = 30
    repeat_action_probability: float = 0.25
    frame_stack: int = 4
    screen_size: int = 84
    max_episode_frames: int = 108_000
    fire_on_reset: bool = False
    left_head_start: float = 0.0
    shard: tuple[int, int] | None = None

    def __post_init__(self) -> None:
        if self.obs_mode not in OBS_MODES:
            raise ConfigError(
                f"breakout: obs_mode must be one of {list(OBS_MODES)}, got {self.obs_mode!r}"
            )
        if self.num_envs < 1:
            raise ConfigError(f"num_envs must be >= 1, got {self.num_envs}")
        if not 1 <= self.left_columns <= BRICK_COLUMNS:
            raise ConfigError(
                f"left_columns must be in 1..{BRICK_COLUMNS}, got {self.left_columns}"
            )
        if self.camera_size < 8 or self.screen_size < 8:
            raise ConfigError(
                "camera_size and screen_size must be >= 8, got "
                f"{self.camera_size}, {self.screen_size}"
            )
        if (
            self.frame_skip < 1
            or self.frame_stack < 1
            or self.noop_max < 0
            or self.max_episode_frames < 1
        ):
            raise ConfigError(
                "frame_skip, frame_stack and max_episode_frames must be >= 1 and noop_max "
                f">= 0, got {self.frame_skip}, {self.frame_stack}, {self.max_episode_frames}, "
                f"{self.noop_max}"
            )
        if not 0.0 <= self.repeat_action_probability <= 1.0:
            raise ConfigError(
                f"repeat_action_probability must be in [0, 1], got {self.repeat_action_probability}"
            )
        if not 0.0 <= self.left_head_start <= 1.0:
            raise ConfigError(f"left_head_start must be in [0, 1], got {self.left_head_start}")
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
