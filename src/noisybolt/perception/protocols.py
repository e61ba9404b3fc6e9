"""The contracts between worlds, the bolt's eyes and its fluent detectors.

The perception layer sits below ``envs``: it never imports a world. Worlds (and any user
world) meet :class:`BoltObservable`; detectors meet :class:`FluentDetector`.

The world–bolt contract for a single Gymnasium env is its ``info``: a *labelled* env
(one wrapped in :class:`noisybolt.FluentLabels`, or a shipped world) names its fluents in
an attribute ``fluent_names`` (read through ``env.get_wrapper_attr``) and puts, at reset
and at every step, for the state just reached:

- ``info["bolt_image"]`` (:data:`BOLT_IMAGE_KEY`): uint8 ``[H, W, 3]``, what the bolt's
  camera sees, noise included;
- ``info["true_fluents"]`` (:data:`TRUE_FLUENTS_KEY`): bool ``[n_fluents]``, the ground
  truth in the order of ``fluent_names`` (labels and metrics only, never the agent's).

A world on a grid may also declare a ``grid_layout`` attribute
(:class:`noisybolt.envs.layout.GridLayout`) and put the agent's cell ``(x, y)`` in
``info["grid_position"]`` (:data:`GRID_POSITION_KEY`), for pictures of where a policy goes.

A vector env with same-step autoreset reports the ended episodes' last views in
``info["final_info"]`` under the same keys (Gymnasium's convention).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Protocol, runtime_checkable

import numpy as np

__all__ = [
    "BOLT_IMAGE_KEY",
    "GRID_POSITION_KEY",
    "TRUE_FLUENTS_KEY",
    "AutoresetBoltObservable",
    "BoltObservable",
    "CameraSpec",
    "FluentDetector",
]

#: ``info`` key of the bolt camera's image of the state just reached (see the module docs).
BOLT_IMAGE_KEY = "bolt_image"
#: ``info`` key of the true fluents of the state just reached (see the module docs).
TRUE_FLUENTS_KEY = "true_fluents"
#: ``info`` key of the agent's grid cell ``(x, y)``, for worlds that declare a grid layout.
GRID_POSITION_KEY = "grid_position"


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
class AutoresetBoltObservable(BoltObservable, Protocol):
    """A batched world that starts an ended episode's successor in the same step (what
    the batched bolt trains on), and still shows the bolt the ended episode's last view.

    Rows of environments whose episode did not end equal the current view.
    """

    def final_bolt_images(self) -> np.ndarray:
        """uint8 ``[num_envs, H, W, C]``: the bolt's view of the states the last step
        reached, before the autoreset."""
        ...

    def final_true_fluents(self) -> np.ndarray:
        """bool ``[num_envs, n_fluents]``: the ground truth of those states."""
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
