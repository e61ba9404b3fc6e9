"""The restraining bolt's reward engine: confidence bands, Algorithm 1, reward timing.

Pure numpy; knows nothing of Gymnasium or torch.

* :class:`Spec`: an LTLf formula with its terminal reward, low-confidence cost and
  reward timing (by default the paper's: +1 per accepting step, 0.5 per low-confidence fluent).
* :class:`Thresholds` and the band functions: the paper's eq. 1.
* :class:`BoltEngine`: Algorithm 1, stateless, batched over environments and specs.
* :class:`RestrainingBolt`: the engine plus DFA states and episode timing (reset, the
  carried first reward, auto-reset of vectorised environments).
* :class:`RewardScheme`: how specs are paid on top of Algorithm 1 (``paper``, or
  ``compliance``: compliance first, with :class:`ProgressShaping`).
* :class:`BoltSettings`: every setting of a bolt (bands, cost mode, scheme, tracking,
  ending) in one frozen object, which every layer that builds a bolt takes whole.
* :class:`BeliefSettings` and :class:`BeliefEngine`: belief tracking (``tracking=
  "belief"``), a distribution over each spec's DFA states from evidence over time.
* :class:`AugmentedDFA`: the explicit augmented DFA of Fig. 2a, a reference to test and
  benchmark Algorithm 1 against.
* :mod:`noisybolt.bolt.product`: the product of a tabular world and the DFAs, planned by
  backward induction: exact R^c_max and the compliance scheme's exact scale.

Example:
    >>> import numpy as np
    >>> from noisybolt.logic import DFA
    >>> always_e = DFA.from_function(["e"], n_states=2, initial_state=0,
    ...     accepting=[True, False], delta=lambda q, m: 0 if q == 0 and m & 1 else 1)
    >>> bolt = RestrainingBolt([Spec("G(e)", terminal_reward=1.0, low_confidence_cost=0.5)],
    ...                        ["e"], dfas=[always_e])
    >>> bolt.reset(np.array([[0.8]])).total.tolist()  # accepting, but e seen with low confidence
    [0.5]
    >>> bolt.step(np.array([[0.99]])).total.tolist()  # 1.0 + 0.5 carried from reset
    [1.5]
"""

from __future__ import annotations

from noisybolt.bolt.augmented import AugmentedDFA, AugmentedEdge, AugmentedStep
from noisybolt.bolt.bands import (
    DEFAULT_THRESHOLDS,
    Band,
    Thresholds,
    check_probs,
    confidence_bands,
    high_confidence_mask,
    low_confidence_mask,
    proportional_weights,
    truth_mask,
)
from noisybolt.bolt.belief import (
    BELIEF_OBSERVATIONS,
    TRACKING_MODES,
    BeliefEngine,
    BeliefObservation,
    BeliefSettings,
    Tracking,
)
from noisybolt.bolt.constraint import CONSTRAINT_KEYS, CostLimit, LagrangeMultiplier, episode_costs
from noisybolt.bolt.engine import COST_MODES, BoltEngine, BoltStep, CostMode
from noisybolt.bolt.restraining_bolt import RestrainingBolt
from noisybolt.bolt.schemes import (
    REWARD_SCHEMES,
    ReturnBounds,
    RewardScheme,
    RewardSchemeName,
    compliance_scale,
)
from noisybolt.bolt.settings import BoltSettings
from noisybolt.bolt.shaping import ProgressShaping, progress_potential
from noisybolt.bolt.spec import REWARD_TIMINGS, RewardTiming, Spec

__all__ = [
    "BELIEF_OBSERVATIONS",
    "CONSTRAINT_KEYS",
    "COST_MODES",
    "DEFAULT_THRESHOLDS",
    "REWARD_SCHEMES",
    "REWARD_TIMINGS",
    "TRACKING_MODES",
    "AugmentedDFA",
    "AugmentedEdge",
    "AugmentedStep",
    "Band",
    "BeliefEngine",
    "BeliefObservation",
    "BeliefSettings",
    "BoltEngine",
    "BoltSettings",
    "BoltStep",
    "CostLimit",
    "CostMode",
    "LagrangeMultiplier",
    "ProgressShaping",
    "RestrainingBolt",
    "ReturnBounds",
    "RewardScheme",
    "RewardSchemeName",
    "RewardTiming",
    "Spec",
    "Thresholds",
    "Tracking",
    "check_probs",
    "compliance_scale",
    "confidence_bands",
    "episode_costs",
    "high_confidence_mask",
    "low_confidence_mask",
    "progress_potential",
    "proportional_weights",
    "truth_mask",
]
