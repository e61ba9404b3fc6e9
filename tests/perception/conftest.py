"""A toy world on a line: a fast BoltObservable for collection and training tests."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
import pytest
from gymnasium import spaces

from noisybolt.perception.protocols import CameraSpec

LINE = 8


class PlainLineWorld:
    """``num_envs`` dots on a line of 8 cells; the bolt sees an 8x8 image with a lit column.

    Fluents: ``at_left`` (cell 0), ``at_right`` (cell 7), ``middle`` (cells 2-5). Actions:
    0 left, 1 right, 2 stay. Random walks only (no scripted states).
    """

    fluent_names = ("at_left", "at_right", "middle")

    def __init__(self, *, num_envs: int = 4) -> None:
        self.num_envs = num_envs
        self.single_action_space = spaces.Discrete(3)
        self.action_space = spaces.MultiDiscrete([3] * num_envs)
        self.camera_spec = CameraSpec("line", LINE, LINE)
        self._pos = np.full(num_envs, 3, dtype=np.int64)

    def reset(self, *, seed: int | None = None) -> tuple[np.ndarray, dict[str, Any]]:
        self._pos[:] = 3
        return self._pos.copy(), {}

    def step(self, actions: np.ndarray) -> tuple[Any, ...]:
        move = np.where(actions == 0, -1, np.where(actions == 1, 1, 0))
        self._pos = np.clip(self._pos + move, 0, LINE - 1)
        zeros = np.zeros(self.num_envs, dtype=bool)
        return self._pos.copy(), np.zeros(self.num_envs), zeros, zeros, {}

    def bolt_images(self) -> np.ndarray:
        images = np.zeros((self.num_envs, LINE, LINE, 3), dtype=np.uint8)
        images[np.arange(self.num_envs), :, self._pos] = 255
        return images

    def true_fluents(self) -> np.ndarray:
        p = self._pos
        return np.stack([p == 0, p == LINE - 1, (p >= 2) & (p <= 5)], axis=1)


class LineWorld(PlainLineWorld):
    """The line world with scripted jumps to random cells for collection."""

    def sample_collection_states(self, rng: np.random.Generator) -> None:
        self._pos = rng.integers(0, LINE, self.num_envs)


@pytest.fixture
def line_world() -> LineWorld:
    """A scripted line world with 4 envs."""
    return LineWorld(num_envs=4)


@pytest.fixture
def make_line_world() -> Callable[..., PlainLineWorld]:
    """Factory: ``make_line_world(num_envs=, scripted=)``."""

    def make(*, num_envs: int = 4, scripted: bool = True) -> PlainLineWorld:
        return (LineWorld if scripted else PlainLineWorld)(num_envs=num_envs)

    return make
