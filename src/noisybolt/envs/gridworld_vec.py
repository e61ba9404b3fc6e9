"""The gridworld, natively vectorised: all rooms stepped and drawn at once with numpy.

:class:`VectorGridworld` holds the batch's state as arrays (``x``, ``y``, heading, step
counter) and is tested step for step identical to ``num_envs`` copies of
:class:`~noisybolt.envs.gridworld.GridworldEnv` (observations in every mode, rewards,
terminations, truncations, fluents). No step does a Python loop over rooms: observations
come from tables precomputed per state (``"view"``), a static room with the agent written
in (``"grid"``), or a tile compositor (``"rgb"`` and the bolt's camera).

It is a Gymnasium :class:`~gymnasium.vector.VectorEnv` with **same-step autoreset**
(``metadata["autoreset_mode"] == AutoresetMode.SAME_STEP``): a step that ends an episode
returns the *new* episode's first observation, and the last observation of the ended one
in ``infos["final_obs"]`` (an object array, None for rooms that did not end, with mask
``infos["_final_obs"]``), as Gymnasium's ``SyncVectorEnv`` does in that mode. This is
also SB3's convention, so :class:`~noisybolt.envs.sb3.SB3VecEnv` adapts it with no
extra copy.

The bolt reads the world through ``infos`` (the contract of
:mod:`noisybolt.perception.protocols`), batched as a ``SyncVectorEnv`` of
:class:`~noisybolt.envs.gridworld.GridworldEnv` s would batch them (tested equal): at
reset and step ``infos["bolt_image"]``, ``infos["true_fluents"]`` and
``infos["grid_position"]`` (each with its ``_key`` mask), and after a step that ended
episodes the ended rooms' last state under the same keys in ``infos["final_info"]``. The
values are :class:`~noisybolt.envs.deferred.DeferredArray` s: the camera renders and
draws its noise only when someone reads them (``np.asarray``), once per step for the
current and the ended rooms together, so a world stepped without a bolt costs and draws
what it always did. :meth:`VectorGridworld.bolt_images`, :meth:`~VectorGridworld.true_fluents`
and their ``final_`` forms are views of the same values (sample collection reads them
after :meth:`~VectorGridworld.sample_collection_states`, which is no step).

Example:
    >>> world = VectorGridworld(num_envs=3, obs_mode="grid", seed=0)
    >>> obs, infos = world.reset(seed=0)
    >>> obs.shape, np.asarray(infos["true_fluents"]).shape
    ((3, 6, 6, 3), (3, 7))
    >>> obs, rewards, terminated, truncated, infos = world.step(np.array([2, 1, 3]))
    >>> rewards.tolist(), np.asarray(infos["bolt_image"]).shape, infos["grid_position"][0]
    ([-1.5, -1.5, -1.5], (3, 48, 48, 3), array([2, 1]))
"""

from __future__ import annotations

from collections.abc import Sequence
from functools import lru_cache
from typing import Any

import numpy as np
from gymnasium import spaces
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from noisybolt.bolt.schemes import ReturnBounds
from noisybolt.envs.bounds import episode_return_bounds
from noisybolt.envs.deferred import DeferredArray
from noisybolt.envs.gridworld import (
    AGENT_COLOUR,
    AGENT_OBJECT,
    CELL_GOAL,
    CELL_WALL,
    DIRECTION_VECTORS,
    ENCODING_EMPTY,
    ENCODING_GOAL,
    ENCODING_WALL,
    GridworldCamera,
    GridworldConfig,
    agent_sprite_ids,
    gridworld_fluents,
    resolve_fluents,
    room_cells,
    room_compositor,
)
from noisybolt.errors import ConfigError
from noisybolt.perception.noise import NoiseSpec
from noisybolt.perception.protocols import (
    BOLT_IMAGE_KEY,
    FINAL_INFO_KEY,
    GRID_POSITION_KEY,
    TRUE_FLUENTS_KEY,
    CameraSpec,
)

__all__ = ["VectorGridworld", "egocentric_views", "room_encoding"]

_VIEW = 7  # MiniGrid's default agent_view_size


@lru_cache(maxsize=32)
def room_encoding(size: int) -> np.ndarray:
    """MiniGrid's encoding of the empty room without the agent, ``[x, y, 3]`` uint8."""
    table = np.array([ENCODING_EMPTY, ENCODING_WALL, ENCODING_GOAL], dtype=np.uint8)
    enc = table[room_cells(size)]
    enc.setflags(write=False)
    return enc


