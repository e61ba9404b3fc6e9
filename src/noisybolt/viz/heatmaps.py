"""Where policies go: visit counts over many episodes, drawn as heat-maps over the room.

:func:`visit_counts` and :func:`trajectory_heatmap` show where a policy goes over many
evaluation episodes, drawn over the room like the paper's Fig. 3, with the goal and the
two corners of the paper's specs outlined; :func:`compare_heatmaps` draws several
policies so side by side (e.g. one agent trained without and with a bolt).

Drawn with matplotlib's Agg canvas (no display, no pyplot state), written atomically.

Example:
    >>> paths = [[(1, 1), (2, 1), (2, 1)], [(1, 1), (1, 2)]]
    >>> visit_counts(paths, size=4)  # [y, x]: the agent turned in place at (2, 1)
    array([[0, 0, 0, 0],
           [0, 2, 2, 0],
           [0, 1, 0, 0],
           [0, 0, 0, 0]])
    >>> visit_counts(paths, size=4, per_episode=True)[1]  # episodes through each cell of row 1
    array([0, 2, 1, 0])
"""

from __future__ import annotations

import io
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.patches import Rectangle

from noisybolt.envs.layout import GridLayout
from noisybolt.errors import ConfigError
from noisybolt.io import atomic_write_bytes
from noisybolt.viz.episodes import DPI, Cell, PathLike, Room

__all__ = ["compare_heatmaps", "gridworld_room", "trajectory_heatmap", "visit_counts"]


def _no_position(world: Any) -> Cell:
    raise ConfigError("this layout describes a room for drawing only; it reads no positions")


def gridworld_room(
    size: int, *, goal: Cell | None = None, start: Cell | None = (1, 1), corners: bool = True
) -> GridLayout:
    """The gridworld's room as a :class:`GridLayout` to draw: walls around ``size`` cells.

    Args:
        size: room side in cells, walls included (the outer ring is wall).
        goal: the goal cell (None: ``(size-2, size-2)``, the gridworld's).
        start: the start cell to mark, or None.
        corners: outline the top-right ``(size-2, 1)`` and bottom-left ``(1, size-2)``
            cells (the paper's ``top_right_corner`` and ``bottom_left_corner``).
    """
    if isinstance(size, bool) or not isinstance(size, (int, np.integer)) or size < 1:
        raise ConfigError(f"size must be a positive integer, got {size!r}")
    size = int(size)
    marks = {"top-right": (size - 2, 1), "bottom-left": (1, size - 2)} if corners else {}
    return GridLayout(
        width=size,
        height=size,
        position=_no_position,
        walls=True,
        goal=(size - 2, size - 2) if goal is None else goal,
        start=start,
        marks=marks,
    )


def _room(room: Room) -> GridLayout:
    return room if isinstance(room, GridLayout) else gridworld_room(room)


def visit_counts(
    positions_per_episode: Sequence[Sequence[Cell]], *, size: Room, per_episode: bool = False
) -> np.ndarray:
    """How often each cell was visited, int64 ``[height, width]`` indexed ``[y, x]`` (as pictured).

    Args:
        positions_per_episode: per episode, the agent's ``(x, y)`` cell at every time step
            (e.g. :attr:`EpisodeRecording.positions`).
        size: the gridworld's room side in cells (walls included), or a world's
            :class:`~noisybolt.envs.layout.GridLayout`.
        per_episode: count each episode at most once per cell (how many episodes went
            through it) instead of once per time step (turning in place counts again).

    Raises:
        ConfigError: for a cell outside the room or a malformed position.
    """
    room = _room(size)
    width, height = room.width, room.height
    counts = np.zeros((height, width), dtype=np.int64)
    for e, episode in enumerate(positions_per_episode):
        cells = np.asarray(episode)
        if cells.size == 0:
            continue
        if cells.ndim != 2 or cells.shape[1] != 2 or not np.all(np.mod(cells, 1) == 0):
            raise ConfigError(f"episode {e}: positions must be integer (x, y) pairs")
        cells = cells.astype(np.int64)
        outside = np.flatnonzero(((cells < 0) | (cells >= np.array([width, height]))).any(axis=1))
        if outside.size:
            t = int(outside[0])
            raise ConfigError(
                f"episode {e}, step {t}: cell {tuple(cells[t].tolist())} is outside a "
                f"{width}x{height} room"
            )
        if per_episode:
            cells = np.unique(cells, axis=0)
        np.add.at(counts, (cells[:, 1], cells[:, 0]), 1)
    return counts


