"""One Breakout game as a plain Gymnasium env: :class:`BreakoutEnv`, a one-game
:class:`~noisybolt.envs.breakout.world.BreakoutWorld` labelled for the bolt, for
:class:`~noisybolt.wrappers.RestrainingBoltWrapper` and recorded episodes (GIFs).
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np

from noisybolt.envs.breakout.world import BreakoutWorld
from noisybolt.errors import ConfigError
from noisybolt.perception.protocols import (
    BOLT_IMAGE_KEY,
    FINAL_INFO_KEY,
    TRUE_FLUENTS_KEY,
    CameraSpec,
)

__all__ = ["BreakoutEnv"]


class BreakoutEnv(gym.Env[np.ndarray, np.int64]):
    """One game of :class:`BreakoutWorld` as a plain Gymnasium env, labelled for the bolt
    (``info["bolt_image"]`` and ``info["true_fluents"]`` at reset and step), for
    :class:`~noisybolt.wrappers.RestrainingBoltWrapper` and recorded episodes (GIFs).

    After a step that ends the game it shows that game's last state (observation, bolt
    image, fluents, ``render()``) until :meth:`reset`, as a Gymnasium env must, although
    the world underneath has already started the next game.

    Args:
        render_mode: ``"rgb_array"`` (the raw colour frame) or None.
        **kwargs: :class:`BreakoutWorld` settings (``seed``, ``noise``, ``fluents``, ...).

    Example:
        >>> env = BreakoutEnv(seed=0, fluents=["left_gone_row5"])
        >>> obs, _ = env.reset(seed=0)
        >>> obs.shape, env.bolt_image().shape, env.true_fluents().tolist(), env.render().shape
        ((4, 84, 84), (84, 84, 3), [False], (210, 160, 3))
        >>> env.close()
    """

    metadata: dict[str, Any] = {"render_modes": ["rgb_array"]}  # noqa: RUF012 (gym's API)

    def __init__(self, *, render_mode: str | None = "rgb_array", **kwargs: Any) -> None:
        if render_mode not in (None, "rgb_array"):
            raise ConfigError(
                f"breakout: render_mode must be 'rgb_array' or None, not {render_mode!r}"
            )
        if kwargs.get("obs_mode", "stack") is None:
            kwargs.pop("obs_mode")  # the factory's "world default"
        self._world = BreakoutWorld(num_envs=1, **kwargs)
        self.render_mode = render_mode
        self.observation_space = self._world.single_observation_space
        self.action_space = self._world.single_action_space
        self._ended = False
        self._world_labels: dict[str, Any] = {}  # the world's labels of the state shown

    @property
    def world(self) -> BreakoutWorld:
        """The one-game world underneath."""
        return self._world

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        """Starts a new game (re-seeded when ``seed`` is given)."""
        super().reset(seed=seed)
        obs, info = self._world.reset(seed=seed, options=options)
        self._ended = False
        self._world_labels = info
        return obs[0], self._labelled({"lives": int(info["lives"][0])})

    def step(self, action: Any) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        """One agent step (``frame_skip`` frames)."""
        if self._ended:
            raise RuntimeError("the game has ended: call reset()")
        obs, rewards, terminated, truncated, info = self._world.step(np.array([int(action)]))
        self._ended = bool(terminated[0] or truncated[0])
        self._world_labels = info
        if self._ended:
            obs = info["final_obs"][0][None]
            self._world_labels = info[FINAL_INFO_KEY]
        info = self._labelled({})
        return obs[0], float(rewards[0]), bool(terminated[0]), bool(truncated[0]), info

    def _labelled(self, info: dict[str, Any]) -> dict[str, Any]:
        # The world–bolt contract (noisybolt.perception.protocols), read by the bolt.
        info[TRUE_FLUENTS_KEY] = self.true_fluents()
        info[BOLT_IMAGE_KEY] = self.bolt_image()
        return info

    @property
    def fluent_names(self) -> tuple[str, ...]:
        """The bolt's fluents."""
        return self._world.fluent_names

    @property
    def camera_spec(self) -> CameraSpec:
        """The bolt camera's size and noise."""
        return self._world.camera_spec

    def bolt_image(self) -> np.ndarray:
        """uint8 ``[S, S, 3]``: the bolt's noisy view of the state the last step reached
        (row 0 of the world's ``info["bolt_image"]``, or of its ``final_info``'s)."""
        return np.asarray(self._world_labels[BOLT_IMAGE_KEY])[0]

    def true_fluents(self) -> np.ndarray:
        """bool ``[n_fluents]``: the ground truth of that state."""
        return np.asarray(self._world_labels[TRUE_FLUENTS_KEY])[0]

    def render(self) -> np.ndarray | None:
        """The raw colour frame (210x160) of that state."""
        if self.render_mode is None:
            return None
        if self._ended and 0 in self._world._final_rgb:
            return self._world._final_rgb[0].copy()
        return self._world.frames()[0]

    def close(self) -> None:
        """Releases the console."""
        self._world.close()
