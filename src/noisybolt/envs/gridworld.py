"""The paper's gridworld: MiniGrid's empty room with four actions and its own rewards.

The room is ``size`` cells wide and high, walls included (MiniGrid's convention: size 6
is a 4x4 floor). The agent starts at ``(1, 1)`` facing east; the green goal sits in the
far corner ``(size-2, size-2)``. Coordinates are MiniGrid's: ``x`` grows east, ``y``
grows *south*; headings are ``0=E, 1=S, 2=W, 3=N``.

Actions (:class:`GridAction`), numbered like MiniGrid's for the three it shares:

==========  ========================  ====================
our action  meaning                   MiniGrid action
==========  ========================  ====================
0           turn left                 ``Actions.left`` (0)
1           turn right                ``Actions.right`` (1)
2           move forward              ``Actions.forward`` (2)
3           no-op                     ``Actions.done`` (6)
==========  ========================  ====================

Rewards: every step pays ``step_reward`` (-1.5); the step that enters the goal also pays
``goal_reward`` (+100) and terminates, so an optimal 7-action episode returns
``100 - 7 * 1.5 = 89.5``. This replaces MiniGrid's own success reward
``1 - 0.9 * step_count / max_steps``. Episodes are truncated after ``max_steps``
(MiniGrid's ``4 * size**2`` by default); a step can be both terminated and truncated, as
in MiniGrid.

Agent observations (``obs_mode``), all uint8 with MiniGrid's array layouts:

- ``"grid"``: the fully observable symbolic room, ``[size, size, 3]`` indexed
  ``[x, y, (object, colour, state)]`` exactly as MiniGrid's ``FullyObsWrapper`` (the agent
  is ``(10, 0, heading)``);
- ``"view"``: MiniGrid's egocentric ``[7, 7, 3]`` view (what the paper's stack used);
- ``"rgb"``: the top-down picture ``[size*obs_tile_size, size*obs_tile_size, 3]``,
  MiniGrid's ``get_frame(highlight=False)``.

The bolt's camera is separate from the agent's observation: a top-down picture at
``camera_tile_size`` pixels per cell (default 8, so 48x48x3 for size 6: small, so that a
fluent classifier stays cheap), drawn with MiniGrid's own tiles and then passed through a
noise model. Ground-truth fluents (:data:`GRIDWORLD_FLUENTS`) come from
:func:`gridworld_fluents`, for labels and metrics only.

Example:
    >>> env = GridworldEnv(obs_mode="grid")
    >>> obs, info = env.reset(seed=0)
    >>> obs.shape, int(obs[1, 1, 0])  # the agent (object 10) at (1, 1)
    ((6, 6, 3), 10)
    >>> obs, reward, terminated, truncated, info = env.step(GridAction.FORWARD)
    >>> reward, terminated
    (-1.5, False)
    >>> dict(zip(env.fluent_names, env.true_fluents().tolist()))["facing_right"]
    True
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace
from enum import IntEnum
from functools import lru_cache
from typing import Any, SupportsFloat

import numpy as np
from gymnasium import spaces
from minigrid.core.actions import Actions
from minigrid.core.constants import COLOR_TO_IDX, OBJECT_TO_IDX
from minigrid.core.grid import Grid
from minigrid.core.mission import MissionSpace
from minigrid.core.world_object import Goal
from minigrid.minigrid_env import MiniGridEnv

from noisybolt.envs.fluents import select_fluents
from noisybolt.envs.layout import GridLayout
from noisybolt.errors import ConfigError, UnknownNameError
from noisybolt.perception.cameras import TileCompositor
from noisybolt.perception.noise import (
    DEFAULT_REGION,
    Compose,
    NoiseModel,
    NoiseSpec,
    RegionalDegradation,
    make_noise,
)
from noisybolt.perception.protocols import (
    BOLT_IMAGE_KEY,
    GRID_POSITION_KEY,
    TRUE_FLUENTS_KEY,
    CameraSpec,
)

__all__ = [
    "DIRECTION_VECTORS",
    "GRIDWORLD_FLUENTS",
    "MINIGRID_ACTIONS",
    "OBS_MODES",
    "START_HEADINGS",
    "GridAction",
    "GridworldCamera",
    "GridworldConfig",
    "GridworldEnv",
    "bottom_left_region",
    "cell_region",
    "fit_regional_default",
    "gridworld_fluents",
    "resolve_fluents",
]

WORLD_NAME = "gridworld"

#: The gridworld's fluent vocabulary, in the column order of :func:`gridworld_fluents`.
GRIDWORLD_FLUENTS: tuple[str, ...] = (
    "on_edge",
    "top_right_corner",
    "bottom_left_corner",
    "facing_up",
    "facing_down",
    "facing_left",
    "facing_right",
)

#: Agent observation modes.
OBS_MODES: tuple[str, ...] = ("grid", "view", "rgb")

#: ``(dx, dy)`` of one step forward for headings 0=E, 1=S, 2=W, 3=N (MiniGrid's DIR_TO_VEC).
DIRECTION_VECTORS = np.array([[1, 0], [0, 1], [-1, 0], [0, -1]], dtype=np.intp)

_EAST, _SOUTH, _WEST, _NORTH = 0, 1, 2, 3
#: The agent's possible start headings, by name (MiniGrid's direction numbers).
START_HEADINGS: dict[str, int] = {"east": _EAST, "south": _SOUTH, "west": _WEST, "north": _NORTH}


class GridAction(IntEnum):
    """The four actions of the gridworld (see the module docstring for MiniGrid's)."""

    LEFT = 0
    RIGHT = 1
    FORWARD = 2
    NOOP = 3


#: MiniGrid's action for each of ours, indexed by :class:`GridAction`.
MINIGRID_ACTIONS: tuple[Actions, ...] = (
    Actions.left,
    Actions.right,
    Actions.forward,
    Actions.done,
)

# Cell kinds of the static room, used by the vectorised form.
CELL_FLOOR, CELL_WALL, CELL_GOAL = 0, 1, 2

# MiniGrid encodings (object, colour, state).
ENCODING_EMPTY = (OBJECT_TO_IDX["empty"], 0, 0)
ENCODING_WALL = (OBJECT_TO_IDX["wall"], COLOR_TO_IDX["grey"], 0)
ENCODING_GOAL = (OBJECT_TO_IDX["goal"], COLOR_TO_IDX["green"], 0)
AGENT_OBJECT, AGENT_COLOUR = OBJECT_TO_IDX["agent"], COLOR_TO_IDX["red"]


def _check_int(name: str, value: object, *, low: int) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < low:
        raise ConfigError(f"{name} must be an integer >= {low}, got {value!r}")
    return int(value)


def _check_float(name: str, value: object) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float, np.number)):
        raise ConfigError(f"{name} must be a finite number, got {value!r}")
    if not math.isfinite(float(value)):
        raise ConfigError(f"{name} must be a finite number, got {value!r}")
    return float(value)


