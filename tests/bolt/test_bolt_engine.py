"""Algorithm 1 over a batch (BoltEngine): hand-computed transitions, costs and properties."""

from __future__ import annotations

import numpy as np
import pytest
from bolt_helpers import F_E_AND_T, always, eventually_all, prob_matrices, random_dfas
from hypothesis import given
from hypothesis import strategies as st

import noisybolt.bolt.engine as engine_module
from noisybolt.bolt import BoltEngine, Spec, Thresholds
from noisybolt.errors import ConfigError, UnknownFluentError
from noisybolt.logic import DFA

T, C = 10.0, 2.0  # terminal reward and low-confidence cost of the hand-computed cases
SPEC = Spec("F(e & t)", terminal_reward=T, low_confidence_cost=C)


def one_step(probs: list[float], state: int = 0, **kwargs: object) -> tuple[int, float, int]:
    """(next state, reward, n_low) of F(e & t) from ``state`` on one environment."""
    engine = BoltEngine([SPEC], [F_E_AND_T], ["e", "t"], **kwargs)  # type: ignore[arg-type]
    out = engine.step(np.array([[state]]), np.array([probs]))
    return int(out.next_states[0, 0]), float(out.total[0]), int(out.n_low[0, 0])


# ---------------------------------------------------------------- the brief's hand cases
def test_low_e_high_t_moves_to_accepting_with_one_cost() -> None:
    assert one_step([0.7, 0.95]) == (1, T - 1 * C, 1)


def test_absent_e_stays_with_no_reward() -> None:
    assert one_step([0.4, 0.95]) == (0, 0.0, 0)


def test_exactly_half_is_true_and_low() -> None:
    assert one_step([0.5, 0.95]) == (1, T - C, 1)


def test_exactly_high_threshold_is_still_low() -> None:
    assert one_step([0.9, 0.95]) == (1, T - C, 1)


def test_just_above_high_threshold_is_high() -> None:
    assert one_step([0.9000001, 0.95]) == (1, T, 0)


def test_two_low_fluents_cost_twice() -> None:
    assert one_step([0.6, 0.8]) == (1, T - 2 * C, 2)


def test_the_self_loop_charges_its_low_support_fluents_too() -> None:
    # The self-loop's guard !e | !t depends on e and t; e is true but unsure.
    assert one_step([0.7, 0.2]) == (0, -C, 1)


def test_accepting_sink_has_an_empty_support_and_pays_every_step() -> None:
    assert one_step([0.7, 0.7], state=1) == (1, T, 0)


def test_fluents_outside_the_guard_support_cost_nothing() -> None:
    # F(e) over the vocabulary (e, t): t is a don't-care, so a low t is free.
    f_e = eventually_all(["e"])
    spec = Spec("F(e)", terminal_reward=T, low_confidence_cost=C)
    engine = BoltEngine([spec], [f_e], ["e", "t"])
    out = engine.step(np.array([[0], [0]]), np.array([[0.95, 0.7], [0.7, 0.7]]))
    assert out.n_low[:, 0].tolist() == [0, 1]
    assert out.total.tolist() == [T, T - C]


def test_result_terms_are_consistent_and_signed() -> None:
    engine = BoltEngine([SPEC], [F_E_AND_T], ["e", "t"])
    probs = np.array([[0.7, 0.95], [0.4, 0.95], [0.95, 0.95], [0.6, 0.6]])
    out = engine.step(np.zeros((4, 1), dtype=np.int64), probs)
    assert out.next_states[:, 0].tolist() == [1, 0, 1, 1]
    assert out.terminal[:, 0].tolist() == [T, 0, T, T]
    assert out.low_confidence[:, 0].tolist() == [-C, 0, 0, -2 * C]
    assert out.accepting[:, 0].tolist() == [True, False, True, True]
    np.testing.assert_array_equal(out.reward, out.terminal + out.low_confidence)
    np.testing.assert_array_equal(out.total, out.reward.sum(axis=1))
    assert not out.carried.any() and not out.terminate.any() and not out.violated.any()
    assert (out.low_confidence <= 0).all()


def test_custom_thresholds() -> None:
    thresholds = Thresholds(truth=0.6, high=0.8)
    assert one_step([0.55, 0.95], thresholds=thresholds) == (0, 0.0, 0)
    assert one_step([0.85, 0.95], thresholds=thresholds) == (1, T, 0)
    assert one_step([0.8, 0.95], thresholds=thresholds) == (1, T - C, 1)


