"""Compliance estimated from the bolt's evidence: hand-computed posteriors, a perfect
detector giving the truth, successive frames' confusion counted once, the intervals, and
the errors that say what to provide."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from noisybolt.bolt.compliance import (
    ErrorModel,
    FluentDynamics,
    aggregate_compliance,
    estimate_compliance,
    fit_dynamics,
    satisfaction_probabilities,
)
from noisybolt.errors import ConfigError, MissingErrorModelError, UnknownFluentError
from noisybolt.logic import DFA


def ever(fluent: str) -> DFA:
    """F(fluent)."""
    return DFA.from_function(
        [fluent],
        n_states=2,
        initial_state=0,
        accepting=[False, True],
        delta=lambda q, m: 1 if q == 1 or m & 1 else 0,
    )


def ever_x_never_y() -> DFA:
    """F(x) & G(!y): 0 waiting, 1 x seen, 2 y seen (violated for good)."""

    def delta(q: int, m: int) -> int:
        if q == 2 or m & 2:
            return 2
        return 1 if q == 1 or m & 1 else 0

    return DFA.from_function(
        ["x", "y"], n_states=3, initial_state=0, accepting=[False, True, False], delta=delta
    )


def symmetric(error: float, n: float = 1000.0, fluents: tuple[str, ...] = ("x",)) -> ErrorModel:
    """Two bands (p < 0.5, p >= 0.5), wrong with probability ``error`` either way."""
    right, wrong = n * (1 - error), n * error
    counts = np.array([[[right, wrong], [wrong, right]]] * len(fluents))
    return ErrorModel(fluent_names=fluents, edges=(0.5,), counts=counts, pseudo_count=0.0)


IID_HALF = FluentDynamics(start=np.array([0.5]), on=np.array([0.5]), off=np.array([0.5]))


def test_a_one_fluent_spec_under_symmetric_errors_gives_the_posterior_computed_by_hand() -> None:
    # Frames independent (each frame's truth a fair coin), right 9 times in 10: P(x_t
    # false | "no") = 0.9, P(x_t false | "yes") = 0.1, and F(x) fails only if every frame
    # was truly false.
    rates = symmetric(0.1).rates()[None]
    episodes = [np.array([[0.2], [0.8]]), np.array([[0.2], [0.3]]), np.array([[0.9]])]
    p = satisfaction_probabilities(ever("x"), ("x",), episodes, rates, IID_HALF)
    assert p.shape == (1, 3)
    np.testing.assert_allclose(p[0], [1 - 0.9 * 0.1, 1 - 0.9 * 0.9, 1 - 0.1], rtol=1e-12)


def test_a_persistent_fluent_is_believed_from_the_run_not_from_one_glitch() -> None:
    # A fluent that never changes within an episode (start 0.5): its posterior is the
    # product of every frame's likelihood ratio. One "yes" among three "no"s: odds 9 / 9^3.
    still = FluentDynamics(start=np.array([0.5]), on=np.array([0.0]), off=np.array([0.0]))
    rates = symmetric(0.1).rates()[None]
    frames = np.array([[0.1], [0.1], [0.9], [0.1]])
    p = satisfaction_probabilities(ever("x"), ("x",), [frames], rates, still)
    odds = 9.0 / 9.0**3
    assert p[0, 0] == pytest.approx(odds / (1 + odds), rel=1e-12)


@settings(max_examples=40, deadline=None)
@given(
    st.lists(
        st.lists(st.tuples(st.booleans(), st.booleans()), min_size=1, max_size=12),
        min_size=1,
        max_size=6,
    )
)
def test_a_perfect_detector_gives_the_truth_exactly(traces: list[list[tuple[bool, bool]]]) -> None:
    dfa = ever_x_never_y()
    truth = [np.array(t, dtype=bool) for t in traces]
    probs = [t.astype(np.float64) for t in truth]  # a detector sure and right
    counts = np.array([[[500.0, 0.0], [0.0, 500.0]]] * 2)
    perfect = ErrorModel(fluent_names=("x", "y"), edges=(0.5,), counts=counts, pseudo_count=0.0)
    estimate = estimate_compliance({"s": dfa}, ("x", "y"), probs, perfect, n_draws=4)["s"]
    accepted = [dfa.accepts([{"x": bool(a), "y": bool(b)} for a, b in t]) for t in truth]
    np.testing.assert_allclose(estimate.per_episode, np.array(accepted, dtype=float), atol=1e-9)
    assert estimate.rate == pytest.approx(np.mean(accepted))
    assert estimate.episodes_low == estimate.episodes_high == pytest.approx(np.mean(accepted))


@settings(max_examples=30, deadline=None)
@given(
    st.lists(
        st.lists(st.tuples(st.floats(0, 1), st.floats(0, 1)), min_size=1, max_size=10),
        min_size=1,
        max_size=5,
    ),
    st.floats(0.01, 0.4),
)
def test_successions_that_repeat_the_marginal_confusion_change_nothing(
    traces: list[list[tuple[float, float]]], error: float
) -> None:
    # P(band now | band before, truth before, truth now) = P(band now | truth now): the
    # temporal error model reduces to frames independent given the truth.
    dfa = ever_x_never_y()
    model = symmetric(error, fluents=("x", "y"))
    rates = model.rates()[None]
    pairs = np.broadcast_to(rates[:, :, None, :, None, :], (1, 2, 2, 2, 2, 2))
    dynamics = FluentDynamics(np.array([0.3, 0.2]), np.array([0.1, 0.2]), np.array([0.4, 0.3]))
    episodes = [np.array(t) for t in traces]
    alone = satisfaction_probabilities(dfa, ("x", "y"), episodes, rates, dynamics)
    paired = satisfaction_probabilities(
        dfa, ("x", "y"), episodes, rates, dynamics, pair_rates=pairs
    )
    np.testing.assert_allclose(paired, alone, atol=1e-12)
    assert np.all((alone >= -1e-12) & (alone <= 1 + 1e-12))


def test_a_detector_that_repeats_its_errors_is_not_believed_once_per_frame() -> None:
    # "yes" on 5 % of negatives, on every positive; but a "yes" follows a "yes" on the
    # same truth always (the same view, read alike): a long run of "yes" is one piece of
    # evidence, not one per frame.
    counts = np.array([[[950.0, 50.0], [0.0, 1000.0]]])
    pairs = np.zeros((1, 2, 2, 2, 2))
    pairs[0, :, :, 1, 1] = 1000.0  # after "yes", "yes" again whatever the truth
    pairs[0, :, 0, 0, :] = counts[0, 0]  # after "no": the marginal confusion of the truth now
    pairs[0, :, 1, 0, :] = counts[0, 1]
    sticky = ErrorModel(
        fluent_names=("x",), edges=(0.5,), counts=counts, pseudo_count=0.0, pair_counts=pairs
    )
    flat = ErrorModel(fluent_names=("x",), edges=(0.5,), counts=counts, pseudo_count=0.0)
    dynamics = FluentDynamics(np.array([0.0]), np.array([0.02]), np.array([0.3]))

    def believed(model: ErrorModel, run: int) -> float:
        frames = np.array([[0.1]] * 3 + [[0.7]] * run + [[0.1]] * 3)
        rates = model.rates()[None]
        pair_rates = model.pair_rates(rates)
        return float(
            satisfaction_probabilities(
                ever("x"), ("x",), [frames], rates, dynamics, pair_rates=pair_rates
            )[0, 0]
        )

    assert believed(flat, 12) > 0.99  # twelve "independent" yeses
    # Sticky: the run's length adds only the prior's chances of an onset hidden inside it
    # (on = 0.02 a frame), not a likelihood ratio of 19 per frame.
    assert 0.05 < believed(sticky, 1) < believed(sticky, 2) < believed(sticky, 12) < 0.5


def test_fit_dynamics_learns_a_persistent_fluent_from_unlabelled_frames() -> None:
    rng = np.random.default_rng(0)
    rates = symmetric(0.05).rates()
    episodes = []
    for _ in range(60):
        truth = np.zeros(40, dtype=int)
        onset = rng.integers(5, 30)
        truth[onset : onset + 6] = 1  # on for six frames, once
        flip = rng.random(40) < 0.05
        episodes.append(np.where(flip, 1 - truth, truth)[:, None])
    d = fit_dynamics(episodes, rates)
    assert d.off[0] == pytest.approx(1 / 6, abs=0.05)
    assert d.on[0] == pytest.approx(1 / 34, abs=0.015)
    assert d.start[0] < 0.05


def at_most_one_stretch() -> DFA:
    """x true in one stretch at most: 0 not yet, 1 on, 2 off after, 3 on again (violated)."""

    def delta(q: int, m: int) -> int:
        on = bool(m & 1)
        if q in (0, 1):
            return 1 if on else (0 if q == 0 else 2)
        return 3 if on or q == 3 else 2

    return DFA.from_function(
        ["x"], n_states=4, initial_state=0, accepting=[True, True, True, False], delta=delta
    )


def test_a_chain_with_memory_does_not_take_one_wrong_frame_after_a_visit_for_a_return() -> None:
    # Every episode is on for one stretch of six frames; the detector is wrong on 1 % of
    # frames either way. A chain without memory comes on as readily after the visit as
    # before it, so a lone "yes" after the visit reads as a return; with memory, the
    # episodes show that nothing comes back.
    rng = np.random.default_rng(0)
    model = symmetric(0.01)
    episodes = []
    for _ in range(200):
        truth = np.zeros(40)
        onset = rng.integers(5, 30)
        truth[onset : onset + 6] = 1
        wrong = rng.random(40) < 0.01
        episodes.append((np.where(wrong, 1 - truth, truth) * 0.8 + 0.1)[:, None])
    bands = [(e >= 0.5).astype(int) for e in episodes]
    plain = fit_dynamics(bands, model.rates())
    remembering = fit_dynamics(bands, model.rates(), memory=True)
    assert plain.again is None
    assert remembering.again is not None and remembering.again[0] < 1e-3
    assert remembering.on[0] > plain.on[0]  # arrivals, over the frames before them only
    probe = np.array([[0.1]] * 5 + [[0.9]] * 6 + [[0.1]] * 5 + [[0.9]] + [[0.1]] * 5)
    dfa = at_most_one_stretch()
    rates = model.rates()[None]
    assert satisfaction_probabilities(dfa, ("x",), [probe], rates, plain)[0, 0] < 0.7
    assert satisfaction_probabilities(dfa, ("x",), [probe], rates, remembering)[0, 0] > 0.99
    # Every episode complied: the plain chain finds returns that never were.
    rate = estimate_compliance({"once": dfa}, ("x",), episodes, model, memory=False)
    assert rate["once"].rate < 0.95
    assert estimate_compliance({"once": dfa}, ("x",), episodes, model)["once"].rate > 0.99


def test_the_filter_with_memory_and_successions_agrees_with_summing_every_true_trace() -> None:
    # Two fluents, four frames: every one of the 256 true traces weighed by the chains
    # (with memory) and the successive frames' confusion, kept where the DFA accepts.
    rng = np.random.default_rng(2)
    dynamics = FluentDynamics(
        np.array([0.3, 0.2]), np.array([0.2, 0.3]), np.array([0.4, 0.5]), np.array([0.05, 0.6])
    )
    rates = rng.dirichlet(np.ones(2), size=(1, 2, 2))  # [draw, fluent, truth, band]
    pairs = rng.dirichlet(np.ones(2), size=(1, 2, 2, 2, 2))  # [.., before, now, band before]
    bands = rng.integers(0, 2, size=(4, 2))
    dfa = ever_x_never_y()
    got = satisfaction_probabilities(dfa, ("x", "y"), [bands], rates, dynamics, pair_rates=pairs)[
        0, 0
    ]
    total = accepted = 0.0
    for code in range(256):
        truth = (code >> np.arange(8)).reshape(4, 2) & 1
        weight = 1.0
        for f in range(2):
            seen = False
            for t in range(4):
                now = truth[t, f]
                if t == 0:
                    start = dynamics.start[f]
                    weight *= (start if now else 1 - start) * rates[0, f, now, bands[t, f]]
                else:
                    before = truth[t - 1, f]
                    if before:
                        step = 1 - dynamics.off[f] if now else dynamics.off[f]
                    else:
                        rate = (dynamics.again if seen else dynamics.on)[f]  # type: ignore[index]
                        step = rate if now else 1 - rate
                    weight *= step * pairs[0, f, before, now, bands[t - 1, f], bands[t, f]]
                seen = seen or bool(now)
        total += weight
        if dfa.accepts([{"x": bool(r[0]), "y": bool(r[1])} for r in truth]):
            accepted += weight
    assert got == pytest.approx(accepted / total, abs=1e-12)


def test_the_intervals_hold_the_rate_and_widen_where_the_episodes_are_in_doubt() -> None:
    rng = np.random.default_rng(1)
    sure = np.tile(np.r_[np.ones(30), np.zeros(70)], (8, 1))
    doubtful = np.full((8, 100), 0.3)
    a = aggregate_compliance(sure, rng=rng)
    b = aggregate_compliance(doubtful, rng=rng)
    assert a.rate == pytest.approx(0.3) and b.rate == pytest.approx(0.3)
    assert a.episodes_low == a.episodes_high == pytest.approx(0.3)
    assert b.episodes_high - b.episodes_low > 0.1  # these episodes' truths are unknown
    for e in (a, b):
        assert e.low <= e.rate <= e.high
        assert e.low <= e.episodes_low and e.episodes_high <= e.high + 1e-9
    # the policy's rate: about 1.645 * sqrt(0.3 * 0.7 / 100) = 7.5 points either side
    assert a.high - a.low == pytest.approx(2 * 1.645 * np.sqrt(0.21 / 100), abs=0.03)


def test_draws_of_the_error_model_spread_with_few_labelled_images() -> None:
    rng = np.random.default_rng(2)
    few = symmetric(0.1, n=10.0).sample(rng, 2000)[:, 0, 0, 1]  # P("yes" | x false)
    many = symmetric(0.1, n=10000.0).sample(rng, 2000)[:, 0, 0, 1]
    assert few.mean() == pytest.approx(0.1, abs=0.01) and many.mean() == pytest.approx(
        0.1, abs=0.002
    )
    assert few.std() > 10 * many.std()


def test_an_error_model_round_trips_through_json_and_restricts_by_name() -> None:
    pairs = np.arange(2 * 2 * 2 * 3 * 3, dtype=float).reshape(2, 2, 2, 3, 3)
    model = ErrorModel(
        fluent_names=("a", "b"),
        edges=(0.1, 0.5),
        counts=np.arange(12, dtype=float).reshape(2, 2, 3),
        pair_counts=pairs,
    )
    again = ErrorModel.from_dict(model.to_dict())
    assert again.fluent_names == ("a", "b") and again.edges == (0.1, 0.5)
    np.testing.assert_array_equal(again.counts, model.counts)
    np.testing.assert_array_equal(again.pair_counts, pairs)
    only_b = model.restrict(["b"])
    np.testing.assert_array_equal(only_b.counts, model.counts[1:])
    assert only_b.pair_counts is not None and only_b.pair_counts.shape == (1, 2, 2, 3, 3)


def test_a_spec_over_fluents_the_detector_or_its_error_model_lacks_is_refused_by_name() -> None:
    episodes = [np.array([[0.1, 0.9]])]
    with pytest.raises(UnknownFluentError, match="predicts every fluent") as info:
        estimate_compliance({"s": ever("z")}, ("x", "y"), episodes, symmetric(0.1))
    assert info.value.unknown == ("z",)
    with pytest.raises(UnknownFluentError, match="measure the detector") as info:
        estimate_compliance({"s": ever("y")}, ("x", "y"), episodes, symmetric(0.1))
    assert info.value.unknown == ("y",)


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"edges": (0.5, 0.4)}, "increase"),
        ({"edges": (1.0,)}, "increase"),
        ({"counts": np.ones((1, 2, 3))}, "shape"),
        ({"counts": -np.ones((1, 2, 2))}, ">= 0"),
        ({"counts": np.array([[[5.0, 5.0], [0.0, 0.0]]]), "pseudo_count": 0.0}, "true"),
    ],
)
def test_a_malformed_error_model_is_refused(kwargs: dict[str, object], match: str) -> None:
    settings_: dict[str, object] = {
        "fluent_names": ("x",),
        "edges": (0.5,),
        "counts": np.ones((1, 2, 2)),
        **kwargs,
    }
    with pytest.raises(ConfigError, match=match):
        ErrorModel(**settings_)  # type: ignore[arg-type]


def test_no_episodes_or_episodes_of_another_width_are_refused() -> None:
    with pytest.raises(ConfigError, match="at least one episode"):
        estimate_compliance({"s": ever("x")}, ("x",), [], symmetric(0.1))
    with pytest.raises(ConfigError, match=r"\[T >= 1, 1\]"):
        estimate_compliance({"s": ever("x")}, ("x",), [np.zeros((3, 2))], symmetric(0.1))


def test_a_fluent_no_labelled_image_showed_true_is_refused_with_what_to_give() -> None:
    # Random play on FrozenLake never reaches the goal: a detector measured there has no
    # idea what it reads at the goal, and an estimate over "at_goal" would be a guess.
    never_true = ErrorModel(
        fluent_names=("x",), edges=(0.5,), counts=np.array([[[2000.0, 0.0], [0.0, 0.0]]])
    )
    with pytest.raises(MissingErrorModelError, match=r"showing x true.*true and false"):
        estimate_compliance({"s": ever("x")}, ("x",), [np.array([[0.1]])], never_true)
