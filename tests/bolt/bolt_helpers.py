"""Hand-built DFAs and Hypothesis strategies shared by the bolt tests.

The DFAs are written with ``DFA.from_function`` so the tests need no LTLf compiler.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from hypothesis import strategies as st

from noisybolt.logic import DFA

#: Probabilities on and around every band boundary, plus the extremes.
BOUNDARY_PROBS = (0.0, 0.3, 0.4999999, 0.5, 0.5000001, 0.7, 0.8999999, 0.9, 0.9000001, 1.0)


def eventually_all(fluents: Sequence[str], formula: str = "") -> DFA:
    """``F(f1 & ... & fn)``: state 0 until every fluent holds at once, then accepting sink 1."""
    everything = (1 << len(fluents)) - 1
    return DFA.from_function(
        fluents,
        n_states=2,
        initial_state=0,
        accepting=[False, True],
        delta=lambda q, m: 1 if q == 1 or m == everything else 0,
        formula=formula or f"F({' & '.join(fluents)})",
    )


def always(fluent: str = "e", fluents: Sequence[str] | None = None) -> DFA:
    """``G(fluent)``: accepting state 0 (also the empty trace), rejecting sink 1."""
    fluents = list(fluents or [fluent])
    bit = 1 << fluents.index(fluent)
    return DFA.from_function(
        fluents,
        n_states=2,
        initial_state=0,
        accepting=[True, False],
        delta=lambda q, m: 0 if q == 0 and m & bit else 1,
        formula=f"G({fluent})",
    )


def last_is(fluent: str = "e") -> DFA:
    """Accepting iff the last letter has ``fluent``: it can enter and leave acceptance."""
    return DFA.from_function(
        [fluent],
        n_states=2,
        initial_state=0,
        accepting=[False, True],
        delta=lambda q, m: 1 if m & 1 else 0,
        formula=f"F({fluent} & last)",
    )


F_E_AND_T = eventually_all(["e", "t"], "F(e & t)")


@st.composite
def random_dfas(
    draw: st.DrawFn, fluents: Sequence[str] | None = None, max_fluents: int = 4, max_states: int = 5
) -> DFA:
    """A random complete DFA over 1..max_fluents fluents and 1..max_states states."""
    if fluents is None:
        n_fluents = draw(st.integers(1, max_fluents))
        fluents = [f"f{i}" for i in range(n_fluents)]
    n_states = draw(st.integers(1, max_states))
    n_letters = 1 << len(fluents)
    table = draw(
        st.lists(
            st.lists(st.integers(0, n_states - 1), min_size=n_letters, max_size=n_letters),
            min_size=n_states,
            max_size=n_states,
        )
    )
    accepting = draw(st.lists(st.booleans(), min_size=n_states, max_size=n_states))
    initial = draw(st.integers(0, n_states - 1))
    return DFA.from_table(
        fluents, initial_state=initial, accepting=accepting, next_state=np.array(table)
    )


def probabilities() -> st.SearchStrategy[float]:
    """Probabilities, often exactly on a band boundary."""
    return st.one_of(st.sampled_from(BOUNDARY_PROBS), st.floats(0.0, 1.0))


@st.composite
def prob_matrices(draw: st.DrawFn, n_envs: int, n_fluents: int) -> np.ndarray:
    """float64 ``[n_envs, n_fluents]`` probabilities."""
    values = draw(
        st.lists(probabilities(), min_size=n_envs * n_fluents, max_size=n_envs * n_fluents)
    )
    return np.array(values, dtype=np.float64).reshape(n_envs, n_fluents)
