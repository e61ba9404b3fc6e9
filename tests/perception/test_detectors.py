"""The oracle and the synthetic detector: exactness, reproducibility, band frequencies."""

from __future__ import annotations

import math

import numpy as np
import pytest

from noisybolt.errors import ConfigError, UnknownFluentError
from noisybolt.perception.detectors import BetaNoise, OracleDetector, SyntheticDetector
from noisybolt.perception.metrics import band_fractions
from noisybolt.perception.protocols import FluentDetector

NAMES = ("on_edge", "top_right_corner", "bottom_left_corner")


def _truth(n: int, seed: int = 0) -> np.ndarray:
    return np.random.default_rng(seed).random((n, len(NAMES))) < 0.5


def _images(n: int) -> np.ndarray:
    return np.zeros((n, 2, 2, 3), dtype=np.uint8)


def _beta_mass(a: float, b: float, lo: float, hi: float) -> float:
    """P(lo <= X <= hi) for X ~ Beta(a, b), by the trapezoid rule on a fine grid."""
    x = np.linspace(max(lo, 1e-9), min(hi, 1 - 1e-9), 200_001)
    log_norm = math.lgamma(a + b) - math.lgamma(a) - math.lgamma(b)
    pdf = np.exp(log_norm + (a - 1) * np.log(x) + (b - 1) * np.log1p(-x))
    return float(np.trapezoid(pdf, x))


def test_oracle_is_the_truth():
    truth = _truth(50)
    oracle = OracleDetector(NAMES)
    assert isinstance(oracle, FluentDetector) and oracle.needs_truth
    probs = oracle.predict(_images(50), truth=truth)
    assert probs.dtype == np.float32
    np.testing.assert_array_equal(probs, truth.astype(np.float32))
    np.testing.assert_array_equal(
        oracle.predict(_images(1), truth=np.array([[1, 0, 1]])), [[1.0, 0.0, 1.0]]
    )


def test_oracle_refuses_missing_or_misshapen_truth():
    oracle = OracleDetector(NAMES)
    with pytest.raises(ValueError, match="truth"):
        oracle.predict(_images(2))
    with pytest.raises(ValueError, match=r"\[n, 3\]"):
        oracle.predict(_images(2), truth=np.zeros((2, 2), bool))
    with pytest.raises(ValueError, match="images"):
        oracle.predict(_images(3), truth=np.zeros((2, 3), bool))
    with pytest.raises(ConfigError):
        OracleDetector(("a", "a"))


def test_synthetic_is_seeded_and_reproducible():
    truth = _truth(100)
    a = SyntheticDetector(NAMES, seed=5)
    b = SyntheticDetector(NAMES, seed=5)
    first = a.predict(_images(100), truth=truth)
    np.testing.assert_array_equal(first, b.predict(_images(100), truth=truth))
    second = a.predict(_images(100), truth=truth)
    assert not np.array_equal(first, second)  # a stream, not a fixed mapping
    a.reset()
    np.testing.assert_array_equal(a.predict(_images(100), truth=truth), first)
    assert not np.array_equal(
        SyntheticDetector(NAMES, seed=6).predict(_images(100), truth=truth), first
    )
    assert first.dtype == np.float32 and ((first >= 0) & (first <= 1)).all()


@pytest.mark.parametrize(
    "noise", [BetaNoise.high_confidence(), BetaNoise.low_confidence(), BetaNoise(0.6, 0.4, 5, 9)]
)
def test_synthetic_band_frequencies_match_the_beta_model(noise):
    n = 20_000
    truth = np.zeros((n, len(NAMES)), dtype=bool)
    truth[: n // 2] = True
    detector = SyntheticDetector(NAMES, seed=1, default=noise)
    probs = detector.predict(_images(n), truth=truth)
    (ap, bp), (an, bn) = noise.beta_parameters()
    for rows, (a, b) in ((slice(0, n // 2), (ap, bp)), (slice(n // 2, n), (an, bn))):
        got = band_fractions(probs[rows])
        expected = (
            _beta_mass(a, b, 0.9, 1.0),
            _beta_mass(a, b, 0.5, 0.9),
            _beta_mass(a, b, 0.0, 0.5),
        )
        m = (n // 2) * len(NAMES)
        for fraction, p in zip(got, expected, strict=True):
            assert abs(fraction - p) <= 5 * math.sqrt(p * (1 - p) / m) + 1e-3


def test_one_fluent_mostly_low_band_others_high():
    n = 5000
    truth = np.ones((n, len(NAMES)), dtype=bool)
    detector = SyntheticDetector(
        NAMES, seed=0, fluents={"bottom_left_corner": BetaNoise.low_confidence()}
    )
    probs = detector.predict(_images(n), truth=truth)
    dim = band_fractions(probs[:, 2])
    assert dim.low > 0.9 and dim.high < 0.05
    for j in (0, 1):
        assert band_fractions(probs[:, j]).high > 0.95
    negatives = detector.predict(_images(n), truth=~truth)
    assert (negatives < 0.5).mean() > 0.95


def test_fit_calibrates_to_another_detectors_outputs():
    n = 20_000
    truth = _truth(n, seed=2)
    model = {"on_edge": BetaNoise(0.93, 0.08, 25, 40), "bottom_left_corner": BetaNoise(0.7, 0.2)}
    source = SyntheticDetector(NAMES, seed=3, fluents=model)
    probs = source.predict(_images(n), truth=truth)
    fitted = SyntheticDetector.fit(probs, truth, fluent_names=NAMES, seed=4)
    for name, noise in model.items():
        got = fitted.noise[name]
        assert got.positive_mean == pytest.approx(noise.positive_mean, abs=0.01)
        assert got.negative_mean == pytest.approx(noise.negative_mean, abs=0.01)
        assert got.positive_concentration == pytest.approx(noise.positive_concentration, rel=0.1)
    again = fitted.predict(_images(n), truth=truth)
    for j in range(len(NAMES)):
        for a, b in zip(
            band_fractions(probs[truth[:, j], j]),
            band_fractions(again[truth[:, j], j]),
            strict=True,
        ):
            assert a == pytest.approx(b, abs=0.03)


def test_synthetic_settings_are_checked():
    with pytest.raises(UnknownFluentError, match="known"):
        SyntheticDetector(NAMES, seed=0, fluents={"facing_up": BetaNoise()})
    with pytest.raises(ConfigError, match="positive_mean"):
        BetaNoise(positive_mean=1.0)
    with pytest.raises(ConfigError, match="negative_concentration"):
        BetaNoise(negative_concentration=0.0)
    detector = SyntheticDetector(NAMES, seed=0)
    assert detector.needs_truth and isinstance(detector, FluentDetector)
    assert detector.to_dict()["noise"]["on_edge"]["positive_mean"] == 0.97
