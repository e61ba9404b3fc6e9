"""Detection metrics against hand-computed values."""

from __future__ import annotations

import math

import numpy as np
import pytest

from noisybolt.perception.metrics import (
    BandFractions,
    accuracy,
    auroc,
    band_fractions,
    build_report,
    expected_calibration_error,
)


def test_auroc_hand_computed():
    # positives 0.35, 0.8; negatives 0.1, 0.4: 3 of 4 pairs ordered right.
    assert auroc(np.array([0.1, 0.4, 0.35, 0.8]), np.array([0, 0, 1, 1])) == 0.75


def test_auroc_ties_count_half():
    # one positive, one negative with equal scores; one clear win -> (1 + 0.5) / 2
    scores = np.array([0.5, 0.5, 0.9])
    labels = np.array([False, True, True])
    assert auroc(scores, labels) == 0.75
    assert auroc(np.full(4, 0.3), np.array([0, 1, 0, 1])) == 0.5


def test_auroc_extremes_and_undefined():
    assert auroc(np.array([0.1, 0.2, 0.8, 0.9]), np.array([0, 0, 1, 1])) == 1.0
    assert auroc(np.array([0.9, 0.8, 0.2, 0.1]), np.array([0, 0, 1, 1])) == 0.0
    assert math.isnan(auroc(np.array([0.1, 0.9]), np.array([1, 1])))


def test_auroc_matches_pairwise_definition():
    rng = np.random.default_rng(0)
    scores = rng.integers(0, 10, 200) / 10  # many ties
    labels = rng.random(200) < 0.3
    pos, neg = scores[labels], scores[~labels]
    pairwise = ((pos[:, None] > neg[None]) + 0.5 * (pos[:, None] == neg[None])).mean()
    assert auroc(scores, labels) == pytest.approx(pairwise)


def test_ece_hand_computed():
    # two bins: [0, .5): conf .25, acc .5 ; [.5, 1]: conf .75, acc 1 -> .5*.25 + .5*.25
    probs = np.array([0.25, 0.25, 0.75, 0.75])
    labels = np.array([0, 1, 1, 1])
    assert expected_calibration_error(probs, labels, n_bins=2) == pytest.approx(0.25)
    # ten bins; p = 1.0 falls in the last bin, not an eleventh
    probs = np.array([1.0, 0.95, 0.05, 0.0])
    labels = np.array([1, 1, 0, 0])
    # bin 9: conf .975 acc 1 (2 samples); bin 0: conf .025 acc 0 (2 samples)
    assert expected_calibration_error(probs, labels) == pytest.approx(0.025)


def test_ece_perfectly_calibrated_is_zero():
    probs = np.array([0.2] * 5 + [0.8] * 5)
    labels = np.array([1, 0, 0, 0, 0, 1, 1, 1, 1, 0])
    assert expected_calibration_error(probs, labels) == pytest.approx(0.0)


def test_accuracy_threshold_is_inclusive():
    assert accuracy(np.array([0.5, 0.49]), np.array([True, False])) == 1.0


def test_bands_follow_equation_1():
    # 0.9 is low (<= 0.9), 0.5 is low (>= 0.5)
    assert band_fractions(np.array([0.91, 0.9, 0.5, 0.49])) == BandFractions(0.25, 0.5, 0.25)
    assert band_fractions(np.array([0.8]), high_threshold=0.7) == BandFractions(1.0, 0.0, 0.0)
    with pytest.raises(ValueError, match="thresholds"):
        band_fractions(np.array([0.5]), truth_threshold=0.9, high_threshold=0.5)


def test_bad_inputs_are_refused():
    with pytest.raises(ValueError, match="differ"):
        auroc(np.array([0.1, 0.2]), np.array([1]))
    with pytest.raises(ValueError, match=r"\[0, 1\]"):
        accuracy(np.array([1.5]), np.array([1]))
    with pytest.raises(ValueError, match="0/1"):
        accuracy(np.array([0.5]), np.array([2]))


def test_report_per_fluent():
    probs = np.array([[0.95, 0.7], [0.6, 0.87], [0.2, 0.3], [0.05, 0.6]])
    truth = np.array([[True, True], [True, True], [False, False], [False, False]])
    report = build_report(probs, truth, fluent_names=("t", "b"))
    t, b = report["t"], report["b"]
    assert (t.n_positive, t.n_negative) == (2, 2)
    assert t.accuracy == 1.0 and t.auroc == 1.0
    assert t.positive_bands == BandFractions(0.5, 0.5, 0.0)
    assert b.positive_bands == BandFractions(0.0, 1.0, 0.0)  # the paper's b: never > 0.87
    assert b.positive_max == pytest.approx(0.87)
    assert b.accuracy == 0.75  # 0.6 on a negative is a false alarm
    assert b.negative_bands == BandFractions(0.0, 0.5, 0.5)
    assert report.min_accuracy == 0.75
    table = report.format_table()
    assert "t" in table and "0.870" in table
    data = report.to_dict()
    assert data["fluents"][1]["positive_bands"] == {"high": 0.0, "low": 1.0, "absent": 0.0}
    with pytest.raises(KeyError, match="known"):
        report["e"]
    with pytest.raises(ValueError, match=r"\[n, 3\]"):
        build_report(probs, truth, fluent_names=("a", "b", "c"))
