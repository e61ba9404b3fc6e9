"""Agents: the paper's policy body and Stable-Baselines3 PPO, A2C and DQN."""

from __future__ import annotations

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
