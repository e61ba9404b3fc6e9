"""Reliability diagrams: how often what was called ``p`` likely really happened.

:func:`reliability_bins` groups predicted probabilities (a compliance estimate's
per-episode ``P(complied)``) into equal-width bins and counts how often the event really
happened in each; :func:`reliability_diagram` draws them, one line per group (a spec, a
camera), against the diagonal of perfect calibration, with the expected calibration
error in the legend. Drawn with matplotlib's Agg canvas, written atomically.

Example:
    >>> import numpy as np
    >>> bins = reliability_bins(np.array([0.1, 0.2, 0.8, 0.9]), np.array([0, 0, 1, 0]),
    ...                         n_bins=2)
    >>> bins.confidence.round(3).tolist(), bins.frequency.tolist(), bins.counts.tolist()
    ([0.15, 0.85], [0.0, 0.5], [2, 2])
"""

from __future__ import annotations

import io
from collections.abc import Mapping
from pathlib import Path
from typing import NamedTuple

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from noisybolt.errors import ConfigError
from noisybolt.io import atomic_write_bytes
from noisybolt.viz.episodes import DPI, PathLike

__all__ = ["ReliabilityBins", "reliability_bins", "reliability_diagram"]


class ReliabilityBins(NamedTuple):
    """Filled bins of a reliability diagram (empty bins left out).

    Attributes:
        confidence: float64 ``[n]``: the mean predicted probability in each bin.
        frequency: float64 ``[n]``: how often the event happened there.
        counts: int64 ``[n]``: predictions in each bin.
    """

    confidence: np.ndarray
    frequency: np.ndarray
    counts: np.ndarray


def reliability_bins(
    probs: np.ndarray, outcomes: np.ndarray, *, n_bins: int = 10
) -> ReliabilityBins:
    """Equal-width bins of ``probs`` (bin ``b`` holds ``b / n_bins <= p < (b + 1) /
    n_bins``, the last one 1 too), as :func:`~noisybolt.perception.metrics.
    expected_calibration_error` bins them.

    Raises:
        ConfigError: shapes that differ, or fewer than one bin.
    """
    probs = np.asarray(probs, dtype=np.float64).ravel()
    outcomes = np.asarray(outcomes, dtype=np.float64).ravel()
    if probs.shape != outcomes.shape or n_bins < 1:
        raise ConfigError(f"probs {probs.shape} and outcomes {outcomes.shape} must match")
    which = np.minimum((probs * n_bins).astype(np.int64), n_bins - 1)
    counts = np.bincount(which, minlength=n_bins)
    filled = counts > 0
    confidence = np.bincount(which, weights=probs, minlength=n_bins)[filled] / counts[filled]
    frequency = np.bincount(which, weights=outcomes, minlength=n_bins)[filled] / counts[filled]
    return ReliabilityBins(confidence, frequency, counts[filled])


def reliability_diagram(
    groups: Mapping[str, tuple[np.ndarray, np.ndarray]],
    path: PathLike,
    *,
    title: str = "compliance estimates: reliability",
    n_bins: int = 10,
) -> Path:
    """Draws one reliability line per group and writes the PNG to ``path``.

    Args:
        groups: label -> ``(probs, outcomes)``: predicted probabilities and what happened
            (bool or 0/1), e.g. per spec each episode's ``P(complied)`` and its truth.
        path: where to write the PNG.
        title: the figure's title.
        n_bins: equal-width bins.

    Returns:
        The path written.
    """
    fig = Figure(figsize=(5.0, 5.0))
    FigureCanvasAgg(fig)
    ax = fig.add_subplot(1, 1, 1)
    ax.plot([0, 1], [0, 1], color="0.6", linestyle="--", linewidth=1, label="calibrated")
    for label, (probs, outcomes) in groups.items():
        bins = reliability_bins(probs, outcomes, n_bins=n_bins)
        total = max(int(bins.counts.sum()), 1)
        ece = float(np.sum(bins.counts * np.abs(bins.frequency - bins.confidence)) / total)
        sizes = 15 + 150 * bins.counts / total
        line = ax.plot(bins.confidence, bins.frequency, linewidth=1.2)[0]
        ax.scatter(
            bins.confidence,
            bins.frequency,
            s=sizes,
            color=line.get_color(),
            label=f"{label} (n={total}, ECE {ece:.3f})",
        )
    ax.set_xlim(0, 1)
    ax.set_ylim(0, 1)
    ax.set_xlabel("estimated P(complied), bin mean")
    ax.set_ylabel("episodes that truly complied")
    ax.set_title(title, fontsize=10)
    ax.legend(fontsize=7, loc="upper left")
    fig.tight_layout()
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=DPI)
    out = Path(path)
    atomic_write_bytes(out, buffer.getvalue())
    return out
