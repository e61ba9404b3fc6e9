"""A detector's error model: its confusion per fluent and confidence band, measured.

The compliance estimate (:mod:`noisybolt.bolt.compliance`) weighs each frame by how the
detector's bands behaved on labelled images it never learnt from. A classifier trained by
:func:`~noisybolt.perception.training.train_classifier` records that model, measured on
its held-out validation part, in its ``training`` notes under :data:`ERROR_MODEL_NOTE`
(beside its validation accuracy); a classifier file saved before it did, or a user's
detector, is measured on labelled images the caller gives (:func:`error_model_of`).

Example:
    >>> import numpy as np
    >>> probs = np.array([[0.95], [0.7], [0.3], [0.05]])
    >>> truth = np.array([[True], [True], [False], [False]])
    >>> model = measure_error_model(probs, truth, fluent_names=("x",))
    >>> model.counts.tolist()  # bands p < 0.1, < 0.5, < 0.9, >= 0.9; false then true
    [[[1.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 1.0]]]
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Protocol

import numpy as np

from noisybolt.bolt.compliance import DEFAULT_EDGES, ErrorModel
from noisybolt.errors import ConfigError, MissingErrorModelError
from noisybolt.perception.protocols import FluentDetector

__all__ = [
    "ERROR_MODEL_NOTE",
    "LabelledImages",
    "error_model_of",
    "measure_error_model",
    "recorded_error_model",
]

#: Where a classifier's ``training`` notes keep its error model (a dict of
#: :meth:`ErrorModel.to_dict`).
ERROR_MODEL_NOTE = "error_model"


class LabelledImages(Protocol):
    """Bolt images with their true fluents (a :class:`~noisybolt.perception.dataset.
    FluentDataset` is one)."""

    @property
    def images(self) -> np.ndarray:
        """uint8 ``[n, H, W, C]``."""
        ...

    @property
    def labels(self) -> np.ndarray:
        """bool ``[n, n_fluents]``."""
        ...

    @property
    def fluent_names(self) -> tuple[str, ...]:
        """The labels' columns."""
        ...


def measure_error_model(
    probs: np.ndarray,
    truth: np.ndarray,
    *,
    fluent_names: Sequence[str],
    edges: Sequence[float] = DEFAULT_EDGES,
    pseudo_count: float = 0.5,
) -> ErrorModel:
    """Counts each fluent's bands on labelled images.

    Args:
        probs: float ``[n, k]``: the detector's probabilities of the images.
        truth: bool ``[n, k]``: their true fluents.
        fluent_names: the ``k`` columns.
        edges: the band edges.
        pseudo_count: the Dirichlet prior's count per cell.

    Raises:
        ConfigError: shapes that differ.
    """
    probs = np.asarray(probs, dtype=np.float64)
    truth = np.asarray(truth, dtype=bool)
    names = tuple(fluent_names)
    if probs.ndim != 2 or probs.shape != truth.shape or probs.shape[1] != len(names):
        raise ConfigError(
            f"probs {probs.shape} and truth {truth.shape} must both be [n, {len(names)}]"
        )
    bands = np.searchsorted(np.array(edges, dtype=np.float64), probs, side="right")
    n_bands = len(edges) + 1
    counts = np.zeros((len(names), 2, n_bands))
    for f in range(len(names)):
        for t in (0, 1):
            counts[f, t] = np.bincount(bands[truth[:, f] == bool(t), f], minlength=n_bands)
    return ErrorModel(
        fluent_names=names, edges=tuple(edges), counts=counts, pseudo_count=pseudo_count
    )


def recorded_error_model(detector: object) -> ErrorModel | None:
    """The error model a classifier's training notes hold, or None (a file saved before
    they held one, or a detector without notes)."""
    notes = getattr(detector, "training", None)
    if not isinstance(notes, dict) or ERROR_MODEL_NOTE not in notes:
        return None
    return ErrorModel.from_dict(notes[ERROR_MODEL_NOTE])


def error_model_of(
    detector: FluentDetector,
    *,
    labelled: LabelledImages | None = None,
    edges: Sequence[float] = DEFAULT_EDGES,
) -> ErrorModel:
    """The detector's error model: measured on ``labelled`` when given, else the one it
    recorded when trained.

    Raises:
        MissingErrorModelError: neither (say what to give).
        UnknownFluentError: ``labelled`` lacks some of the detector's fluents.
    """
    if labelled is not None:
        names = tuple(detector.fluent_names)
        columns = _columns(tuple(labelled.fluent_names), names)
        truth = np.asarray(labelled.labels, dtype=bool)[:, columns]
        probs = detector.predict(
            np.asarray(labelled.images), truth=truth if detector.needs_truth else None
        )
        return measure_error_model(probs, truth, fluent_names=names, edges=edges)
    recorded = recorded_error_model(detector)
    if recorded is not None:
        return recorded
    raise MissingErrorModelError(
        f"the detector {type(detector).__name__} (fluents {list(detector.fluent_names)}) has "
        "no measured error rates: a classifier trained by this version of noisybolt records "
        "them on its held-out images; for another detector (or a classifier file saved "
        "before), give labelled images it did not learn from (error_model_of(detector, "
        "labelled=FluentDataset(...)); `noisybolt evaluate` collects them from the world "
        "unless --no-ground-truth is given with no --labelled set)"
    )


def _columns(have: tuple[str, ...], want: tuple[str, ...]) -> list[int]:
    from noisybolt.errors import UnknownFluentError

    missing = tuple(f for f in want if f not in have)
    if missing:
        raise UnknownFluentError(
            f"the labelled images lack labels of {list(missing)}: label every fluent the "
            f"detector predicts ({list(want)})",
            unknown=missing,
            known=have,
        )
    return [have.index(f) for f in want]
