"""The explicit augmented DFA of Fig. 2a, and its equivalence with Algorithm 1."""

from __future__ import annotations

import numpy as np
import pytest
from bolt_helpers import BOUNDARY_PROBS, F_E_AND_T, eventually_all, prob_matrices, random_dfas
from hypothesis import given
from hypothesis import strategies as st

from noisybolt.bolt import AugmentedDFA, BoltEngine, Spec, Thresholds
from noisybolt.logic import DFA, compile_ltlf

T, C = 10.0, 2.0


def augment(dfa: DFA, **kwargs: object) -> AugmentedDFA:
    return AugmentedDFA.from_dfa(dfa, terminal_reward=T, low_confidence_cost=C, **kwargs)  # type: ignore[arg-type]


def test_fig_2a_four_edges_from_0_to_1_with_their_rewards() -> None:
    aug = augment(F_E_AND_T)
    to_accepting = {e.guard: e.reward for e in aug.edges(0) if e.dst == 1}
    assert to_accepting == {
        "e_h & t_h": T,
        "e_l & t_h": T - C,
        "e_h & t_l": T - C,
        "e_l & t_l": T - 2 * C,
    }


def test_fig_2a_self_loops_split_positive_and_free_support_fluents() -> None:
    aug = augment(F_E_AND_T)
    loops = {e.guard: e.reward for e in aug.edges(0) if e.dst == 0}
    # !e | !t = !e  (t free: low or not)  +  e & !t  (e split high/low)
    assert loops == {"!e & !t_l": 0.0, "!e & t_l": -C, "e_h & !t": 0.0, "e_l & !t": -C}
    assert [(e.guard, e.reward) for e in aug.edges(1)] == [("true", T)]
    assert aug.n_edges == 9
    assert (aug.out_degree(0), aug.out_degree(1)) == (8, 1)


@pytest.mark.parametrize("n", [1, 2, 3, 4, 5, 6])
def test_edge_count_grows_exponentially_with_the_fluents_on_an_edge(n: int) -> None:
    aug = augment(eventually_all([f"a{i}" for i in range(n)]))
    edges = aug.edges(0)
    assert sum(e.dst == 1 for e in edges) == 2**n  # the paper's 2^(n_e)
    assert sum(e.dst == 0 for e in edges) == n * 2 ** (n - 1)  # n disjoint cubes of !a1|..|!an
    assert aug.out_degree(1) == 1


@pytest.mark.parametrize(
    ("probs", "state", "reward"),
    [
        ([0.7, 0.95], 1, T - C),
        ([0.4, 0.95], 0, 0.0),
        ([0.5, 0.95], 1, T - C),
        ([0.9, 0.95], 1, T - C),
        ([0.9000001, 0.95], 1, T),
        ([0.7, 0.2], 0, -C),
    ],
)
def test_hand_cases_on_the_augmented_dfa(probs: list[float], state: int, reward: float) -> None:
    out = augment(F_E_AND_T).step_batch(np.array([0]), np.array([probs]))
    assert (int(out.next_states[0]), float(out.reward[0])) == (state, reward)


@given(st.data(), random_dfas(max_fluents=4, max_states=5))
def test_augmented_dfa_gives_the_same_transitions_and_rewards_as_algorithm_1(
    data: st.DataObject, dfa: DFA
) -> None:
    terminal = data.draw(st.sampled_from([0.0, 1.0, 10.0, -3.0]))
    cost = data.draw(st.sampled_from([0.0, 0.5, 2.0]))
    thresholds = data.draw(
        st.sampled_from([Thresholds(), Thresholds(truth=0.3, high=0.7), Thresholds(0.5, 0.5)])
    )
    n_envs = 8
    probs = data.draw(prob_matrices(n_envs, dfa.n_fluents))
    states = np.array(
        data.draw(st.lists(st.integers(0, dfa.n_states - 1), min_size=n_envs, max_size=n_envs))
    )
    spec = Spec("random", terminal_reward=terminal, low_confidence_cost=cost)
    expected = BoltEngine([spec], [dfa], dfa.fluents, thresholds=thresholds).step(
        states[:, None], probs
    )
    aug = AugmentedDFA.from_dfa(
        dfa, terminal_reward=terminal, low_confidence_cost=cost, thresholds=thresholds
    )
    got = aug.step_batch(states, probs)
    np.testing.assert_array_equal(got.next_states, expected.next_states[:, 0])
    np.testing.assert_array_equal(got.n_low, expected.n_low[:, 0])
    np.testing.assert_allclose(got.reward, expected.total, rtol=0, atol=1e-12)


def test_every_expanded_letter_takes_exactly_one_edge_on_a_larger_dfa() -> None:
    # Exhaustive over the band grid for F(a & b & c) from both states.
    dfa = eventually_all(["a", "b", "c"])
    grid = np.array(np.meshgrid(*[BOUNDARY_PROBS] * 3)).reshape(3, -1).T
    aug = augment(dfa)
    engine = BoltEngine([Spec("F", terminal_reward=T, low_confidence_cost=C)], [dfa], dfa.fluents)
    for q in (0, 1):
        states = np.full(len(grid), q)
        got = aug.step_batch(states, grid)  # raises if 0 or 2+ edges matched
        expected = engine.step(states[:, None], grid)
        np.testing.assert_array_equal(got.next_states, expected.next_states[:, 0])
        np.testing.assert_allclose(got.reward, expected.total)


def test_bad_input_to_the_augmented_dfa() -> None:
    aug = augment(F_E_AND_T)
    with pytest.raises(ValueError, match=r"probs\[0, 0\] \(fluent 'e'\) is nan"):
        aug.step_batch(np.array([0]), np.array([[np.nan, 0.5]]))
    with pytest.raises(ValueError, match=r"states\[0\] = 2"):
        aug.step_batch(np.array([2]), np.array([[0.5, 0.5]]))
    with pytest.raises(ValueError, match="shape"):
        aug.step_batch(np.array([0, 0]), np.array([[0.5, 0.5]]))


PAPER_FORMULAS = [
    "G(e)",
    "!F(t)",
    "F(t & X(!(F(t))))",
    "(F(t & X(!(F(t)))) & !F(b)) | (F(b & X(!(F(b)))) & !F(t))",
]


@pytest.mark.parametrize("formula", PAPER_FORMULAS)
def test_augmented_dfa_agrees_with_algorithm_1_on_the_papers_gridworld_specs(
    formula: str, monkeypatch: pytest.MonkeyPatch, tmp_path: object
) -> None:
    monkeypatch.setenv("NOISYBOLT_CACHE_DIR", str(tmp_path))
    dfa = compile_ltlf(formula, ["e", "t", "b"])
    grid = np.array(np.meshgrid(*[BOUNDARY_PROBS] * 3)).reshape(3, -1).T
    aug = augment(dfa)
    engine = BoltEngine(
        [Spec(formula, terminal_reward=T, low_confidence_cost=C)], [dfa], dfa.fluents
    )
    for q in range(dfa.n_states):
        states = np.full(len(grid), q)
        got = aug.step_batch(states, grid)
        expected = engine.step(states[:, None], grid)
        np.testing.assert_array_equal(got.next_states, expected.next_states[:, 0])
        np.testing.assert_allclose(got.reward, expected.total)
