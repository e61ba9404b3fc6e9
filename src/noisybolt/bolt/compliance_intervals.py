"""A compliance rate with its intervals, from episodes' probabilities of compliance.

The rate is the mean of the episodes' probabilities. Its interval draws, many times:
error rates from their posterior (one draw of the episodes' probabilities), each
episode's truth from its probability under them, and Bayesian-bootstrap weights over the
episodes (Rubin 1981); the rate's quantiles give the interval for *the policy's*
compliance rate. Without the bootstrap they give one for the share of *these* episodes
that complied. See :mod:`noisybolt.bolt.compliance`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from noisybolt.errors import ConfigError

__all__ = ["ComplianceEstimate", "aggregate_compliance"]


@dataclass(frozen=True)
class ComplianceEstimate:
    """A spec's estimated compliance rate over a set of episodes, never ground truth.

    Attributes:
        rate: the mean of the episodes' probabilities of compliance.
        low: the interval's lower end, for the policy's compliance rate (sample and error
            model).
        high: its upper end.
        episodes_low: the lower end for the share of *these* episodes that complied
            (error model and the episodes' unknown truths; no resampling of episodes).
        episodes_high: its upper end.
        level: the intervals' probability (0.9).
        per_episode: float64 ``[n_episodes]``: each episode's ``P(complied | evidence)``.
    """

    rate: float
    low: float
    high: float
    episodes_low: float
    episodes_high: float
    level: float
    per_episode: np.ndarray = field(repr=False, compare=False)

    @property
    def n_episodes(self) -> int:
        """How many episodes it is over."""
        return int(self.per_episode.size)

    def to_dict(self, *, with_episodes: bool = False) -> dict[str, Any]:
        """A JSON-able dict (the episodes' probabilities only when asked)."""
        out: dict[str, Any] = {
            "rate": self.rate,
            "low": self.low,
            "high": self.high,
            "episodes_low": self.episodes_low,
            "episodes_high": self.episodes_high,
            "level": self.level,
            "n_episodes": self.n_episodes,
        }
        if with_episodes:
            out["per_episode"] = self.per_episode.tolist()
        return out


def aggregate_compliance(
    draws: np.ndarray,
    *,
    rng: np.random.Generator,
    level: float = 0.9,
    n_resamples: int = 4000,
) -> ComplianceEstimate:
    """The compliance rate and its intervals from per-draw episode probabilities.

    Args:
        draws: float ``[n_draws, n_episodes]``: each episode's probability of compliance
            under each draw of the error model.
        rng: seeds the resampling.
        level: the intervals' probability.
        n_resamples: draws of the rate.

    Example:
        >>> sure = np.ones((4, 100))  # every episode surely complied
        >>> e = aggregate_compliance(sure, rng=np.random.default_rng(0))
        >>> e.rate, e.episodes_low, e.episodes_high, e.high
        (1.0, 1.0, 1.0, 1.0)
    """
    draws = np.asarray(draws, dtype=np.float64)
    if draws.ndim != 2 or draws.shape[1] == 0:
        raise ConfigError(f"draws must be [n_draws, n_episodes >= 1], got {draws.shape}")
    if not 0 < level < 1:
        raise ConfigError(f"level must be in (0, 1), got {level}")
    n_draws, n = draws.shape
    which = rng.integers(0, n_draws, size=n_resamples)
    truth = rng.random((n_resamples, n)) < draws[which]  # each episode's truth, drawn
    weights = rng.dirichlet(np.ones(n), size=n_resamples)
    policy = np.clip((weights * truth).sum(axis=1), 0.0, 1.0)
    these = truth.mean(axis=1)
    tail = (1 - level) / 2
    per_episode = draws.mean(axis=0)
    rate = float(per_episode.mean())
    # The drawn truths are whole episodes: where every episode is all but sure, their
    # quantiles may sit a rounding error beyond the mean of the probabilities.
    return ComplianceEstimate(
        rate=rate,
        low=min(rate, float(np.quantile(policy, tail))),
        high=max(rate, float(np.quantile(policy, 1 - tail))),
        episodes_low=min(rate, float(np.quantile(these, tail))),
        episodes_high=max(rate, float(np.quantile(these, 1 - tail))),
        level=level,
        per_episode=per_episode,
    )
