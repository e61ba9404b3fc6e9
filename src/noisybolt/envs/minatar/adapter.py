"""One MinAtar Breakout game as a plain Gymnasium env: :class:`MinAtarBreakoutEnv`, a
one-game :class:`~noisybolt.envs.minatar.world.MinAtarBreakoutWorld` labelled for the bolt,
for :class:`~noisybolt.wrappers.RestrainingBoltWrapper` and recorded episodes (GIFs).
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np

from noisybolt.envs.minatar.board import BOARD_SIDE, CHANNELS
from noisybolt.envs.minatar.camera import render_boards
from noisybolt.envs.minatar.world import WORLD_NAME, MinAtarBreakoutWorld
from noisybolt.errors import ConfigError
from noisybolt.perception.protocols import (
    BOLT_IMAGE_KEY,
    FINAL_INFO_KEY,
    TRUE_FLUENTS_KEY,
    CameraSpec,
)

__all__ = ["RENDER_TILE", "MinAtarBreakoutEnv"]

#: Pixels per board cell in :meth:`MinAtarBreakoutEnv.render` (160x160 frames for GIFs).
RENDER_TILE = 16


class MinAtarBreakoutEnv(gym.Env[np.ndarray, np.int64]):
    """One game of :class:`MinAtarBreakoutWorld` as a plain Gymnasium env, labelled for the
    bolt (``info["bolt_image"]`` and ``info["true_fluents"]`` at reset and step).

    After a step that ends the game it shows that game's last state (observation, bolt
    image, fluents, ``render()``) until :meth:`reset`, as a Gymnasium env must, although
    the world underneath has already started the next game.

    Args:
        render_mode: ``"rgb_array"`` (the board drawn without noise, 160x160) or None.
        **settings: :class:`MinAtarBreakoutWorld` settings (``seed``, ``noise``,
            ``fluents``, ...); ``obs_mode`` None or ``"board"``.

    Example:
        >>> env = MinAtarBreakoutEnv(seed=0, fluents=["brick_clear_left"])
        >>> obs, info = env.reset(seed=0)
        >>> obs.shape, info["bolt_image"].shape, info["true_fluents"].tolist(), env.render().shape
        ((10, 10, 4), (40, 40, 3), [False], (160, 160, 3))
    """

    metadata: dict[str, Any] = {"render_modes": ["rgb_array"]}  # noqa: RUF012 (gym's API)

    def __init__(self, *, render_mode: str | None = "rgb_array", **settings: Any) -> None:
        if render_mode not in (None, "rgb_array"):
            raise ConfigError(
                f"{WORLD_NAME}: render_mode must be 'rgb_array' or None, not {render_mode!r}"
            )
        if settings.pop("obs_mode", None) not in (None, "board"):
            raise ConfigError(f"{WORLD_NAME}: obs_mode must be 'board' (MinAtar's state)")
        settings.pop("num_envs", None)
        self._world = MinAtarBreakoutWorld(num_envs=1, **settings)
        self.render_mode = render_mode
        self.observation_space = self._world.single_observation_space
        self.action_space = self._world.single_action_space
        self._ended = False
        self._board = np.zeros((BOARD_SIDE, BOARD_SIDE, len(CHANNELS)), np.uint8)  # shown
        self._labels: dict[str, Any] = {}  # the world's labels of that state

    @property
    def world(self) -> MinAtarBreakoutWorld:
        """The one-game world underneath."""
        return self._world

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        """Starts a new game (re-seeded when ``seed`` is given)."""
        super().reset(seed=seed)
        obs, info = self._world.reset(seed=seed, options=options)
        self._ended = False
        return self._show(obs[0], info)

    def step(self, action: Any) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        """One MinAtar step."""
        if self._ended:
            raise RuntimeError("the game has ended: call reset()")
        obs, rewards, terminated, truncated, info = self._world.step(np.array([int(action)]))
        self._ended = bool(terminated[0] or truncated[0])
        board, labels = obs[0], info
        if self._ended:
            board, labels = info["final_obs"][0], info[FINAL_INFO_KEY]
        shown, out = self._show(board, labels)
        return shown, float(rewards[0]), bool(terminated[0]), bool(truncated[0]), out

    def _show(self, board: np.ndarray, labels: dict[str, Any]) -> tuple[np.ndarray, dict]:
        self._board = np.asarray(board, np.uint8)
        self._labels = labels
        # The world–bolt contract (noisybolt.perception.protocols), read by the bolt.
        info = {TRUE_FLUENTS_KEY: self.true_fluents(), BOLT_IMAGE_KEY: self.bolt_image()}
        return self._board.copy(), info

    @property
    def fluent_names(self) -> tuple[str, ...]:
        """The bolt's fluents."""
        return self._world.fluent_names

    @property
    def camera_spec(self) -> CameraSpec:
        """The bolt camera's size and noise."""
        return self._world.camera_spec

    def bolt_image(self) -> np.ndarray:
        """uint8 ``[S, S, 3]``: the bolt's noisy view of the state shown."""
        return np.asarray(self._labels[BOLT_IMAGE_KEY])[0]

    def true_fluents(self) -> np.ndarray:
        """bool ``[n_fluents]``: the ground truth of the state shown."""
        return np.asarray(self._labels[TRUE_FLUENTS_KEY])[0]

    def render(self) -> np.ndarray | None:
        """The state shown, drawn as the bolt's camera draws it without noise, 160x160."""
        if self.render_mode is None:
            return None
        return render_boards(self._board[None].astype(bool), RENDER_TILE)[0]

    def close(self) -> None:
        """Releases the game."""
        self._world.close()
