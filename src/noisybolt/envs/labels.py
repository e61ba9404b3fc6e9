"""Labels as a wrapper: any Gymnasium env made bolt-ready with a few fluent functions.

:class:`FluentLabels` computes the bolt's fluents and its camera image of the state just
reached and puts them in ``info`` at reset and at every step, under the keys of the
world–bolt contract (:mod:`noisybolt.perception.protocols`: ``info["bolt_image"]`` and
``info["true_fluents"]``). The agent's observation, reward and episode ends are the
wrapped env's, untouched.

Example:
    >>> import gymnasium as gym
    >>> env = FluentLabels(
    ...     gym.make("FrozenLake-v1", render_mode="rgb_array", is_slippery=False),
    ...     fluents={"at_goal": lambda lake: lake.s == 15, "top_row": lambda lake: lake.s < 4},
    ... )
    >>> obs, info = env.reset(seed=0)
    >>> env.fluent_names, info["true_fluents"].tolist(), info["bolt_image"].shape
    (('at_goal', 'top_row'), [False, True], (256, 256, 3))
    >>> obs, reward, terminated, truncated, info = env.step(1)  # down
    >>> info["true_fluents"].tolist()
    [False, False]
"""

from __future__ import annotations

import os
from collections.abc import Callable, Mapping
from typing import Any, Literal, SupportsFloat

import gymnasium as gym
import numpy as np

from noisybolt.bolt.schemes import ReturnBounds
from noisybolt.envs.deferred import DeferredArray
from noisybolt.envs.layout import GridLayout
from noisybolt.errors import CameraError, ConfigError, FluentFunctionError, UnlabelledEnvError
from noisybolt.logic.syntax import check_fluent_names
from noisybolt.perception.dataset import FluentDataset
from noisybolt.perception.noise import NoiseSpec, make_noise
from noisybolt.perception.protocols import (
    BOLT_IMAGE_KEY,
    GRID_POSITION_KEY,
    TRUE_FLUENTS_KEY,
    CameraSpec,
)

__all__ = [
    "Camera",
    "FluentFn",
    "FluentLabels",
    "batched_labels_from_info",
    "blind_camera",
    "carries",
    "collect_labelled_samples",
    "declares_goal_of",
    "fluent_names_of",
    "headless_rendering",
    "labels_from_info",
    "render_camera",
]

#: A fluent: the world's state (``env.unwrapped``) to True or False.
FluentFn = Callable[[Any], bool]
#: A bolt camera: the env (the wrapped one, as the user gave it) to uint8 ``[H, W, 3]``.
Camera = Callable[[gym.Env], np.ndarray]


def blind_camera(env: gym.Env) -> np.ndarray:
    """The camera of ``FluentLabels(..., camera=False)``: a 1x1 black image, nothing drawn."""
    return np.zeros((1, 1, 3), dtype=np.uint8)


def render_camera(env: gym.Env) -> np.ndarray:
    """The default bolt camera: the env's own ``render()`` (``render_mode="rgb_array"``)."""
    return env.render()  # type: ignore[return-value]


def headless_rendering() -> None:
    """On a machine without a display, pygame's renderers (Gymnasium's classic-control
    and Box2D worlds, drawn for the bolt's camera and for ``--gif``) draw into SDL's
    dummy video driver: without it, SDL prints "error: XDG_RUNTIME_DIR is invalid" on
    every world it renders, an alarm about nothing. noisybolt never opens a window; a
    value the user set is kept. The command line sets it up at start, and
    :class:`FluentLabels` when it wraps an env (before the env's first render), so a
    world trained from Python is as quiet."""
    if not os.environ.get("DISPLAY") and not os.environ.get("WAYLAND_DISPLAY"):
        os.environ.setdefault("SDL_VIDEODRIVER", "dummy")


