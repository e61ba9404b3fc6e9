"""The restraining bolt as a Gymnasium wrapper and as a batched SB3 vector-env wrapper."""

from __future__ import annotations

from noisybolt.wrappers._common import BOLT_REWARD_KEY, ENV_REWARD_KEY, EPISODE_COST_KEY
from noisybolt.wrappers._inputs import DETECTOR_NAMES, DetectorName
from noisybolt.wrappers.atari import ClipGameReward, LifeLossTerminal
from noisybolt.wrappers.bolt_vec_env import BoltVecEnv
from noisybolt.wrappers.bolt_wrapper import BoltObservableEnv, RestrainingBoltWrapper
from noisybolt.wrappers.make_vec import make_bolted_vec_env
from noisybolt.wrappers.normalize import SplitRewardNormalize

__all__ = [
    "BOLT_REWARD_KEY",
    "DETECTOR_NAMES",
    "ENV_REWARD_KEY",
    "EPISODE_COST_KEY",
    "BoltObservableEnv",
    "BoltVecEnv",
    "ClipGameReward",
    "DetectorName",
    "LifeLossTerminal",
    "RestrainingBoltWrapper",
    "SplitRewardNormalize",
    "make_bolted_vec_env",
]