@dataclass(frozen=True)
class GridworldConfig:
    """Everything that defines a gridworld, shared by the MiniGrid and vectorised forms.

    Attributes:
        size: room side in cells, walls included (>= 4).
        max_steps: steps before truncation; None means MiniGrid's ``4 * size**2``.
        step_reward: reward paid on every step.
        goal_reward: extra reward on the step that enters the goal.
        obs_mode: the agent's observation, one of :data:`OBS_MODES`.
        obs_tile_size: pixels per cell of the ``"rgb"`` observation.
        camera_tile_size: pixels per cell of the bolt's camera.
        start_heading: where the agent faces at the start, top-left (:data:`START_HEADINGS`):
            ``"east"`` (the paper's, MiniGrid's default) makes the route by the top-right
            corner one turn shorter than the one by the bottom-left corner, ``"south"`` the
            reverse.

    Raises:
        ConfigError: for an out-of-range value (the message names the parameter).
        UnknownNameError: for an unknown ``obs_mode`` or ``start_heading``.
    """

    size: int = 6
    max_steps: int | None = None
    step_reward: float = -1.5
    goal_reward: float = 100.0
    obs_mode: str = "grid"
    obs_tile_size: int = 8
    camera_tile_size: int = 8
    start_heading: str = "east"

    def __post_init__(self) -> None:
        _check_int("size", self.size, low=4)
        if self.start_heading not in START_HEADINGS:
            raise UnknownNameError(
                f"unknown start_heading {self.start_heading!r}; known: {', '.join(START_HEADINGS)}",
                name=str(self.start_heading),
                known=tuple(START_HEADINGS),
            )
        if self.max_steps is not None:
            _check_int("max_steps", self.max_steps, low=1)
        _check_float("step_reward", self.step_reward)
        _check_float("goal_reward", self.goal_reward)
        if self.obs_mode not in OBS_MODES:
            raise UnknownNameError(
                f"unknown obs_mode {self.obs_mode!r}; known: {', '.join(OBS_MODES)}",
                name=str(self.obs_mode),
                known=OBS_MODES,
            )
        _check_int("obs_tile_size", self.obs_tile_size, low=1)
        _check_int("camera_tile_size", self.camera_tile_size, low=1)

    @property
    def step_limit(self) -> int:
        """The resolved ``max_steps``."""
        return self.max_steps if self.max_steps is not None else 4 * self.size**2

    @property
    def start(self) -> tuple[int, int, int]:
        """The agent's start ``(x, y, heading)``."""
        return (1, 1, START_HEADINGS[self.start_heading])

    @property
    def goal(self) -> tuple[int, int]:
        """The goal cell ``(x, y)``."""
        return (self.size - 2, self.size - 2)

    def observation_shape(self) -> tuple[int, int, int]:
        """Shape of one agent observation for :attr:`obs_mode`."""
        if self.obs_mode == "grid":
            return (self.size, self.size, 3)
        if self.obs_mode == "view":
            return (7, 7, 3)
        side = self.size * self.obs_tile_size
        return (side, side, 3)

    def observation_space(self) -> spaces.Box:
        """The agent's observation space (uint8 in [0, 255], as MiniGrid's image spaces)."""
        return spaces.Box(0, 255, shape=self.observation_shape(), dtype=np.uint8)


