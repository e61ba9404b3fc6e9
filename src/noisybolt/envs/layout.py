"""A world's grid, declared: where the agent is, so heat-maps can show where a policy goes.

A world on a grid of cells declares a :class:`GridLayout`: the grid's size in cells, a
function reading the agent's cell from the world's state, and what a picture of the grid
marks (walls, the goal, the start, named cells). A labelled env
(:class:`noisybolt.FluentLabels`) given ``grid=`` puts the agent's cell into ``info`` at
reset and at every step under :data:`~noisybolt.perception.protocols.GRID_POSITION_KEY`,
and exposes the layout as its ``grid_layout`` attribute; the shipped gridworld does both
natively. ``noisybolt evaluate --heatmap`` draws any world that declares one.

Example (Gymnasium's FrozenLake: 4x4 cells, state ``s = 4*row + col``):
    >>> lake = GridLayout(
    ...     width=4, height=4, position=lambda env: (env.s % 4, env.s // 4), goal=(3, 3),
    ...     start=(0, 0),
    ... )
    >>> class Lake:
    ...     s = 6
    >>> lake.cell_of(Lake())
    (2, 1)
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

from noisybolt.errors import ConfigError

__all__ = ["Cell", "GridLayout", "PositionFn"]

#: A cell ``(x, y)``: ``x`` grows to the right (east), ``y`` downwards (south), as drawn.
Cell = tuple[int, int]
#: The agent's cell, read from the world's state (``env.unwrapped``).
PositionFn = Callable[[Any], Cell]


def _is_int(value: Any) -> bool:
    return isinstance(value, int) and not isinstance(value, bool)


@dataclass(frozen=True)
class GridLayout:
    """A world's grid of cells and how to read the agent's cell from its state.

    Attributes:
        width: cells from west to east (walls included, if the world has them).
        height: cells from north to south.
        position: the world's state (``env.unwrapped``) → the agent's ``(x, y)`` cell.
        walls: the outer ring of cells is wall (MiniGrid's rooms): drawn grey, never
            counted.
        goal: the goal cell, outlined in pictures (None: none drawn).
        start: the start cell, marked S (None: none drawn).
        marks: further cells to outline, by name (e.g. the corners a spec talks about).

    Raises:
        ConfigError: for a non-positive size, a non-callable ``position``, or a goal,
            start or mark outside the grid.
    """

    width: int
    height: int
    position: PositionFn
    walls: bool = False
    goal: Cell | None = None
    start: Cell | None = None
    marks: Mapping[str, Cell] = field(default_factory=dict)

    def __post_init__(self) -> None:
        for name in ("width", "height"):
            value = getattr(self, name)
            if not _is_int(value) or value < 1:
                raise ConfigError(f"GridLayout {name} must be a positive integer, got {value!r}")
        if not callable(self.position):
            raise ConfigError(
                f"GridLayout position must be a function of the world's state returning the "
                f"agent's (x, y) cell, got {self.position!r}"
            )
        cells = {"goal": self.goal, "start": self.start}
        cells.update({f"mark {name!r}": cell for name, cell in dict(self.marks).items()})
        for what, cell in cells.items():
            if cell is not None:
                self.check_cell(cell, what=f"the {what}")
        object.__setattr__(self, "marks", {str(k): tuple(v) for k, v in dict(self.marks).items()})

    def check_cell(self, cell: Any, *, what: str) -> Cell:
        """``cell`` as an ``(x, y)`` pair of ints inside the grid.

        Raises:
            ConfigError: naming ``what``, for anything else.
        """
        try:
            x, y = cell
        except (TypeError, ValueError):
            raise ConfigError(f"{what} must be an (x, y) cell, got {cell!r}") from None
        if not (_is_int(x) or hasattr(x, "__index__")) or not (
            _is_int(y) or hasattr(y, "__index__")
        ):
            raise ConfigError(f"{what} must be an (x, y) pair of integers, got {cell!r}")
        x, y = int(x), int(y)
        if not (0 <= x < self.width and 0 <= y < self.height):
            raise ConfigError(
                f"{what} {(x, y)} is outside the {self.width}x{self.height} grid "
                f"(x in [0, {self.width}), y in [0, {self.height}))"
            )
        return (x, y)

    def cell_of(self, world: Any) -> Cell:
        """The agent's cell in ``world`` (the unwrapped env), checked to lie in the grid.

        Raises:
            ConfigError: if the position function raises, or returns no cell of the grid.
        """
        try:
            cell = self.position(world)
        except Exception as exc:
            raise ConfigError(
                f"the grid layout's position function raised {type(exc).__name__}: {exc}; it "
                "must return the agent's (x, y) cell for any state the env reaches"
            ) from exc
        return self.check_cell(cell, what="the agent's cell (from the layout's position)")
