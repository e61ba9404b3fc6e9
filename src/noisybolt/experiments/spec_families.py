"""Specs nobody tuned for: generated from the specification patterns of Dwyer, Avrunin &
Corbett (ICSE 1999), kept where a compliant route to the goal exists.

The patterns (absence, existence, universality, precedence, response, bounded existence)
under the scopes *globally*, *before R* and *after Q*, in their LTL mappings read over
finite traces (``W`` written out as ``(a U b) | G(a)``), and conjunctions of two, over
one to three of a world's fluents. :func:`generate_spec_suite` draws a fixed number of
them with a seeded generator, compiles each, and keeps those that are satisfiable, not
true of every trace, not one of the paper's specs, and, planned exactly on the
gridworld's product (:func:`~noisybolt.experiments.optimal.optimal_constrained_return`
with ``require_goal``), followed by some episode that reaches the goal; it records that
episode's return (R^c_max) and length.

Example:
    >>> suite = generate_spec_suite(n_specs=3, seed=0)
    >>> len(suite), all(s.rc_max is not None for s in suite)
    (3, True)
    >>> suite == generate_spec_suite(n_specs=3, seed=0)
    True
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from noisybolt.errors import ConfigError
from noisybolt.logic import DFA, compile_ltlf, is_satisfiable, is_valid

__all__ = [
    "PATTERNS",
    "SCOPES",
    "SUITE_FLUENTS",
    "GeneratedSpec",
    "generate_spec_suite",
    "pattern_formula",
]

#: The gridworld fluents the suite draws from: where the agent is (not which way it faces,
#: which any route can satisfy by turning on the spot).
SUITE_FLUENTS: tuple[str, ...] = ("on_edge", "top_right_corner", "bottom_left_corner")


def _weak_until(a: str, b: str) -> str:
    return f"(({a}) U ({b})) | G({a})"


# Each pattern maps (P, S, scope formula builder inputs) to LTLf text. P is the pattern's
# subject; S is its second fluent (precedence: S precedes P; response: S responds to P).
_GLOBAL: dict[str, Callable[[str, str], str]] = {
    "absence": lambda p, s: f"G(!{p})",
    "existence": lambda p, s: f"F({p})",
    "universality": lambda p, s: f"G({p})",
    "precedence": lambda p, s: _weak_until(f"!{p}", s),
    "response": lambda p, s: f"G({p} -> F({s}))",
    "bounded_existence": lambda p, s: f"!F({p} & F(!{p} & F({p})))",
}
_BEFORE: dict[str, Callable[[str, str, str], str]] = {
    "absence": lambda p, s, r: f"F({r}) -> (!{p} U {r})",
    "existence": lambda p, s, r: _weak_until(f"!{r}", f"{p} & !{r}"),
    "universality": lambda p, s, r: f"F({r}) -> ({p} U {r})",
    "precedence": lambda p, s, r: f"F({r}) -> (!{p} U ({s} | {r}))",
    "response": lambda p, s, r: f"F({r}) -> (({p} -> (!{r} U ({s} & !{r}))) U {r})",
    "bounded_existence": lambda p, s, r: (
        f"F({r}) -> !(!{r} U ({p} & !{r} & (!{r} U (!{p} & !{r} & (!{r} U ({p} & !{r}))))))"
    ),
}
_AFTER: dict[str, Callable[[str, str, str], str]] = {
    "absence": lambda p, s, q: f"G({q} -> G(!{p}))",
    "existence": lambda p, s, q: f"G(!{q}) | F({q} & F({p}))",
    "universality": lambda p, s, q: f"G({q} -> G({p}))",
    "precedence": lambda p, s, q: f"G(!{q}) | F({q} & ({_weak_until(f'!{p}', s)}))",
    "response": lambda p, s, q: f"G({q} -> G({p} -> F({s})))",
    "bounded_existence": lambda p, s, q: f"G({q} -> !F({p} & F(!{p} & F({p}))))",
}
#: The pattern families.
PATTERNS: tuple[str, ...] = tuple(_GLOBAL)
#: The scopes.
SCOPES: tuple[str, ...] = ("globally", "before", "after")
_TWO_FLUENT = frozenset({"precedence", "response"})


def pattern_formula(pattern: str, scope: str, p: str, s: str = "", r: str = "") -> str:
    """The LTLf text of one pattern under one scope.

    Args:
        pattern: one of :data:`PATTERNS`.
        scope: one of :data:`SCOPES`.
        p: the pattern's subject.
        s: the second fluent of ``precedence`` and ``response``.
        r: the scope's fluent (R for ``before``, Q for ``after``).

    Example:
        >>> pattern_formula("response", "globally", "top_right_corner", "on_edge")
        'G(top_right_corner -> F(on_edge))'
    """
    if pattern not in PATTERNS or scope not in SCOPES:
        raise ConfigError(f"unknown pattern/scope {pattern!r}/{scope!r}: {PATTERNS} x {SCOPES}")
    if pattern in _TWO_FLUENT and not s:
        raise ConfigError(f"the {pattern} pattern needs a second fluent")
    if scope == "globally":
        return _GLOBAL[pattern](p, s)
    if not r:
        raise ConfigError(f"the {scope} scope needs its fluent")
    return (_BEFORE if scope == "before" else _AFTER)[pattern](p, s, r)


@dataclass(frozen=True)
class GeneratedSpec:
    """One spec of the suite.

    Attributes:
        name: a short label (``index-family``).
        family: the pattern and scope (``"response/after"``), ``+`` joined for a conjunction.
        formula: the LTLf text.
        rc_max: the best environment return of a compliant episode that reaches the goal.
        steps: that episode's length.
        shortest_complies: whether the world's unconstrained shortest route already complies
            (then the spec constrains little; the suite keeps some of each kind).
    """

    name: str
    family: str
    formula: str
    rc_max: float
    steps: int
    shortest_complies: bool


def _draw(rng: np.random.Generator, fluents: Sequence[str]) -> tuple[str, str]:
    pattern = str(rng.choice(PATTERNS))
    scope = str(rng.choice(SCOPES))
    names = [str(f) for f in rng.permutation(list(fluents))]
    p, s, r = names[0], names[1 % len(names)], names[2 % len(names)]
    return f"{pattern}/{scope}", pattern_formula(pattern, scope, p, s, r)


def generate_spec_suite(
    *,
    n_specs: int = 24,
    seed: int = 0,
    fluents: Sequence[str] = SUITE_FLUENTS,
    conjunction_share: float = 0.34,
    constraining_share: float = 0.5,
    max_draws: int = 5000,
) -> tuple[GeneratedSpec, ...]:
    """Draws ``n_specs`` distinct gridworld specs that a goal-reaching episode can follow.

    Args:
        n_specs: how many specs to keep.
        seed: seeds the draws (the suite is a function of its arguments).
        fluents: the fluents patterns are instantiated over.
        conjunction_share: the share of draws that conjoin two patterns.
        constraining_share: at least this share of the specs must be broken by the world's
            unconstrained shortest route (most random patterns are not: a suite of those
            would say little about specs whose compliant route is a detour).
        max_draws: give up after this many draws.

    Raises:
        ConfigError: fewer than ``n_specs`` specs qualified in ``max_draws`` draws.
    """
    # Imported here: the planner imports the gridworld, which pulls in MiniGrid.
    from noisybolt.envs.gridworld import GRIDWORLD_FLUENTS
    from noisybolt.experiments.optimal import (
        optimal_constrained_return,
        optimal_unconstrained_return,
    )
    from noisybolt.runs.specs import PAPER_SPECS

    shortest = optimal_unconstrained_return(require_goal=True)
    paper = [compile_ltlf(f, GRIDWORLD_FLUENTS) for f in PAPER_SPECS.values() if "brick" not in f]
    rng = np.random.default_rng(seed)
    kept: list[GeneratedSpec] = []
    seen: set[str] = set()
    need_constraining = int(np.ceil(constraining_share * n_specs))
    for _ in range(max_draws):
        if len(kept) == n_specs:
            break
        constraining = sum(not k.shortest_complies for k in kept)
        free_slots = n_specs - len(kept) - max(0, need_constraining - constraining)
        family, formula = _draw(rng, fluents)
        if rng.random() < conjunction_share:
            other_family, other = _draw(rng, fluents)
            family, formula = f"{family}+{other_family}", f"({formula}) & ({other})"
        if formula in seen:
            continue
        seen.add(formula)
        dfa = compile_ltlf(formula, GRIDWORLD_FLUENTS)
        if not is_satisfiable(dfa) or is_valid(dfa) or any(_equivalent(dfa, p) for p in paper):
            continue
        best = optimal_constrained_return([dfa], require_goal=True)
        if best.value is None or best.steps is None:
            continue
        complies = _accepts_route(dfa, shortest.states)
        if complies and free_slots <= 0:
            continue
        kept.append(
            GeneratedSpec(
                name=f"s{len(kept):02d}-{family.replace('/', '-')}",
                family=family,
                formula=formula,
                rc_max=float(best.value),
                steps=int(best.steps),
                shortest_complies=complies,
            )
        )
    if len(kept) < n_specs:
        raise ConfigError(
            f"only {len(kept)} of {n_specs} generated specs qualified in {max_draws} draws"
        )
    return tuple(kept)


def _accepts_route(dfa: DFA, states: Sequence[tuple[int, int, int]]) -> bool:
    """Whether ``dfa`` accepts the trace of the gridworld states visited (reset included)."""
    from noisybolt.envs.gridworld import GRIDWORLD_FLUENTS, gridworld_fluents

    xs, ys, ds = (np.array(v) for v in zip(*states, strict=True))
    truth = gridworld_fluents(xs, ys, ds, size=6)
    trace = [dict(zip(GRIDWORLD_FLUENTS, map(bool, row), strict=True)) for row in truth]
    return dfa.accepts(trace)


def _equivalent(a: DFA, b: DFA) -> bool:
    """Whether two DFAs over the same vocabulary accept the same non-empty traces."""
    if a.fluents != b.fluents:
        return False
    letters = range(1 << a.n_fluents)
    seen: set[tuple[int, int]] = set()
    frontier = [(a.initial_state, b.initial_state)]
    first = True
    while frontier:
        pair = frontier.pop()
        if not first and pair in seen:
            continue
        if not first:
            seen.add(pair)
            if bool(a.accepting[pair[0]]) != bool(b.accepting[pair[1]]):
                return False
        first = False
        for m in letters:
            nxt = (int(a.next_state[pair[0], m]), int(b.next_state[pair[1], m]))
            if nxt not in seen:
                frontier.append(nxt)
    return True
