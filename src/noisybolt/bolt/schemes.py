"""Reward schemes: how the bolt's rewards are set, on top of Algorithm 1.

A scheme never changes Algorithm 1's DFA moves or its low-confidence charges; it sets
what a spec pays and when, and whether progress is shaped.

* ``paper``: the paper's reading, today's behaviour and what ``reproduce`` uses: each
  spec's own ``terminal_reward`` (+1 by default) on ``every_step`` whose successor is
  accepting, no shaping. Fine where the shortest route already complies (Table 1), but
  for a user's spec it can make breaking the spec optimal (a detour costs more steps
  than +1 per accepting step pays) or make not finishing attractive (an agent paid
  every step it sits in an accepting state loiters).
* ``compliance`` (the default for ``noisybolt train``): compliance first, then the
  world's return. Each spec pays ``scale`` once, at the end of the episode, if its DFA
  accepts the episode (plain LTLf semantics: ``episode_end`` timing), and nothing for
  merely staying in an accepting state; ``scale`` exceeds the width of the world's
  episode returns (:func:`compliance_scale`), so with the return undiscounted an episode
  that complies is worth more than any that does not, whatever either earns from the
  world. With ``pay_on_change`` (the default) acceptance is paid as the DFA enters an
  accepting state and taken back if it leaves one (``on_change`` timing), rather than paid
  at the end (``episode_end``): the same sum over every episode less what its first
  observation already accepts (nothing is paid for where an episode starts, which no
  action chose), and nothing is left to collect when the episode ends. Paid at the end, a
  learner that discounts (``gamma`` 0.99) values the payment more the sooner the episode
  ends, so in a world where surviving is the task, ending the episode while the spec
  accepts became the best thing to do: on CartPole the bolted agents dropped the pole at
  once (returns of 9 against 500), on Breakout losing the last ball quickly paid. With
  acceptance paid as it changes, staying in a state is worth the same to the bolt however
  long the episode lasts. Potential-based progress shaping (:mod:`noisybolt.bolt.shaping`)
  pays progress towards acceptance as it happens, so a detour is rewarded before the spec
  is satisfied, without changing which policy is optimal.
* ``constrained``: compliance as a constraint with a budget
  (:mod:`noisybolt.bolt.constraint`). The specs are paid as under ``compliance``, but
  at a price the learner's run sets between rollouts: a learned Lagrange multiplier
  ``λ`` in ``[0, 1]`` times ``scale``, which starts at 0 (the task is learned first,
  as unbolted) and rises only while the episodes' measured cost (the specs they leave
  unsatisfied) exceeds the budget. At ``λ = 1`` it pays what ``compliance`` pays.

Example:
    >>> scheme = RewardScheme("compliance", scale=compliance_scale(ReturnBounds(-216.0, 98.5)))
    >>> round(scheme.scale, 2)
    345.95
    >>> spec = scheme.apply(Spec("F(a)", terminal_reward=1.0, low_confidence_cost=0.5))
    >>> spec.terminal_reward == scheme.scale, spec.reward_timing, spec.low_confidence_cost
    (True, 'on_change', 0.5)
    >>> RewardScheme("compliance", scale=1.0, pay_on_change=False).apply(spec).reward_timing
    'episode_end'
    >>> RewardScheme("paper").apply(spec) is spec
    True
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Literal, get_args

from noisybolt.bolt.spec import Spec
from noisybolt.errors import ConfigError, UnknownNameError

__all__ = [
    "COMPLIANCE_MARGIN",
    "REWARD_SCHEMES",
    "ReturnBounds",
    "RewardScheme",
    "RewardSchemeName",
    "compliance_scale",
]

#: The reward schemes (see the module docstring).
RewardSchemeName = Literal["compliance", "constrained", "paper"]
#: The accepted values of :data:`RewardSchemeName`.
REWARD_SCHEMES: tuple[str, ...] = get_args(RewardSchemeName)
#: How far the compliance scale exceeds the width of the world's returns (a strict
#: inequality needs some margin; 10 % keeps it strict under rounding and VecNormalize).
COMPLIANCE_MARGIN = 1.1


@dataclass(frozen=True)
class ReturnBounds:
    """Bounds on a world's (undiscounted) return over one episode.

    Attributes:
        low: no episode returns less.
        high: no episode returns more.

    Raises:
        ConfigError: a non-finite bound, or ``low > high``.
    """

    low: float
    high: float

    def __post_init__(self) -> None:
        for name in ("low", "high"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                raise ConfigError(f"ReturnBounds.{name} must be a number, got {value!r}")
            if not math.isfinite(value):
                raise ConfigError(f"ReturnBounds.{name} must be finite, got {value!r}")
            object.__setattr__(self, name, float(value))
        if self.low > self.high:
            raise ConfigError(f"ReturnBounds: low {self.low} is above high {self.high}")

    @property
    def width(self) -> float:
        """``high - low``: the most one episode's return can differ from another's."""
        return self.high - self.low


def compliance_scale(bounds: ReturnBounds) -> float:
    """The acceptance reward that puts compliance first: :data:`COMPLIANCE_MARGIN` times
    the width of the world's returns (1 where every episode returns the same)."""
    return COMPLIANCE_MARGIN * bounds.width if bounds.width > 0 else 1.0


