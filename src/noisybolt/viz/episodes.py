"""An episode of a bolted policy, recorded with what the bolt saw, and drawn as a GIF.

* :func:`record_episode` runs a policy for one episode in a
  :class:`~noisybolt.wrappers.RestrainingBoltWrapper` and keeps everything worth drawing:
  the world's frames, what the bolt's noisy camera saw, the fluent probabilities and
  their confidence bands, the bolt's and the true DFA states, rewards, actions and (in
  grid worlds) the agent's cell.
* :func:`save_episode_gif` draws each step as the world, the bolt's view, per-fluent
  probability bars coloured by band (eq. 1's thresholds drawn), and per spec its DFA
  state as the bolt believes it and as the ground truth has it.
Everything is drawn with matplotlib's Agg canvas (no display, no pyplot state) and
written atomically.
"""

from __future__ import annotations

import os
import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import imageio.v3 as iio
import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.patches import Circle, Rectangle

from noisybolt.bolt import Band, confidence_bands
from noisybolt.envs.layout import GridLayout
from noisybolt.errors import ConfigError
from noisybolt.io import atomic_write_bytes
from noisybolt.perception.protocols import BOLT_IMAGE_KEY, GRID_POSITION_KEY
from noisybolt.wrappers.bolt_wrapper import RestrainingBoltWrapper

__all__ = [
    "BAND_COLOURS",
    "DPI",
    "EpisodeRecording",
    "default_frame",
    "policy_from_model",
    "record_episode",
    "render_episode_frames",
    "save_episode_gif",
]

Policy = Callable[[Any], Any]
FrameFn = Callable[[Any], np.ndarray]
PathLike = str | os.PathLike[str]
Cell = tuple[int, int]
#: A room for :func:`trajectory_heatmap`: the gridworld's side in cells, or any world's
#: declared :class:`~noisybolt.envs.layout.GridLayout`.
Room = int | GridLayout

#: Bar colour of each confidence band (Okabe-Ito: readable by colour-blind viewers).
BAND_COLOURS: dict[Band, str] = {
    Band.ABSENT: "#9a9a9a",
    Band.LOW: "#e69f00",
    Band.HIGH: "#0072b2",
}
_ACCEPT_COLOUR, _REJECT_COLOUR = "#009e73", "#d55e00"
_BAND_LABELS = {Band.ABSENT: "absent", Band.LOW: "low", Band.HIGH: "high"}


