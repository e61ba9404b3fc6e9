"""Labelled single envs as one vectorised world, for the batched bolt and for training.

:class:`LabelledVectorEnv` steps copies of a labelled env (see
:class:`~noisybolt.envs.labels.FluentLabels`) in a Gymnasium ``SyncVectorEnv`` with
*same-step* autoreset, and keeps what their ``info`` said at reset and step, so it meets
:class:`~noisybolt.perception.protocols.BoltObservable` (``bolt_images``, ``true_fluents``,
and the last view of an episode that just ended, from ``info["final_info"]``). It is what
:func:`noisybolt.make_bolted_vec_env` and a world named by factory path are built on.

Example:
    >>> import gymnasium as gym
    >>> from noisybolt.envs.labels import FluentLabels
    >>> def lake():
    ...     env = gym.make("FrozenLake-v1", render_mode="rgb_array", is_slippery=False)
    ...     return FluentLabels(env, fluents={"at_goal": lambda e: e.s == 15})
    >>> world = LabelledVectorEnv([lake, lake])
    >>> obs, _ = world.reset(seed=0)
    >>> world.fluent_names, world.true_fluents().tolist(), world.bolt_images().shape
    (('at_goal',), [[False], [False]], (2, 256, 256, 3))
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium.vector import AutoresetMode, SyncVectorEnv

from noisybolt.bolt.schemes import ReturnBounds
from noisybolt.envs.labels import fluent_names_of
from noisybolt.errors import ConfigError, UnlabelledEnvError
from noisybolt.perception.protocols import BOLT_IMAGE_KEY, TRUE_FLUENTS_KEY, CameraSpec

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
        self.num_envs = self._venv.num_envs
        self.single_observation_space = self._venv.single_observation_space
        self.single_action_space = self._venv.single_action_space
        self.observation_space = self._venv.observation_space
        self.action_space = self._venv.action_space
        self.render_mode = self._venv.render_mode
        self._first_seed = seed
        self._images: np.ndarray | None = None
        self._truth: np.ndarray | None = None
        self._final_images: np.ndarray | None = None
        self._final_truth: np.ndarray | None = None

    @property
    def envs(self) -> list[gym.Env]:
        """The labelled envs, one per index."""
        return self._venv.envs

    def reset(
        self, *, seed: int | list[int | None] | None = None, options: dict[str, Any] | None = None
    ) -> tuple[Any, dict[str, Any]]:
        """Resets every env (env ``i`` with ``seed + i``) and keeps their labels."""
        if seed is None:
            seed, self._first_seed = self._first_seed, None
        else:
            self._first_seed = None
        obs, info = self._venv.reset(seed=seed, options=options)
        self._images, self._truth = _labels(info, self.num_envs, "reset")
        self._final_images, self._final_truth = self._images, self._truth
        return obs, info

    def step(self, actions: Any) -> tuple[Any, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        """Steps every env; an ended one is reset in the same step (its last view kept)."""
        obs, rewards, terminated, truncated, info = self._venv.step(actions)
        self._images, self._truth = _labels(info, self.num_envs, "step")
        ended = np.flatnonzero(np.logical_or(terminated, truncated))
        if ended.size:
            final_images, final_truth = _labels(info["final_info"], self.num_envs, "step", ended)
            self._final_images, self._final_truth = self._images.copy(), self._truth.copy()
            self._final_images[ended] = final_images[ended]
            self._final_truth[ended] = final_truth[ended]
        else:
            self._final_images, self._final_truth = self._images, self._truth
        return obs, rewards, terminated, truncated, info

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
        """uint8 ``[num_envs, H, W, 3]``: the bolt's view of every env now."""
        self._need_reset()
        assert self._images is not None
        return self._images

    def true_fluents(self) -> np.ndarray:
        """bool ``[num_envs, n_fluents]``: the ground truth of every env now."""
        self._need_reset()
        assert self._truth is not None
        return self._truth

    def final_bolt_images(self) -> np.ndarray:
        """The bolt's view of the states the last step reached, before autoreset."""
        self._need_reset()
        assert self._final_images is not None
        return self._final_images

    def final_true_fluents(self) -> np.ndarray:
        """The ground truth of the states the last step reached, before autoreset."""
        self._need_reset()
        assert self._final_truth is not None
        return self._final_truth

    def render(self) -> tuple[Any, ...] | None:
        """Every env's ``render()``."""
        return self._venv.render()

    def close_extras(self, **kwargs: Any) -> None:
        """Closes the envs."""
        self._venv.close(**kwargs)


def _labels_of_one(info: dict[str, Any]) -> tuple[Any, Any]:
    if BOLT_IMAGE_KEY not in info or TRUE_FLUENTS_KEY not in info:
        raise UnlabelledEnvError(
            f"an env's info at reset has no {BOLT_IMAGE_KEY!r} or {TRUE_FLUENTS_KEY!r}: "
            "wrap it in noisybolt.FluentLabels"
        )
    return info[BOLT_IMAGE_KEY], info[TRUE_FLUENTS_KEY]


def _labels(
    info: dict[str, Any], n: int, where: str, rows: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """The batched labels of a vector ``info`` (checked present for ``rows``, default all)."""
    rows = np.arange(n) if rows is None else rows
    for key in (BOLT_IMAGE_KEY, TRUE_FLUENTS_KEY):
        present = info.get(f"_{key}")
        if key not in info or present is None or not np.all(np.asarray(present)[rows]):
            raise UnlabelledEnvError(
                f"an env's info at {where} has no {key!r}: a bolted env must put "
                f"info[{BOLT_IMAGE_KEY!r}] and info[{TRUE_FLUENTS_KEY!r}] at reset and step; "
                "wrap it in noisybolt.FluentLabels"
            )
    images = np.asarray(info[BOLT_IMAGE_KEY])
    if images.dtype != np.uint8 or images.ndim != 4:
        raise ConfigError(f"bolt images must be uint8 [H, W, 3], got {images.dtype} {images.shape}")
    return images, np.asarray(info[TRUE_FLUENTS_KEY], dtype=bool)
