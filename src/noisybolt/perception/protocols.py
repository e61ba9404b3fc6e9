"""The contracts between worlds, the bolt's eyes and its fluent detectors.

The perception layer sits below ``envs``: it never imports a world. Worlds (and any user
world) meet :class:`BoltObservable`; detectors meet :class:`FluentDetector`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Protocol, runtime_checkable

import numpy as np

__all__ = ["BoltObservable", "CameraSpec", "FluentDetector"]


@dataclass(frozen=True)
class CameraSpec:
    """What a bolt camera produces, so a classifier can refuse images it was not made for.

    Attributes:
        world: the world's registry name (e.g. ``"gridworld"``, ``"breakout"``).
        height: image height in pixels.
        width: image width in pixels.
        channels: number of channels (3 for RGB).
        noise: a JSON-able description of the noise model applied (name and parameters).
        extra: any further JSON-able settings that change what the camera shows.
    """

    world: str
    height: int
    width: int
    channels: int = 3
    noise: dict[str, Any] = field(default_factory=dict)
    extra: dict[str, Any] = field(default_factory=dict)

    @property
    def shape(self) -> tuple[int, int, int]:
        """``(height, width, channels)`` of one image."""
        return (self.height, self.width, self.channels)


@runtime_checkable
class BoltObservable(Protocol):
    """A (vectorised) world as the restraining bolt sees it.

    ``bolt_images`` is the bolt's camera *with its noise*, ``true_fluents`` the ground truth
    used for labels and metrics only: it must never reach the agent.
    """

    @property
    def fluent_names(self) -> tuple[str, ...]:
        """The world's fluent vocabulary, in the column order of :meth:`true_fluents`."""
        ...

    @property
    def num_envs(self) -> int:
        """Number of environments in the batch."""
        ...

    @property
    def camera_spec(self) -> CameraSpec:
        """The bolt camera's output format and noise settings."""
        ...

    def bolt_images(self) -> np.ndarray:
        """uint8 ``[num_envs, H, W, C]``: what the bolt's camera sees now."""
        ...

    def true_fluents(self) -> np.ndarray:
        """bool ``[num_envs, n_fluents]``: the ground-truth fluents now."""
        ...


@runtime_checkable
class FluentDetector(Protocol):
    """Maps a batch of bolt images to fluent probabilities.

    Detectors that cheat by reading ground truth (the oracle, the synthetic detector) set
    ``needs_truth`` and receive it through ``truth``; image classifiers ignore it.
    """

    @property
    def fluent_names(self) -> tuple[str, ...]:
        """The fluents it predicts, in column order."""
        ...

    @property
    def needs_truth(self) -> bool:
        """Whether :meth:`predict` needs the ``truth`` argument."""
        ...

    def predict(self, images: np.ndarray, *, truth: np.ndarray | None = None) -> np.ndarray:
        """float32 ``[n, n_fluents]`` probabilities for uint8 images ``[n, H, W, C]``."""
        ...
