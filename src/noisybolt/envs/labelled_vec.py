"""Labelled single envs as one vectorised world, for the batched bolt and for training.

:class:`LabelledVectorEnv` steps copies of a labelled env (see
:class:`~noisybolt.envs.labels.FluentLabels`) in a Gymnasium ``SyncVectorEnv`` with
*same-step* autoreset, whose batched ``info`` is then the world–bolt contract of
:mod:`noisybolt.perception.protocols` as it stands: the envs' labels batched at reset and
step, and an ended episode's last ones in ``info["final_info"]``. It checks that they are
there (an unlabelled env is refused at its first reset or step) and names the fluents. It
is what :func:`noisybolt.make_bolted_vec_env` and a world named by factory path are built
on; :meth:`~LabelledVectorEnv.bolt_images` and :meth:`~LabelledVectorEnv.true_fluents`
(views of the last ``info``) serve sample collection.

Example:
    >>> import gymnasium as gym
    >>> from noisybolt.envs.labels import FluentLabels
    >>> def lake():
    ...     env = gym.make("FrozenLake-v1", render_mode="rgb_array", is_slippery=False)
    ...     return FluentLabels(env, fluents={"at_goal": lambda e: e.s == 15})
    >>> world = LabelledVectorEnv([lake, lake])
    >>> obs, info = world.reset(seed=0)
    >>> world.fluent_names, info["true_fluents"].tolist(), info["bolt_image"].shape
    (('at_goal',), [[False], [False]], (2, 256, 256, 3))
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium.vector import AutoresetMode, SyncVectorEnv

from noisybolt.bolt.schemes import ReturnBounds
from noisybolt.envs.deferred import DeferredArray
from noisybolt.envs.labels import batched_labels_from_info, declares_goal_of, fluent_names_of
from noisybolt.errors import ConfigError, UnlabelledEnvError
from noisybolt.perception.protocols import (
    BOLT_IMAGE_KEY,
    FINAL_INFO_KEY,
    TRUE_FLUENTS_KEY,
    CameraSpec,
)

__all__ = ["LabelledVectorEnv"]


class LabelledVectorEnv(gym.vector.VectorEnv):
    """Labelled envs stepped together with same-step autoreset (see the module docs).

    Args:
        env_fns: one function per environment, each returning a labelled env with the
            same fluents (usually the same factory repeated).
        seed: seeds the first reset that is given no seed (env ``i`` with ``seed + i``).

    Raises:
        ConfigError: no env functions, or envs whose fluents differ.
        UnlabelledEnvError: an env declares no fluents (or its ``info`` lacks the labels).
    """

    metadata: dict[str, Any] = {"autoreset_mode": AutoresetMode.SAME_STEP}  # noqa: RUF012

    def __init__(
        self, env_fns: Sequence[Callable[[], gym.Env]], *, seed: int | None = None
    ) -> None:
        if not env_fns:
            raise ConfigError("LabelledVectorEnv needs at least one env function")
        self._venv = SyncVectorEnv(list(env_fns), autoreset_mode=AutoresetMode.SAME_STEP)
        names = {fluent_names_of(env) for env in self._venv.envs}
        if len(names) != 1:
            raise ConfigError(f"the envs of one world must share their fluents, got {names}")
        self._fluent_names = names.pop()
        for env in self._venv.envs:  # the images read before the next step: see _labels
            if _has_attr(env, "defer_camera"):
                env.set_wrapper_attr("defer_camera", True)
        #: Whether its episodes have a goal (:func:`~noisybolt.envs.labels.declares_goal_of`).
        self.declares_goal = any(declares_goal_of(env) for env in self._venv.envs)
        self.num_envs = self._venv.num_envs
        self.single_observation_space = self._venv.single_observation_space
        self.single_action_space = self._venv.single_action_space
        self.observation_space = self._venv.observation_space
        self.action_space = self._venv.action_space
        self.render_mode = self._venv.render_mode
        self._first_seed = seed
        self._images: np.ndarray | None = None  # the labels of the last reset or step
        self._truth: np.ndarray | None = None

    @property
    def envs(self) -> list[gym.Env]:
        """The labelled envs, one per index."""
        return self._venv.envs

    def reset(
        self, *, seed: int | list[int | None] | None = None, options: dict[str, Any] | None = None
    ) -> tuple[Any, dict[str, Any]]:
        """Resets every env (env ``i`` with ``seed + i``); checks their labels."""
        if seed is None:
            seed, self._first_seed = self._first_seed, None
        else:
            self._first_seed = None
        obs, info = self._venv.reset(seed=seed, options=options)
        self._images, self._truth = self._labels(info, where="reset")
        return obs, info

    def step(self, actions: Any) -> tuple[Any, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        """Steps every env; an ended one is reset in the same step, its last labels in
        ``info["final_info"]`` (checked there)."""
        obs, rewards, terminated, truncated, info = self._venv.step(actions)
        self._images, self._truth = self._labels(info, where="step")
        ended = np.flatnonzero(np.logical_or(terminated, truncated))
        if ended.size:
            self._labels(info.get(FINAL_INFO_KEY, {}), where="step", rows=ended)
        return obs, rewards, terminated, truncated, info

    def _labels(
        self, info: dict[str, Any], *, where: str, rows: np.ndarray | None = None
    ) -> tuple[Any, np.ndarray]:
        """Checks ``info``'s labels, its images made one batch that renders when read.

        Each env's image is rendered when first read
        (:class:`~noisybolt.envs.labels.FluentLabels`); ``SyncVectorEnv`` gathers those
        per-env values in an object array, made here one
        :class:`~noisybolt.envs.deferred.DeferredArray` ``[num_envs, H, W, C]`` (a row
        of an env without an image, in ``final_info``, reads as zeros).
        """
        images = info.get(BOLT_IMAGE_KEY)
        if isinstance(images, np.ndarray) and images.dtype == object:
            info[BOLT_IMAGE_KEY] = _batch_of_views(images)
        return batched_labels_from_info(
            info, self.num_envs, where=where, rows=rows, read_images=False
        )

    def _need_reset(self) -> None:
        if self._images is None:
            raise ConfigError("LabelledVectorEnv: call reset() before reading the bolt's view")

    def return_bounds(self) -> ReturnBounds | None:
        """The bounds on one episode's return that the labelled envs declare
        (``FluentLabels(return_bounds=...)``), or None (see :mod:`noisybolt.envs.bounds`)."""
        bounds: ReturnBounds | None = self._venv.envs[0].get_wrapper_attr("episode_return_bounds")
        return bounds

    # ------------------------------------------------------------ BoltObservable

    @property
    def fluent_names(self) -> tuple[str, ...]:
        """The world's fluents, in the column order of :meth:`true_fluents`."""
        return self._fluent_names

    @property
    def camera_spec(self) -> CameraSpec:
        """The first env's camera.

        An image's size is known once an env has shown one: asked before the first
        :meth:`reset`, this resets env 0 once (unseeded) to look.
        """
        env = self._venv.envs[0]
        if self._images is None:
            _, info = env.reset()
            image = np.asarray(_labels_of_one(info)[0])
        else:
            image = self._images[0]
        try:
            spec = env.get_wrapper_attr("camera_spec")
        except AttributeError:
            height, width, channels = image.shape
            name = type(env.unwrapped).__name__
            spec = CameraSpec(world=name, height=height, width=width, channels=channels)
        return spec

    def bolt_images(self) -> np.ndarray:
        """uint8 ``[num_envs, H, W, 3]``: the bolt's view of every env now (the last
        ``info["bolt_image"]``, rendered now if nobody has read it).

        Raises:
            StaleInfoError: read after the envs moved on (a step this object did not make).
        """
        self._need_reset()
        assert self._images is not None
        return np.asarray(self._images)

    def true_fluents(self) -> np.ndarray:
        """bool ``[num_envs, n_fluents]``: the ground truth of every env now (a view of the
        last ``info["true_fluents"]``)."""
        self._need_reset()
        assert self._truth is not None
        return self._truth

    def render(self) -> tuple[Any, ...] | None:
        """Every env's ``render()``."""
        return self._venv.render()

    def close_extras(self, **kwargs: Any) -> None:
        """Closes the envs."""
        self._venv.close(**kwargs)


