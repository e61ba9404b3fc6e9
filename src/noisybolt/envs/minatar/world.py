"""MinAtar Breakout's games, stepped together: :class:`MinAtarBreakoutWorld`.

:class:`MinAtarBreakoutWorld` runs ``num_envs`` games of MinAtar's Breakout (the
``minatar`` package's own ``Environment``, one per game, each with its own seeded
generator for sticky actions and the ball's start) behind Gymnasium's vector API. The
agent sees MinAtar's state, the board ``[10, 10, 4]`` (paddle, ball, trail, bricks) as
uint8 0/1, and plays MinAtar's minimal action set (no-op, left, right); a step is one of
MinAtar's steps (no frame skip: MinAtar has none). Stepped from the same seed it plays
exactly as ``minatar.Environment("breakout")`` seeded with :func:`game_seeds` (tested).

The bolt's side, through ``infos`` (the contract of :mod:`noisybolt.perception.protocols`,
as on ALE Breakout): ``infos["bolt_image"]`` and ``infos["true_fluents"]`` batched at reset
and step, the ended games' last ones in ``infos["final_info"]``, as
:class:`~noisybolt.envs.deferred.DeferredArray` s that draw the camera only when read:
the fluents of :mod:`noisybolt.envs.minatar.board` and the camera of
:mod:`noisybolt.envs.minatar.camera`, both from the board.

``minatar`` is an optional dependency (``pip install "noisybolt[minatar]"``): importing
this module does not import it; building a world without it raises
:class:`~noisybolt.errors.MissingDependencyError`.

Example:
    >>> world = MinAtarBreakoutWorld(num_envs=2, seed=0)
    >>> obs, info = world.reset(seed=0)
    >>> obs.shape, obs.dtype, np.asarray(info["bolt_image"]).shape
    ((2, 10, 10, 4), dtype('uint8'), (2, 40, 40, 3))
    >>> np.asarray(info["true_fluents"]).tolist()
    [[False, False, False, False, False], [False, False, False, False, False]]
"""

from __future__ import annotations

import importlib
from dataclasses import replace
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from gymnasium.vector import AutoresetMode

from noisybolt.bolt.schemes import ReturnBounds
from noisybolt.envs.breakout.camera import resolve_noise
from noisybolt.envs.deferred import DeferredArray
from noisybolt.envs.fluents import select_fluents
from noisybolt.envs.minatar.board import (
    BOARD_SIDE,
    BRICK_COLUMNS,
    BRICK_ROWS,
    CHANNELS,
    FLUENT_NAMES,
    minatar_fluents,
)
from noisybolt.envs.minatar.camera import noisy_images, render_boards
from noisybolt.envs.minatar.config import MinAtarBreakoutConfig
from noisybolt.errors import ConfigError, MissingDependencyError
from noisybolt.perception.protocols import (
    BOLT_IMAGE_KEY,
    FINAL_INFO_KEY,
    TRUE_FLUENTS_KEY,
    CameraSpec,
)

__all__ = ["WORLD_NAME", "MinAtarBreakoutWorld", "game_seeds", "load_minatar"]

#: The world's registry name (:mod:`noisybolt.envs.registry`), in messages and camera specs.
WORLD_NAME = "minatar-breakout"


def load_minatar() -> Any:
    """The ``minatar`` package, imported now.

    Raises:
        MissingDependencyError: it is not installed (naming the extra that installs it).
    """
    try:
        return importlib.import_module("minatar")
    except ImportError as error:
        raise MissingDependencyError(
            f"world {WORLD_NAME!r} needs the minatar package ({error}); install it with "
            "pip install 'noisybolt[minatar]'",
            package="minatar",
            extra="minatar",
        ) from error