@dataclass(frozen=True, eq=False)
class EpisodeRecording:
    """One recorded episode of a bolted policy. ``T`` is the number of steps taken.

    Index ``t`` of a ``[T+1, ...]`` array is the state after ``t`` steps (``0``: after
    reset, when the bolt has already read the first observation); index ``t`` of a
    ``[T]`` array is the step from state ``t`` to ``t+1``.

    Attributes:
        frames: uint8 ``[T+1, H, W, 3]``: the world as a person sees it.
        bolt_images: uint8 ``[T+1, h, w, c]``: exactly what the bolt's (noisy) camera saw.
        probs: float ``[T+1, k]``: the detector's fluent probabilities.
        bands: int8 ``[T+1, k]``: their confidence bands (:class:`~noisybolt.bolt.Band`).
        dfa_states: int ``[T+1, m]``: every spec's DFA state as the bolt tracks it.
        true_dfa_states: int ``[T+1, m]``: the same DFAs run on the true fluents.
        env_rewards: float ``[T]``: the world's reward of each step.
        bolt_rewards: float ``[T]``: the bolt's shaping reward of each step (the reset
            transition's reward is in the first step's, as the wrapper pays it).
        actions: ``[T]``: the actions taken.
        positions: int ``[T+1, 2]`` of ``(x, y)`` cells when the world has an
            ``agent_pos``, else None.
        fluent_names: the ``k`` fluents, in column order.
        spec_names: the ``m`` specs' names (their formulas where unnamed).
        accepting: per spec, bool ``[n_states]``: which of its DFA states accept.
        truth_threshold: a fluent is true iff its probability is at least this.
        high_threshold: a true fluent is seen clearly iff its probability is above this.
        terminated: whether the last step ended the task.
        truncated: whether the last step hit a limit outside the task (both are False
            when ``max_steps`` cut the recording short).
        world_view: what ``frames`` show: ``"world"``, or ``"bolt's camera"`` for a world
            that draws no picture of itself (its frames are then the bolt's images).
    """

    frames: np.ndarray
    bolt_images: np.ndarray
    probs: np.ndarray
    bands: np.ndarray
    dfa_states: np.ndarray
    true_dfa_states: np.ndarray
    env_rewards: np.ndarray
    bolt_rewards: np.ndarray
    actions: np.ndarray
    positions: np.ndarray | None
    fluent_names: tuple[str, ...]
    spec_names: tuple[str, ...]
    accepting: tuple[np.ndarray, ...]
    truth_threshold: float = 0.5
    high_threshold: float = 0.9
    terminated: bool = False
    truncated: bool = False
    world_view: str = "world"

    def __post_init__(self) -> None:
        n = self.n_steps + 1
        k, m = len(self.fluent_names), len(self.spec_names)
        expected: dict[str, tuple[int | None, ...]] = {
            "frames": (n, None, None, 3),
            "bolt_images": (n, None, None, None),
            "probs": (n, k),
            "bands": (n, k),
            "dfa_states": (n, m),
            "true_dfa_states": (n, m),
            "env_rewards": (n - 1,),
            "bolt_rewards": (n - 1,),
        }
        if self.positions is not None:
            expected["positions"] = (n, 2)
        for name, shape in expected.items():
            actual = np.shape(getattr(self, name))
            if len(actual) != len(shape) or any(
                s is not None and a != s for a, s in zip(actual, shape, strict=True)
            ):
                wanted = tuple("*" if s is None else s for s in shape)
                raise ValueError(f"EpisodeRecording.{name} has shape {actual}, expected {wanted}")
        if len(self.accepting) != m:
            raise ValueError(f"accepting has {len(self.accepting)} masks for {m} specs")

    @property
    def n_steps(self) -> int:
        """``T``, the number of steps taken."""
        return int(np.shape(self.actions)[0])

    @property
    def env_return(self) -> float:
        """The sum of the world's rewards (the episode's R_π)."""
        return float(np.sum(self.env_rewards))

    @property
    def bolt_return(self) -> float:
        """The sum of the bolt's shaping rewards."""
        return float(np.sum(self.bolt_rewards))

    @property
    def bolt_accepting(self) -> np.ndarray:
        """bool ``[T+1, m]``: whether the bolt's DFA state of each spec is accepting."""
        return _accepting_of(self.dfa_states, self.accepting)

    @property
    def true_accepting(self) -> np.ndarray:
        """bool ``[T+1, m]``: whether each spec's true DFA state is accepting."""
        return _accepting_of(self.true_dfa_states, self.accepting)


def _accepting_of(states: np.ndarray, accepting: Sequence[np.ndarray]) -> np.ndarray:
    columns = [np.asarray(mask)[states[:, i]] for i, mask in enumerate(accepting)]
    return np.stack(columns, axis=1) if columns else np.zeros((len(states), 0), dtype=bool)


def default_frame(world: Any) -> np.ndarray:
    """The world's picture for a person: MiniGrid's ``get_frame``, else ``render()``.

    Args:
        world: the unwrapped environment.

    Returns:
        uint8 ``[H, W, 3]``.

    Raises:
        ConfigError: if the world offers neither (pass ``frame_fn`` to
            :func:`record_episode` instead).
    """
    get_frame = getattr(world, "get_frame", None)
    if callable(get_frame):
        # MiniGrid's signature; highlight would shade a partial view the bolt never uses.
        return np.asarray(get_frame(highlight=False))
    frame = world.render() if callable(getattr(world, "render", None)) else None
    if isinstance(frame, np.ndarray) and frame.ndim == 3:
        return frame
    raise ConfigError(
        f"{type(world).__name__} has no get_frame() and its render() gave no RGB array "
        "(create it with render_mode='rgb_array', or pass frame_fn=...)"
    )


def policy_from_model(model: Any, *, deterministic: bool = True) -> Policy:
    """A :func:`record_episode` policy from a Stable-Baselines3 model.

    Example:
        >>> class Always2:
        ...     def predict(self, obs, deterministic=True):
        ...         return np.array(2), None
        >>> policy_from_model(Always2())({"image": None})
        2
    """

    def policy(obs: Any) -> Any:
        action, _ = model.predict(obs, deterministic=deterministic)
        action = np.asarray(action)
        return action.item() if action.shape == () else action

    return policy


