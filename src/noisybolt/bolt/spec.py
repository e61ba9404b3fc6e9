"""A restraining specification: an LTLf formula with its rewards and reward timing."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import KW_ONLY, dataclass
from typing import Literal, Protocol, get_args

import numpy as np

from noisybolt.errors import ConfigError, UnsatisfiableSpecError
from noisybolt.logic import DFA, is_satisfiable, is_valid

__all__ = [
    "DEFAULT_COST",
    "DEFAULT_REWARD",
    "REWARD_TIMINGS",
    "RewardTiming",
    "Spec",
    "check_satisfiable",
    "vacuous_message",
]

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


class _Named(Protocol):
    """What the check reads of a spec: a :class:`Spec`, or its fields as given."""

    @property
    def name(self) -> str: ...

    @property
    def formula(self) -> str: ...


def check_satisfiable(
    specs: Sequence[_Named], dfas: Sequence[DFA], *, world: str | None = None
) -> list[_Named]:
    """Refuses a spec no trace satisfies; returns those every trace satisfies (the bolt
    asks for nothing there: the caller says so, :func:`vacuous_message`).

    Reads the compiled DFAs' graphs (:func:`~noisybolt.logic.is_satisfiable`,
    :func:`~noisybolt.logic.is_valid`): cheap, no compiling. ``world``: the world whose
    fluents the DFAs were compiled over, for the message. A spec and DFA count that
    differ is left for :class:`~noisybolt.bolt.RestrainingBolt` to report.

    Raises:
        UnsatisfiableSpecError: no trace of one letter or more satisfies a spec (no
            accepting state is reachable from its DFA's initial state).

    Example:
        >>> from noisybolt.logic import compile_ltlf
        >>> check_satisfiable([Spec("F(a) & G(!a)")], [compile_ltlf("F(a) & G(!a)", ["a"])])
        Traceback (most recent call last):
        ...
        noisybolt.errors.UnsatisfiableSpecError: spec 'F(a) & G(!a)' is unsatisfiable: no \
trace satisfies 'F(a) & G(!a)', so no agent can comply (training under it teaches the \
agent to ignore the bolt); fix the formula
        >>> [vacuous_message(s) for s in check_satisfiable([Spec("a | !a")],
        ...                                                [compile_ltlf("a | !a", ["a"])])]
        ["spec 'a | !a' holds on every trace ('a | !a'): the bolt asks for nothing"]
    """
    vacuous = []
    of = "" if world is None else f" of the {world}'s fluents"
    for spec, dfa in zip(specs, dfas, strict=False):
        if not is_satisfiable(dfa):
            raise UnsatisfiableSpecError(
                f"spec {spec.name!r} is unsatisfiable: no trace{of} satisfies "
                f"{spec.formula!r}, so no agent can comply (training under it teaches the "
                "agent to ignore the bolt); fix the formula",
                formula=spec.formula,
            )
        if is_valid(dfa):
            vacuous.append(spec)
    return vacuous


def vacuous_message(spec: _Named) -> str:
    """What is said of a spec that every trace satisfies (:func:`check_satisfiable`)."""
    return f"spec {spec.name!r} holds on every trace ({spec.formula!r}): the bolt asks for nothing"
