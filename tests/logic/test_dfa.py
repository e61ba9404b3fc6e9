"""The DFA type: dense and compact forms, exact supports, sinks, edges, pickling."""

from __future__ import annotations

import itertools
import pickle

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from noisybolt.errors import DenseTableError, UnknownFluentError
from noisybolt.logic import DFA, GuardDiagram, compile_ltlf
from noisybolt.logic import dfa as dfa_module
from noisybolt.logic.dfa import support_from_table


def brute_support(table: np.ndarray) -> np.ndarray:
    """Support of every cell's guard by definition: flip each bit of each letter of the guard."""
    n_states, n_letters = table.shape
    n_fluents = n_letters.bit_length() - 1
    support = np.zeros(table.shape, dtype=np.uint64)
    for q in range(n_states):
        for t in set(table[q].tolist()):
            guard = {a for a in range(n_letters) if table[q, a] == t}
            mask = 0
            for v in range(n_fluents):
                if any((a ^ (1 << v) in guard) != (a in guard) for a in range(n_letters)):
                    mask |= 1 << v
            for a in guard:
                support[q, a] = mask
    return support


@st.composite
def tables(draw: st.DrawFn, max_fluents: int = 4, max_states: int = 5) -> np.ndarray:
    """Random transition tables, often depending on only some bits of the letter."""
    n_fluents = draw(st.integers(0, max_fluents))
    n_states = draw(st.integers(1, max_states))
    n_letters = 1 << n_fluents
    cells = draw(
        st.lists(
            st.integers(0, n_states - 1),
            min_size=n_states * n_letters,
            max_size=n_states * n_letters,
        )
    )
    table = np.array(cells, dtype=np.int64).reshape(n_states, n_letters)
    relevant = draw(st.integers(0, n_letters - 1))
    return table[:, np.arange(n_letters) & relevant]


def from_table(table: np.ndarray, accepting: list[bool] | None = None) -> DFA:
    n_states, n_letters = table.shape
    fluents = [f"f{i}" for i in range(n_letters.bit_length() - 1)]
    if accepting is None:
        accepting = [q % 2 == 1 for q in range(n_states)]
    return DFA.from_table(fluents, initial_state=0, accepting=accepting, next_state=table)


@given(tables())
def test_support_from_table_is_the_boolean_support(table: np.ndarray) -> None:
    assert np.array_equal(support_from_table(table), brute_support(table))


@given(tables())
def test_from_table_keeps_table_and_numbering(table: np.ndarray) -> None:
    dfa = from_table(table)
    assert np.array_equal(dfa.next_state, table)
    assert np.array_equal(dfa.support, brute_support(table))
    assert not dfa.is_compact
    # The diagram holds the same function, and its per-edge supports are the same.
    for q, a in itertools.product(range(table.shape[0]), range(table.shape[1])):
        assert dfa._successor(q, a) == table[q, a]
    states = np.repeat(np.arange(table.shape[0]), table.shape[1])
    masks = np.tile(np.arange(table.shape[1]), table.shape[0]).astype(np.uint64)
    walked, support = dfa._walk(states, masks)
    assert np.array_equal(walked, table.reshape(-1))
    assert np.array_equal(support, dfa.support.reshape(-1))


@given(tables(max_fluents=4, max_states=4), st.data())
def test_compact_forms_step_like_the_dense_one(table: np.ndarray, data: st.DataObject) -> None:
    dense = from_table(table)
    kwargs = {
        "fluents": dense.fluents,
        "initial_state": 0,
        "accepting": dense.accepting,
        "diagram": dense.diagram,
    }
    original = dfa_module.DENSE_TABLE_LIMIT
    try:
        # Below the full table but above the projection onto the tested fluents...
        dfa_module.DENSE_TABLE_LIMIT = dense.n_states << len(dense.relevant_fluents)
        projected = DFA(**kwargs)
        # ... and below both: the diagram is walked.
        dfa_module.DENSE_TABLE_LIMIT = 0
        walked = DFA(**kwargs)
    finally:
        dfa_module.DENSE_TABLE_LIMIT = original
    n = 40
    states = np.array(
        data.draw(st.lists(st.integers(0, dense.n_states - 1), min_size=n, max_size=n))
    )
    masks = np.array(
        data.draw(st.lists(st.integers(0, table.shape[1] - 1), min_size=n, max_size=n)),
        dtype=np.uint64,
    )
    expected = dense.step_batch(states, masks)
    for dfa in (projected, walked):
        got = dfa.step_batch(states, masks)
        assert np.array_equal(got[0], expected[0]) and np.array_equal(got[1], expected[1])
        assert [(e.src, e.dst, e.support) for e in dfa.edges()] == [
            (e.src, e.dst, e.support) for e in dense.edges()
        ]
    if dense.n_fluents > len(dense.relevant_fluents) and dense.n_states > 0:
        assert projected._projected is not None and projected.is_compact
    assert walked.is_compact and walked._projected is None
    with pytest.raises(DenseTableError, match="DENSE_TABLE_LIMIT"):
        _ = walked.next_state
    with pytest.raises(DenseTableError):
        _ = walked.support