def record_episode(
    env: RestrainingBoltWrapper,
    policy: Policy,
    *,
    seed: int | None,
    max_steps: int | None = None,
    frame_fn: FrameFn | None = None,
) -> EpisodeRecording:
    """Runs ``policy`` for one episode and records what :func:`save_episode_gif` draws.

    The bolt's images are the very ones its detector read: the env's
    ``info["bolt_image"]`` at reset and every step (the world–bolt contract, so any
    labelled env records, e.g. one in :class:`noisybolt.FluentLabels`); recording takes
    no second, differently noised look, so it does not change the episode.

    Args:
        env: the bolted environment (it is reset with ``seed``).
        policy: maps the wrapper's observation ``{"image", "dfa"}`` to an action; see
            :func:`policy_from_model` for a Stable-Baselines3 model.
        seed: the reset seed.
        max_steps: stop after this many steps even if the episode goes on (None: run
            until it terminates or is truncated).
        frame_fn: the world's picture, given ``env.unwrapped`` (default
            :func:`default_frame`; a world that gives none, e.g. a Gymnasium env made
            without ``render_mode`` whose :class:`~noisybolt.FluentLabels` has a camera of
            its own, is drawn as the bolt's camera sees it, and ``world_view`` says so).

    Returns:
        The recording; ``T`` is the number of steps taken.

    Raises:
        ConfigError: for a negative ``max_steps``, frames that cannot be drawn, or an
            ``info`` without the bolt's image.
    """
    if max_steps is not None and (isinstance(max_steps, bool) or max_steps < 0):
        raise ConfigError(f"max_steps must be None or an integer >= 0, got {max_steps!r}")
    world: Any = env.unwrapped
    world_view = "world"
    bolt = env.bolt
    thresholds = bolt.thresholds

    frames: list[np.ndarray] = []
    bolt_images: list[np.ndarray] = []
    probs: list[np.ndarray] = []
    bands: list[np.ndarray] = []
    states: list[np.ndarray] = []
    true_states: list[np.ndarray] = []
    positions: list[Cell] = []
    env_rewards: list[float] = []
    bolt_rewards: list[float] = []
    actions: list[Any] = []
    # The contract's cell when the world declares its grid; MiniGrid's agent_pos otherwise.
    has_position: bool | None = None

    def keep(info: dict[str, Any]) -> None:
        # Copies throughout: a world or the bolt may hand out views of buffers it reuses.
        if BOLT_IMAGE_KEY not in info:
            raise ConfigError(
                f"the bolted env's info has no {BOLT_IMAGE_KEY!r}: record_episode draws what "
                "the bolt saw from it (wrap the env in noisybolt.FluentLabels)"
            )
        bolt_images.append(np.array(info[BOLT_IMAGE_KEY], dtype=np.uint8, copy=True))
        p = np.array(info["fluent_probs"], dtype=np.float64)
        probs.append(p)
        # reset's info carries no bands; both come from the same thresholds.
        band = info.get("confidence_bands")
        bands.append(confidence_bands(p, thresholds) if band is None else np.array(band))
        states.append(np.array(info["dfa_states"], dtype=np.int64))
        true_states.append(np.array(info["true_dfa_states"], dtype=np.int64))
        nonlocal frame_fn, world_view
        if frame_fn is None:  # decided on the first view, after the reset
            try:
                with warnings.catch_warnings():  # Gymnasium warns of a render without a mode
                    warnings.simplefilter("ignore")
                    default_frame(world)
                frame_fn = default_frame
            except ConfigError:  # no picture of itself: the bolt's images stand in
                world_view = "bolt's camera"
                frame_fn = lambda _world: bolt_images[-1]  # noqa: E731
        frames.append(np.array(frame_fn(world), dtype=np.uint8))
        nonlocal has_position
        cell = info.get(GRID_POSITION_KEY)
        if cell is None and hasattr(world, "agent_pos"):
            cell = world.agent_pos
        if has_position is None:
            has_position = cell is not None
        if has_position:
            if cell is None:
                raise ConfigError(
                    f"the env's info lost its {GRID_POSITION_KEY!r} in the middle of an episode"
                )
            positions.append((int(cell[0]), int(cell[1])))

    terminated = truncated = False
    obs, info = env.reset(seed=seed)
    keep(info)
    while max_steps is None or len(actions) < max_steps:
        action = policy(obs)
        obs, _, terminated, truncated, info = env.step(action)
        actions.append(action)
        env_rewards.append(float(info["env_reward"]))
        bolt_rewards.append(float(info["bolt_reward"]))
        keep(info)
        if terminated or truncated:
            break
    shapes = {f.shape for f in frames}
    if len(shapes) != 1 or len(next(iter(shapes))) != 3 or next(iter(shapes))[2] != 3:
        raise ConfigError(f"frames must all be RGB [H, W, 3] of one shape, got {sorted(shapes)}")

    return EpisodeRecording(
        frames=np.stack(frames),
        bolt_images=np.stack(bolt_images),
        probs=np.stack(probs),
        bands=np.stack(bands).astype(np.int8),
        dfa_states=np.stack(states),
        true_dfa_states=np.stack(true_states),
        env_rewards=np.asarray(env_rewards, dtype=np.float64),
        bolt_rewards=np.asarray(bolt_rewards, dtype=np.float64),
        actions=np.asarray(actions),
        positions=np.asarray(positions, dtype=np.int64) if has_position else None,
        fluent_names=tuple(bolt.fluents),
        spec_names=tuple(spec.name or spec.formula for spec in bolt.specs),
        accepting=tuple(np.array(dfa.accepting, dtype=bool) for dfa in bolt.dfas),
        truth_threshold=float(thresholds.truth),
        high_threshold=float(thresholds.high),
        terminated=bool(terminated),
        truncated=bool(truncated),
        world_view=world_view,
    )


