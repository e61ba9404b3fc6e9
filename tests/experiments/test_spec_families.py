"""The generated spec suite: seeded, distinct, satisfiable, feasible, not the paper's."""

from __future__ import annotations

import pytest

from noisybolt.envs.gridworld import GRIDWORLD_FLUENTS
from noisybolt.errors import ConfigError
from noisybolt.experiments.optimal import optimal_constrained_return
from noisybolt.experiments.spec_families import (
    PATTERNS,
    SCOPES,
    _equivalent,
    generate_spec_suite,
    pattern_formula,
)
from noisybolt.logic import compile_ltlf, holds
from noisybolt.runs.specs import PAPER_SPECS


def test_suite_is_seeded_distinct_feasible_and_half_constraining() -> None:
    suite = generate_spec_suite(n_specs=8, seed=1)
    assert suite == generate_spec_suite(n_specs=8, seed=1)
    assert suite != generate_spec_suite(n_specs=8, seed=2)
    assert len({s.formula for s in suite}) == 8
    assert sum(not s.shortest_complies for s in suite) >= 4
    paper = [compile_ltlf(f, GRIDWORLD_FLUENTS) for f in PAPER_SPECS.values() if "brick" not in f]
    for spec in suite:
        dfa = compile_ltlf(spec.formula, GRIDWORLD_FLUENTS)
        assert not any(_equivalent(dfa, p) for p in paper)
        best = optimal_constrained_return([spec.formula], require_goal=True)
        assert best.value == spec.rc_max and best.steps == spec.steps


def test_paper_spec_equivalence_is_semantic() -> None:
    a = compile_ltlf("G(!top_right_corner)", GRIDWORLD_FLUENTS)
    b = compile_ltlf("!F(top_right_corner)", GRIDWORLD_FLUENTS)
    c = compile_ltlf("F(top_right_corner)", GRIDWORLD_FLUENTS)
    assert _equivalent(a, b) and not _equivalent(a, c)


def test_patterns_mean_what_their_names_say() -> None:
    t = [{"p": False, "s": False, "r": False}]
    p_then_s = [{"p": True, "s": False, "r": False}, {"p": False, "s": True, "r": False}]
    assert holds(pattern_formula("response", "globally", "p", "s"), p_then_s)
    assert not holds(pattern_formula("response", "globally", "p", "s"), p_then_s[:1])
    assert not holds(pattern_formula("precedence", "globally", "p", "s"), p_then_s)
    assert holds(pattern_formula("existence", "after", "p", "", "r"), t)  # r never comes
    twice = [{"p": True}, {"p": False}, {"p": True}]
    assert not holds(pattern_formula("bounded_existence", "globally", "p"), twice)
    assert len(PATTERNS) == 6 and SCOPES == ("globally", "before", "after")
    with pytest.raises(ConfigError):
        pattern_formula("response", "globally", "p")
