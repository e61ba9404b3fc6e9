"""SB3's ``MultiInputPolicy`` for each algorithm, with the DFA states one-hot in one op.

SB3 prepares a ``Dict`` observation (``preprocess_obs``) before any features extractor sees
it, and one-hot encodes a ``MultiDiscrete`` entry one sub-space at a time; on the small
batches of a rollout step that costs about as much as the agent's convolutions. These
policies are SB3's own, except that observations for a
:class:`~noisybolt.agents.extractor.BoltFeaturesExtractor` are prepared by
:meth:`~noisybolt.agents.extractor.BoltFeaturesExtractor.preprocess`: the same tensors,
with one scatter for all DFA states. They add no parameters, so a model saved with SB3's
``MultiInputPolicy`` loads into them unchanged (its ``policy_class`` entry is rebuilt from
the run's config, see :func:`noisybolt.runs.models.load_model`).
"""

from __future__ import annotations

from typing import Any

import torch
from stable_baselines3 import A2C, DQN, PPO
from stable_baselines3.common.base_class import BaseAlgorithm
from stable_baselines3.common.policies import BaseModel, MultiInputActorCriticPolicy
from stable_baselines3.common.torch_layers import BaseFeaturesExtractor
from stable_baselines3.dqn.policies import MultiInputPolicy as DQNMultiInputPolicy
from stable_baselines3.dqn.policies import QNetwork

from noisybolt.agents.extractor import BoltFeaturesExtractor
from noisybolt.agents.hyperparams import algorithm_class

__all__ = ["BoltActorCriticPolicy", "BoltDQNPolicy", "policy_class"]


class _ExtractorPreprocesses(BaseModel):
    """``BaseModel.extract_features`` with the bolt's extractor preparing its own input.

    Placed after the SB3 policy in a subclass's bases, so that it stands in for
    ``BaseModel``'s method wherever SB3 calls ``super().extract_features``.
    """

    def extract_features(self, obs: Any, features_extractor: BaseFeaturesExtractor) -> Any:
        if isinstance(features_extractor, BoltFeaturesExtractor) and isinstance(obs, dict):
            prepared = features_extractor.preprocess(obs, normalize_images=self.normalize_images)
            out: torch.Tensor = features_extractor(prepared)
            return out
        return super().extract_features(obs, features_extractor)


class BoltActorCriticPolicy(MultiInputActorCriticPolicy, _ExtractorPreprocesses):
    """SB3's ``MultiInputPolicy`` of PPO and A2C (see the module docstring)."""


class _BoltQNetwork(QNetwork, _ExtractorPreprocesses):
    """SB3's Q-network (see the module docstring)."""


class BoltDQNPolicy(DQNMultiInputPolicy):
    """SB3's ``MultiInputPolicy`` of DQN (see the module docstring)."""

    def make_q_net(self) -> QNetwork:
        # SB3's make_q_net, building the Q-network above.
        net_args = self._update_features_extractor(self.net_args, features_extractor=None)
        return _BoltQNetwork(**net_args).to(self.device)


_POLICIES: dict[type[BaseAlgorithm], type[BaseModel]] = {
    PPO: BoltActorCriticPolicy,
    A2C: BoltActorCriticPolicy,
    DQN: BoltDQNPolicy,
}


def policy_class(algo: str) -> type[BaseModel]:
    """The policy class noisybolt builds ``algo``'s model with.

    Raises:
        UnknownNameError: an unknown algorithm (from
            :func:`~noisybolt.agents.hyperparams.algorithm_class`).
    """
    return _POLICIES[algorithm_class(algo)]
