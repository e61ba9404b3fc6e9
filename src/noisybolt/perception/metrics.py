"""How good a fluent detector is: accuracy, AUROC, calibration and confidence bands.

The bolt uses a detector's probabilities in two ways (DESIGN.md): thresholded at
``truth_threshold`` to move its automata, and banded (high above ``high_threshold``, low
between the two thresholds) to charge for low-confidence fluents. So besides the usual
accuracy and AUROC, a report gives each fluent's *band distribution on true positives*:
the fraction of positives the bolt sees clearly (high band), only dimly (low band), or not
at all (below ``truth_threshold``). The paper's classifier for ``bottom_left_corner``
never exceeded 0.87: all of its true positives were low-band or missed.

Example:
    >>> import numpy as np
    >>> probs = np.array([[0.95], [0.7], [0.2], [0.1]], dtype=np.float32)
    >>> truth = np.array([[True], [True], [False], [False]])
    >>> report = build_report(probs, truth, fluent_names=("t",))
    >>> report.fluents[0].accuracy, report.fluents[0].auroc
    (1.0, 1.0)
    >>> report.fluents[0].positive_bands
    BandFractions(high=0.5, low=0.5, absent=0.0)
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import asdict, dataclass
from typing import Any, NamedTuple

import numpy as np

__all__ = [
    "BandFractions",
    "ClassifierReport",
    "FluentReport",
    "accuracy",
    "auroc",
    "band_fractions",
    "build_report",
    "expected_calibration_error",
]


class BandFractions(NamedTuple):
    """Fractions of a set of probabilities in each confidence band (they sum to 1).

    Attributes:
        high: fraction with ``p > high_threshold``.
        low: fraction with ``truth_threshold <= p <= high_threshold``.
        absent: fraction with ``p < truth_threshold``.
    """

    high: float
    low: float
    absent: float


def _as_pair(probs: np.ndarray, labels: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    probs = np.asarray(probs, dtype=np.float64).ravel()
    labels = np.asarray(labels).ravel()
    if labels.dtype != np.bool_:
        if not np.isin(labels, (0, 1)).all():
            raise ValueError("labels must be booleans or 0/1")
        labels = labels.astype(bool)
    if probs.shape != labels.shape:
        raise ValueError(f"probs {probs.shape} and labels {labels.shape} differ in length")
    if probs.size and (np.isnan(probs).any() or probs.min() < 0.0 or probs.max() > 1.0):
        raise ValueError("probabilities must lie in [0, 1] (no NaN)")
    return probs, labels


def accuracy(probs: np.ndarray, labels: np.ndarray, *, threshold: float = 0.5) -> float:
    """Fraction of ``probs >= threshold`` that agree with ``labels`` (NaN if empty).

    Example:
        >>> accuracy(np.array([0.9, 0.4, 0.5]), np.array([True, True, False]))
        0.3333333333333333
    """
    probs, labels = _as_pair(probs, labels)
    if probs.size == 0:
        return float("nan")
    return float(np.mean((probs >= threshold) == labels))


def auroc(scores: np.ndarray, labels: np.ndarray) -> float:
    """Area under the ROC curve: P(score of a random positive > a random negative).

    Ties count one half (the Mann-Whitney U statistic with mid-ranks). NaN when there are
    no positives or no negatives, since the area is then undefined.

    Example:
        >>> auroc(np.array([0.1, 0.4, 0.35, 0.8]), np.array([0, 0, 1, 1]))
        0.75
    """
    scores, labels = _as_pair(scores, labels)
    n_pos = int(labels.sum())
    n_neg = labels.size - n_pos
    if n_pos == 0 or n_neg == 0:
        return float("nan")
    order = np.argsort(scores, kind="mergesort")
    sorted_scores = scores[order]
    ranks = np.empty(scores.size, dtype=np.float64)
    # Mid-ranks: every run of equal scores gets the mean of the ranks it spans.
    starts = np.flatnonzero(np.r_[True, sorted_scores[1:] != sorted_scores[:-1]])
    ends = np.r_[starts[1:], scores.size]
    mid = (starts + ends + 1) / 2.0  # 1-based mean rank of each run
    ranks[order] = np.repeat(mid, ends - starts)
    u = ranks[labels].sum() - n_pos * (n_pos + 1) / 2.0
    return float(u / (n_pos * n_neg))


def expected_calibration_error(probs: np.ndarray, labels: np.ndarray, *, n_bins: int = 10) -> float:
    """Expected calibration error over ``n_bins`` equal-width bins of the probability.

    ``ECE = sum_b (n_b / n) * |mean(labels in b) - mean(probs in b)|``; bin ``b`` holds
    ``b / n_bins <= p < (b + 1) / n_bins`` (the last bin includes 1). NaN if empty.

    Example:
        >>> expected_calibration_error(np.array([0.25, 0.25, 0.75, 0.75]),
        ...                            np.array([0, 1, 1, 1]), n_bins=2)
        0.25
    """
    if n_bins < 1:
        raise ValueError(f"n_bins must be >= 1, got {n_bins}")
    probs, labels = _as_pair(probs, labels)
    if probs.size == 0:
        return float("nan")
    bins = np.minimum((probs * n_bins).astype(np.int64), n_bins - 1)
    counts = np.bincount(bins, minlength=n_bins)
    conf = np.bincount(bins, weights=probs, minlength=n_bins)
    hits = np.bincount(bins, weights=labels.astype(np.float64), minlength=n_bins)
    filled = counts > 0
    gaps = np.abs(hits[filled] - conf[filled])  # = n_b * |acc_b - conf_b|
    return float(gaps.sum() / probs.size)


def band_fractions(
    probs: np.ndarray, *, truth_threshold: float = 0.5, high_threshold: float = 0.9
) -> BandFractions:
    """Fractions of ``probs`` in the high, low and absent bands (paper eq. 1).

    Example:
        >>> band_fractions(np.array([0.95, 0.9, 0.5, 0.49]))
        BandFractions(high=0.25, low=0.5, absent=0.25)
    """
    if not 0.0 <= truth_threshold <= high_threshold <= 1.0:
        raise ValueError(
            "thresholds must satisfy 0 <= truth_threshold <= high_threshold <= 1, got "
            f"truth_threshold={truth_threshold}, high_threshold={high_threshold}"
        )
    probs = np.asarray(probs, dtype=np.float64).ravel()
    if probs.size == 0:
        nan = float("nan")
        return BandFractions(nan, nan, nan)
    high = float(np.mean(probs > high_threshold))
    low = float(np.mean((probs >= truth_threshold) & (probs <= high_threshold)))
    absent = float(np.mean(probs < truth_threshold))
    return BandFractions(high=high, low=low, absent=absent)


@dataclass(frozen=True)
class FluentReport:
    """How well one fluent is detected.

    Attributes:
        name: the fluent.
        n_positive: number of samples where it is true.
        n_negative: number of samples where it is false.
        accuracy: accuracy at ``truth_threshold``.
        auroc: area under the ROC curve (NaN if one class is missing).
        ece: expected calibration error (10 bins).
        positive_bands: band distribution of the probabilities on true positives.
        negative_bands: band distribution of the probabilities on true negatives (its
            ``high`` and ``low`` are false alarms seen clearly or dimly).
        positive_max: the highest probability given to a true positive.
        positive_median: the median probability given to a true positive.
    """

    name: str
    n_positive: int
    n_negative: int
    accuracy: float
    auroc: float
    ece: float
    positive_bands: BandFractions
    negative_bands: BandFractions
    positive_max: float
    positive_median: float

    def to_dict(self) -> dict[str, Any]:
        """A JSON-able dict (band fractions as ``{"high", "low", "absent"}`` dicts)."""
        out = asdict(self)
        out["positive_bands"] = self.positive_bands._asdict()
        out["negative_bands"] = self.negative_bands._asdict()
        return out


@dataclass(frozen=True)
class ClassifierReport:
    """Per-fluent detection quality over one labelled set of images.

    Attributes:
        fluents: one :class:`FluentReport` per fluent, in column order.
        truth_threshold: the threshold that makes a probability "true".
        high_threshold: the threshold above which a probability is high-confidence.
    """

    fluents: tuple[FluentReport, ...]
    truth_threshold: float = 0.5
    high_threshold: float = 0.9

    def __getitem__(self, name: str) -> FluentReport:
        """The report of the fluent called ``name``."""
        for fluent in self.fluents:
            if fluent.name == name:
                return fluent
        raise KeyError(f"no fluent {name!r}; known: {[f.name for f in self.fluents]}")

    @property
    def min_accuracy(self) -> float:
        """The worst fluent's accuracy."""
        return min(f.accuracy for f in self.fluents)

    def to_dict(self) -> dict[str, Any]:
        """A JSON-able dict of the whole report."""
        return {
            "truth_threshold": self.truth_threshold,
            "high_threshold": self.high_threshold,
            "fluents": [f.to_dict() for f in self.fluents],
        }

    def format_table(self) -> str:
        """A fixed-width text table, one row per fluent."""
        head = (
            f"{'fluent':<20} {'n+':>6} {'n-':>6} {'acc':>7} {'AUROC':>7} {'ECE':>7} "
            f"{'+high':>6} {'+low':>6} {'+<0.5':>6} {'+max':>6}"
        )
        lines = [head, "-" * len(head)]
        for f in self.fluents:
            b = f.positive_bands
            lines.append(
                f"{f.name:<20} {f.n_positive:>6d} {f.n_negative:>6d} {f.accuracy:>7.4f} "
                f"{f.auroc:>7.4f} {f.ece:>7.4f} {b.high:>6.3f} {b.low:>6.3f} "
                f"{b.absent:>6.3f} {f.positive_max:>6.3f}"
            )
        lines.append(
            f"bands on true positives: high p > {self.high_threshold}, low "
            f"{self.truth_threshold} <= p <= {self.high_threshold}, absent p < "
            f"{self.truth_threshold}"
        )
        return "\n".join(lines)


