"""A restraining specification: an LTLf formula with its rewards and reward timing."""

from __future__ import annotations

import math
from dataclasses import KW_ONLY, dataclass
from typing import Literal, get_args

import numpy as np

from noisybolt.errors import ConfigError

__all__ = ["DEFAULT_COST", "DEFAULT_REWARD", "REWARD_TIMINGS", "RewardTiming", "Spec"]

#: A spec's default terminal reward: the paper's +1 for each step its DFA is accepting.
DEFAULT_REWARD = 1.0
#: A spec's default low-confidence cost: the paper's 0.5 for each fluent on the taken edge
#: that the bolt saw with low confidence.
DEFAULT_COST = 0.5

#: When a spec's terminal reward is paid (see :class:`Spec`).
RewardTiming = Literal["every_step", "on_entry", "episode_end", "on_change"]
#: The accepted values of :data:`RewardTiming`.
REWARD_TIMINGS: tuple[str, ...] = get_args(RewardTiming)


@dataclass(frozen=True)
class Spec:
    """One of the bolt's wishes: an LTLf formula over the bolt's fluents, and its rewards.

    Attributes:
        formula: LTLf text in ltlf2dfa syntax, e.g. ``"F(e & t)"``.
        terminal_reward: reward paid when the DFA is in an accepting state (when exactly
            depends on ``reward_timing``); any finite number. Default
            :data:`DEFAULT_REWARD` (1.0, the paper's).
        low_confidence_cost: the *cost* (a non-negative magnitude) charged for each fluent
            on the taken edge that the bolt saw with low confidence; it enters the reward
            with a minus sign. Default :data:`DEFAULT_COST` (0.5, the paper's).
        reward_timing: ``"every_step"`` pays on every transition whose successor is
            accepting (the paper's Algorithm 1; default); ``"on_entry"`` only on a
            transition from a non-accepting state into an accepting one (the first
            transition of an episode counts as an entry when it lands on an accepting
            state); ``"episode_end"`` only on the transition that ends the episode
            (termination or truncation), if its successor is accepting (plain LTLf
            semantics); ``"on_change"`` pays it on each transition into an accepting
            state and takes it back on each transition out of one, nothing at the end
            and nothing on the episode's first transition (read before any action: an
            episode that starts accepting starts at 0): over any episode the sum is
            ``episode_end``'s less what the first transition accepts, which no action
            changes, and nothing is left to collect when the episode ends, so a learner
            that discounts is not paid for ending an accepted episode sooner. The
            low-confidence cost is charged on every transition in all four.
        name: a short label for logs and info dicts; defaults to the formula.

    Raises:
        ConfigError: an empty formula, a non-finite reward, a negative or non-finite cost
            or an unknown timing.

    Example:
        >>> spec = Spec("F(e & t)", terminal_reward=10.0, low_confidence_cost=2.0)
        >>> spec.name, spec.reward_timing
        ('F(e & t)', 'every_step')
        >>> Spec("G(e)").terminal_reward, Spec("G(e)").low_confidence_cost  # the paper's
        (1.0, 0.5)
        >>> Spec("G(e)", reward_timing="later")
        Traceback (most recent call last):
        ...
        noisybolt.errors.ConfigError: Spec 'G(e)': reward_timing 'later' is not one of \
['every_step', 'on_entry', 'episode_end', 'on_change']
    """

    formula: str
    _: KW_ONLY
    terminal_reward: float = DEFAULT_REWARD
    low_confidence_cost: float = DEFAULT_COST
    reward_timing: RewardTiming = "every_step"
    name: str = ""

    def __post_init__(self) -> None:
        if not isinstance(self.formula, str) or not self.formula.strip():
            raise ConfigError(f"Spec.formula must be a non-empty string, got {self.formula!r}")
        label = self.name or self.formula
        if not isinstance(label, str):
            raise ConfigError(f"Spec.name must be a string, got {self.name!r}")
        for field_name in ("terminal_reward", "low_confidence_cost"):
            value = getattr(self, field_name)
            if isinstance(value, bool) or not isinstance(value, (int, float, np.number)):
                raise ConfigError(f"Spec {label!r}: {field_name} must be a number, got {value!r}")
            if not math.isfinite(value):
                raise ConfigError(f"Spec {label!r}: {field_name} must be finite, got {value!r}")
            object.__setattr__(self, field_name, float(value))
        if self.low_confidence_cost < 0:
            raise ConfigError(
                f"Spec {label!r}: low_confidence_cost is a cost and must be >= 0, got "
                f"{self.low_confidence_cost!r} (it is subtracted from the reward)"
            )
        if self.reward_timing not in REWARD_TIMINGS:
            raise ConfigError(
                f"Spec {label!r}: reward_timing {self.reward_timing!r} is not one of "
                f"{list(REWARD_TIMINGS)}"
            )
        object.__setattr__(self, "name", label)