# --------------------------------------------------------------------------- episode GIF


DPI = 100
_MAX_DRAWN_STATES = 8  # more DFA states than this are written, not drawn as circles


def _shorten(text: str, width: int) -> str:
    return text if len(text) <= width else text[: width - 1] + "…"


class _EpisodeCanvas:
    """One matplotlib figure whose artists are updated in place for every step.

    Building the figure once and only changing image data, bar widths, colours and
    texts keeps a frame to a few tens of milliseconds.
    """

    def __init__(self, rec: EpisodeRecording, *, action_names: Sequence[str] | None) -> None:
        self.rec = rec
        self.action_names = action_names
        k, m = len(rec.fluent_names), len(rec.spec_names)
        # Layout in inches: the world and the bolt's view side by side, then a column of
        # fluent bars over a band legend over one two-line row per spec.
        width, right, right_w = 10.0, 6.45, 3.45
        row_h, dfa_head = 0.6, 0.3
        dfa_h = dfa_head + row_h * m
        bars_h = 0.22 * k + 0.1
        legend_h = 0.3
        height = max(3.6, 0.45 + 0.25 + bars_h + 0.25 + legend_h + dfa_h + 0.15)
        self.fig = Figure(figsize=(width, height), dpi=DPI)
        self.canvas = FigureCanvasAgg(self.fig)
        fig = self.fig

        def box(
            left: float, bottom: float, w: float, h: float
        ) -> tuple[float, float, float, float]:
            return (left / width, bottom / height, w / width, h / height)

        self.title = fig.text(0.1 / width, 1 - 0.12 / height, "", va="top", fontsize=11)
        side = min(3.0, height - 0.8)
        image_bottom = (height - 0.45 - side) / 2
        ax_world = fig.add_axes(box(0.1, image_bottom, 3.0, side))
        ax_bolt = fig.add_axes(box(3.25, image_bottom, 3.0, side))
        world_title = "world" if rec.world_view == "world" else "world (no render: the bolt's view)"
        for ax, name in ((ax_world, world_title), (ax_bolt, "bolt's camera")):
            ax.set_xticks([])
            ax.set_yticks([])
            ax.set_title(name, fontsize=9)
        self.world_im = ax_world.imshow(rec.frames[0], interpolation="nearest")
        self.bolt_im = ax_bolt.imshow(rec.bolt_images[0], interpolation="nearest")

        # Fluent probabilities: one horizontal bar each, both thresholds drawn.
        label_w = 1.3
        bars_bottom = 0.15 + dfa_h + legend_h + 0.25
        ax_bars = fig.add_axes(box(right + label_w, bars_bottom, right_w - label_w, bars_h))
        y = np.arange(k)
        self.bars = ax_bars.barh(y, np.zeros(k), height=0.7, color=BAND_COLOURS[Band.ABSENT])
        self.values = [
            ax_bars.text(0.0, i, "", va="center", ha="left", fontsize=7) for i in range(k)
        ]
        ax_bars.set_yticks(y, [_shorten(n, 20) for n in rec.fluent_names], fontsize=8)
        ax_bars.set_ylim(k - 0.5, -0.5)
        ax_bars.set_xlim(0.0, 1.0)
        ax_bars.set_xticks([0.0, rec.truth_threshold, rec.high_threshold])
        ax_bars.tick_params(axis="x", labelsize=7, pad=1)
        # Redrawn every frame, after the bars, so that they stay on top of them.
        self.thresholds = [
            ax_bars.axvline(rec.truth_threshold, color="black", lw=0.8, ls="--"),
            ax_bars.axvline(rec.high_threshold, color="black", lw=0.8, ls=":"),
        ]
        fig.text(
            (right + right_w / 2) / width,
            (bars_bottom + bars_h + 0.08) / height,
            "fluent probabilities",
            ha="center",
            va="bottom",
            fontsize=9,
        )
        fig.legend(
            [Rectangle((0, 0), 1, 1, color=BAND_COLOURS[b]) for b in Band],
            [_BAND_LABELS[b] for b in Band],
            loc="center",
            bbox_to_anchor=box(right, 0.15 + dfa_h, right_w, legend_h),
            ncol=3,
            fontsize=7,
            frameon=False,
            handlelength=1.0,
            columnspacing=1.2,
        )

        # DFA states: per spec, its name and states as text, then its states as circles:
        # filled = the bolt's state, ring = the true state, double outline = accepting.
        ax_dfa = fig.add_axes(box(right, 0.15, right_w, dfa_h))
        ax_dfa.set_xlim(0.0, right_w)
        ax_dfa.set_ylim(dfa_h, 0.0)
        ax_dfa.axis("off")
        ax_dfa.text(0.0, 0.12, "DFA states", fontsize=9, va="center")
        ax_dfa.text(
            right_w,
            0.12,
            "filled: bolt   ring: truth   double: accepting",
            fontsize=7,
            va="center",
            ha="right",
        )
        self.dfa_rows: list[tuple[list[Circle], list[Circle], Any]] = []
        for i, name in enumerate(rec.spec_names):
            top = dfa_head + row_h * i + 0.12
            ax_dfa.text(0.0, top, _shorten(name, 30), fontsize=8, va="center", weight="bold")
            status = ax_dfa.text(right_w, top, "", fontsize=8, va="center", ha="right")
            fills: list[Circle] = []
            rings: list[Circle] = []
            n_states = len(rec.accepting[i])
            for q in range(min(n_states, _MAX_DRAWN_STATES)):
                centre = (0.15 + 0.3 * q, top + 0.27)
                if rec.accepting[i][q]:
                    ax_dfa.add_patch(Circle(centre, 0.085, fill=False, lw=0.8, ec="black"))
                fill = Circle(centre, 0.06, fc="white", ec="black", lw=0.8)
                ring = Circle(centre, 0.115, fill=False, lw=1.8, ec="none")
                ax_dfa.add_patch(fill)
                ax_dfa.add_patch(ring)
                ax_dfa.text(centre[0] + 0.13, centre[1], f"{q}", fontsize=6, va="center")
                fills.append(fill)
                rings.append(ring)
            if n_states > _MAX_DRAWN_STATES:
                ax_dfa.text(
                    0.15 + 0.3 * _MAX_DRAWN_STATES, top + 0.27, "…", fontsize=8, va="center"
                )
            self.dfa_rows.append((fills, rings, status))

        # Blitting: everything that never changes (axes, labels, legends) is drawn once,
        # and each frame only redraws the artists below on top of that background. Text
        # is most of the cost of a matplotlib frame, so this is several times faster.
        self.dynamic: list[Any] = [self.title, self.world_im, self.bolt_im]
        self.dynamic += [*self.bars, *self.thresholds, *self.values]
        for fills, rings, status in self.dfa_rows:
            self.dynamic += [*fills, *rings, status]
        for artist in self.dynamic:
            artist.set_animated(True)
        self.canvas.draw()
        self.background = self.canvas.copy_from_bbox(fig.bbox)

    def _action_text(self, t: int) -> str:
        if t == 0:
            return "reset"
        action = self.rec.actions[t - 1]
        if self.action_names is not None and np.ndim(action) == 0:
            index = int(action)
            if 0 <= index < len(self.action_names):
                return self.action_names[index]
        return str(np.asarray(action).tolist())

    def draw(self, t: int) -> np.ndarray:
        rec = self.rec
        env_return = float(np.sum(rec.env_rewards[:t]))
        bolt_return = float(np.sum(rec.bolt_rewards[:t]))
        self.title.set_text(
            f"step {t}/{rec.n_steps}   action: {self._action_text(t)}   "
            f"env return {env_return:+.1f}   bolt return {bolt_return:+.1f}"
        )
        self.world_im.set_data(rec.frames[t])
        self.bolt_im.set_data(rec.bolt_images[t])
        for bar, text, p, band in zip(
            self.bars, self.values, rec.probs[t], rec.bands[t], strict=True
        ):
            bar.set_width(float(p))
            bar.set_color(BAND_COLOURS[Band(int(band))])
            text.set_text(f"{p:.2f}")
            inside = p > 0.8  # a long bar holds its own label
            text.set_x(float(p) - 0.02 if inside else float(p) + 0.02)
            text.set_horizontalalignment("right" if inside else "left")
            text.set_color("white" if inside else "black")
        accepting = rec.bolt_accepting[t]
        true_accepting = rec.true_accepting[t]
        for i, (fills, rings, status) in enumerate(self.dfa_rows):
            q, q_true = int(rec.dfa_states[t, i]), int(rec.true_dfa_states[t, i])
            colour = _ACCEPT_COLOUR if accepting[i] else _REJECT_COLOUR
            true_colour = _ACCEPT_COLOUR if true_accepting[i] else _REJECT_COLOUR
            for state, (fill, ring) in enumerate(zip(fills, rings, strict=True)):
                fill.set_facecolor(colour if state == q else "white")
                ring.set_edgecolor(true_colour if state == q_true else "none")
            mark = "✓" if accepting[i] else "✗"
            true_mark = "✓" if true_accepting[i] else "✗"
            status.set_text(f"bolt: q{q} {mark}    truth: q{q_true} {true_mark}")
            # The bolt misreading the world is what a reader looks for: flag it.
            status.set_color("black" if q == q_true else _REJECT_COLOUR)
        self.canvas.restore_region(self.background)
        for artist in self.dynamic:
            (artist.axes or self.fig).draw_artist(artist)
        return np.asarray(self.canvas.buffer_rgba())[..., :3].copy()


