"""Agents: the paper's policy body, Stable-Baselines3 PPO/A2C/DQN training and evaluation.

Recording GIFs and drawing heat-maps live in :mod:`noisybolt.agents.visualize` (it imports
matplotlib, so it is not imported here).
"""

from __future__ import annotations

from noisybolt.agents.evaluation import EpisodeRecord, EvalResult, evaluate_bolted_policy
from noisybolt.agents.extractor import BoltFeaturesExtractor
from noisybolt.agents.hyperparams import (
    ALGORITHMS,
    algorithm_class,
    load_hyperparams,
    parse_overrides,
)
from noisybolt.agents.specs import PAPER_SPECS, resolve_spec
from noisybolt.agents.training import DetectorConfig, TrainConfig, TrainResult, train

__all__ = [
    "ALGORITHMS",
    "PAPER_SPECS",
    "BoltFeaturesExtractor",
    "DetectorConfig",
    "EpisodeRecord",
    "EvalResult",
    "TrainConfig",
    "TrainResult",
    "algorithm_class",
    "evaluate_bolted_policy",
    "load_hyperparams",
    "parse_overrides",
    "resolve_spec",
    "train",
]