# ---------------------------------------------------------------- proportional cost
@pytest.mark.parametrize(
    ("p_e", "cost"),
    [(0.5, C), (0.6, 0.75 * C), (0.7, 0.5 * C), (0.9, 0.0), (0.95, 0.0)],
)
def test_proportional_cost_scales_with_distance_from_high(p_e: float, cost: float) -> None:
    engine = BoltEngine([SPEC], [F_E_AND_T], ["e", "t"], cost_mode="proportional")
    out = engine.step(np.array([[0]]), np.array([[p_e, 0.95]]))
    assert out.next_states[0, 0] == 1
    assert out.low_confidence[0, 0] == pytest.approx(-cost)
    assert out.total[0] == pytest.approx(T - cost)
    assert out.n_low[0, 0] == (1 if p_e <= 0.9 else 0)  # the count is reported either way


@given(st.data(), random_dfas())
def test_proportional_differs_from_count_only_in_the_cost_and_never_exceeds_it(
    data: st.DataObject, dfa: DFA
) -> None:
    probs = data.draw(prob_matrices(5, dfa.n_fluents))
    states = np.array(data.draw(st.lists(st.integers(0, dfa.n_states - 1), min_size=5, max_size=5)))
    spec = Spec("x", terminal_reward=3.0, low_confidence_cost=1.5)
    count = BoltEngine([spec], [dfa], dfa.fluents).step(states[:, None], probs)
    prop = BoltEngine([spec], [dfa], dfa.fluents, cost_mode="proportional").step(
        states[:, None], probs
    )
    np.testing.assert_array_equal(count.next_states, prop.next_states)
    np.testing.assert_array_equal(count.terminal, prop.terminal)
    np.testing.assert_array_equal(count.n_low, prop.n_low)
    assert (prop.low_confidence >= count.low_confidence - 1e-12).all()
    assert (prop.low_confidence <= 0).all()


# ---------------------------------------------------------------- several specs
def test_rewards_of_several_specs_add_up() -> None:
    specs = [
        SPEC,
        Spec("G(e)", terminal_reward=1.0, low_confidence_cost=0.5),
    ]
    engine = BoltEngine(specs, [F_E_AND_T, always("e")], ["e", "t"])
    assert engine.n_states == (2, 2)
    out = engine.step(np.array([[0, 0], [0, 0]]), np.array([[0.7, 0.95], [0.2, 0.95]]))
    assert out.next_states.tolist() == [[1, 0], [0, 1]]
    # env 0: F(e&t) T - C; G(e) accepting, e low: 1 - 0.5.  env 1: G(e) violated.
    assert out.reward.tolist() == [[T - C, 0.5], [0.0, 0.0]]
    assert out.total.tolist() == [T - C + 0.5, 0.0]
    assert out.violated.tolist() == [[False, False], [False, True]]


def lift(dfa: DFA, fluents: tuple[str, ...]) -> DFA:
    """The same automaton read over a larger, reordered vocabulary."""
    cols = [fluents.index(f) for f in dfa.fluents]

    def delta(q: int, mask: int) -> int:
        local = sum(1 << i for i, c in enumerate(cols) if mask >> c & 1)
        return int(dfa.next_state[q, local])

    return DFA.from_function(
        fluents,
        n_states=dfa.n_states,
        initial_state=dfa.initial_state,
        accepting=dfa.accepting,
        delta=delta,
    )


@given(st.data())
def test_dfas_over_a_permuted_subset_of_the_vocabulary_equal_their_lifted_form(
    data: st.DataObject,
) -> None:
    bolt_fluents = ("a", "b", "c", "d")
    chosen = data.draw(st.permutations(bolt_fluents))[: data.draw(st.integers(1, 3))]
    small = data.draw(random_dfas(fluents=list(chosen)))
    other = data.draw(random_dfas(fluents=list(bolt_fluents)))
    specs = [
        Spec("small", terminal_reward=2.0, low_confidence_cost=1.0, reward_timing="on_entry"),
        Spec("other", terminal_reward=-1.0, low_confidence_cost=0.25),
    ]
    probs = data.draw(prob_matrices(6, 4))
    states = np.stack(
        [
            np.array(data.draw(st.lists(st.integers(0, d.n_states - 1), min_size=6, max_size=6)))
            for d in (small, other)
        ],
        axis=1,
    )
    for mode in ("count", "proportional"):
        a = BoltEngine(specs, [small, other], bolt_fluents, cost_mode=mode).step(states, probs)
        b = BoltEngine(specs, [lift(small, bolt_fluents), other], bolt_fluents, cost_mode=mode)
        expected = b.step(states, probs)
        for name, x, y in zip(a._fields, a, expected, strict=True):
            np.testing.assert_allclose(x, y, err_msg=name)


