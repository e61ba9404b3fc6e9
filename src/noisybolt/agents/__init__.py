"""The learner: the paper's policy network, hyperparameters, warm-startable SB3 algorithms
and their extensions (overlapped rollouts, the Lagrange multiplier of the ``constrained``
scheme, counterfactual experience for DQN).

A run (its config, training loop, checkpoints, evaluation) is :mod:`noisybolt.runs`, one
layer above; pictures are :mod:`noisybolt.viz`. The names that lived here before
(``TrainConfig``, ``train``, ...) still resolve for one release, with a
``DeprecationWarning`` that names their new home.
"""

from __future__ import annotations

from typing import Any

from noisybolt._moved import moved_attribute
from noisybolt.agents.extractor import BoltFeaturesExtractor
from noisybolt.agents.hyperparams import (
    ALGORITHMS,
    algorithm_class,
    load_hyperparams,
    parse_overrides,
)

__all__ = [
    "ALGORITHMS",
    "BoltFeaturesExtractor",
    "algorithm_class",
    "load_hyperparams",
    "parse_overrides",
]


def __getattr__(name: str) -> Any:
    return moved_attribute(__name__, name)