def _outline(ax: Any, cell: Cell, colour: str, *, lw: float, ls: str = "-") -> None:
    ax.add_patch(
        Rectangle((cell[0] - 0.46, cell[1] - 0.46), 0.92, 0.92, fill=False, ec=colour, lw=lw, ls=ls)
    )


_TAG_BOX = {"boxstyle": "round,pad=0.15", "fc": "white", "ec": "none", "alpha": 0.75}


def _draw_routes(
    ax: Any, positions_per_episode: Sequence[Sequence[Cell]], *, max_routes: int
) -> None:
    """Each distinct route once, as wide as the share of episodes that took it."""
    routes: dict[tuple[Cell, ...], int] = {}
    for episode in positions_per_episode:
        route = tuple((int(x), int(y)) for x, y in episode)
        # Turning in place repeats a cell; the drawn line only needs the moves.
        route = tuple(c for i, c in enumerate(route) if i == 0 or c != route[i - 1])
        if route:
            routes[route] = routes.get(route, 0) + 1
    ranked = sorted(routes.items(), key=lambda item: -item[1])[: max(int(max_routes), 0)]
    total = len(positions_per_episode)
    offsets = np.linspace(-0.15, 0.15, len(ranked)) if len(ranked) > 1 else np.zeros(1)
    for offset, (route, n) in zip(offsets, ranked, strict=False):
        cells = np.asarray(route, dtype=float)
        ax.plot(
            cells[:, 0] + offset,
            cells[:, 1] + offset,
            color="#1f3b73",
            lw=0.8 + 4.0 * n / total,
            alpha=0.75,
            solid_capstyle="round",
        )


def _draw_heatmap(
    ax: Any,
    positions_per_episode: Sequence[Sequence[Cell]],
    *,
    room: GridLayout,
    vmax: float | None,
    per_episode: bool,
    draw_paths: bool,
    max_paths: int,
) -> Any:
    """Draws one room's visit frequencies on ``ax``; returns the image (for a colour bar)."""
    if len(positions_per_episode) == 0:
        raise ConfigError("a trajectory heat-map needs at least one episode's positions")
    counts = visit_counts(positions_per_episode, size=room, per_episode=per_episode)
    values = counts / len(positions_per_episode)
    width, height = room.width, room.height
    wall = np.zeros((height, width), dtype=bool)
    if room.walls:
        wall[0, :] = wall[-1, :] = wall[:, 0] = wall[:, -1] = True
    shown = np.ma.masked_array(values, mask=wall)
    if vmax is None:
        vmax = 1.0 if per_episode else max(float(values.max()), 1e-9)
    extent = (-0.5, width - 0.5, height - 0.5, -0.5)
    image = ax.imshow(
        shown, cmap="YlOrRd", vmin=0.0, vmax=vmax, extent=extent, interpolation="nearest"
    )
    ax.imshow(
        np.where(wall, 1.0, np.nan),
        cmap="Greys",
        vmin=0.0,
        vmax=2.0,
        extent=extent,
        interpolation="nearest",
    )
    ax.set_xticks(np.arange(width) - 0.5, minor=True)
    ax.set_yticks(np.arange(height) - 0.5, minor=True)
    ax.grid(which="minor", color="white", lw=1.0)
    ax.tick_params(which="both", length=0, labelbottom=False, labelleft=False)
    # With paths drawn the numbers move to a cell's top-right corner, off the routes.
    dx, dy, ha, va = (0.42, -0.42, "right", "top") if draw_paths else (0.0, 0.0, "center", "center")
    for y, x in zip(*np.nonzero(~wall), strict=True):
        v = values[y, x]
        colour = "#9a9a9a" if v == 0 else "white" if v > 0.6 * vmax else "black"
        text = f"{v:.0%}" if per_episode else f"{v:.1f}"
        ax.text(x + dx, y + dy, text, ha=ha, va=va, fontsize=8, color=colour)
    tag: dict[str, Any] = {"fontsize": 6, "ha": "center", "va": "bottom", "bbox": _TAG_BOX}
    if room.goal is not None:
        _outline(ax, room.goal, "#009e73", lw=2.5)
        ax.text(room.goal[0], room.goal[1] + 0.42, "goal", **tag)
    if room.start is not None:
        ax.text(
            room.start[0] - 0.42, room.start[1] - 0.42, "S", **{**tag, "ha": "left", "va": "top"}
        )
    for name, cell in room.marks.items():
        _outline(ax, cell, "#0072b2", lw=1.6, ls="--")
        ax.text(cell[0], cell[1] + 0.42, name, **tag)
    if draw_paths:
        _draw_routes(ax, positions_per_episode, max_routes=max_paths)
    return image