class FluentLabels(gym.Wrapper, gym.utils.RecordConstructorArgs):
    """Puts the bolt's camera image and the true fluents into ``info`` (see the module docs).

    Checked at construction: the fluent names (ltlf2dfa atoms, no repeats), that every
    fluent and the camera are callable, and that an env without a camera renders RGB
    arrays. Checked at every reset and step (the first reset catches a wrong definition
    before any training): each fluent function returns a bool; and each image the camera
    renders is a uint8 ``[H, W, 3]`` image of the same shape each time.

    With :attr:`defer_camera` set (a vectorised world of these envs sets it,
    :class:`~noisybolt.envs.labelled_vec.LabelledVectorEnv`, so every training run), the
    camera renders the first image at once (it fixes the size), then each image when
    someone first reads ``info["bolt_image"]`` (a
    :class:`~noisybolt.envs.deferred.DeferredArray`; read it before the next step), and
    an episode's last image before a reset: a bolt whose detector reads the truth, an
    unbolted agent, random play never pay for a render or draw its noise (FrozenLake's
    pygame render costs 12 ms a step against the env's own 0.03). Unset (the default for
    an env used alone), every image is rendered at once, a plain array.

    Args:
        env: any Gymnasium env.
        fluents: ``{name: fn}``, in the bolt's column order; each ``fn`` is called with
            ``env.unwrapped`` (where the state lives) and returns a bool.
        camera: the bolt's camera, called with ``env``; default: ``env.render()``.
            False: none, for a bolt whose detector reads the truth (oracle, synthetic,
            a noisy sensor of your own): nothing is ever rendered, not even at episode
            ends, the bolt's images are 1x1 black, and a classifier is refused.
        noise: the camera's noise (see :func:`noisybolt.perception.noise.make_noise`);
            seeded by ``reset(seed=...)``, so a seeded run sees the same noise again.
        success: optional goal test, the name of one of ``fluents`` or a function like
            them; at the end of an episode its value goes to ``info["is_success"]``
            (the Gymnasium/SB3 convention read by goal rates).
        name: the world's name in the camera's :class:`CameraSpec` (default: the env's
            Gymnasium id, else its class name).
        return_bounds: ``(least, most)`` one episode's return can be, if known: the
            ``compliance`` reward scheme sets what complying is worth from it (see
            :mod:`noisybolt.envs.bounds`); without it that scheme needs an explicit scale.
        grid: for a world on a grid of cells, its :class:`~noisybolt.envs.layout.GridLayout`
            (size, and how to read the agent's cell): the cell goes to
            ``info["grid_position"]`` at reset and step, and ``noisybolt evaluate
            --heatmap`` can draw where a policy goes.

    Raises:
        ConfigError: no fluents, a malformed or repeated name, a fluent that is not
            callable, an unknown ``success`` fluent, or a ``grid`` that is not a
            ``GridLayout`` (and, at reset or step, an agent's cell outside it).
        CameraError: no camera given and the env does not render ``"rgb_array"``.
        FluentFunctionError: (at reset or step) a fluent function raised or returned a
            non-bool; the message names the fluent.
    """

    def __init__(
        self,
        env: gym.Env,
        *,
        fluents: Mapping[str, FluentFn],
        camera: Camera | Literal[False] | None = None,
        noise: NoiseSpec = None,
        success: str | FluentFn | None = None,
        name: str | None = None,
        return_bounds: tuple[float, float] | None = None,
        grid: GridLayout | None = None,
    ) -> None:
        gym.utils.RecordConstructorArgs.__init__(
            self,
            fluents=fluents,
            camera=camera,
            noise=noise,
            success=success,
            name=name,
            return_bounds=return_bounds,
            grid=grid,
        )
        super().__init__(env)
        headless_rendering()  # the camera renders the env, most often a pygame one
        if not isinstance(fluents, Mapping) or not fluents:
            raise ConfigError(
                "FluentLabels needs fluents={name: fn(env) -> bool, ...} with at least one "
                f"fluent, got {fluents!r}"
            )
        try:
            names = check_fluent_names(list(fluents))
        except (TypeError, ValueError) as exc:
            raise ConfigError(f"FluentLabels: bad fluent name: {exc}") from exc
        for fluent, fn in fluents.items():
            if not callable(fn):
                raise FluentFunctionError(
                    f"fluent {fluent!r} must be a function of the env returning a bool, got {fn!r}",
                    fluent=fluent,
                )
        if camera is False:
            camera = blind_camera  # a bolt that reads the truth only: nothing rendered
        elif camera is None:
            if env.render_mode != "rgb_array":
                raise CameraError(
                    f"FluentLabels: no camera given, so the bolt looks through the env's "
                    f"render(), but the env's render_mode is {env.render_mode!r}; make the "
                    "env with render_mode='rgb_array', or pass camera=fn(env) -> uint8 [H, W, 3]"
                )
            camera = render_camera
        elif not callable(camera):
            raise CameraError(f"camera must be a function env -> uint8 [H, W, 3], got {camera!r}")
        if isinstance(success, str) and success not in fluents:
            raise ConfigError(
                f"success={success!r} is not one of the fluents {list(names)}; name one, or "
                "pass a function env -> bool"
            )
        if success is not None and not isinstance(success, str) and not callable(success):
            raise ConfigError(f"success must be a fluent name or a function, got {success!r}")
        if return_bounds is not None:
            if not isinstance(return_bounds, tuple | list) or len(return_bounds) != 2:
                raise ConfigError(
                    f"return_bounds must be (least, most) of an episode's return, got "
                    f"{return_bounds!r}"
                )
            self._return_bounds: ReturnBounds | None = ReturnBounds(*return_bounds)
        else:
            self._return_bounds = None
        if grid is not None and not isinstance(grid, GridLayout):
            raise ConfigError(
                f"grid must be a noisybolt.GridLayout(width=, height=, position=...), got {grid!r}"
            )
        self._grid = grid
        self._names = names
        self._fns = tuple(fluents.values())
        self._camera = camera
        self._noise = make_noise(noise)
        self._success = success
        self._world_name = name or (
            env.spec.id if env.spec is not None else type(env.unwrapped).__name__
        )
        self._shape: tuple[int, int, int] | None = None
        self._rng = np.random.default_rng()
        #: Render each image when first read, not at once (see the class docs).
        self.defer_camera = False
        # The image of the last reset or step, rendered when first read (see _label).
        self._view: DeferredArray | None = None

    @property
    def fluent_names(self) -> tuple[str, ...]:
        """The bolt's fluents, in the column order of ``info["true_fluents"]``."""
        return self._names

    @property
    def episode_return_bounds(self) -> ReturnBounds | None:
        """The declared bounds on one episode's return (None: not declared)."""
        return self._return_bounds

    @property
    def declares_goal(self) -> bool:
        """Whether its episodes have a goal to reach (``success`` given): evaluations
        report goal rates only for such a world, and count compliance alone as success
        for one without."""
        return self._success is not None

    @property
    def grid_layout(self) -> GridLayout | None:
        """The declared grid (None: the world declared none, so no heat-maps)."""
        return self._grid

    @property
    def camera_spec(self) -> CameraSpec:
        """The bolt camera's image format and noise (known from the first reset on).

        Raises:
            CameraError: before the first reset.
        """
        if self._shape is None:
            raise CameraError("the camera's image size is known after the first reset()")
        height, width, channels = self._shape
        return CameraSpec(
            world=self._world_name,
            height=height,
            width=width,
            channels=channels,
            noise=self._noise.describe(),
        )

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[Any, dict[str, Any]]:
        """Resets the env (a seed also re-seeds the camera's noise) and labels the first state."""
        # The last step's view is the ended episode's last one (in final_info, read after
        # a vector env's same-step autoreset): rendered now, before the state is gone.
        if self._view is not None and not self._view.expired:
            self._view.value  # noqa: B018
        obs, info = self.env.reset(seed=seed, options=options)
        if seed is not None:
            self._rng = np.random.default_rng(seed)
        return obs, self._label(info)

    def step(self, action: Any) -> tuple[Any, SupportsFloat, bool, bool, dict[str, Any]]:
        """Steps the env and labels the state it reached."""
        obs, reward, terminated, truncated, info = self.env.step(action)
        info = self._label(info)
        if self._success is not None and (terminated or truncated):
            info["is_success"] = self._is_success()
        return obs, reward, terminated, truncated, info

    def _label(self, info: dict[str, Any]) -> dict[str, Any]:
        info = dict(info)
        info[TRUE_FLUENTS_KEY] = self._true_fluents()
        # Deferred, the camera is rendered (and its noise drawn) only if someone reads
        # the image before the next step. The first image is rendered at once: it fixes
        # the camera's size.
        if self._view is not None:
            self._view.expire()
        if self._shape is None or not self.defer_camera:
            info[BOLT_IMAGE_KEY] = self._bolt_image()
            self._view = None
        else:
            self._view = DeferredArray(self._bolt_image, shape=self._shape, dtype=np.uint8)
            info[BOLT_IMAGE_KEY] = self._view
        if self._grid is not None:
            info[GRID_POSITION_KEY] = self._grid.cell_of(self.env.unwrapped)
        return info

    def _true_fluents(self) -> np.ndarray:
        world = self.env.unwrapped
        truth = np.empty(len(self._names), dtype=bool)
        for i, (fluent, fn) in enumerate(zip(self._names, self._fns, strict=True)):
            truth[i] = _call_fluent(fluent, fn, world)
        return truth

    def _is_success(self) -> bool:
        if isinstance(self._success, str):
            return bool(self._true_fluents()[self._names.index(self._success)])
        assert self._success is not None
        return _call_fluent("success", self._success, self.env.unwrapped)

    def _bolt_image(self) -> np.ndarray:
        try:
            image = self._camera(self.env)
        except Exception as exc:
            raise CameraError(
                f"the bolt's camera raised {type(exc).__name__}: {exc}; it must return "
                "uint8 [H, W, 3] for any state the env reaches"
            ) from exc
        if not isinstance(image, np.ndarray) or image.dtype != np.uint8 or image.ndim != 3:
            got = (
                f"{image.dtype} {list(image.shape)}"
                if isinstance(image, np.ndarray)
                else type(image).__name__
            )
            raise CameraError(
                f"the bolt's camera must return a numpy uint8 [H, W, 3] image, got {got}"
            )
        if image.shape[2] != 3 or min(image.shape) < 1:
            raise CameraError(
                f"the bolt's camera must return RGB images [H, W, 3], got shape {list(image.shape)}"
            )
        if self._shape is None:
            self._shape = image.shape
        elif image.shape != self._shape:
            raise CameraError(
                f"the bolt's camera returned shape {list(image.shape)} after "
                f"{list(self._shape)}: every image must have one size"
            )
        seen = self._noise.apply(image[None], self._rng)[0]
        # A camera may hand out a buffer it draws the next frame into.
        return seen.copy() if np.shares_memory(seen, image) else seen


