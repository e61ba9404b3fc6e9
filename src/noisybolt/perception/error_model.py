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
from typing import Any, Protocol

import numpy as np

from noisybolt.bolt.compliance import DEFAULT_EDGES, ErrorModel
from noisybolt.errors import ConfigError, MissingErrorModelError
from noisybolt.perception.protocols import (
    BOLT_IMAGE_KEY,
    FINAL_INFO_KEY,
    TRUE_FLUENTS_KEY,
    FluentDetector,
)

__all__ = [
    "ERROR_MODEL_NOTE",
    "LabelledImages",
    "error_model_of",
    "measure_error_model",
    "record_labelled_play",
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
    sequences: Sequence[tuple[np.ndarray, np.ndarray]] = (),
) -> ErrorModel:
    """Counts each fluent's bands on labelled images (and on labelled episodes, successive
    frames' bands).

    Args:
        probs: float ``[n, k]``: the detector's probabilities of the images.
        truth: bool ``[n, k]``: their true fluents.
        fluent_names: the ``k`` columns.
        edges: the band edges.
        pseudo_count: the Dirichlet prior's count per cell.
        sequences: labelled episodes, each ``(probs [T, k], truth [T, k])`` in time order
            (:func:`record_labelled_play`): how the detector's band on one frame follows
            its band on the last, given the truth on both (a smudge that reads "maybe"
            reads it again on the next frame, whatever the truth); none: frames taken as
            independent given the truth.

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
    pairs = None
    if sequences:
        grid = np.array(edges, dtype=np.float64)
        pairs = np.zeros((len(names), 2, 2, n_bands, n_bands))
        fluent = np.arange(len(names))[None, :]
        for seq_probs, seq_truth in sequences:
            b = np.searchsorted(grid, np.asarray(seq_probs, dtype=np.float64), side="right")
            held = np.asarray(seq_truth, dtype=bool).astype(np.int64)
            if b.shape != held.shape or b.ndim != 2 or b.shape[1] != len(names):
                raise ConfigError(f"each sequence must be [T, {len(names)}] probs and truth")
            fl = np.broadcast_to(fluent, b[1:].shape)
            np.add.at(pairs, (fl, held[:-1], held[1:], b[:-1], b[1:]), 1.0)
    return ErrorModel(
        fluent_names=names,
        edges=tuple(edges),
        counts=counts,
        pseudo_count=pseudo_count,
        pair_counts=pairs,
    )


def record_labelled_play(
    world: Any, detector: FluentDetector, *, episodes: int, seed: int, max_frames: int = 100_000
) -> list[tuple[np.ndarray, np.ndarray]]:
    """Labelled episodes of seeded random play: every frame's detector probabilities and
    true fluents, in time order (what :func:`measure_error_model` counts successive
    frames on).

    Args:
        world: a labelled vector world (Gymnasium's vector API; its ``info`` carries the
            bolt's image and the true fluents, see :mod:`noisybolt.perception.protocols`)
            with a discrete action space.
        detector: the detector, its fluents in the world's order.
        episodes: how many episodes to record (fewer if ``max_frames`` runs out first).
        seed: seeds the world and the actions.
        max_frames: the most frames to play.

    Returns:
        ``[(probs float64 [T, k], truth bool [T, k]), ...]``.
    """
    rng = np.random.default_rng(seed)
    n_actions = int(world.single_action_space.n)
    n = int(world.num_envs)

    def look(images: Any, truth: np.ndarray) -> np.ndarray:
        out = detector.predict(np.asarray(images), truth=truth if detector.needs_truth else None)
        return np.asarray(out, dtype=np.float64)

    _, info = world.reset(seed=seed)
    truth = np.asarray(info[TRUE_FLUENTS_KEY], dtype=bool)
    probs = look(info[BOLT_IMAGE_KEY], truth)
    current: list[list[tuple[np.ndarray, np.ndarray]]] = [[(probs[i], truth[i])] for i in range(n)]
    done: list[tuple[np.ndarray, np.ndarray]] = []
    frames = n
    while len(done) < episodes and frames < max_frames:
        _, _, terminated, truncated, info = world.step(rng.integers(0, n_actions, size=n))
        ended = np.flatnonzero(np.asarray(terminated) | np.asarray(truncated))
        truth = np.asarray(info[TRUE_FLUENTS_KEY], dtype=bool)
        images = np.asarray(info[BOLT_IMAGE_KEY])
        last_truth = truth.copy()
        if ended.size:
            final = info[FINAL_INFO_KEY]
            last_truth[ended] = np.asarray(final[TRUE_FLUENTS_KEY], dtype=bool)[ended]
            images = np.concatenate([images, np.asarray(final[BOLT_IMAGE_KEY])[ended]])
        seen = look(images, np.concatenate([truth, last_truth[ended]]))
        probs, last = seen[:n], seen[:n].copy()
        last[ended] = seen[n:]
        frames += n
        for i in range(n):
            if i in ended:
                steps = [*current[i], (last[i], last_truth[i])]
                done.append((np.stack([p for p, _ in steps]), np.stack([t for _, t in steps])))
                current[i] = [(probs[i], truth[i])]
            else:
                current[i].append((probs[i], truth[i]))
    return done[:episodes]


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
    sequences: Sequence[tuple[np.ndarray, np.ndarray]] = (),
    edges: Sequence[float] | None = None,
) -> ErrorModel:
    """The detector's error model: measured on ``labelled`` images when given, else the
    one it recorded when trained, else measured on the frames of ``sequences``; with
    ``sequences`` (labelled episodes, :func:`record_labelled_play`), how successive
    frames' bands follow each other too.

    Raises:
        MissingErrorModelError: neither labelled images, nor a recorded model, nor
            labelled episodes (the message says what to give).
        UnknownFluentError: ``labelled`` lacks some of the detector's fluents.
    """
    names = tuple(detector.fluent_names)
    recorded = recorded_error_model(detector) if labelled is None else None
    if edges is None:
        edges = recorded.edges if recorded is not None else DEFAULT_EDGES
    if labelled is not None:
        columns = _columns(tuple(labelled.fluent_names), names)
        truth = np.asarray(labelled.labels, dtype=bool)[:, columns]
        probs = detector.predict(
            np.asarray(labelled.images), truth=truth if detector.needs_truth else None
        )
    elif recorded is not None:
        if not sequences:
            return recorded
        probs = truth = np.zeros((0, len(names)))
    elif sequences:
        probs = np.concatenate([p for p, _ in sequences])
        truth = np.concatenate([t for _, t in sequences])
    else:
        raise MissingErrorModelError(
            f"the detector {type(detector).__name__} (fluents {list(names)}) has no measured "
            "error rates: a classifier trained by this version of noisybolt records them on "
            "its held-out images; for another detector (or a classifier file saved before), "
            "give labelled images it did not learn from (error_model_of(detector, "
            "labelled=FluentDataset(...)), `noisybolt evaluate --labelled DATASET`) or "
            "labelled episodes (sequences=record_labelled_play(world, detector, ...))"
        )
    model = measure_error_model(probs, truth, fluent_names=names, edges=edges, sequences=sequences)
    if recorded is not None:  # the recorded confusion, with the episodes' successions
        return ErrorModel(
            fluent_names=names,
            edges=recorded.edges,
            counts=recorded.restrict(names).counts,
            pseudo_count=recorded.pseudo_count,
            pair_counts=model.pair_counts,
        )
    return model


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
