"""Satisfiability, vacuity and distance to acceptance, against the independent evaluator."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from noisybolt.logic import compile_ltlf, distance_to_acceptance, holds, is_satisfiable, is_valid

FLUENTS = ["a", "b"]
LETTERS = [
    dict(zip(FLUENTS, bits, strict=True)) for bits in itertools.product([False, True], repeat=2)
]


def _traces(max_len: int):
    for n in range(1, max_len + 1):
        yield from itertools.product(LETTERS, repeat=n)


@pytest.mark.parametrize(
    "formula",
    [
        "F(a)",
        "G(a)",
        "F(a) & G(!a)",
        "a | !a",
        "F(a & X(b))",
        "G(a -> F(b))",
        "a & X(!a) & G(a)",
        "F(a) & F(b)",
        "(a U b) | G(a)",
        "X(a) & X(!a)",
        "last",
        "WX(false)",
    ],
)
def test_satisfiable_and_valid_agree_with_the_evaluator_on_short_traces(formula: str) -> None:
    dfa = compile_ltlf(formula, FLUENTS)
    verdicts = [holds(formula, list(trace)) for trace in _traces(4)]
    # Every DFA here has at most 5 states: a witness, if any, has at most that many letters.
    assert is_satisfiable(dfa) == any(verdicts)
    assert is_valid(dfa) == all(verdicts)


def test_distance_counts_letters_to_acceptance_by_hand() -> None:
    dfa = compile_ltlf("F(a & X(F(b & X(F(a)))))", FLUENTS)
    distance = distance_to_acceptance(dfa)
    assert distance[dfa.initial_state] == 3
    q = dfa.step(dfa.initial_state, {"a": True, "b": False})
    assert distance[q] == 2
    assert distance[dfa.accepting].tolist() == [0] * int(dfa.accepting.sum())


def test_distance_over_the_world_letters_and_rejecting_sinks() -> None:
    dfa = compile_ltlf("F(a) & F(b)", FLUENTS)
    assert distance_to_acceptance(dfa)[dfa.initial_state] == 1  # the letter a & b
    only_one = np.array([0b00, 0b01, 0b10])  # a world that never shows a and b together
    assert distance_to_acceptance(dfa, only_one)[dfa.initial_state] == 2
    never = compile_ltlf("G(!a)", FLUENTS)
    sink = never.step(never.initial_state, {"a": True, "b": False})
    assert distance_to_acceptance(never)[sink] == -1
    # A world whose letters cannot reach acceptance keeps the distance over all letters.
    assert distance_to_acceptance(dfa, np.array([0b00]))[dfa.initial_state] == 1