def resolve_fluents(fluents: Sequence[str] | None) -> tuple[tuple[str, ...], np.ndarray]:
    """Check a fluent selection and return it with its columns in :data:`GRIDWORLD_FLUENTS`.

    Args:
        fluents: fluent names in the order wanted, or None for all of them.

    Returns:
        ``(names, columns)``.

    Raises:
        UnknownFluentError: if a name is not a gridworld fluent.
    """
    return select_fluents("gridworld", GRIDWORLD_FLUENTS, fluents)


def gridworld_fluents(
    x: np.ndarray, y: np.ndarray, direction: np.ndarray, *, size: int
) -> np.ndarray:
    """Ground-truth fluents of a batch of agent states.

    Args:
        x: integer ``[n]`` columns (east is +x).
        y: integer ``[n]`` rows (south is +y, MiniGrid's convention).
        direction: integer ``[n]`` headings, 0=E, 1=S, 2=W, 3=N.
        size: room side in cells, walls included.

    Returns:
        bool ``[n, 7]`` in the order of :data:`GRIDWORLD_FLUENTS`: ``on_edge`` (a floor
        cell touching the outer wall), ``top_right_corner`` (``(size-2, 1)``),
        ``bottom_left_corner`` (``(1, size-2)``), then the four headings.

    Example:
        >>> gridworld_fluents(np.array([4, 2]), np.array([1, 2]), np.array([3, 0]), size=6)
        array([[ True,  True, False,  True, False, False, False],
               [False, False, False, False, False, False,  True]])
    """
    x, y, d = np.asarray(x), np.asarray(y), np.asarray(direction)
    last = size - 2
    out = np.empty((x.shape[0], len(GRIDWORLD_FLUENTS)), dtype=bool)
    out[:, 0] = (x == 1) | (x == last) | (y == 1) | (y == last)
    out[:, 1] = (x == last) & (y == 1)
    out[:, 2] = (x == 1) & (y == last)
    out[:, 3] = d == _NORTH
    out[:, 4] = d == _SOUTH
    out[:, 5] = d == _WEST
    out[:, 6] = d == _EAST
    return out


