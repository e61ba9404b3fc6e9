"""What the single and the batched bolt wrappers share: checks, spaces and info records."""

from __future__ import annotations

from collections.abc import Sequence

import gymnasium as gym
import numpy as np

from noisybolt.bolt import DEFAULT_THRESHOLDS, BoltStep, CostMode, RestrainingBolt, Spec, Thresholds
from noisybolt.errors import IncompatibleError, UnknownFluentError
from noisybolt.logic.dfa import DFA
from noisybolt.perception.protocols import FluentDetector

__all__ = ["BoltParts", "bolt_info", "build_bolt", "dict_observation_space"]

# Band codes are computed once per batch by the wrappers (``confidence_bands``).


class BoltParts:
    """The bolt that shapes the reward and its ground-truth twin that only measures.

    ``bolt`` reads the detector's probabilities; ``truth`` reads the world's true fluents
    as 0/1 probabilities, so its DFA states say whether the agent *really* complied. The
    twin's rewards are never used.
    """

    def __init__(self, bolt: RestrainingBolt, truth: RestrainingBolt) -> None:
        self.bolt = bolt
        self.truth = truth


def build_bolt(
    specs: Sequence[Spec],
    detector: FluentDetector,
    world_fluents: Sequence[str],
    *,
    n_envs: int,
    dfas: Sequence[DFA] | None = None,
    thresholds: Thresholds = DEFAULT_THRESHOLDS,
    cost_mode: CostMode = "count",
    end_on_violation: bool = False,
) -> BoltParts:
    """Checks that specs, detector and world agree, and builds the bolt and its twin.

    Raises:
        UnknownFluentError: a spec reads a fluent the world does not have (the message
            lists the world's fluents).
        IncompatibleError: the detector predicts other fluents than the world's.
    """
    world_fluents = tuple(world_fluents)
    if tuple(detector.fluent_names) != world_fluents:
        raise IncompatibleError(
            f"the detector predicts {list(detector.fluent_names)} but the world's fluents are "
            f"{list(world_fluents)}; use a detector made for this world"
        )
    bolt = RestrainingBolt(
        specs,
        world_fluents,
        dfas=dfas,
        thresholds=thresholds,
        cost_mode=cost_mode,
        n_envs=n_envs,
        end_on_violation=end_on_violation,
    )
    truth = RestrainingBolt(
        bolt.specs, world_fluents, dfas=bolt.dfas, thresholds=thresholds, n_envs=n_envs
    )
    return BoltParts(bolt, truth)


def check_world_fluents(fluents: Sequence[str], specs_fluents: Sequence[str]) -> None:
    """Raises ``UnknownFluentError`` listing the world's fluents if a spec needs others."""
    unknown = tuple(f for f in specs_fluents if f not in fluents)
    if unknown:
        raise UnknownFluentError(
            f"unknown fluent(s) {list(unknown)}; this world's fluents are {list(fluents)}",
            unknown=unknown,
            known=tuple(fluents),
        )


def dict_observation_space(image_space: gym.Space, n_states: Sequence[int]) -> gym.spaces.Dict:
    """``Dict{"image": the world's observation, "dfa": MultiDiscrete(n_states)}``."""
    return gym.spaces.Dict(
        {
            "image": image_space,
            "dfa": gym.spaces.MultiDiscrete(np.asarray(n_states, dtype=np.int64)),
        }
    )


def bolt_info(
    index: int,
    *,
    env_reward: float,
    out: BoltStep,
    probs: np.ndarray,
    bands: np.ndarray,
    true_states: np.ndarray,
    true_accepting: np.ndarray,
) -> dict[str, object]:
    """The ``info`` entries one environment's step reports (arrays are per spec/fluent).

    Batched arrays are sliced, not copied: each entry is a view of row ``index``.
    """
    return {
        "env_reward": float(env_reward),
        "bolt_reward": float(out.total[index]),
        "bolt_terminal": out.terminal[index],
        "bolt_low_confidence": out.low_confidence[index],
        "bolt_carried": float(out.carried[index]),
        "fluent_probs": probs[index],
        "confidence_bands": bands[index],
        "dfa_states": out.next_states[index],
        "dfa_violated": out.violated[index],
        "true_dfa_states": true_states[index],
        "true_accepting": true_accepting[index],
    }