def _has_attr(env: gym.Env, name: str) -> bool:
    try:
        env.get_wrapper_attr(name)
    except AttributeError:
        return False
    return True


def _batch_of_views(views: np.ndarray) -> DeferredArray:
    """One batched image from per-env views (arrays, deferred arrays or None)."""
    shown = [v for v in views if v is not None]
    if not shown:
        raise UnlabelledEnvError(f"no env put info[{BOLT_IMAGE_KEY!r}]: wrap them in FluentLabels")
    first = shown[0]
    shape = (len(views), *first.shape)

    def stack() -> np.ndarray:
        out = np.zeros(shape, dtype=np.uint8)
        for i, view in enumerate(views):
            if view is not None:
                out[i] = np.asarray(view)
        return out

    return DeferredArray(stack, shape=shape, dtype=np.uint8)


def _labels_of_one(info: dict[str, Any]) -> tuple[Any, Any]:
    if BOLT_IMAGE_KEY not in info or TRUE_FLUENTS_KEY not in info:
        raise UnlabelledEnvError(
            f"an env's info at reset has no {BOLT_IMAGE_KEY!r} or {TRUE_FLUENTS_KEY!r}: "
            "wrap it in noisybolt.FluentLabels"
        )
    return info[BOLT_IMAGE_KEY], info[TRUE_FLUENTS_KEY]