@given(st.data())
def test_the_step_batch_path_equals_the_stacked_dense_tables(
    data: st.DataObject,
) -> None:
    dfas = [data.draw(random_dfas(fluents=["a", "b", "c"])) for _ in range(2)]
    specs = [
        Spec("one", terminal_reward=1.0, low_confidence_cost=0.5),
        Spec("two", terminal_reward=4.0, low_confidence_cost=3.0, reward_timing="episode_end"),
    ]
    probs = data.draw(prob_matrices(5, 3))
    states = np.stack(
        [
            np.array(data.draw(st.lists(st.integers(0, d.n_states - 1), min_size=5, max_size=5)))
            for d in dfas
        ],
        axis=1,
    )
    done = np.array(data.draw(st.lists(st.booleans(), min_size=5, max_size=5)))
    dense = BoltEngine(specs, dfas, ["c", "a", "b"], cost_mode="proportional")
    expected = dense.step(states, probs, done=done)
    original = engine_module._dense_tables
    engine_module._dense_tables = lambda dfa: None  # as for DFAs in compact form
    try:
        compact = BoltEngine(specs, dfas, ["c", "a", "b"], cost_mode="proportional")
    finally:
        engine_module._dense_tables = original
    assert compact._flat_next is None
    got = compact.step(states, probs, done=done)
    for name, x, y in zip(got._fields, got, expected, strict=True):
        np.testing.assert_allclose(x, y, err_msg=name)


@given(st.data(), random_dfas())
def test_a_batch_equals_its_environments_one_by_one(data: st.DataObject, dfa: DFA) -> None:
    n_envs = 4
    probs = data.draw(prob_matrices(n_envs, dfa.n_fluents))
    states = np.array(
        data.draw(st.lists(st.integers(0, dfa.n_states - 1), min_size=n_envs, max_size=n_envs))
    )[:, None]
    engine = BoltEngine([SPEC], [dfa], dfa.fluents)
    batch = engine.step(states, probs)
    for i in range(n_envs):
        single = engine.step(states[i : i + 1], probs[i : i + 1])
        for name, x, y in zip(batch._fields, batch, single, strict=True):
            np.testing.assert_array_equal(x[i], y[0], err_msg=name)


# ---------------------------------------------------------------- timing and violation
def test_on_entry_pays_only_when_entering_acceptance() -> None:
    spec = Spec("F(e & t)", terminal_reward=T, low_confidence_cost=C, reward_timing="on_entry")
    engine = BoltEngine([spec], [F_E_AND_T], ["e", "t"])
    probs = np.full((2, 2), 0.95)
    out = engine.step(np.array([[0], [1]]), probs)
    assert out.terminal[:, 0].tolist() == [T, 0.0]  # 0 -> 1 enters; 1 -> 1 stays


def test_on_entry_counts_the_first_transition_as_an_entry() -> None:
    # G(e)'s initial state accepts the empty trace; its first letter still "enters".
    spec = Spec("G(e)", terminal_reward=1.0, low_confidence_cost=0.0, reward_timing="on_entry")
    engine = BoltEngine([spec], [always("e")], ["e"])
    probs = np.array([[0.95]])
    assert engine.step(np.array([[0]]), probs, first=True).total.tolist() == [1.0]
    assert engine.step(np.array([[0]]), probs, first=False).total.tolist() == [0.0]


def test_episode_end_pays_only_when_done_and_accepting() -> None:
    spec = Spec("F(e & t)", terminal_reward=T, low_confidence_cost=C, reward_timing="episode_end")
    engine = BoltEngine([spec], [F_E_AND_T], ["e", "t"])
    probs = np.array([[0.95, 0.95], [0.95, 0.95], [0.2, 0.2]])
    states = np.zeros((3, 1), dtype=np.int64)
    out = engine.step(states, probs, done=np.array([False, True, True]))
    assert out.terminal[:, 0].tolist() == [0.0, T, 0.0]