def _colour_bar(fig: Figure, image: Any, cax: Any, *, per_episode: bool) -> None:
    bar = fig.colorbar(image, cax=cax)
    bar.set_label("share of episodes visiting" if per_episode else "visits per episode", fontsize=8)
    bar.ax.tick_params(labelsize=7)
    if per_episode:
        bar.ax.yaxis.set_major_formatter(lambda v, _: f"{v:.0%}")


def _save_png(fig: Figure, path: PathLike, dpi: int) -> Path:
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=dpi)
    path = Path(path)
    atomic_write_bytes(path, buffer.getvalue())
    return path


def _episodes(n: int) -> str:
    return f"{n} episode{'s' if n != 1 else ''}"


def _resolve_room(
    size: int | None,
    layout: GridLayout | None,
    goal: Cell | None,
    start: Cell | None,
    corners: bool,
) -> GridLayout:
    if (size is None) == (layout is None):
        raise ConfigError(
            "give the room either as size= (the gridworld's side) or as layout= (a world's "
            "GridLayout), exactly one of them"
        )
    if layout is not None:
        if not isinstance(layout, GridLayout):
            raise ConfigError(f"layout must be a noisybolt.GridLayout, got {layout!r}")
        return layout
    assert size is not None
    return gridworld_room(size, goal=goal, start=start, corners=corners)


def trajectory_heatmap(
    positions_per_episode: Sequence[Sequence[Cell]],
    *,
    path: PathLike,
    size: int | None = None,
    layout: GridLayout | None = None,
    title: str = "Where the policy goes",
    goal: Cell | None = None,
    start: Cell | None = (1, 1),
    corners: bool = True,
    per_episode: bool = True,
    draw_paths: bool = False,
    max_paths: int = 20,
    figsize: tuple[float, float] = (5.0, 4.4),
    dpi: int = DPI,
) -> Path:
    """Draws cell visit frequencies over a grid (the paper's Fig. 3, over many episodes).

    Each cell is coloured and labelled by the share of episodes that went through it
    (``per_episode``) or by its mean visits per episode; walls are grey, the goal outlined
    in green, the start marked S, and named cells outlined dashed. The room is either the
    gridworld's (``size``: walls around, the goal in the far corner, the paper's two
    corners outlined) or any world's declared :class:`~noisybolt.envs.layout.GridLayout`
    (``layout``: its own walls, goal, start and marks; ``goal``, ``start`` and
    ``corners`` are then not used).

    Args:
        positions_per_episode: per episode, the ``(x, y)`` cell at every time step.
        path: the PNG to write (atomically; folders are created).
        size: the gridworld's room side in cells, walls included.
        layout: a world's grid, instead of ``size``.
        title: the figure's title.
        goal: (with ``size``) the goal cell (None: ``(size-2, size-2)``, the gridworld's).
        start: (with ``size``) the start cell to mark, or None.
        corners: (with ``size``) outline the top-right ``(size-2, 1)`` and bottom-left
            ``(1, size-2)``.
        per_episode: colour by the share of episodes visiting a cell, else by mean visits
            per episode (time spent).
        draw_paths: also draw the episodes' routes as lines, each distinct route once, as
            wide as the share of episodes that took it (routes are slightly offset so that
            shared stretches stay visible).
        max_paths: the most distinct routes drawn (the most frequent ones).
        figsize: inches; the PNG is ``figsize * dpi`` pixels.
        dpi: pixels per inch.

    Returns:
        ``path`` as a :class:`~pathlib.Path`.

    Raises:
        ConfigError: for no episodes, a cell outside the room, or not exactly one of
            ``size`` and ``layout``.
    """
    room = _resolve_room(size, layout, goal, start, corners)
    if len(positions_per_episode) == 0:
        raise ConfigError("trajectory_heatmap needs at least one episode's positions")
    fig = Figure(figsize=figsize, dpi=dpi)
    FigureCanvasAgg(fig)
    ax = fig.add_axes((0.04, 0.04, 0.72, 0.84))
    cax = fig.add_axes((0.80, 0.12, 0.035, 0.68))
    image = _draw_heatmap(
        ax,
        positions_per_episode,
        room=room,
        vmax=None,
        per_episode=per_episode,
        draw_paths=draw_paths,
        max_paths=max_paths,
    )
    _colour_bar(fig, image, cax, per_episode=per_episode)
    n_episodes = len(positions_per_episode)
    fig.suptitle(f"{title}  ({_episodes(n_episodes)})", fontsize=10, y=0.955)
    return _save_png(fig, path, dpi)