def _call_fluent(fluent: str, fn: FluentFn, world: Any) -> bool:
    try:
        value = fn(world)
    except Exception as exc:
        raise FluentFunctionError(
            f"fluent {fluent!r}: its function raised {type(exc).__name__}: {exc}",
            fluent=fluent,
        ) from exc
    if not isinstance(value, (bool, np.bool_)):
        raise FluentFunctionError(
            f"fluent {fluent!r} must return a bool, got {value!r} "
            f"({type(value).__name__}); e.g. return bool(...)",
            fluent=fluent,
        )
    return bool(value)


def declares_goal_of(env: gym.Env) -> bool:
    """Whether a labelled env has a goal (``declares_goal`` anywhere in its wrapper stack,
    as :class:`FluentLabels` sets it); an env labelled by other means that does not say
    is taken to have one (its ``info["is_success"]``, where it sets it, is the goal).

    Example:
        >>> import gymnasium as gym
        >>> lake = gym.make("FrozenLake-v1", render_mode="rgb_array")
        >>> fluents = {"top": lambda e: e.s < 4}
        >>> declares_goal_of(FluentLabels(lake, fluents=fluents, success="top"))
        True
        >>> declares_goal_of(FluentLabels(lake, fluents=fluents))
        False
    """
    try:
        return bool(env.get_wrapper_attr("declares_goal"))
    except AttributeError:
        return True