def game_seeds(seed: int | None, num_envs: int) -> list[int]:
    """The seed of each game's MinAtar generator in a world seeded ``seed``: game ``g``
    plays as ``minatar.Environment("breakout")`` after ``seed(game_seeds(seed, n)[g])`` and
    ``reset()`` (its camera noise comes from another stream of the same child seed). A
    world's game ``g`` has the same seed whatever the number of games after it (a shard's
    games play as in the whole world).

    Example:
        >>> game_seeds(0, 2) == game_seeds(0, 3)[:2], len(set(game_seeds(0, 3)))
        (True, 3)
    """
    children = np.random.SeedSequence(seed).spawn(num_envs)
    return [int(child.generate_state(1)[0]) for child in children]


def _camera_rngs(seed: int | None, first: int, count: int) -> list[np.random.Generator]:
    """Games ``first`` .. ``first + count - 1``'s camera generators."""
    children = np.random.SeedSequence(seed).spawn(first + count)[first:]
    return [np.random.default_rng(child.spawn(1)[0]) for child in children]


class MinAtarBreakoutWorld(gym.vector.VectorEnv):
    """``num_envs`` MinAtar Breakout games stepped together, seen by the agent and the bolt.

    An episode terminates when the ball passes the paddle (MinAtar has one life;
    ``termination_is_success`` is False) and is truncated after
    ``max_episode_steps`` steps. Gymnasium vector API with **same-step autoreset**, like
    :class:`~noisybolt.envs.breakout.world.BreakoutWorld` and SB3: a step that ends an
    episode returns the new episode's first observation, the ended one's last in
    ``infos["final_obs"]`` (object array, mask ``infos["_final_obs"]``), and the bolt's
    labels of the state each game reached before the reset in ``infos["final_info"]``.

    Observations: uint8 ``[num_envs, 10, 10, 4]``, MinAtar's state (0 or 1; channels in
    :data:`~noisybolt.envs.minatar.board.CHANNELS`). Actions: ``Discrete(3)`` per game,
    MinAtar's minimal action set (no-op, left, right). Rewards: 1 per brick broken.

    Args:
        config: the world's settings (default: :class:`MinAtarBreakoutConfig`'s).
        **settings: settings as keywords (the fields of :class:`MinAtarBreakoutConfig`),
            over ``config``'s where both are given.

    Raises:
        ConfigError: an out-of-range setting or noise.
        UnknownNameError: a MinAtar game without fluents here.
        UnknownFluentError: a fluent this world does not have.
        MissingDependencyError: ``minatar`` is not installed.
    """

    termination_is_success = False

    def __init__(self, config: MinAtarBreakoutConfig | None = None, **settings: Any) -> None:
        config = (
            MinAtarBreakoutConfig(**settings) if config is None else replace(config, **settings)
        )
        self.config = config
        self._fluent_names, self._fluent_columns = select_fluents(
            WORLD_NAME, FLUENT_NAMES, config.fluents
        )
        self._noise, noise_description = resolve_noise(config.noise)
        minatar = load_minatar()
        self.metadata = {"autoreset_mode": AutoresetMode.SAME_STEP}
        self.autoreset_mode = AutoresetMode.SAME_STEP
        self.num_envs = n = config.num_envs
        self._games = [
            minatar.Environment(config.game, sticky_action_prob=config.sticky_action_prob)
            for _ in range(n)
        ]
        self._actions = tuple(int(a) for a in self._games[0].minimal_action_set())
        self.single_observation_space = spaces.Box(
            0, 1, (BOARD_SIDE, BOARD_SIDE, len(CHANNELS)), np.uint8
        )
        self.single_action_space = spaces.Discrete(len(self._actions))
        self.observation_space = gym.vector.utils.batch_space(self.single_observation_space, n)
        self.action_space = gym.vector.utils.batch_space(self.single_action_space, n)
        side = config.camera_size
        self._camera_spec = CameraSpec(
            world=WORLD_NAME,
            height=side,
            width=side,
            channels=3,
            noise=noise_description,
            # tile_size and cells: the on-the-fly classifier reads the image tile by tile
            # and keeps each cell apart (runs.detectors.classifier_architecture).
            extra={
                "source": "MinAtar board drawn in tiles",
                "tile_size": config.tile_size,
                "cells": BOARD_SIDE,
            },
        )
        self._boards = np.zeros((n, BOARD_SIDE, BOARD_SIDE, len(CHANNELS)), bool)
        self._steps = np.zeros(n, np.int64)
        self._done = np.zeros(n, bool)
        self._final_boards: dict[int, np.ndarray] = {}
        self._every = np.ones(n, bool)  # the labels' masks: every game
        self._every.setflags(write=False)
        self._labels: dict[str, Any] = {}
        self._final_labels: dict[str, Any] = {}
        self._camera_rngs: list[np.random.Generator] = []
        self._seed_all(config.seed)
        self._started = False
        self._info()

    # -- seeding and resets ---------------------------------------------------------------
    def _seed_all(self, seed: int | None) -> None:
        # Game g of the whole world (g = shard's first + i) draws from the g-th child of
        # the seed, whichever process runs it: a world split into shards plays the same.
        if seed is None:  # one entropy for every game, drawn here
            seed = int(np.random.SeedSequence().generate_state(1)[0])
        first, _ = self.config.games
        seeds = game_seeds(seed, first + self.num_envs)[first:]
        for game, game_seed in zip(self._games, seeds, strict=True):
            game.seed(game_seed)
            game.reset()
        self._camera_rngs = _camera_rngs(seed, first, self.num_envs)
        self._steps[:] = 0
        self._read_boards()

    def _read_boards(self) -> None:
        for i, game in enumerate(self._games):
            self._boards[i] = game.state()

    def reset(
        self, *, seed: int | list[int] | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        """Resets every game (re-seeding them and the camera noise if ``seed`` is given).

        Options: ``reset_mask`` (bool ``[num_envs]``) resets only those games.
        """
        if isinstance(seed, list):
            raise ConfigError("MinAtarBreakoutWorld.reset takes one int seed for the whole batch")
        self._clear_step_state()
        self._started = True
        if seed is not None:
            self._seed_all(seed)
            return self._observations(), self._info()
        mask = np.ones(self.num_envs, bool)
        if options and "reset_mask" in options:
            mask = np.asarray(options["reset_mask"], dtype=bool)
            if mask.shape != (self.num_envs,):
                raise ValueError(f"reset_mask must be bool [{self.num_envs}], got {mask.shape}")
        for i in np.flatnonzero(mask):
            self._games[i].reset()
            self._steps[i] = 0
        self._read_boards()
        return self._observations(), self._info()

    def _observations(self) -> np.ndarray:
        return self._boards.astype(np.uint8)

    def _clear_step_state(self) -> None:
        self._done = np.zeros(self.num_envs, bool)
        self._final_boards = {}

    # -- stepping -------------------------------------------------------------------------
    def step(
        self, actions: Any
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        """Advances every game by one MinAtar step."""
        if not self._started:
            raise RuntimeError("call reset() before step()")
        actions = np.asarray(actions)
        if actions.shape != (self.num_envs,):
            raise ValueError(f"actions must be [{self.num_envs}], got {actions.shape}")
        if (
            not np.issubdtype(actions.dtype, np.integer)
            or actions.min() < 0
            or actions.max() >= len(self._actions)
        ):
            raise ValueError(f"actions must be integers in [0, {len(self._actions)})")
        self._clear_step_state()
        rewards = np.zeros(self.num_envs, np.float64)
        terminated = np.zeros(self.num_envs, bool)
        truncated = np.zeros(self.num_envs, bool)
        final_obs: np.ndarray | None = None
        limit = self.config.max_episode_steps
        for i, game in enumerate(self._games):
            reward, terminal = game.act(self._actions[int(actions[i])])
            rewards[i] = reward
            self._steps[i] += 1
            terminated[i] = bool(terminal)
            truncated[i] = not terminal and self._steps[i] >= limit
            board = game.state()
            if terminated[i] or truncated[i]:
                if final_obs is None:
                    final_obs = np.full(self.num_envs, None, dtype=object)
                self._final_boards[i] = board
                final_obs[i] = board.astype(np.uint8)
                game.reset()
                self._steps[i] = 0
                board = game.state()
            self._boards[i] = board
        self._done = terminated | truncated
        infos = self._info()
        if final_obs is not None:
            infos.update(
                final_obs=final_obs,
                _final_obs=self._done.copy(),
                **{FINAL_INFO_KEY: self._final_labels, f"_{FINAL_INFO_KEY}": self._done.copy()},
            )
        return self._observations(), rewards, terminated, truncated, infos

    def _info(self) -> dict[str, Any]:
        """The info of a reset or step: the bolt's labels of the states it reached (new
        labels: the last ones expire)."""
        for labels in (self._labels, self._final_labels):
            for value in labels.values():
                if isinstance(value, DeferredArray):
                    value.expire()
        n, k, side = self.num_envs, len(self._fluent_names), self.config.camera_size
        boards = self._boards.copy()
        images = DeferredArray(
            lambda: self._capture(boards, range(n)), shape=(n, side, side, 3), dtype=np.uint8
        )
        self._labels = {
            BOLT_IMAGE_KEY: images,
            TRUE_FLUENTS_KEY: DeferredArray(
                lambda: self._fluents(boards), shape=(n, k), dtype=bool
            ),
        }
        info: dict[str, Any] = {**self._labels, **{f"_{key}": self._every for key in self._labels}}
        if not self._final_boards:
            self._final_labels = self._labels
            return info
        ended = sorted(self._final_boards)
        final_boards = boards.copy()
        final_boards[ended] = np.stack([self._final_boards[i] for i in ended])

        def final_images() -> np.ndarray:
            # The current view first, then the ended games' last boards: the camera's
            # noise draws keep that order however the values are read.
            out = images.value.copy()
            out[ended] = self._capture(final_boards[ended], ended)
            return out

        done = self._done
        self._final_labels = {
            BOLT_IMAGE_KEY: DeferredArray(final_images, shape=(n, side, side, 3), dtype=np.uint8),
            TRUE_FLUENTS_KEY: DeferredArray(
                lambda: self._fluents(final_boards), shape=(n, k), dtype=bool
            ),
            f"_{BOLT_IMAGE_KEY}": done,
            f"_{TRUE_FLUENTS_KEY}": done,
        }
        return info

    def _capture(self, boards: np.ndarray, games: Any) -> np.ndarray:
        images = render_boards(boards, self.config.tile_size)
        return noisy_images(images, self._noise, [self._camera_rngs[g] for g in games])

    def _fluents(self, boards: np.ndarray) -> np.ndarray:
        return minatar_fluents(boards)[:, self._fluent_columns]

    # -- the bolt's view ------------------------------------------------------------------
    @property
    def fluent_names(self) -> tuple[str, ...]:
        """The bolt's fluents, in the column order of :meth:`true_fluents`."""
        return self._fluent_names

    @property
    def monotone_fluents(self) -> tuple[str, ...]:
        """Fluents that, once true, stay true while the wall stands: all of them (a brick
        gone stays gone). Belief tracking is told so (``BeliefSettings.monotone``). A new
        wall comes only once the last one is cleared, when every ``F`` spec over these
        has long been accepted."""
        return self._fluent_names

    @property
    def camera_spec(self) -> CameraSpec:
        """The bolt camera's size and noise."""
        return self._camera_spec

    def return_bounds(self) -> ReturnBounds:
        """Bounds on an episode's score: 0 to one point every second step (a brick hit
        sends the ball back where it came from, and MinAtar scores no brick on the step
        after a hit), ``(max_episode_steps + 1) // 2``."""
        return ReturnBounds(0.0, float((self.config.max_episode_steps + 1) // 2))

    def clipped_return_bounds(self) -> ReturnBounds:
        """The same bounds: every reward is already 0 or 1."""
        return self.return_bounds()

    def boards(self) -> np.ndarray:
        """bool ``[num_envs, 10, 10, 4]``: every game's board now."""
        return self._boards.copy()

    def true_fluents(self) -> np.ndarray:
        """bool ``[num_envs, n_fluents]``: a view of ``infos["true_fluents"]`` of the last
        reset or step."""
        return np.asarray(self._labels[TRUE_FLUENTS_KEY])

    def final_true_fluents(self) -> np.ndarray:
        """Ground truth of the states the last step reached, before autoreset (a view of
        ``infos["final_info"]["true_fluents"]``; rows that did not end as now)."""
        return np.asarray(self._final_labels[TRUE_FLUENTS_KEY])

    def bolt_images(self) -> np.ndarray:
        """uint8 ``[num_envs, S, S, 3]``: the camera's noisy view, a view of
        ``infos["bolt_image"]`` of the last reset or step."""
        return np.asarray(self._labels[BOLT_IMAGE_KEY])

    def final_bolt_images(self) -> np.ndarray:
        """The bolt's view of the states the last step reached, before autoreset."""
        return np.asarray(self._final_labels[BOLT_IMAGE_KEY])

    @property
    def dones(self) -> np.ndarray:
        """bool ``[num_envs]``: which games ended an episode in the last step."""
        return self._done.copy()

    def render(self) -> tuple[np.ndarray, ...] | None:
        """Each game's board drawn by the bolt's camera, without its noise."""
        return tuple(render_boards(self._boards, self.config.tile_size))

    # -- scripted exploration for sample collection ---------------------------------------
    def sample_collection_states(self, rng: np.random.Generator) -> None:
        """Puts a random wall, paddle and ball into every game so that every fluent's
        values are common (random play never clears the left column).

        With probability 1/2 the left column is empty (a positive), otherwise a random
        non-empty subset of its bricks stands (a negative, down to one brick: the hard
        case); every other brick stands with a probability drawn uniformly per game, and
        at least one does (an empty wall is replaced by a new one). The paddle goes to a
        random column, the ball to a random cell below the wall, moving diagonally, its
        trail one cell behind it. This writes MinAtar's game attributes (``brick_map``,
        ``pos``, ``ball_x``, ``ball_y``, ``ball_dir``, ``last_x``, ``last_y``).
        """
        self._clear_step_state()
        rows = slice(BRICK_ROWS[0], BRICK_ROWS[-1] + 1)
        for i, game in enumerate(self._games):
            state = game.env
            if state.terminal:
                game.reset()
                self._steps[i] = 0
            wall = rng.random((len(BRICK_ROWS), BRICK_COLUMNS)) < rng.random()
            if rng.random() < 0.5:
                wall[:, 0] = False
            else:
                wall[:, 0] = rng.random(len(BRICK_ROWS)) < rng.random()
                if not wall[:, 0].any():
                    wall[rng.integers(len(BRICK_ROWS)), 0] = True
            if not wall[:, 1:].any():
                wall[rng.integers(len(BRICK_ROWS)), rng.integers(1, BRICK_COLUMNS)] = True
            state.brick_map[:] = 0
            state.brick_map[rows, :] = wall
            state.pos = int(rng.integers(BOARD_SIDE))
            direction = int(rng.integers(4))  # 0: up-left, 1: up-right, 2: down-right, 3: down-left
            x, y = int(rng.integers(BOARD_SIDE)), int(rng.integers(BRICK_ROWS[-1] + 2, 9))
            dx, dy = ((-1, -1), (1, -1), (1, 1), (-1, 1))[direction]
            state.ball_x, state.ball_y, state.ball_dir = x, y, direction
            state.last_x = int(np.clip(x - dx, 0, BOARD_SIDE - 1))
            state.last_y = int(np.clip(y - dy, 0, BOARD_SIDE - 1))
            state.strike = False
        self._read_boards()
        self._info()  # the views (bolt_images, true_fluents) show the new boards

    def close_extras(self, **kwargs: Any) -> None:
        """Releases the games."""
        self._games = []
