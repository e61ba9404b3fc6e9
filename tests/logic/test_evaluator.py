"""The evaluator on hand-computed cases, and both compilers against it on tricky formulas."""

from __future__ import annotations

import numpy as np
import pytest
from logic_helpers import BACKENDS, all_traces, as_letters, run_batch

from noisybolt.logic import compile_ltlf, holds
from noisybolt.logic.evaluator import holds_batch

A, B, C, NONE = {"a": True}, {"b": True}, {"c": True}, {}
AB = {"a": True, "b": True}

# (formula, trace, expected), each computed by hand from the clauses in evaluator.py.
CASES = [
    # strong next needs a next position; weak next is true without one
    ("X(a)", [A], False),
    ("X(a)", [NONE, A], True),
    ("X(a)", [A, NONE], False),
    ("WX(a)", [NONE], True),
    ("WX(a)", [NONE, NONE], False),
    ("WX(a)", [NONE, A], True),
    ("!X(a)", [A], True),
    ("X(true)", [A], False),
    ("WX(false)", [A], True),
    # last is the last position
    ("last", [A], True),
    ("last", [A, A], False),
    ("F(last & a)", [NONE, A], True),
    ("F(last & a)", [A, NONE], False),
    ("G(!last -> a)", [A, A, NONE], True),
    ("G(!last -> a)", [A, NONE, NONE], False),
    ("X(last)", [NONE, NONE], True),
    ("X(last)", [NONE, NONE, NONE], False),
    # until needs its right side somewhere, the left side until then (not at that point)
    ("a U b", [B], True),
    ("a U b", [A, A], False),
    ("a U b", [A, AB], True),
    ("a U b", [A, B], True),
    ("a U b", [NONE, B], False),
    # release: b until and including the point where a holds, or b throughout
    ("a R b", [B, B], True),
    ("a R b", [B, NONE], False),
    ("a R b", [AB, NONE], True),
    ("a R b", [B, A], False),
    ("a R b", [B, AB, NONE], True),
    # chains: U and R nest to the right, -> folds to the left, <-> means all equal
    ("a U b U c", [A, B, C], True),
    ("a U b U c", [A, C], True),
    ("a U b U c", [B, A, C], False),
    ("a -> b -> c", [NONE], False),  # (a -> b) -> c; a -> (b -> c) would hold
    ("a -> b -> c", [A], True),
    ("a <-> b <-> c", [A], False),  # all equal; a chain of binary <-> would hold
    ("a <-> b <-> c", [NONE], True),
    ("a <-> b <-> c", [{"a": True, "b": True, "c": True}], True),
    ("a <-> X(a)", [A], False),
    ("a <-> X(a)", [NONE], True),
    # F and G, the paper's shapes
    ("G(a)", [A, A], True),
    ("G(a)", [A, NONE], False),
    ("F(a & X(!F(a)))", [A, NONE], True),
    ("F(a & X(!F(a)))", [A], False),
    ("F(a & X(!F(a)))", [A, NONE, A], False),
    ("F(a & X(!F(a)))", [A, A, NONE], True),
    ("!F(a)", [NONE, NONE], True),
    ("G(a -> F(b))", [A, NONE, B], True),
    ("G(a -> F(b))", [A, B, A], False),
    ("G(a -> X(b))", [A, B, NONE], True),
    ("G(a -> X(b))", [NONE, A], False),
    ("G(a -> WX(b))", [NONE, A], True),
]


@pytest.mark.parametrize(("formula", "trace", "expected"), CASES)
def test_hand_computed(formula: str, trace: list[dict[str, bool]], expected: bool) -> None:
    assert holds(formula, trace) is expected
    fluents = ["a", "b", "c"]
    truth = np.array([[[letter.get(f, False) for f in fluents] for letter in trace]])
    assert holds_batch(formula, truth, fluents).tolist() == [expected]


@pytest.mark.parametrize("backend", BACKENDS)
def test_compilers_on_hand_computed(backend: str) -> None:
    for formula, trace, expected in CASES:
        dfa = compile_ltlf(formula, ["a", "b", "c"], backend=backend)
        assert dfa.accepts(trace) is expected, (formula, trace)


def test_positions_and_letters() -> None:
    assert holds("a", [NONE, A], i=1)
    assert holds("last", [NONE, NONE], i=1)
    assert holds("a & !b", [{"a"}])  # a letter may be the set of true fluents
    with pytest.raises(ValueError, match="empty"):
        holds("a", [])
    with pytest.raises(ValueError, match="position 2"):
        holds("a", [A], i=2)
    with pytest.raises(ValueError, match="shape"):
        holds_batch("a", np.zeros((2, 0, 1), dtype=bool), ["a"])


TRICKY = [
    "a R (b U c)",
    "(a U b) R (c | X(a))",
    "G(a <-> X(b))",
    "!(a U (b R X(c)))",
    "X(X(a)) | WX(WX(!b))",
    "G(F(a)) <-> F(G(b))",
    "(a -> b) U (last & c)",
    "WX(a) & X(b -> last)",
    "F(a) -> G(b) -> c",
    "a <-> b <-> X(c)",
    "G(a -> (b R c))",
    "F(last) & !X(last) & (a U last)",
]


@pytest.mark.parametrize("formula", TRICKY)
def test_tricky_formulas_on_all_short_traces(formula: str) -> None:
    fluents = ["a", "b", "c"]
    for backend in BACKENDS:
        dfa = compile_ltlf(formula, fluents, backend=backend)
        for length in range(1, 5):
            truth = all_traces(3, length)
            expected = holds_batch(formula, truth, fluents)
            assert np.array_equal(run_batch(dfa, truth), expected), (backend, length)
        # The scalar evaluator agrees with the vectorised one (a sample).
        sample = all_traces(3, 3)[::37]
        for letters, truth_value in zip(
            as_letters(sample, fluents), holds_batch(formula, sample, fluents), strict=True
        ):
            assert holds(formula, letters) is bool(truth_value)