def fluent_names_of(env: gym.Env) -> tuple[str, ...]:
    """The fluents a labelled env declares (``fluent_names`` anywhere in its wrapper stack).

    Raises:
        UnlabelledEnvError: the env declares none.
    """
    try:
        names = env.get_wrapper_attr("fluent_names")
    except AttributeError:
        raise UnlabelledEnvError(
            f"{env} is not labelled for the bolt: it has no fluent_names; wrap it in "
            "noisybolt.FluentLabels(env, fluents={name: fn(env) -> bool})"
        ) from None
    return tuple(names)


def labels_from_info(info: dict[str, Any], *, where: str) -> tuple[np.ndarray, np.ndarray]:
    """``(bolt image, true fluents)`` of one env's ``info`` (the world–bolt contract).

    Raises:
        UnlabelledEnvError: a key is missing.
    """
    try:
        return np.asarray(info[BOLT_IMAGE_KEY]), np.asarray(info[TRUE_FLUENTS_KEY], dtype=bool)
    except KeyError as exc:
        raise UnlabelledEnvError(
            f"the env's info at {where} has no {exc.args[0]!r}: a bolted env must put "
            f"info[{BOLT_IMAGE_KEY!r}] and info[{TRUE_FLUENTS_KEY!r}] at reset and step; "
            "wrap it in noisybolt.FluentLabels"
        ) from None


def carries(info: Mapping[str, Any], key: str, rows: np.ndarray | None = None) -> bool:
    """Whether a batched ``info`` holds ``key`` for ``rows`` (default all): the key and
    its ``_key`` mask, True on those rows."""
    present = info.get(f"_{key}")
    if key not in info or present is None:
        return False
    return bool(np.all(present if rows is None else np.asarray(present)[rows]))


