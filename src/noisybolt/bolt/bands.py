"""Confidence bands of the paper's eq. 1, and the checks every probability array passes.

A fluent's probability ``p`` (from the bolt's classifier) falls in one of three bands:

* **high** if ``p > high`` (default 0.9): the bolt saw the fluent clearly;
* **low** if ``truth <= p <= high``: the bolt thinks the fluent holds, but is unsure;
* **absent** if ``p < truth`` (default 0.5): the bolt thinks the fluent does not hold.

A fluent is *true* (for choosing the DFA edge) iff it is low or high, i.e. ``p >= truth``.
Both boundaries belong to the low band: ``p == 0.5`` and ``p == 0.9`` are low.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from enum import IntEnum

import numpy as np

from noisybolt.errors import ConfigError

__all__ = [
    "DEFAULT_THRESHOLDS",
    "Band",
    "Thresholds",
    "check_probs",
    "confidence_bands",
    "high_confidence_mask",
    "low_confidence_mask",
    "proportional_weights",
    "truth_mask",
]


class Band(IntEnum):
    """Band codes returned by :func:`confidence_bands` (int8 arrays hold these values)."""

    ABSENT = 0
    LOW = 1
    HIGH = 2


@dataclass(frozen=True)
class Thresholds:
    """The two thresholds of eq. 1.

    Attributes:
        truth: a fluent is true iff ``p >= truth``.
        high: a true fluent is seen with high confidence iff ``p > high``.

    Raises:
        ConfigError: unless ``0 < truth <= high < 1``.

    Example:
        >>> Thresholds()
        Thresholds(truth=0.5, high=0.9)
        >>> Thresholds(truth=0.6, high=0.95).high
        0.95
    """

    truth: float = 0.5
    high: float = 0.9

    def __post_init__(self) -> None:
        for name in ("truth", "high"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float, np.floating)):
                raise ConfigError(f"Thresholds.{name} must be a number, got {value!r}")
            if not math.isfinite(value):
                raise ConfigError(f"Thresholds.{name} must be finite, got {value!r}")
            object.__setattr__(self, name, float(value))
        if not 0.0 < self.truth <= self.high < 1.0:
            raise ConfigError(
                f"thresholds must satisfy 0 < truth <= high < 1, got truth={self.truth}, "
                f"high={self.high}"
            )


#: The paper's thresholds: true at p >= 0.5, high confidence above 0.9.
DEFAULT_THRESHOLDS = Thresholds()


def check_probs(
    probs: object,
    *,
    n_fluents: int | None = None,
    n_envs: int | None = None,
    fluents: Sequence[str] | None = None,
) -> np.ndarray:
    """Checks a batch of fluent probabilities and returns it as a float64 array.

    Args:
        probs: array-like ``[n_envs, n_fluents]`` of floating-point probabilities.
        n_fluents: the expected number of columns (None: any).
        n_envs: the expected number of rows (None: any).
        fluents: fluent names, used only to make messages readable.

    Returns:
        float64 ``[n_envs, n_fluents]`` (the input itself when it already is one).

    Raises:
        ValueError: wrong number of dimensions, wrong shape, a non-floating dtype, or a
            value that is NaN or outside [0, 1]; the message names the first offending
            ``[env, fluent]`` index and its value.

    Example:
        >>> check_probs([[0.2, 0.7]], n_fluents=2)
        array([[0.2, 0.7]])
        >>> check_probs([[0.2, float("nan")]], fluents=["e", "t"])
        Traceback (most recent call last):
        ...
        ValueError: probs[0, 1] (fluent 't') is nan; probabilities must be numbers in [0, 1]
    """
    array = np.asarray(probs)
    if not np.issubdtype(array.dtype, np.floating):
        raise ValueError(
            f"probs must be a floating-point array, got dtype {array.dtype}; convert "
            "detector outputs with .astype(np.float64)"
        )
    if array.ndim != 2:
        raise ValueError(f"probs must have shape [n_envs, n_fluents], got shape {array.shape}")
    if n_envs is not None and array.shape[0] != n_envs:
        raise ValueError(f"probs has {array.shape[0]} rows, expected n_envs={n_envs}")
    if n_fluents is not None and array.shape[1] != n_fluents:
        names = f" {list(fluents)}" if fluents is not None else ""
        raise ValueError(
            f"probs has {array.shape[1]} columns, expected n_fluents={n_fluents}{names}"
        )
    array = array.astype(np.float64, copy=False)
    # One pass for the common case; NaN makes either comparison false.
    if array.size and not (array.min() >= 0.0 and array.max() <= 1.0):
        bad = ~((array >= 0.0) & (array <= 1.0))
        env, col = (int(i) for i in np.argwhere(bad)[0])
        name = f" (fluent {fluents[col]!r})" if fluents is not None else ""
        raise ValueError(
            f"probs[{env}, {col}]{name} is {float(array[env, col])!r}; probabilities must be "
            "numbers in [0, 1]"
        )
    return array


def truth_mask(probs: np.ndarray, thresholds: Thresholds = DEFAULT_THRESHOLDS) -> np.ndarray:
    """bool, same shape as ``probs``: the fluent is true (``p >= truth``).

    Example:
        >>> truth_mask(np.array([0.49, 0.5, 0.95]))
        array([False,  True,  True])
    """
    return np.asarray(probs) >= thresholds.truth


def low_confidence_mask(
    probs: np.ndarray, thresholds: Thresholds = DEFAULT_THRESHOLDS
) -> np.ndarray:
    """bool, same shape as ``probs``: the fluent is in the low band (``truth <= p <= high``).

    Example:
        >>> low_confidence_mask(np.array([0.49, 0.5, 0.9, 0.9000001]))
        array([False,  True,  True, False])
    """
    probs = np.asarray(probs)
    return (probs >= thresholds.truth) & (probs <= thresholds.high)


def high_confidence_mask(
    probs: np.ndarray, thresholds: Thresholds = DEFAULT_THRESHOLDS
) -> np.ndarray:
    """bool, same shape as ``probs``: the fluent is in the high band (``p > high``).

    Example:
        >>> high_confidence_mask(np.array([0.9, 0.9000001]))
        array([False,  True])
    """
    return np.asarray(probs) > thresholds.high


def confidence_bands(probs: np.ndarray, thresholds: Thresholds = DEFAULT_THRESHOLDS) -> np.ndarray:
    """int8 band codes (:class:`Band`), same shape as ``probs``.

    Example:
        >>> confidence_bands(np.array([0.4, 0.5, 0.7, 0.9, 0.95])).tolist()
        [0, 1, 1, 1, 2]
    """
    probs = np.asarray(probs)
    return (probs >= thresholds.truth).astype(np.int8) + (probs > thresholds.high)


def proportional_weights(
    probs: np.ndarray, thresholds: Thresholds = DEFAULT_THRESHOLDS
) -> np.ndarray:
    """float64, same shape as ``probs``: each fluent's share of the cost in proportional mode.

    The paper suggests letting the low-confidence cost "depend upon the probability". We
    scale it by how far ``p`` is from being seen clearly::

        w(p) = (high - p) / (high - truth)   if truth <= p <= high   (low band)
        w(p) = 0                             otherwise

    so the weight is 1 at the truth threshold (the least sure a true fluent can be), falls
    linearly to 0 at the high threshold (where the high band, which costs nothing, begins)
    and never exceeds the count mode's weight of 1. When ``truth == high`` the low band is
    the single point ``p == truth`` and its weight is 1.

    Example:
        >>> proportional_weights(np.array([0.4, 0.5, 0.7, 0.9, 0.95])).round(6).tolist()
        [0.0, 1.0, 0.5, 0.0, 0.0]
    """
    probs = np.asarray(probs, dtype=np.float64)
    low = (probs >= thresholds.truth) & (probs <= thresholds.high)
    width = thresholds.high - thresholds.truth
    if width == 0.0:
        return low.astype(np.float64)
    return np.where(low, (thresholds.high - probs) / width, 0.0)