def compare_heatmaps(
    panels: Mapping[str, Sequence[Sequence[Cell]]],
    *,
    path: PathLike,
    title: str,
    size: int | None = None,
    layout: GridLayout | None = None,
    goal: Cell | None = None,
    start: Cell | None = (1, 1),
    corners: bool = True,
    per_episode: bool = True,
    draw_paths: bool = True,
    max_paths: int = 20,
    panel_inches: float = 3.6,
    dpi: int = DPI,
) -> Path:
    """Draws several policies' heat-maps side by side on one colour scale, in one PNG.

    Each panel is drawn as :func:`trajectory_heatmap` draws its room (with the routes
    by default): e.g. the same agent trained without and with a bolt.

    Args:
        panels: panel title (may span lines) → per episode, the ``(x, y)`` cells visited;
            drawn left to right in the mapping's order.
        path: the PNG to write (atomically; folders are created).
        title: the figure's title (may span lines), e.g. the spec.
        size, layout: the room, as for :func:`trajectory_heatmap` (exactly one).
        goal, start, corners, per_episode, draw_paths, max_paths: as for
            :func:`trajectory_heatmap`.
        panel_inches: each room's longer side in inches.
        dpi: pixels per inch.

    Returns:
        ``path`` as a :class:`~pathlib.Path`.

    Raises:
        ConfigError: for no panels, a panel without episodes, or a cell outside the room.

    Example:
        >>> import tempfile, pathlib
        >>> out = pathlib.Path(tempfile.mkdtemp()) / "compare.png"
        >>> compare_heatmaps(
        ...     {"along the top": [[(1, 1), (2, 1), (3, 1), (4, 1), (4, 2), (4, 3), (4, 4)]],
        ...      "down the west wall": [[(1, 1), (1, 2), (1, 3), (1, 4), (2, 4), (3, 4), (4, 4)]]},
        ...     size=6, path=out, title="two routes").name
        'compare.png'
    """
    room = _resolve_room(size, layout, goal, start, corners)
    if not panels:
        raise ConfigError("compare_heatmaps needs at least one panel")
    for label, episodes in panels.items():
        if len(episodes) == 0:
            raise ConfigError(f"panel {label!r} has no episodes to draw")
    n = len(panels)
    title_lines = title.count("\n") + 1
    label_lines = max(label.count("\n") + 1 for label in panels)
    # Inches: a margin, the rooms with a gap between them, then the colour bar on the right;
    # the title and the panels' titles above the rooms.
    longer = max(room.width, room.height)
    panel_w = panel_inches * room.width / longer
    panel_h = panel_inches * room.height / longer
    margin, gap, bar_w = 0.15, 0.35, 0.9
    head = 0.25 + 0.22 * title_lines + 0.2 * label_lines
    width = margin + n * panel_w + (n - 1) * gap + bar_w
    height = margin + panel_h + head
    fig = Figure(figsize=(width, height), dpi=dpi)
    FigureCanvasAgg(fig)
    # One colour scale for every panel, so that equal colours mean equal numbers.
    vmax: float | None = 1.0 if per_episode else None
    if vmax is None:
        vmax = (
            max(float(visit_counts(e, size=room).max()) / len(e) for e in panels.values()) or 1e-9
        )
    image = None
    for i, (label, episodes) in enumerate(panels.items()):
        left = margin + i * (panel_w + gap)
        ax = fig.add_axes((left / width, margin / height, panel_w / width, panel_h / height))
        image = _draw_heatmap(
            ax,
            episodes,
            room=room,
            vmax=vmax,
            per_episode=per_episode,
            draw_paths=draw_paths,
            max_paths=max_paths,
        )
        ax.set_title(f"{label}  ({_episodes(len(episodes))})", fontsize=9)
    cax = fig.add_axes(
        (
            (width - bar_w + 0.15) / width,
            (margin + 0.1 * panel_h) / height,
            0.14 / width,
            0.8 * panel_h / height,
        )
    )
    _colour_bar(fig, image, cax, per_episode=per_episode)
    fig.suptitle(title, fontsize=10, y=1 - 0.1 / height, va="top")
    return _save_png(fig, path, dpi)
