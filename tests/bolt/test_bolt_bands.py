"""Confidence bands (paper eq. 1), thresholds and the checks on probabilities."""

from __future__ import annotations

import numpy as np
import pytest
from bolt_helpers import prob_matrices
from hypothesis import given

from noisybolt.bolt import (
    Band,
    Thresholds,
    check_probs,
    confidence_bands,
    high_confidence_mask,
    low_confidence_mask,
    proportional_weights,
    truth_mask,
)
from noisybolt.errors import ConfigError


@pytest.mark.parametrize(
    ("p", "band"),
    [
        (0.0, Band.ABSENT),
        (0.4999999, Band.ABSENT),
        (0.5, Band.LOW),  # the truth threshold belongs to the low band
        (0.7, Band.LOW),
        (0.9, Band.LOW),  # so does the high threshold
        (0.9000001, Band.HIGH),
        (1.0, Band.HIGH),
    ],
)
def test_bands_of_eq1_at_and_around_the_boundaries(p: float, band: Band) -> None:
    probs = np.array([p])
    assert confidence_bands(probs)[0] == band
    assert truth_mask(probs)[0] == (band != Band.ABSENT)
    assert low_confidence_mask(probs)[0] == (band == Band.LOW)
    assert high_confidence_mask(probs)[0] == (band == Band.HIGH)


def test_custom_thresholds_move_the_bands() -> None:
    thresholds = Thresholds(truth=0.6, high=0.8)
    probs = np.array([0.55, 0.6, 0.8, 0.85])
    assert confidence_bands(probs, thresholds).tolist() == [0, 1, 1, 2]


def test_bands_keep_the_shape_and_use_int8() -> None:
    bands = confidence_bands(np.full((3, 4), 0.95))
    assert bands.shape == (3, 4)
    assert bands.dtype == np.int8
    assert (bands == Band.HIGH).all()


@given(prob_matrices(4, 3))
def test_every_probability_is_in_exactly_one_band(probs: np.ndarray) -> None:
    bands = confidence_bands(probs)
    low, high = low_confidence_mask(probs), high_confidence_mask(probs)
    absent = ~truth_mask(probs)
    assert np.array_equal(absent.astype(int) + low + high, np.ones(probs.shape, dtype=int))
    assert np.array_equal(bands == Band.LOW, low)
    assert np.array_equal(bands == Band.HIGH, high)


@pytest.mark.parametrize(
    ("truth", "high"),
    [(0.0, 0.9), (0.5, 1.0), (0.95, 0.9), (-0.1, 0.5), (float("nan"), 0.9), (0.5, float("inf"))],
)
def test_thresholds_must_satisfy_0_lt_truth_le_high_lt_1(truth: float, high: float) -> None:
    with pytest.raises(ConfigError):
        Thresholds(truth=truth, high=high)


@pytest.mark.parametrize("bad", ["0.5", None, True])
def test_thresholds_must_be_numbers(bad: object) -> None:
    with pytest.raises(ConfigError, match="must be a number"):
        Thresholds(truth=bad)  # type: ignore[arg-type]


def test_equal_thresholds_make_a_one_point_low_band() -> None:
    thresholds = Thresholds(truth=0.7, high=0.7)
    assert confidence_bands(np.array([0.69, 0.7, 0.71]), thresholds).tolist() == [0, 1, 2]
    assert proportional_weights(np.array([0.69, 0.7, 0.71]), thresholds).tolist() == [0, 1, 0]


def test_proportional_weights_hand_values() -> None:
    # w = (0.9 - p) / 0.4 in the low band, 0 elsewhere.
    probs = np.array([0.3, 0.5, 0.6, 0.7, 0.8, 0.9, 0.95])
    expected = [0.0, 1.0, 0.75, 0.5, 0.25, 0.0, 0.0]
    np.testing.assert_allclose(proportional_weights(probs), expected, atol=1e-12)


@given(prob_matrices(3, 3))
def test_proportional_weights_lie_in_unit_interval_and_only_in_the_low_band(
    probs: np.ndarray,
) -> None:
    weights = proportional_weights(probs)
    assert ((weights >= 0) & (weights <= 1)).all()
    assert not weights[~low_confidence_mask(probs)].any()


# ---------------------------------------------------------------- check_probs: bad input
def test_check_probs_accepts_lists_and_float32() -> None:
    out = check_probs(np.array([[0.0, 1.0]], dtype=np.float32), n_fluents=2, n_envs=1)
    assert out.dtype == np.float64
    assert check_probs([[0.5]]).tolist() == [[0.5]]


@pytest.mark.parametrize(
    ("value", "shown"),
    [(float("nan"), "nan"), (-0.1, "-0.1"), (1.5, "1.5"), (float("inf"), "inf")],
)
def test_check_probs_names_the_offending_env_fluent_and_value(value: float, shown: str) -> None:
    probs = np.full((3, 2), 0.5)
    probs[2, 1] = value
    with pytest.raises(ValueError, match=r"probs\[2, 1\] \(fluent 't'\) is " + shown) as info:
        check_probs(probs, n_fluents=2, fluents=["e", "t"])
    assert "[0, 1]" in str(info.value)


def test_check_probs_reports_the_first_bad_index_in_row_major_order() -> None:
    probs = np.full((3, 3), 0.5)
    probs[1, 2] = np.nan
    probs[2, 0] = 2.0
    with pytest.raises(ValueError, match=r"probs\[1, 2\] is nan"):
        check_probs(probs)


@pytest.mark.parametrize(
    ("probs", "message"),
    [
        (np.full(3, 0.5), "shape"),
        (np.full((1, 2, 3), 0.5), "shape"),
        (np.full((2, 3), 0.5), "3 columns, expected n_fluents=2"),
        (np.full((4, 2), 0.5), "4 rows, expected n_envs=2"),
        (np.ones((2, 2), dtype=np.int64), "floating-point"),
        (np.ones((2, 2), dtype=bool), "floating-point"),
        (np.array([[0.5, "x"]], dtype=object), "floating-point"),
    ],
)
def test_check_probs_rejects_wrong_shapes_and_dtypes(probs: np.ndarray, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        check_probs(probs, n_fluents=2, n_envs=2)