def cell_region(size: int, x: int, y: int) -> list[float]:
    """The ``[top, left, bottom, right]`` image fractions covering cell ``(x, y)``.

    Regional noise models take boxes as fractions of the image, so one box fits any tile
    size; this converts a gridworld cell into one.
    """
    return [y / size, x / size, (y + 1) / size, (x + 1) / size]


def bottom_left_region(size: int = 6) -> list[list[float]]:
    """The ``regional`` noise model's default box for a room of any size.

    It spans the bottom row of floor from the bottom-left corner cell ``(1, size-2)`` up
    to the goal (excluded): cells that agree on every fluent but ``bottom_left_corner``
    (see :class:`noisybolt.perception.noise.RegionalDegradation` for why one cell is not
    enough). For ``size=6`` it equals ``noisybolt.perception.noise.DEFAULT_REGION``; the
    gridworld's camera swaps it in when the default box meets a room of another size.
    For ``size=4`` it is the corner cell alone, which a classifier sees through.
    """
    return [[(size - 2) / size, 1 / size, (size - 1) / size, (size - 2) / size]]


@lru_cache(maxsize=32)
def _tile_atlas(tile_size: int) -> np.ndarray:
    """MiniGrid's own tiles, so our pictures match its renderer pixel for pixel.

    Ids: 0 floor, 1 wall, 2 goal, 3 + h the agent heading h on the floor, 7 + h the agent
    heading h on the goal. MiniGrid's tiles are float after its supersampling; its
    ``Grid.render`` truncates them into uint8, and so do we.
    """
    from minigrid.core.world_object import Wall

    tiles = [
        Grid.render_tile(None, None, False, tile_size),
        Grid.render_tile(Wall(), None, False, tile_size),
        Grid.render_tile(Goal(), None, False, tile_size),
    ]
    tiles += [Grid.render_tile(None, h, False, tile_size) for h in range(4)]
    tiles += [Grid.render_tile(Goal(), h, False, tile_size) for h in range(4)]
    atlas = np.stack([np.asarray(t).astype(np.uint8) for t in tiles])
    atlas.setflags(write=False)
    return atlas


def room_cells(size: int) -> np.ndarray:
    """Cell kinds of the static room, ``[x, y]``: floor 0, wall 1, goal 2."""
    cells = np.full((size, size), CELL_FLOOR, dtype=np.int8)
    cells[0, :] = cells[-1, :] = cells[:, 0] = cells[:, -1] = CELL_WALL
    cells[size - 2, size - 2] = CELL_GOAL
    return cells


def room_compositor(size: int, tile_size: int) -> TileCompositor:
    """A compositor drawing the static room; the agent is a sprite (see ``_tile_atlas``)."""
    layout = room_cells(size).T.astype(np.intp)  # images are [row=y, col=x]
    return TileCompositor(_tile_atlas(tile_size), layout=layout)


def agent_sprite_ids(x: np.ndarray, y: np.ndarray, direction: np.ndarray, size: int) -> np.ndarray:
    """Atlas ids of the agent's tile: on the floor, or on the goal (terminal states)."""
    on_goal = (x == size - 2) & (y == size - 2)
    return np.where(on_goal, 7, 3) + direction


def fit_regional_default(model: NoiseModel, size: int) -> NoiseModel:
    """Move a ``regional`` model's default box (made for 6x6) onto a room of ``size``.

    Only models left at the default box change; an explicit box is the user's choice.
    """
    if isinstance(model, Compose):
        return Compose(models=tuple(fit_regional_default(m, size) for m in model.models))
    if isinstance(model, RegionalDegradation) and model.boxes == DEFAULT_REGION and size != 6:
        boxes = tuple(tuple(box) for box in bottom_left_region(size))
        return replace(model, boxes=boxes)  # type: ignore[arg-type]
    return model


