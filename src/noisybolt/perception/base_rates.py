"""Base rates of fluents in play, estimated from a detector's outputs alone (prior shift).

A classifier trained on a balanced set (each fluent true in half of its images) reports
probabilities under that prior, ``P_train(x | image)``. In play a fluent may hold on 3 %
of the frames; the probability the bolt should use is the one under the play prior
(Saerens, Latinne & Decaestecker, "Adjusting the outputs of a classifier to new a priori
probabilities", Neural Computation 14, 2002)::

    odds_play(x | image) = odds_train(x | image) * odds(pi_play) / odds(pi_train)

``pi_play`` need not be known: it is the fixed point of the EM iteration of that paper,
run on unlabelled play frames (no ground truth): adjust every frame's probability to the
current estimate, and take their mean as the next estimate. Each fluent is a binary
problem of its own.

How fast a fluent's truth changes is read off the same unlabelled frames
(:func:`estimate_switch_rates`): for a two-state Markov chain the lag-one autocorrelation
of the truth is ``1 - s`` (``s`` the switch rate of
:class:`~noisybolt.bolt.BeliefSettings`), and a detector's probabilities follow the truth
closely enough that theirs is a usable estimate (on the gridworld, for corners and
headings alike, within 0.03 of the truth's under both the clean and the smudged camera).

Example:
    >>> import numpy as np
    >>> rng = np.random.default_rng(0)
    >>> truth = rng.random((20000, 1)) < 0.1  # the fluent holds on 10 % of play frames
    >>> # A detector calibrated on a balanced set: right 90 % of the time, says 0.9 or 0.1.
    >>> right = rng.random(truth.shape) < 0.9
    >>> probs = np.where(truth == right, 0.9, 0.1)
    >>> probs.mean().round(2)  # what the detector's average says: far from 10 %
    np.float64(0.24)
    >>> estimate_base_rates(probs).rates.round(2).tolist()
    [0.1]
    >>> adjust_probs(np.array([[0.9]]), base_rates=[0.1]).round(3).tolist()
    [[0.5]]
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any, NamedTuple

import numpy as np

from noisybolt.bolt.belief import BeliefSettings
from noisybolt.errors import BaseRateError

__all__ = [
    "BaseRateEstimate",
    "adjust_probs",
    "belief_settings_from_play",
    "estimate_base_rates",
    "estimate_switch_rates",
]

_EPS = 1e-9


class BaseRateEstimate(NamedTuple):
    """The outcome of :func:`estimate_base_rates`.

    Attributes:
        rates: float64 ``[n_fluents]``, each fluent's estimated frequency in play.
        iterations: EM iterations run.
        converged: whether every rate moved less than the tolerance in the last one.
    """

    rates: np.ndarray
    iterations: int
    converged: bool


def _rates(value: float | Sequence[float] | np.ndarray, n: int, name: str) -> np.ndarray:
    array = np.broadcast_to(np.asarray(value, dtype=np.float64), (n,)).copy()
    if not np.all(np.isfinite(array)) or np.any((array < 0.0) | (array > 1.0)):
        raise BaseRateError(f"{name} must lie in [0, 1] per fluent, got {array.tolist()}")
    return array


def _probs(probs: object) -> np.ndarray:
    array = np.asarray(probs, dtype=np.float64)
    if array.ndim != 2:
        raise ValueError(f"probs must have shape [n_frames, n_fluents], got {array.shape}")
    if array.size and not (array.min() >= 0.0 and array.max() <= 1.0):
        raise ValueError("probs must be probabilities in [0, 1] (no NaN)")
    return array


def adjust_probs(
    probs: np.ndarray,
    *,
    base_rates: float | Sequence[float] | np.ndarray,
    training_prior: float | Sequence[float] | np.ndarray = 0.5,
) -> np.ndarray:
    """Detector probabilities re-expressed under the play base rates (Saerens et al.).

    Args:
        probs: float ``[n_frames, n_fluents]`` under the training prior.
        base_rates: each fluent's frequency in play (one number for all, or per fluent).
        training_prior: each fluent's frequency in the detector's training set.

    Returns:
        float64 ``[n_frames, n_fluents]``.

    Raises:
        BaseRateError: a rate outside [0, 1].
        ValueError: ``probs`` not a 2-D array of probabilities.
    """
    probs = _probs(probs)
    n = probs.shape[1]
    play = np.clip(_rates(base_rates, n, "base_rates"), _EPS, 1 - _EPS)
    train = np.clip(_rates(training_prior, n, "training_prior"), _EPS, 1 - _EPS)
    up, down = play / train, (1 - play) / (1 - train)
    weighted = probs * up
    return weighted / (weighted + (1 - probs) * down)


def estimate_base_rates(
    probs: np.ndarray,
    *,
    training_prior: float | Sequence[float] | np.ndarray = 0.5,
    max_iterations: int = 1000,
    tolerance: float = 1e-7,
) -> BaseRateEstimate:
    """Each fluent's frequency in play from unlabelled frames (EM of Saerens et al. 2002).

    Args:
        probs: float ``[n_frames, n_fluents]``: the detector on frames of play (e.g.
            random play), no labels needed.
        training_prior: each fluent's frequency in the detector's training set.
        max_iterations: EM iterations at most.
        tolerance: stop when no rate moves more than this.

    Returns:
        The :class:`BaseRateEstimate`.

    Raises:
        BaseRateError: a training prior outside [0, 1].
        ValueError: ``probs`` empty or not a 2-D array of probabilities, or bad settings.
    """
    probs = _probs(probs)
    if probs.shape[0] == 0:
        raise ValueError("estimate_base_rates needs at least one frame")
    if max_iterations < 1 or not (tolerance > 0 and math.isfinite(tolerance)):
        raise ValueError("max_iterations must be >= 1 and tolerance finite and > 0")
    n = probs.shape[1]
    train = _rates(training_prior, n, "training_prior")
    rates = probs.mean(axis=0)  # the first E-step under the training prior
    converged = False
    iterations = 0
    while not converged and iterations < max_iterations:
        new = adjust_probs(probs, base_rates=rates, training_prior=train).mean(axis=0)
        converged = bool(np.all(np.abs(new - rates) < tolerance))
        rates = new
        iterations += 1
    return BaseRateEstimate(rates=rates, iterations=iterations, converged=converged)


def estimate_switch_rates(episodes: Sequence[np.ndarray], *, floor: float = 0.01) -> np.ndarray:
    """Each fluent's switch rate from the detector's probabilities over play (no labels).

    ``1 - r`` with ``r`` the lag-one autocorrelation of the probabilities, pooled over
    episodes (each ``[T, n_fluents]``, in time order), clipped to ``[floor, 1]``.

    Args:
        episodes: the detector's probabilities per episode, float ``[T, n_fluents]``.
        floor: the smallest rate returned (a fluent that never changes in the frames).

    Returns:
        float64 ``[n_fluents]``.

    Raises:
        ValueError: no episode with two frames, or episodes of different widths.

    Example:
        >>> steady = np.repeat([[0.0], [1.0]], 10, axis=0)  # on after 10 of 20 frames
        >>> estimate_switch_rates([steady]).round(2).tolist()
        [0.15]
    """
    arrays = [_probs(e) for e in episodes]
    usable = [a for a in arrays if len(a) >= 2]
    if not usable:
        raise ValueError("estimate_switch_rates needs an episode of at least two frames")
    if len({a.shape[1] for a in usable}) != 1:
        raise ValueError("every episode must have the same number of fluents")
    mean = np.concatenate(usable).mean(axis=0)
    lagged = sum(((a[:-1] - mean) * (a[1:] - mean)).sum(axis=0) for a in usable)
    spread = sum(((a - mean) ** 2).sum(axis=0) for a in usable)
    with np.errstate(invalid="ignore", divide="ignore"):
        correlation = np.where(spread > 0, lagged / spread, 1.0)
    return np.clip(1.0 - correlation, floor, 1.0)


def belief_settings_from_play(
    episodes: Sequence[np.ndarray],
    *,
    training_prior: float | Sequence[float] | np.ndarray = 0.5,
    switch_rates: bool = False,
    min_base_rate: float = 0.01,
    **settings: Any,
) -> BeliefSettings:
    """:class:`~noisybolt.bolt.BeliefSettings` with base rates estimated from play.

    Args:
        episodes: the detector's probabilities over unlabelled episodes of play, each
            float ``[T, n_fluents]`` in the bolt's fluent order.
        training_prior: each fluent's frequency in the detector's training set.
        switch_rates: estimate the switch rates too (:func:`estimate_switch_rates`);
            False keeps the settings' (measured on the gridworld, the estimated rates
            cost recall of short visits, see ``benchmarks/README.md``).
        min_base_rate: the least base rate given to any fluent. EM puts at 0 what the
            play frames never show (a brick random play never reaches) or, for a
            classifier surer of its negatives than of anything else, what it cannot see
            clearly; at 0 the bolt would never believe the event, however clearly a
            trained agent later shows it. 0.01 kept every measured false acceptance of
            belief tracking at or under 5 % (``benchmarks/belief_tracking.py``).
        settings: any other :class:`~noisybolt.bolt.BeliefSettings` field.

    Raises:
        ValueError: no frames; BaseRateError, ConfigError: bad settings.

    Example:
        >>> frames = [np.array([[0.9], [0.1], [0.1], [0.1]])]
        >>> belief_settings_from_play(frames, monotone=("x",)).monotone
        ('x',)
    """
    frames = np.concatenate([_probs(e) for e in episodes])
    prior = np.broadcast_to(np.asarray(training_prior, dtype=np.float64), (frames.shape[1],))
    if not 0.0 <= min_base_rate <= 1.0:
        raise BaseRateError(f"min_base_rate must lie in [0, 1], got {min_base_rate!r}")
    estimate = estimate_base_rates(frames, training_prior=prior)
    rates = np.maximum(estimate.rates, min_base_rate)
    extra: dict[str, Any] = {}
    if switch_rates:
        extra["switch_rate"] = tuple(float(r) for r in estimate_switch_rates(episodes))
    return BeliefSettings(
        base_rates=tuple(float(r) for r in rates),
        training_prior=tuple(float(p) for p in prior),
        **{**extra, **settings},
    )
