"""A vector env for wrapper tests that plays back what a test scripts: the parts of SB3's
``VecEnv`` interface that no wrapper under test reads, written once."""

from __future__ import annotations

from typing import Any

import numpy as np
from gymnasium import spaces
from stable_baselines3.common.vec_env import VecEnv


class PlaybackVecEnv(VecEnv):
    """``num_envs`` games of one-number observations and two actions; a subclass plays
    back its script in ``reset`` and ``step_wait``."""

    def __init__(self, num_envs: int) -> None:
        super().__init__(num_envs, spaces.Box(0, 1, (1,), np.float32), spaces.Discrete(2))

    def step_async(self, actions: np.ndarray) -> None:
        pass

    def close(self) -> None:
        pass

    def get_attr(self, attr_name: str, indices: Any = None) -> list[Any]:
        return [None] * self.num_envs

    def set_attr(self, attr_name: str, value: Any, indices: Any = None) -> None:
        pass

    def env_method(self, method_name: str, *args: Any, indices: Any = None, **kw: Any) -> list:
        return []

    def env_is_wrapped(self, wrapper_class: Any, indices: Any = None) -> list[bool]:
        return [False] * self.num_envs