@lru_cache(maxsize=32)
def egocentric_views(size: int) -> np.ndarray:
    """MiniGrid's 7x7 egocentric view for every state, ``[x, y, heading, 7, 7, 3]``.

    Reimplements ``MiniGridEnv.gen_obs`` with ``see_through_walls=True`` (tested equal):
    the 7x7 square ahead of the agent (outside the room reads as wall), rotated so the
    agent looks up from the bottom-middle cell, where the agent's own cell reads as empty.
    """
    enc = room_encoding(size)
    pad = _VIEW
    padded = np.empty((size + 2 * pad, size + 2 * pad, 3), dtype=np.uint8)
    padded[...] = ENCODING_WALL
    padded[pad : pad + size, pad : pad + size] = enc
    views = np.empty((size, size, 4, _VIEW, _VIEW, 3), dtype=np.uint8)
    half = _VIEW // 2
    # Top-left corner of the view square per heading (MiniGridEnv.get_view_exts).
    offsets = {0: (0, -half), 1: (-half, 0), 2: (-_VIEW + 1, -half), 3: (-half, -_VIEW + 1)}
    for x in range(size):
        for y in range(size):
            for d, (ox, oy) in offsets.items():
                tx, ty = x + ox + pad, y + oy + pad
                square = padded[tx : tx + _VIEW, ty : ty + _VIEW]
                # Grid.rotate_left applied d + 1 times is a clockwise quarter turn each.
                view = np.rot90(square, k=-(d + 1), axes=(0, 1)).copy()
                view[half, _VIEW - 1] = ENCODING_EMPTY
                views[x, y, d] = view
    views.setflags(write=False)
    return views


