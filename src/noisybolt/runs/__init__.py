"""Runs: one training or evaluation of a bolted agent, from its config to its directory.

The config schema (data only) and the loading of old files (:mod:`~noisybolt.runs.config`,
:mod:`~noisybolt.runs.sections`, :mod:`~noisybolt.runs.schema`), the one
:func:`~noisybolt.runs.resolution.resolve` that every door calls (``train()``, ``noisybolt
train``, ``check``, sweeps, ``reproduce``), the env stack (:mod:`~noisybolt.runs.environments`),
training and its callbacks, checkpoints and stopping, the run directory
(:mod:`~noisybolt.runs.rundir`), and evaluation (:mod:`~noisybolt.runs.evaluation`,
:mod:`~noisybolt.runs.run_evaluation`). The learner itself (network, policies,
hyperparameters, SB3 extensions) is :mod:`noisybolt.agents`, one layer below.

Example:
    >>> from noisybolt.runs import TrainConfig
    >>> TrainConfig.create(specs=["G(!top_right_corner)"], frames=1000).algorithm.name
    'ppo'
"""

from __future__ import annotations

from noisybolt.runs.config import DetectorConfig, TrainConfig
from noisybolt.runs.evaluation import EpisodeRecord, EvalResult, evaluate_bolted_policy
from noisybolt.runs.resolution import resolve
from noisybolt.runs.specs import PAPER_SPECS, resolve_spec
from noisybolt.runs.training import TrainResult, train

__all__ = [
    "PAPER_SPECS",
    "DetectorConfig",
    "EpisodeRecord",
    "EvalResult",
    "TrainConfig",
    "TrainResult",
    "evaluate_bolted_policy",
    "resolve",
    "resolve_spec",
    "train",
]