def batched_labels_from_info(
    info: Mapping[str, Any],
    n_envs: int,
    *,
    where: str,
    rows: np.ndarray | None = None,
    read_images: bool = True,
) -> tuple[Any, np.ndarray]:
    """``(bolt images, true fluents)`` of a vector env's batched ``info`` (the world–bolt
    contract, :mod:`noisybolt.perception.protocols`): uint8 ``[n_envs, H, W, C]`` and bool
    ``[n_envs, n_fluents]``, read with ``np.asarray`` (a deferred value is computed now).

    Args:
        info: the batched info (or its ``final_info``).
        n_envs: the batch size.
        where: ``"reset"`` or ``"step"``, for the message.
        rows: the rows that must carry labels (their ``_key`` masks True); default all.
        read_images: False: the images are returned as the world gave them, a
            :class:`~noisybolt.envs.deferred.DeferredArray` not computed (checked by its
            shape and dtype), for a reader that may not need them.

    Raises:
        UnlabelledEnvError: a key or a row of its mask is missing.
        ConfigError: the images are not uint8 ``[n_envs, H, W, C]`` or the fluents not
            ``[n_envs, n_fluents]``.
    """
    for key in (BOLT_IMAGE_KEY, TRUE_FLUENTS_KEY):
        if not carries(info, key, rows):
            raise UnlabelledEnvError(
                f"an env's info at {where} has no {key!r}: a bolted vector env must put "
                f"info[{BOLT_IMAGE_KEY!r}] and info[{TRUE_FLUENTS_KEY!r}] (with their '_' "
                "masks) at reset and step, and in info['final_info'] for an ended episode; "
                "wrap its envs in noisybolt.FluentLabels"
            )
    images = info[BOLT_IMAGE_KEY]
    if read_images or not isinstance(images, DeferredArray):
        images = np.asarray(images)
    truth = np.asarray(info[TRUE_FLUENTS_KEY], dtype=bool)
    if images.dtype != np.uint8 or len(images.shape) != 4 or images.shape[0] != n_envs:
        raise ConfigError(
            f"info[{BOLT_IMAGE_KEY!r}] at {where} must be uint8 [{n_envs}, H, W, C], got "
            f"{images.dtype} {images.shape}"
        )
    if truth.ndim != 2 or len(truth) != n_envs:
        raise ConfigError(
            f"info[{TRUE_FLUENTS_KEY!r}] at {where} must be bool [{n_envs}, n_fluents], got "
            f"shape {truth.shape}"
        )
    return images, truth


def collect_labelled_samples(
    env: gym.Env, *, num_samples: int, seed: int = 0, name: str | None = None
) -> FluentDataset:
    """Labelled bolt images from a labelled env played at random (to train a classifier).

    Args:
        env: a labelled env (``info["bolt_image"]``, ``info["true_fluents"]``); it is
            reset with ``seed`` and left wherever the play ended.
        num_samples: images to collect (one per reset and step).
        seed: seeds the resets and the random actions.
        name: the camera's world name (default: the env's ``camera_spec`` if it has one).

    Raises:
        ConfigError: ``num_samples`` < 1.
        UnlabelledEnvError: the env is not labelled.
    """
    if isinstance(num_samples, bool) or not isinstance(num_samples, int) or num_samples < 1:
        raise ConfigError(f"num_samples must be an integer >= 1, got {num_samples!r}")
    fluent_names = fluent_names_of(env)
    action_space = env.action_space
    action_space.seed(seed)
    images: list[np.ndarray] = []
    labels: list[np.ndarray] = []
    _, info = env.reset(seed=seed)
    while True:
        image, truth = labels_from_info(info, where="reset" if not images else "step")
        images.append(image.astype(np.uint8, copy=False))
        labels.append(truth)
        if len(images) == num_samples:
            break
        _, _, terminated, truncated, info = env.step(action_space.sample())
        if terminated or truncated:
            image, truth = labels_from_info(info, where="step")
            images.append(image.astype(np.uint8, copy=False))
            labels.append(truth)
            if len(images) == num_samples:
                break
            _, info = env.reset()
    height, width = images[0].shape[:2]
    try:
        camera = env.get_wrapper_attr("camera_spec")
    except AttributeError:
        camera = CameraSpec(world=name or type(env.unwrapped).__name__, height=height, width=width)
    return FluentDataset(
        images=np.stack(images),
        labels=np.stack(labels),
        fluent_names=fluent_names,
        camera_spec=camera,
        seed=seed,
    )
