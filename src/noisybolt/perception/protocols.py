"""The contracts between worlds, the bolt's eyes and its fluent detectors.

The perception layer sits below ``envs``: it never imports a world. Detectors meet
:class:`FluentDetector`; a world hands the bolt what it needs through ``info``, the one
world–bolt contract, defined here and nowhere else.

**A single env** is *labelled* (wrapped in :class:`noisybolt.FluentLabels`, or a shipped
world) when it names its fluents in an attribute ``fluent_names`` (read through
``env.get_wrapper_attr``) and puts, at reset and at every step, for the state just reached:

- ``info["bolt_image"]`` (:data:`BOLT_IMAGE_KEY`): uint8 ``[H, W, 3]``, what the bolt's
  camera sees, noise included;
- ``info["true_fluents"]`` (:data:`TRUE_FLUENTS_KEY`): bool ``[n_fluents]``, the ground
  truth in the order of ``fluent_names`` (labels and metrics only, never the agent's);
- optionally, for a world that declares a ``grid_layout`` attribute
  (:class:`noisybolt.envs.layout.GridLayout`), ``info["grid_position"]``
  (:data:`GRID_POSITION_KEY`): the agent's cell ``(x, y)``, for pictures of where a policy
  goes.

**A vector env** (what the batched bolt, :class:`noisybolt.wrappers.BoltVecEnv`, trains
on) has ``fluent_names`` and ``num_envs``, resets an ended episode in the same step
(Gymnasium's ``AutoresetMode.SAME_STEP``), and puts the same keys into its batched
``info`` as Gymnasium's ``SyncVectorEnv`` batches the infos of single labelled envs:

- ``info["bolt_image"]``: uint8 ``[num_envs, H, W, 3]``; ``info["true_fluents"]``: bool
  ``[num_envs, n_fluents]``; ``info["grid_position"]``: int ``[num_envs, 2]`` (optional),
  each with its mask ``info["_" + key]`` (bool ``[num_envs]``, True: the row is there),
  at reset and at every step. After a step that ends episodes they describe the *new*
  episodes' first states;
- ``info["final_info"]`` (:data:`FINAL_INFO_KEY`, with mask ``info["_final_info"]``) on a
  step that ended episodes: the same keys for the states those episodes *reached*, before
  the reset, in the ended rows (masks True there; other rows are not the bolt's to read).
  The bolt needs them to take an episode's last transition.

A value is an array or anything ``np.asarray`` turns into one: the shipped worlds put
:class:`~noisybolt.envs.deferred.DeferredArray` s there, which render the camera only when
read, and only until the world's next reset or step. The batched bolt reads these keys and
nothing else of the world (no methods, no attributes but ``fluent_names``), straight from
the Gymnasium vector env's ``info``, before :class:`noisybolt.envs.SB3VecEnv` turns it into
SB3's list of per-env dicts.

:class:`BoltObservable` is the narrower view that sample collection
(:mod:`noisybolt.perception.dataset`) reads after moving a world to scripted states.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Protocol, runtime_checkable

import numpy as np

__all__ = [
    "BOLT_IMAGE_KEY",
    "BOLT_PROBS_KEY",
    "FINAL_INFO_KEY",
    "GRID_POSITION_KEY",
    "TRUE_FLUENTS_KEY",
    "BoltObservable",
    "CameraSpec",
    "FluentDetector",
    "goal_declared",
]

#: ``info`` key of the bolt camera's image of the state just reached (see the module docs).
BOLT_IMAGE_KEY = "bolt_image"
#: ``info`` key of the true fluents of the state just reached (see the module docs).
TRUE_FLUENTS_KEY = "true_fluents"
#: ``info`` key of the bolt's detector's probabilities of ``bolt_image`` (float32
#: ``[n, n_fluents]``, the world's fluent order), where the world computed them beside its
#: camera (:class:`~noisybolt.envs.worker_world.WorkerWorld` given the run's classifier):
#: the bolt then reads them instead of calling its detector.
BOLT_PROBS_KEY = "bolt_probs"
#: ``info`` key of the agent's grid cell ``(x, y)``, for worlds that declare a grid layout.
GRID_POSITION_KEY = "grid_position"
#: A vector env's ``info`` key of the ended episodes' last labels (Gymnasium's name).
FINAL_INFO_KEY = "final_info"


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
    """A vectorised world as sample collection sees it: its camera and its ground truth now.

    ``bolt_images`` is the bolt's camera *with its noise*, ``true_fluents`` the ground truth
    used for labels and metrics only: it must never reach the agent. For the shipped
    worlds both are views of the ``info`` of their last reset or step (see the module
    docs); the bolt itself reads ``info``, not these.
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


def goal_declared(world: object) -> bool:
    """Whether a vectorised world's episodes have a goal to reach: its ``declares_goal``
    if it says (a world of :class:`~noisybolt.FluentLabels` envs: whether ``success`` was
    given), else its ``termination_is_success`` (the gridworld: an episode ends only at
    the goal; Breakout: a game ends lost). A world without one gets no goal rate, and its
    evaluations count compliance alone as success.

    Example:
        >>> from types import SimpleNamespace as N
        >>> goal_declared(N(termination_is_success=True)), goal_declared(N())
        (True, False)
        >>> goal_declared(N(declares_goal=True, termination_is_success=False))
        True
    """
    declared = getattr(world, "declares_goal", None)
    if declared is not None:
        return bool(declared)
    return bool(getattr(world, "termination_is_success", False))


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