@dataclass(frozen=True)
class RewardScheme:
    """A reward scheme and its settings.

    Attributes:
        name: ``"compliance"``, ``"constrained"`` or ``"paper"`` (see the module
            docstring).
        scale: ``compliance`` and ``constrained`` (the price at ``λ = 1``): what each
            spec's acceptance is worth (per-spec values may replace it, see
            :meth:`apply`); must be finite and > 0.
        shaping: not ``paper``: add potential-based progress shaping.
        pay_on_change: not ``paper``: pay acceptance as the DFA enters it and take
            it back as it leaves (``on_change`` timing) rather than at the episode's end
            (``episode_end``).

    Raises:
        UnknownNameError: an unknown scheme.
        ConfigError: a missing, negative, zero or non-finite scale for ``compliance``, or
            a scale or shaping given to ``paper``.
    """

    name: str = "compliance"
    scale: float | None = None
    shaping: bool = True
    pay_on_change: bool = True

    def __post_init__(self) -> None:
        if self.name not in REWARD_SCHEMES:
            raise UnknownNameError(
                f"unknown reward scheme {self.name!r}; known schemes: {list(REWARD_SCHEMES)}",
                name=str(self.name),
                known=REWARD_SCHEMES,
            )
        if self.name == "paper":
            if self.scale is not None:
                raise ConfigError(
                    "the paper scheme pays each spec's own terminal_reward: set that instead "
                    "of a reward scale, or use --reward compliance"
                )
            object.__setattr__(self, "shaping", False)
            object.__setattr__(self, "pay_on_change", False)
            return
        _check_scale(self.scale, f"the {self.name} scheme's scale")
        object.__setattr__(self, "scale", float(self.scale))  # type: ignore[arg-type]

    def apply(self, spec: Spec, *, scale: float | None = None) -> Spec:
        """``spec`` as this scheme pays it; ``scale`` replaces the scheme's for this spec.

        ``paper`` returns ``spec`` unchanged; ``compliance`` sets its terminal reward to
        the scale and its timing to ``on_change`` (``episode_end`` without
        ``pay_on_change``); its low-confidence cost is kept. ``constrained`` pays as
        ``compliance`` (its bolt's price scales the payments while it trains).
        """
        if self.name == "paper":
            if scale is not None:
                raise ConfigError(f"spec {spec.name!r}: a reward scale needs --reward compliance")
            return spec
        value = self.scale if scale is None else _check_scale(scale, f"spec {spec.name!r}'s scale")
        timing = "on_change" if self.pay_on_change else "episode_end"
        return replace(spec, terminal_reward=float(value), reward_timing=timing)  # type: ignore[arg-type]


def _check_scale(value: object, what: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ConfigError(f"{what} must be a number, got {value!r}")
    if not math.isfinite(value) or value <= 0:
        raise ConfigError(f"{what} must be finite and > 0, got {value!r}")
    return float(value)