class VectorGridworld(VectorEnv):
    """``num_envs`` gridworld rooms stepped as arrays (see the module docstring).

    Args:
        num_envs: number of rooms (>= 1).
        size: room side in cells, walls included.
        max_steps: truncation limit; None for MiniGrid's ``4 * size**2``.
        step_reward: reward of every step.
        goal_reward: extra reward for entering the goal.
        obs_mode: ``"grid"``, ``"view"`` or ``"rgb"`` (see :mod:`noisybolt.envs.gridworld`).
        obs_tile_size: pixels per cell of the ``"rgb"`` observation.
        camera_tile_size: pixels per cell of the bolt's camera.
        start_heading: the agent's heading at the start (see
            :class:`~noisybolt.envs.gridworld.GridworldConfig`).
        noise: the bolt camera's noise spec.
        fluents: the bolt's fluents, in order (default: all seven).
        seed: seeds the camera noise now; ``reset(seed=...)`` re-seeds it.
        render_mode: None or ``"rgb_array"`` (MiniGrid's 32-pixel tiles, no highlight).
    """

    #: An episode terminates only by reaching the goal (SB3VecEnv reports ``is_success``).
    termination_is_success = True

    metadata: dict[str, Any] = {  # noqa: RUF012 (Gymnasium's convention)
        "autoreset_mode": AutoresetMode.SAME_STEP,
        "render_modes": ["rgb_array"],
    }

    def __init__(
        self,
        num_envs: int = 1,
        *,
        size: int = 6,
        max_steps: int | None = None,
        step_reward: float = -1.5,
        goal_reward: float = 100.0,
        obs_mode: str = "grid",
        obs_tile_size: int = 8,
        camera_tile_size: int = 8,
        start_heading: str = "east",
        noise: NoiseSpec = "none",
        fluents: Sequence[str] | None = None,
        seed: int | None = None,
        render_mode: str | None = None,
    ) -> None:
        if isinstance(num_envs, bool) or not isinstance(num_envs, int | np.integer) or num_envs < 1:
            raise ConfigError(f"num_envs must be an integer >= 1, got {num_envs!r}")
        if render_mode not in (None, "rgb_array"):
            raise ConfigError(f"render_mode must be None or 'rgb_array', got {render_mode!r}")
        self.config = GridworldConfig(
            size=size,
            max_steps=max_steps,
            step_reward=step_reward,
            goal_reward=goal_reward,
            obs_mode=obs_mode,
            obs_tile_size=obs_tile_size,
            camera_tile_size=camera_tile_size,
            start_heading=start_heading,
        )
        self.num_envs = int(num_envs)
        self.render_mode = render_mode
        self.metadata = dict(type(self).metadata)
        self.autoreset_mode = AutoresetMode.SAME_STEP
        self.single_observation_space = self.config.observation_space()
        self.single_action_space = spaces.Discrete(4)
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        self._fluent_names, self._fluent_columns = resolve_fluents(fluents)
        # The selected fluents of every state (x, y, heading): [size, size, 4, n_fluents].
        side = self.config.size
        gx, gy, gd = np.meshgrid(np.arange(side), np.arange(side), np.arange(4), indexing="ij")
        every_state = gridworld_fluents(gx.ravel(), gy.ravel(), gd.ravel(), size=side)
        self._fluent_table = every_state[:, self._fluent_columns].reshape(side, side, 4, -1)
        self._fluent_table.setflags(write=False)
        self._camera = GridworldCamera(size=size, tile_size=camera_tile_size, noise=noise)
        self._noise_rng = np.random.default_rng(seed)

        s = self.config.size
        self._cells = room_cells(s)
        self._step_limit = self.config.step_limit
        self._rgb = room_compositor(s, obs_tile_size) if obs_mode == "rgb" else None
        self._views = egocentric_views(s) if obs_mode == "view" else None
        self._room = room_encoding(s)
        self._render_compositor = room_compositor(s, 32) if render_mode else None

        n = self.num_envs
        x0, y0, d0 = self.config.start
        self._start = (x0, y0, d0)
        self._x = np.full(n, x0, dtype=np.intp)
        self._y = np.full(n, y0, dtype=np.intp)
        self._dir = np.full(n, d0, dtype=np.intp)
        self._steps = np.zeros(n, dtype=np.int64)
        self._final = (self._x.copy(), self._y.copy(), self._dir.copy())
        self._done = np.zeros(n, dtype=bool)
        self._every = np.ones(n, dtype=bool)  # the labels' masks: every room has them
        self._every.setflags(write=False)
        # The labels of the last reset or step (and of the states it reached before any
        # autoreset); the info and the bolt_images()/true_fluents() views share them.
        self._labels: dict[str, Any] = {}
        self._final_labels: dict[str, Any] = {}
        self._deferred: tuple[DeferredArray, ...] = ()
        self._label_shapes = (
            (n, *self._camera.spec.shape),
            (n, len(self._fluent_names)),
        )
        self._label()

    # ------------------------------------------------------------------ Gymnasium API

    def reset(
        self, *, seed: int | Sequence[int] | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        """Put every room back at the start; a seed re-seeds the camera noise.

        Args:
            seed: an int (or a list of ints) seeding the bolt camera's noise generator.
            options: must be None or empty (the start state is fixed).

        Returns:
            ``(observations, infos)``, ``infos`` holding the bolt's labels (see the
            module docs).
        """
        if options:
            raise ConfigError(f"VectorGridworld.reset takes no options, got {options!r}")
        if seed is not None:
            self._noise_rng = np.random.default_rng(seed)
            self._np_random = self._noise_rng
            self._np_random_seed = seed if isinstance(seed, int) else -1
        x0, y0, d0 = self._start
        n = self.num_envs
        self._x = np.full(n, x0, dtype=np.intp)
        self._y = np.full(n, y0, dtype=np.intp)
        self._dir = np.full(n, d0, dtype=np.intp)
        self._steps[:] = 0
        self._final = (self._x, self._y, self._dir)
        self._done = np.zeros(n, dtype=bool)
        return self._observe(self._x, self._y, self._dir), self._label()

    def step(
        self, actions: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        """Step every room; rooms whose episode ends restart in the same step.

        Args:
            actions: integer ``[num_envs]`` in [0, 4): 0 left, 1 right, 2 forward, 3 no-op.

        Returns:
            ``(observations, rewards float64, terminations, truncations, infos)``; see the
            module docstring for ``infos`` (the bolt's labels, ``final_obs`` and
            ``final_info``).
        """
        a = np.asarray(actions)
        kind = a.dtype.kind  # checks written for speed: a step is a few microseconds
        if a.shape != (self.num_envs,) or kind not in "iu":
            raise ValueError(f"actions must be integers of shape ({self.num_envs},), got {a!r}")
        if np.count_nonzero(a > 3 if kind == "u" else a & -4):  # outside [0, 4)
            raise ValueError(f"actions must be in [0, 4), got {a!r}")
        x, y, d = self._x, self._y, self._dir
        self._steps += 1
        forward = a == 2
        front_x = x + DIRECTION_VECTORS[d, 0]
        front_y = y + DIRECTION_VECTORS[d, 1]
        front = self._cells[front_x, front_y]
        move = forward & (front != CELL_WALL)
        terminated = forward & (front == CELL_GOAL)
        truncated = self._steps >= self._step_limit
        x = np.where(move, front_x, x)
        y = np.where(move, front_y, y)
        d = _TURN[d, a]
        rewards = self.config.step_reward + self.config.goal_reward * terminated

        done = terminated | truncated
        self._final = (x, y, d)
        self._done = done
        final_obs = None
        ended = bool(np.count_nonzero(done))
        if ended:
            idx = np.flatnonzero(done)
            final_obs = np.full(self.num_envs, None, dtype=object)
            last = self._observe(x[idx], y[idx], d[idx])
            for k, i in enumerate(idx):  # only the rooms that ended, for the object array
                final_obs[i] = last[k]
            x0, y0, d0 = self._start
            x = np.where(done, x0, x)
            y = np.where(done, y0, y)
            d = np.where(done, d0, d)
            self._steps[done] = 0
        self._x, self._y, self._dir = x, y, d
        infos = self._label(ended)
        if final_obs is not None:
            infos.update(
                final_obs=final_obs,
                _final_obs=done.copy(),
                **{FINAL_INFO_KEY: self._final_labels, f"_{FINAL_INFO_KEY}": done.copy()},
            )
        return self._observe(x, y, d), rewards, terminated, truncated, infos

    def render(self) -> tuple[np.ndarray, ...] | None:
        """With ``render_mode="rgb_array"``: one 32-pixel-tile frame per room."""
        if self._render_compositor is None:
            return None
        frames = self._render_compositor.render_sprites(
            agent_sprite_ids(self._x, self._y, self._dir, self.config.size),
            rows=self._y,
            cols=self._x,
        )
        return tuple(frames)

    # ------------------------------------------------------------ BoltObservable API

    def return_bounds(self) -> ReturnBounds:
        """Bounds on an episode's return: every step pays ``step_reward``, the goal once
        ``goal_reward`` more, within ``step_limit`` steps (see :mod:`noisybolt.envs.bounds`)."""
        step = self.config.step_reward
        goal = self.config.goal_reward
        return episode_return_bounds(
            step_reward=(step, step), horizon=self._step_limit, bonus=(min(goal, 0), max(goal, 0))
        )

    @property
    def fluent_names(self) -> tuple[str, ...]:
        """The bolt's fluents, in the column order of :meth:`true_fluents`."""
        return self._fluent_names

    @property
    def camera_spec(self) -> CameraSpec:
        """The bolt camera's format and noise."""
        return self._camera.spec

    def bolt_images(self) -> np.ndarray:
        """uint8 ``[num_envs, H, W, 3]``: the bolt's noisy view of the current states.

        A view of ``infos["bolt_image"]`` of the last reset or step (or of the states
        :meth:`sample_collection_states` or :meth:`set_agent_state` set): one camera call
        and one noise draw per step, however often it is read.
        """
        return np.asarray(self._labels[BOLT_IMAGE_KEY])

    def true_fluents(self) -> np.ndarray:
        """bool ``[num_envs, n_fluents]``: the ground truth of the current states (a view
        of ``infos["true_fluents"]``)."""
        return np.asarray(self._labels[TRUE_FLUENTS_KEY])

    def final_bolt_images(self) -> np.ndarray:
        """The bolt's view of the states the last step *reached*, before autoreset: a view
        of ``infos["final_info"]["bolt_image"]``, and of :meth:`bolt_images` for rooms whose
        episode did not just end."""
        return np.asarray(self._final_labels[BOLT_IMAGE_KEY])

    def final_true_fluents(self) -> np.ndarray:
        """Ground truth of the states the last step reached, before autoreset (a view of
        ``infos["final_info"]["true_fluents"]``, rows that did not end as now)."""
        return np.asarray(self._final_labels[TRUE_FLUENTS_KEY])

    @property
    def dones(self) -> np.ndarray:
        """bool ``[num_envs]``: which rooms ended an episode in the last step."""
        return self._done.copy()

    def sample_collection_states(self, rng: np.random.Generator) -> None:
        """Move every room to a random state, for collecting the bolt's training images.

        Positions are uniform over the floor, the goal included (the bolt sees the
        terminal state of every successful episode), headings uniform; each room starts a
        fresh episode there. Meets ``noisybolt.perception.dataset.SupportsCollectionStates``.
        """
        s = self.config.size
        self._x = rng.integers(1, s - 1, size=self.num_envs).astype(np.intp)
        self._y = rng.integers(1, s - 1, size=self.num_envs).astype(np.intp)
        self._dir = rng.integers(0, 4, size=self.num_envs).astype(np.intp)
        self._steps[:] = 0
        self._final = (self._x, self._y, self._dir)
        self._done = np.zeros(self.num_envs, dtype=bool)
        self._label()

    def set_agent_state(
        self,
        x: np.ndarray,
        y: np.ndarray,
        direction: np.ndarray,
        *,
        steps: np.ndarray | None = None,
    ) -> None:
        """Place every room's agent by hand (tests, planning, scripted collection).

        Raises:
            ConfigError: if a position is not on the floor or a heading is outside [0, 4).
        """
        x, y, d = (np.asarray(v, dtype=np.intp).reshape(self.num_envs) for v in (x, y, direction))
        s = self.config.size
        if ((x < 1) | (x > s - 2) | (y < 1) | (y > s - 2)).any():
            raise ConfigError(f"agent positions must be floor cells 1..{s - 2}, got {x}, {y}")
        if ((d < 0) | (d > 3)).any():
            raise ConfigError(f"headings must be in [0, 4), got {d}")
        self._x, self._y, self._dir = x.copy(), y.copy(), d.copy()
        self._steps[:] = 0 if steps is None else np.asarray(steps).reshape(self.num_envs)
        self._final = (self._x, self._y, self._dir)
        self._done = np.zeros(self.num_envs, dtype=bool)
        self._label()

    # ---------------------------------------------------------------------- state

    @property
    def agent_state(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Copies of ``(x, y, heading)``, integer ``[num_envs]`` each."""
        return (self._x.copy(), self._y.copy(), self._dir.copy())

    @property
    def step_counts(self) -> np.ndarray:
        """Steps taken in each room's current episode."""
        return self._steps.copy()

    def clean_bolt_images(self) -> np.ndarray:
        """The bolt camera's pictures of the current states before noise."""
        return self._camera.render(self._x, self._y, self._dir)

    # -------------------------------------------------------------------- helpers

    def _label(self, ended: bool = False) -> dict[str, Any]:
        """The labels of the states just set (the info of a reset or step, see the module
        docs; ``ended``: some episode ended in this step); the last ones expire. Returns a
        new info dict holding them."""
        for value in self._deferred:
            value.expire()
        n, done, every = self.num_envs, self._done, self._every
        x, y, d = self._x, self._y, self._dir
        images_shape, fluents_shape = self._label_shapes
        snapshot = _Snapshot(self, (x, y, d), self._final if ended else None, done)
        images = DeferredArray(snapshot.images, shape=images_shape, dtype=_UINT8)
        fluents = DeferredArray(snapshot.fluents, shape=fluents_shape, dtype=_BOOL)
        cells = DeferredArray(snapshot.cells, shape=(n, 2), dtype=_INT64)
        self._labels = labels = {
            BOLT_IMAGE_KEY: images,
            TRUE_FLUENTS_KEY: fluents,
            GRID_POSITION_KEY: cells,
        }
        if ended:
            final_images = DeferredArray(snapshot.final_images, shape=images_shape, dtype=_UINT8)
            final_fluents = DeferredArray(snapshot.final_fluents, shape=fluents_shape, dtype=_BOOL)
            final_cells = DeferredArray(snapshot.final_cells, shape=(n, 2), dtype=_INT64)
            self._final_labels = {
                BOLT_IMAGE_KEY: final_images,
                _IMAGE_MASK: done,
                TRUE_FLUENTS_KEY: final_fluents,
                _FLUENTS_MASK: done,
                GRID_POSITION_KEY: final_cells,
                _CELLS_MASK: done,
            }
            self._deferred = (images, fluents, cells, final_images, final_fluents, final_cells)
        else:
            self._final_labels = labels
            self._deferred = (images, fluents, cells)
        return {
            BOLT_IMAGE_KEY: images,
            _IMAGE_MASK: every,
            TRUE_FLUENTS_KEY: fluents,
            _FLUENTS_MASK: every,
            GRID_POSITION_KEY: cells,
            _CELLS_MASK: every,
        }

    def _fluents(self, x: np.ndarray, y: np.ndarray, d: np.ndarray) -> np.ndarray:
        # A look-up in gridworld_fluents' table of every state (a tenth of computing them).
        return self._fluent_table[x, y, d]

    def _observe(self, x: np.ndarray, y: np.ndarray, d: np.ndarray) -> np.ndarray:
        if self._views is not None:
            return self._views[x, y, d]
        if self._rgb is not None:
            return self._rgb.render_sprites(
                agent_sprite_ids(x, y, d, self.config.size), rows=y, cols=x
            )
        obs = np.empty((len(x), *self._room.shape), dtype=np.uint8)
        obs[...] = self._room
        obs[np.arange(len(x)), x, y] = _AGENT_ENCODING[d]
        return obs

    def __repr__(self) -> str:
        return (
            f"VectorGridworld(num_envs={self.num_envs}, size={self.config.size}, "
            f"obs_mode={self.config.obs_mode!r}, noise={self._camera.spec.noise['name']!r})"
        )


_UINT8, _BOOL, _INT64 = np.dtype(np.uint8), np.dtype(bool), np.dtype(np.int64)
#: The heading after each action from each heading: ``_TURN[heading, action]`` (0 turns
#: left, 1 right, 2 and 3 keep it).
_TURN = np.array([[(h - 1) % 4, (h + 1) % 4, h, h] for h in range(4)], dtype=np.intp)
#: MiniGrid's encoding of the agent's cell, per heading: ``(agent, red, heading)``.
_AGENT_ENCODING = np.array([[AGENT_OBJECT, AGENT_COLOUR, h] for h in range(4)], dtype=np.uint8)
# The labels' masks in a batched info (Gymnasium's "_key" convention).
_IMAGE_MASK, _FLUENTS_MASK, _CELLS_MASK = (
    f"_{key}" for key in (BOLT_IMAGE_KEY, TRUE_FLUENTS_KEY, GRID_POSITION_KEY)
)


def _cells(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """int64 ``[n, 2]``: each room's agent cell ``(x, y)`` (``info["grid_position"]``)."""
    return np.stack([x, y], axis=1).astype(np.int64, copy=False)


class _Snapshot:
    """The states one reset or step reached, and the labels computed from them on demand
    (what the info's :class:`~noisybolt.envs.deferred.DeferredArray` s compute)."""

    __slots__ = ("_captured", "_done", "_final", "_now", "_world")

    def __init__(
        self,
        world: VectorGridworld,
        now: tuple[np.ndarray, np.ndarray, np.ndarray],
        final: tuple[np.ndarray, np.ndarray, np.ndarray] | None,
        done: np.ndarray,
    ) -> None:
        self._world, self._now, self._final, self._done = world, now, final, done
        self._captured: tuple[np.ndarray, np.ndarray] | None = None

    def _capture(self) -> tuple[np.ndarray, np.ndarray]:
        """Current and last images with one camera call (the noise has a per-call
        overhead, and its draws keep one order however the values are read)."""
        if self._captured is None:
            world, (x, y, d) = self._world, self._now
            if self._final is None:
                now = world._camera.capture(x, y, d, rng=world._noise_rng)
                self._captured = (now, now)
            else:
                idx = np.flatnonzero(self._done)
                fx, fy, fd = self._final
                n = len(x)
                both = world._camera.capture(
                    np.concatenate([x, fx[idx]]),
                    np.concatenate([y, fy[idx]]),
                    np.concatenate([d, fd[idx]]),
                    rng=world._noise_rng,
                )
                final = both[:n].copy()
                final[idx] = both[n:]
                self._captured = (both[:n], final)
        return self._captured

    def images(self) -> np.ndarray:
        return self._capture()[0]

    def final_images(self) -> np.ndarray:
        return self._capture()[1]

    def fluents(self) -> np.ndarray:
        return self._world._fluents(*self._now)

    def final_fluents(self) -> np.ndarray:
        assert self._final is not None
        return self._world._fluents(*self._final)

    def cells(self) -> np.ndarray:
        return _cells(self._now[0], self._now[1])

    def final_cells(self) -> np.ndarray:
        assert self._final is not None
        return _cells(self._final[0], self._final[1])
