"""Both compilers against the evaluator, and against each other, on generated formulas.

For Hypothesis-generated formulas over 3-4 fluents of depth <= 4: every trace of length 1-4
plus random longer ones is accepted by each backend's DFA iff the evaluator says the formula
holds, and the two backends build the very same minimal automaton (which also checks the
empty trace, i.e. the initial state's acceptance, against MONA).
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from logic_helpers import BACKENDS, HAVE_MONA, all_traces, as_letters, run_batch, same_automaton

from noisybolt.logic import compile_ltlf, holds
from noisybolt.logic.evaluator import holds_batch

UNARY = ["!", "X", "WX", "F", "G"]
BINARY = ["&", "|", "->", "<->", "U", "R"]


def formulas(atoms: list[str], depth: int) -> st.SearchStrategy[str]:
    """ltlf2dfa-syntax formulas of nesting depth <= ``depth``, parenthesised, with chains."""
    leaves = st.sampled_from([*atoms, *atoms, "true", "false", "last"])
    if depth == 0:
        return leaves
    sub = formulas(atoms, depth - 1)
    unary = st.builds(lambda op, f: f"{op}({f})", st.sampled_from(UNARY), sub)
    binary = st.builds(lambda op, f, g: f"({f}) {op} ({g})", st.sampled_from(BINARY), sub, sub)
    # n-ary chains, read by ltlf2dfa's own rules (U/R to the right, -> to the left, <-> all equal)
    chain = st.builds(
        lambda op, fs: f" {op} ".join(f"({f})" for f in fs),
        st.sampled_from(BINARY),
        st.lists(sub, min_size=3, max_size=3),
    )
    return st.one_of(leaves, unary, binary, chain)


def check(formula: str, fluents: list[str], seed: int) -> None:
    dfas = [compile_ltlf(formula, fluents, backend=b, cache=False) for b in BACKENDS]
    if HAVE_MONA:
        assert same_automaton(dfas[0], dfas[1]), formula
    rng = np.random.default_rng(seed)
    k = len(fluents)
    batches = [all_traces(k, length) for length in range(1, 5)]
    batches += [rng.random((64, length, k)) < 0.5 for length in (5, 7, 10)]
    for truth in batches:
        expected = holds_batch(formula, truth, fluents)
        for dfa in dfas:
            assert np.array_equal(run_batch(dfa, truth), expected), (formula, truth.shape[1])
    # The scalar API on a few random traces: dfa.accepts(trace) == holds(formula, trace).
    sample = rng.random((8, 6, k)) < 0.5
    for letters in as_letters(sample, fluents):
        assert all(dfa.accepts(letters) is holds(formula, letters) for dfa in dfas), formula


SETTINGS = settings(
    max_examples=100, deadline=None, suppress_health_check=[HealthCheck.too_slow], derandomize=True
)


@SETTINGS
@given(formula=formulas(["a", "b", "c"], 4), seed=st.integers(0, 2**32 - 1))
def test_three_fluents(formula: str, seed: int) -> None:
    check(formula, ["a", "b", "c"], seed)


@settings(SETTINGS, max_examples=50)
@given(formula=formulas(["a", "b", "c", "d"], 4), seed=st.integers(0, 2**32 - 1))
def test_four_fluents(formula: str, seed: int) -> None:
    check(formula, ["a", "b", "c", "d"], seed)


@pytest.mark.slow
@settings(SETTINGS, max_examples=1000, derandomize=False)
@given(formula=formulas(["a", "b", "c", "d"], 4), seed=st.integers(0, 2**32 - 1))
def test_many_formulas(formula: str, seed: int) -> None:
    check(formula, ["a", "b", "c", "d"], seed)