def build_report(
    probs: np.ndarray,
    truth: np.ndarray,
    *,
    fluent_names: Sequence[str],
    truth_threshold: float = 0.5,
    high_threshold: float = 0.9,
) -> ClassifierReport:
    """Reports each fluent's detection quality.

    Args:
        probs: float ``[n, k]`` predicted probabilities.
        truth: bool ``[n, k]`` ground truth.
        fluent_names: the ``k`` fluent names, in column order.
        truth_threshold: a probability at or above it counts as "true".
        high_threshold: a probability above it counts as high-confidence.

    Returns:
        The :class:`ClassifierReport`.
    """
    probs = np.asarray(probs, dtype=np.float64)
    truth = np.asarray(truth, dtype=bool)
    names = tuple(fluent_names)
    if probs.ndim != 2 or probs.shape != truth.shape or probs.shape[1] != len(names):
        raise ValueError(
            f"probs {probs.shape} and truth {truth.shape} must both be [n, {len(names)}]"
        )
    fluents = []
    for j, name in enumerate(names):
        p, y = probs[:, j], truth[:, j]
        pos = p[y]

        def bands(values: np.ndarray) -> BandFractions:
            return band_fractions(
                values, truth_threshold=truth_threshold, high_threshold=high_threshold
            )

        fluents.append(
            FluentReport(
                name=name,
                n_positive=int(y.sum()),
                n_negative=int((~y).sum()),
                accuracy=accuracy(p, y, threshold=truth_threshold),
                auroc=auroc(p, y),
                ece=expected_calibration_error(p, y),
                positive_bands=bands(pos),
                negative_bands=bands(p[~y]),
                positive_max=float(pos.max()) if pos.size else float("nan"),
                positive_median=float(np.median(pos)) if pos.size else float("nan"),
            )
        )
    return ClassifierReport(
        fluents=tuple(fluents), truth_threshold=truth_threshold, high_threshold=high_threshold
    )