class GridworldCamera:
    """The bolt's camera on a batch of gridworld rooms: top-down RGB, then noise.

    Args:
        size: room side in cells, walls included.
        tile_size: pixels per cell (image side is ``size * tile_size``).
        noise: a noise spec (see :func:`noisybolt.perception.noise.make_noise`).

    Example:
        >>> cam = GridworldCamera(size=6, tile_size=8)
        >>> cam.render(np.array([1]), np.array([1]), np.array([0])).shape
        (1, 48, 48, 3)
    """

    def __init__(self, *, size: int = 6, tile_size: int = 8, noise: NoiseSpec = "none") -> None:
        _check_int("size", size, low=4)
        _check_int("camera_tile_size", tile_size, low=1)
        self._size = size
        self._tile_size = tile_size
        self._noise = fit_regional_default(make_noise(noise), size)
        self._compositor = room_compositor(size, tile_size)
        h, w, c = self._compositor.image_shape
        self._spec = CameraSpec(
            world=WORLD_NAME,
            height=h,
            width=w,
            channels=c,
            noise=self._noise.describe(),
            extra={
                "size": size,
                "tile_size": tile_size,
                "renderer": "minigrid-tiles",
                "highlight": False,
            },
        )

    @property
    def spec(self) -> CameraSpec:
        """What the camera produces (resolution, noise)."""
        return self._spec

    @property
    def noise(self) -> NoiseModel:
        """The camera's noise model."""
        return self._noise

    def render(self, x: np.ndarray, y: np.ndarray, direction: np.ndarray) -> np.ndarray:
        """Clean pictures, uint8 ``[n, H, W, 3]``, identical to MiniGrid's renderer."""
        x = np.asarray(x)
        return self._compositor.render_sprites(
            agent_sprite_ids(x, np.asarray(y), np.asarray(direction), self._size),
            rows=np.asarray(y),
            cols=x,
        )

    def capture(
        self, x: np.ndarray, y: np.ndarray, direction: np.ndarray, *, rng: np.random.Generator
    ) -> np.ndarray:
        """What the bolt sees: :meth:`render` passed through the noise model."""
        return self._noise.apply(self.render(x, y, direction), rng)


def _agent_cell(world: Any) -> tuple[int, int]:
    x, y = world.agent_pos
    return (int(x), int(y))