def test_twenty_fluent_formula_is_compact_and_steps() -> None:
    formula = " & ".join(f"G(a{i} -> F(b{i}))" for i in range(1, 11))
    dfa = compile_ltlf(formula, backend="bdd", cache=False)
    assert dfa.n_fluents == 20 and dfa.is_compact
    with pytest.raises(DenseTableError):
        _ = dfa.next_state
    # Pending obligations: a1 and a2 raised, then b1 discharges only the first.
    letters = [{"a1": True, "a2": True}, {"b1": True}]
    q = dfa.run(letters)
    assert not dfa.accepting[q]
    assert dfa.accepts([*letters, {"b2": True}])
    # Exact support of an edge: from the initial (nothing pending) state every pair counts;
    # once a1 is pending, a1 no longer matters for the next edge.
    index = {name: i for i, name in enumerate(dfa.fluents)}
    everything = (1 << 20) - 1
    _, support = dfa.step_batch(np.array([dfa.initial_state]), np.array([0], dtype=np.uint64))
    assert int(support[0]) == everything
    pending = dfa.run([{"a1": True}])
    _, support = dfa.step_batch(np.array([pending]), np.array([0], dtype=np.uint64))
    assert int(support[0]) == everything & ~(1 << index["a1"])
    description = dfa.describe(max_edges=3)
    assert "further edges left out" in description and "products" in description


def test_sinks_hand_made() -> None:
    # 0 -a-> 1 (accepting sink); 0 -!a-> 2 (rejecting sink).
    dfa = DFA.from_function(
        ["a"],
        n_states=3,
        initial_state=0,
        accepting=[False, True, False],
        delta=lambda q, mask: q if q else (1 if mask else 2),
    )
    assert dfa.accepting_sinks.tolist() == [False, True, False]
    assert dfa.rejecting_sinks.tolist() == [False, False, True]


def test_step_and_accepts_check_input() -> None:
    dfa = from_table(np.array([[0, 1], [1, 1]]), accepting=[False, True])
    assert dfa.step(0, {"f0": True}) == 1
    assert dfa.accepts([{"f0": False}, {"f0": True}])
    with pytest.raises(UnknownFluentError, match="vocabulary"):
        dfa.step(0, {"nope": True})
    with pytest.raises(ValueError, match="state 5"):
        dfa.step(5, {})


def test_arrays_are_read_only() -> None:
    dfa = from_table(np.array([[0, 1], [1, 1]]))
    for array in (dfa.next_state, dfa.support, dfa.accepting, dfa.diagram.root):
        with pytest.raises(ValueError):
            array[0] = 0
    with pytest.raises(AttributeError, match="immutable"):
        dfa.initial_state = 1
    with pytest.raises(AttributeError, match="immutable"):
        del dfa.fluents


def test_edges_guards_are_exact() -> None:
    dfa = compile_ltlf("F(a & b)", ["a", "b", "z"], backend="bdd", cache=False)
    for edge in dfa.edges():
        for mask in range(8):
            letter = {f: bool(mask >> i & 1) for i, f in enumerate(dfa.fluents)}
            guard_true = eval_guard(edge.guard, letter)
            assert guard_true == (dfa.step(edge.src, letter) == edge.dst)


def eval_guard(guard: str, letter: dict[str, bool]) -> bool:
    """Evaluates the sum-of-products text of an edge (no eval)."""
    if guard == "true":
        return True
    for product in guard.split(" | "):
        literals = product.strip("()").split(" & ")
        if all(
            letter[lit[1:]] is False if lit.startswith("!") else letter[lit] for lit in literals
        ):
            return True
    return False


@pytest.mark.parametrize("table", [np.array([[0, 1], [1, 1]]), np.zeros((3, 8), dtype=np.int64)])
def test_pickle_round_trip(table: np.ndarray) -> None:
    dfa = from_table(table)
    copy = pickle.loads(pickle.dumps(dfa))
    assert np.array_equal(copy.next_state, dfa.next_state)
    assert np.array_equal(copy.support, dfa.support)
    assert copy.fluents == dfa.fluents and copy.initial_state == dfa.initial_state


def test_pickle_compact() -> None:
    formula = " & ".join(f"G(a{i} -> F(b{i}))" for i in range(1, 11))
    dfa = compile_ltlf(formula, backend="bdd", cache=False)
    copy = pickle.loads(pickle.dumps(dfa))
    assert copy.is_compact and copy.run([{"a3": True}]) == dfa.run([{"a3": True}])


def test_bad_construction_is_refused() -> None:
    good = from_table(np.array([[0, 1], [1, 1]])).diagram
    with pytest.raises(ValueError, match="shape"):
        DFA.from_table(["a"], initial_state=0, accepting=[True], next_state=np.zeros((1, 4)))
    with pytest.raises(ValueError, match="does not exist"):
        DFA.from_table(["a"], initial_state=0, accepting=[True], next_state=np.array([[0, 3]]))
    with pytest.raises(ValueError, match="initial_state"):
        DFA.from_table(["a"], initial_state=2, accepting=[True], next_state=np.array([[0, 0]]))
    with pytest.raises(ValueError, match="duplicate"):
        DFA.from_table(["a", "a"], initial_state=0, accepting=[True], next_state=np.zeros((1, 4)))
    with pytest.raises(TypeError):
        DFA.from_table("ab", initial_state=0, accepting=[True], next_state=np.zeros((1, 4)))
    kwargs = {"fluents": ["f0"], "initial_state": 0, "accepting": [False, True]}
    reversed_order = good._replace(lo=good.hi, hi=good.lo)
    DFA(diagram=reversed_order, **kwargs)  # still a valid diagram
    unreduced = good._replace(hi=good.lo)
    with pytest.raises(ValueError, match="not reduced"):
        DFA(diagram=unreduced, **kwargs)
    with pytest.raises(ValueError, match="permutation"):
        DFA(diagram=good._replace(rank=np.array([1])), **kwargs)
    with pytest.raises(ValueError, match="leaves"):
        DFA(diagram=good._replace(var=np.array([0, -1, 0])), **kwargs)
    assert isinstance(good, GuardDiagram)
