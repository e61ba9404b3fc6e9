"""Base rates and switch rates estimated from a detector's outputs alone."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from noisybolt.errors import BaseRateError
from noisybolt.perception.base_rates import (
    adjust_probs,
    belief_settings_from_play,
    estimate_base_rates,
    estimate_switch_rates,
)


def calibrated_frames(rate: float, accuracy: float, n: int, seed: int) -> np.ndarray:
    """A detector calibrated on a balanced set: says ``accuracy`` or ``1 - accuracy``."""
    rng = np.random.default_rng(seed)
    truth = rng.random((n, 1)) < rate
    right = rng.random((n, 1)) < accuracy
    return np.where(truth == right, accuracy, 1 - accuracy)


def test_adjustment_by_hand() -> None:
    # odds 4 under a balanced prior, play base rate 0.2 (odds 1/4): odds 1.
    np.testing.assert_allclose(adjust_probs(np.array([[0.8]]), base_rates=0.2), [[0.5]])
    # Same priors: unchanged.
    probs = np.array([[0.1, 0.7], [0.95, 0.3]])
    np.testing.assert_allclose(adjust_probs(probs, base_rates=0.5), probs)
    # A training prior of 0.25 and play of 0.25: unchanged too.
    np.testing.assert_allclose(adjust_probs(probs, base_rates=0.25, training_prior=0.25), probs)


@pytest.mark.parametrize("rate", [0.03, 0.1, 0.4, 0.8])
def test_em_recovers_the_play_base_rate_without_labels(rate: float) -> None:
    probs = calibrated_frames(rate, 0.9, 40_000, seed=1)
    estimate = estimate_base_rates(probs)
    assert estimate.converged
    assert estimate.rates[0] == pytest.approx(rate, abs=0.015)
    # The detector's own average is far off: the correction is doing the work.
    assert abs(probs.mean() - rate) > 0.05 or rate == 0.4


@settings(max_examples=30, deadline=None)
@given(st.lists(st.floats(0.0, 1.0), min_size=1, max_size=50), st.floats(0.01, 0.99))
def test_estimates_are_rates(values: list[float], prior: float) -> None:
    estimate = estimate_base_rates(np.array(values)[:, None], training_prior=prior)
    assert 0.0 <= estimate.rates[0] <= 1.0


@pytest.mark.parametrize("bad", [-0.1, 1.1, math.nan])
def test_rates_outside_zero_one_are_refused(bad: float) -> None:
    with pytest.raises(BaseRateError):
        adjust_probs(np.array([[0.5]]), base_rates=bad)
    with pytest.raises(BaseRateError):
        estimate_base_rates(np.array([[0.5]]), training_prior=bad)


def test_switch_rate_of_a_markov_chain_is_recovered() -> None:
    rng = np.random.default_rng(0)
    s, pi = 0.2, 0.3
    episodes = []
    for _ in range(50):
        x = rng.random() < pi
        truth = []
        for _ in range(200):
            if rng.random() < s:  # redraw from the stationary law: switch rate s
                x = rng.random() < pi
            truth.append(x)
        noisy = np.clip(np.array(truth, float) + rng.normal(0, 0.05, 200), 0, 1)
        episodes.append(noisy[:, None])
    assert estimate_switch_rates(episodes)[0] == pytest.approx(s, abs=0.03)


def test_switch_rates_refuse_episodes_too_short() -> None:
    with pytest.raises(ValueError, match="two frames"):
        estimate_switch_rates([np.array([[0.5]])])


def test_module_examples_run() -> None:
    import doctest

    import noisybolt.perception.base_rates as module

    result = doctest.testmod(module, optionflags=doctest.NORMALIZE_WHITESPACE)
    assert result.attempted > 0 and result.failed == 0


def test_belief_settings_from_play_carry_the_em_estimate() -> None:
    probs = calibrated_frames(0.1, 0.9, 20_000, seed=4)
    settings = belief_settings_from_play([probs[:10_000], probs[10_000:]], monotone=("x",))
    assert settings.base_rates == pytest.approx((estimate_base_rates(probs).rates[0],))
    # EM's 0 for a fluent never seen is floored: a trained agent may still produce it.
    never = belief_settings_from_play([np.full((50, 1), 0.01)], min_base_rate=0.02)
    assert never.base_rates == (0.02,)
    with pytest.raises(BaseRateError):
        belief_settings_from_play([probs], min_base_rate=1.5)
    assert settings.monotone == ("x",) and settings.switch_rate == 0.5
    with_rates = belief_settings_from_play([probs], switch_rates=True)
    assert with_rates.switch_rate == pytest.approx(tuple(estimate_switch_rates([probs])))