class GridworldEnv(MiniGridEnv):
    """The gridworld as a MiniGrid environment (the reference form; see the module docs).

    Args:
        size: room side in cells, walls included.
        max_steps: truncation limit; None for MiniGrid's ``4 * size**2``.
        step_reward: reward of every step.
        goal_reward: extra reward for entering the goal.
        obs_mode: ``"grid"``, ``"view"`` or ``"rgb"``.
        obs_tile_size: pixels per cell of the ``"rgb"`` observation.
        camera_tile_size: pixels per cell of the bolt's camera.
        start_heading: the agent's heading at the start (see :class:`GridworldConfig`).
        noise: the bolt camera's noise spec.
        fluents: the bolt's fluents, in order (default: all of :data:`GRIDWORLD_FLUENTS`).
        render_mode: MiniGrid's ``"human"`` or ``"rgb_array"``.
        bolt_labels: put the bolt's camera image and the true fluents in ``info`` at
            reset and step (the world–bolt contract, see
            :mod:`noisybolt.perception.protocols`); False skips the camera's render
            (a plain MiniGrid step is then about four times faster).
        **kwargs: passed on to :class:`minigrid.minigrid_env.MiniGridEnv`.
    """

    def __init__(
        self,
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
        render_mode: str | None = None,
        bolt_labels: bool = True,
        **kwargs: Any,
    ) -> None:
        self.bolt_labels = bool(bolt_labels)
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
        self._fluent_names, self._fluent_columns = resolve_fluents(fluents)
        self._camera = GridworldCamera(size=size, tile_size=camera_tile_size, noise=noise)
        self._bolt_rng = np.random.default_rng()
        super().__init__(
            mission_space=MissionSpace(mission_func=self._gen_mission),
            grid_size=size,
            max_steps=self.config.step_limit,
            see_through_walls=True,  # as MiniGrid's EmptyEnv: nothing inside to hide behind
            render_mode=render_mode,
            **kwargs,
        )
        self.action_space = spaces.Discrete(len(GridAction))
        self.observation_space = self.config.observation_space()

    @staticmethod
    def _gen_mission() -> str:
        return "get to the green goal square"

    def _gen_grid(self, width: int, height: int) -> None:
        self.grid = Grid(width, height)
        self.grid.wall_rect(0, 0, width, height)
        self.put_obj(Goal(), *self.config.goal)
        x, y, heading = self.config.start
        self.agent_pos = (x, y)
        self.agent_dir = heading
        self.mission = self._gen_mission()

    def _reward(self) -> float:
        # MiniGrid pays this on entering the goal; the per-step reward is added in step().
        return self.config.goal_reward

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[Any, dict[str, Any]]:
        """Start an episode; a seed also re-seeds the bolt camera's noise.

        Returns:
            ``(observation, info)``, the observation a uint8 array per ``obs_mode``.
        """
        _, info = super().reset(seed=seed, options=options)
        if seed is not None:
            self._bolt_rng = np.random.default_rng(seed)
        return self.observation(), self._labelled(info)

    def step(self, action: Any) -> tuple[Any, SupportsFloat, bool, bool, dict[str, Any]]:
        """One step; ``action`` is a :class:`GridAction` (0 left, 1 right, 2 forward, 3 no-op).

        Returns:
            ``(observation, reward, terminated, truncated, info)``; the reward a float.
        """
        if not self.action_space.contains(action):
            raise ValueError(f"action must be an integer in [0, 4), got {action!r}")
        _, reward, terminated, truncated, info = super().step(MINIGRID_ACTIONS[int(action)])
        reward = float(reward) + self.config.step_reward
        return self.observation(), reward, terminated, truncated, self._labelled(info)

    def _labelled(self, info: dict[str, Any]) -> dict[str, Any]:
        if self.bolt_labels:
            info = dict(info)
            info[TRUE_FLUENTS_KEY] = self.true_fluents()
            info[BOLT_IMAGE_KEY] = self.bolt_image()
            info[GRID_POSITION_KEY] = _agent_cell(self)
        return info

    def observation(self) -> np.ndarray:
        """The agent's observation of the current state, per ``obs_mode``."""
        mode = self.config.obs_mode
        if mode == "view":
            return self.gen_obs()["image"]
        if mode == "rgb":
            return self.get_frame(highlight=False, tile_size=self.config.obs_tile_size)
        full = self.grid.encode()
        x, y = self.agent_pos
        full[x, y] = (AGENT_OBJECT, AGENT_COLOUR, self.agent_dir)
        return full

    @property
    def fluent_names(self) -> tuple[str, ...]:
        """The bolt's fluents, in the order of :meth:`true_fluents`."""
        return self._fluent_names

    @property
    def grid_layout(self) -> GridLayout:
        """The room as a grid: walls around it, the goal, the start and the spec corners."""
        size = self.config.size
        return GridLayout(
            width=size,
            height=size,
            position=_agent_cell,
            walls=True,
            goal=self.config.goal,
            start=self.config.start[:2],
            marks={"top-right": (size - 2, 1), "bottom-left": (1, size - 2)},
        )

    @property
    def camera_spec(self) -> CameraSpec:
        """The bolt camera's format and noise."""
        return self._camera.spec

    def true_fluents(self) -> np.ndarray:
        """bool ``[n_fluents]``: the ground truth now (labels and metrics only)."""
        x, y = self.agent_pos
        row = gridworld_fluents(
            np.array([x]), np.array([y]), np.array([self.agent_dir]), size=self.config.size
        )[0]
        return row[self._fluent_columns]

    def clean_bolt_image(self) -> np.ndarray:
        """The bolt camera's picture before noise, drawn by MiniGrid's own renderer."""
        return self.get_frame(highlight=False, tile_size=self.config.camera_tile_size)

    def bolt_image(self) -> np.ndarray:
        """uint8 ``[H, W, 3]``: what the bolt's camera sees now, noise included."""
        clean = self.clean_bolt_image()[None]
        return self._camera.noise.apply(clean, self._bolt_rng)[0]