def test_a_rejecting_sink_is_reported_and_ends_the_episode_only_on_request() -> None:
    specs = [
        Spec("G(e)", terminal_reward=1.0, low_confidence_cost=0.0),
        Spec("F(t)", terminal_reward=5.0, low_confidence_cost=0.0, reward_timing="episode_end"),
    ]
    dfas = [always("e", ["e", "t"]), eventually_all(["t"])]
    engine = BoltEngine(specs, dfas, ["e", "t"])
    states = np.zeros((2, 2), dtype=np.int64)
    probs = np.array([[0.1, 0.95], [0.95, 0.95]])  # env 0 breaks G(e); both see t
    plain = engine.step(states, probs)
    assert plain.violated.tolist() == [[True, False], [False, False]]
    assert plain.terminate.tolist() == [False, False]
    assert plain.total.tolist() == [0.0, 1.0]
    ending = engine.step(states, probs, end_on_violation=True)
    assert ending.terminate.tolist() == [True, False]
    # The episode ends at the violation, so the episode_end spec is paid there.
    assert ending.total.tolist() == [5.0, 1.0]


# ---------------------------------------------------------------- bad input
def test_bad_probs_name_the_index() -> None:
    engine = BoltEngine([SPEC], [F_E_AND_T], ["e", "t"])
    probs = np.array([[0.5, 0.5], [0.5, 1.2]])
    with pytest.raises(ValueError, match=r"probs\[1, 1\] \(fluent 't'\) is 1.2"):
        engine.step(np.zeros((2, 1), dtype=np.int64), probs)
    with pytest.raises(ValueError, match="expected n_fluents=2"):
        engine.step(np.zeros((2, 1), dtype=np.int64), np.full((2, 3), 0.5))


@pytest.mark.parametrize(
    ("states", "message"),
    [
        (np.array([[0, 2]]), r"states\[0, 1\] = 2 is not a state of spec 'G\(e\)'"),
        (np.array([[-1, 0]]), r"states\[0, 0\] = -1"),
        (np.array([[0.0, 0.0]]), "integer"),
        (np.array([0, 0]), "shape"),
        (np.array([[0, 0], [0, 0]]), "shape"),
    ],
)
def test_bad_states_raise(states: np.ndarray, message: str) -> None:
    specs = [SPEC, Spec("G(e)", terminal_reward=1.0, low_confidence_cost=0.0)]
    engine = BoltEngine(specs, [F_E_AND_T, always("e")], ["e", "t"])
    with pytest.raises(ValueError, match=message):
        engine.step(states, np.array([[0.5, 0.5]]))


@pytest.mark.parametrize(
    ("done", "message"),
    [(np.array([1, 0]), "bool"), (np.array([True]), "shape")],
)
def test_bad_done_raises(done: np.ndarray, message: str) -> None:
    engine = BoltEngine([SPEC], [F_E_AND_T], ["e", "t"])
    with pytest.raises(ValueError, match=message):
        engine.step(np.zeros((2, 1), dtype=np.int64), np.full((2, 2), 0.5), done=done)


def test_a_dfa_over_unknown_fluents_raises_unknown_fluent_error() -> None:
    dfa = eventually_all(["e", "x"])
    with pytest.raises(UnknownFluentError, match=r"\['x'\].*\['e', 't'\]") as info:
        BoltEngine([SPEC], [dfa], ["e", "t"])
    assert info.value.unknown == ("x",)
    assert info.value.known == ("e", "t")


@pytest.mark.parametrize(
    ("specs", "dfas", "fluents", "kwargs", "message"),
    [
        ([], [], ["e", "t"], {}, "at least one Spec"),
        ([SPEC], [], ["e", "t"], {}, "1 specs but 0 DFAs"),
        ([SPEC, SPEC], [F_E_AND_T, F_E_AND_T], ["e", "t"], {}, "unique"),
        ([SPEC], [F_E_AND_T], ["e", "t"], {"cost_mode": "linear"}, "cost_mode"),
        ([SPEC], [F_E_AND_T], ["e", "t"], {"thresholds": (0.5, 0.9)}, "Thresholds"),
        ([SPEC], [F_E_AND_T], ["e", "t", "e"], {}, "duplicate fluent"),
        ([SPEC], [F_E_AND_T], [], {}, "empty"),
        ([SPEC], [F_E_AND_T], "et", {}, "not the string"),
        (["F(e & t)"], [F_E_AND_T], ["e", "t"], {}, "Spec objects"),
        ([SPEC], ["F(e & t)"], ["e", "t"], {}, "expected a DFA"),
    ],
)
def test_bad_configuration_raises_config_error(
    specs: list, dfas: list, fluents: list, kwargs: dict, message: str
) -> None:
    with pytest.raises(ConfigError, match=message):
        BoltEngine(specs, dfas, fluents, **kwargs)