def render_episode_frames(
    recording: EpisodeRecording, *, action_names: Sequence[str] | None = None
) -> np.ndarray:
    """The pictures :func:`save_episode_gif` animates, uint8 ``[T+1, H, W, 3]``.

    Each shows the world, the bolt's camera, the fluent probabilities (bars coloured by
    band, dashed line at the truth threshold, dotted at the high one), each spec's DFA
    state as the bolt tracks it (filled, green if accepting, red if not) and as the
    ground truth has it (ringed), the step, the action, and the returns so far.

    Args:
        recording: from :func:`record_episode`.
        action_names: names of integer actions, e.g. ``[a.name for a in GridAction]``.
    """
    canvas = _EpisodeCanvas(recording, action_names=action_names)
    return np.stack([canvas.draw(t) for t in range(recording.n_steps + 1)])


def save_episode_gif(
    recording: EpisodeRecording,
    path: PathLike,
    *,
    fps: float = 4.0,
    action_names: Sequence[str] | None = None,
) -> Path:
    """Writes the episode as a looping GIF, one frame per step (see :func:`render_episode_frames`).

    Args:
        recording: from :func:`record_episode`.
        path: the GIF file to write (atomically; folders are created).
        fps: frames per second.
        action_names: names of integer actions.

    Returns:
        ``path`` as a :class:`~pathlib.Path`.

    Raises:
        ConfigError: for a non-positive ``fps``.
    """
    if isinstance(fps, bool) or not isinstance(fps, (int, float)) or not fps > 0:
        raise ConfigError(f"fps must be a positive number, got {fps!r}")
    frames = render_episode_frames(recording, action_names=action_names)
    data = iio.imwrite("<bytes>", frames, extension=".gif", duration=1000.0 / fps, loop=0)
    path = Path(path)
    atomic_write_bytes(path, data)
    return path
