"""Labelled bolt images: collecting them from a world (and, re-exported here, the dataset,
its file and its label counts).

:func:`collect_samples` gathers a :class:`~noisybolt.perception.fluent_dataset.FluentDataset`
from any world meeting :class:`~noisybolt.perception.protocols.BoltObservable`: it
explores with random actions and, where the world offers it
(:class:`SupportsCollectionStates`), with scripted jumps to diverse states, then picks a
subset balanced between positives and negatives of every fluent as far as the pool allows
(:func:`balanced_subset`). Random play keeps the state each step reaches and, for an
episode the step ends, its last state too (read from the step's ``final_info``: a vector
world has already moved on to the next episode), so that a fluent true only as an
episode ends (a goal reached, a hole fallen in) is shown to the classifier.

The dataset and its file format (:func:`save_dataset`, :func:`load_dataset`) are
:mod:`noisybolt.perception.fluent_dataset`'s; how often it shows each fluent, and the
refusal of images a spec's fluent is never true or never false in,
:mod:`noisybolt.perception.label_counts`'s. This module names them all.

Example:
    >>> labels = np.array([[True]] * 2 + [[False]] * 6)
    >>> picked = balanced_subset(labels, 4, np.random.default_rng(0))
    >>> int(labels[picked].sum()), len(picked)
    (2, 4)
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any, Protocol, runtime_checkable

import numpy as np
from tqdm.auto import tqdm

from noisybolt.errors import ConfigError, UnlabelledEnvError
from noisybolt.perception.fluent_dataset import (
    DATASET_FORMAT,
    DATASET_VERSION,
    DatasetSplit,
    FluentDataset,
    load_dataset,
    save_dataset,
)
from noisybolt.perception.label_counts import (
    RARE_FLUENT_IMAGES,
    LabelCounts,
    check_fluents_shown,
    refuse_unseen,
)
from noisybolt.perception.protocols import (
    BOLT_IMAGE_KEY,
    FINAL_INFO_KEY,
    TRUE_FLUENTS_KEY,
    BoltObservable,
    CameraSpec,
)

__all__ = [
    "DATASET_FORMAT",
    "DATASET_VERSION",
    "RARE_FLUENT_IMAGES",
    "DatasetSplit",
    "FluentDataset",
    "LabelCounts",
    "SupportsCollectionStates",
    "balanced_subset",
    "check_fluents_shown",
    "collect_samples",
    "load_dataset",
    "refuse_unseen",
    "save_dataset",
]


@runtime_checkable
class SupportsCollectionStates(Protocol):
    """A world that can jump every environment to a fresh, diverse state (scripted exploration).

    Random play rarely reaches some fluents (Breakout's cleared left column, a grid
    corner); a world that implements this lets collection visit them on purpose. After the
    call, ``bolt_images()`` and ``true_fluents()`` must describe the new states; the
    agent's observation may be stale until the next ``step``.
    """

    def sample_collection_states(self, rng: np.random.Generator) -> None:
        """Moves each environment of the batch to a state drawn with ``rng``."""
        ...


def balanced_subset(
    labels: np.ndarray, size: int, rng: np.random.Generator, *, rounds: int = 64
) -> np.ndarray:
    """Indices of ``size`` rows of ``labels`` balancing positives and negatives per fluent.

    Greedy: in each of about ``rounds`` rounds it takes the rows that fill the largest
    summed *deficit* (how far each fluent's positive or negative count still is from
    ``size / 2``, for the row's value of that fluent), ties broken at random. A fluent
    with few positives in the pool gets all of them; one that is true in most states gets
    as many negatives as exist. Exact balance is often impossible (exclusive fluents such
    as headings cannot all be true half the time), hence "as far as possible".

    Args:
        labels: bool ``[m, k]`` labels of the pool.
        size: how many rows to pick (``<= m``).
        rng: the generator for tie-breaking.
        rounds: how many times the deficits are recomputed.

    Returns:
        int64 ``[size]`` distinct row indices, in the order picked.
    """
    labels = np.asarray(labels, dtype=bool)
    m, k = labels.shape
    if not 0 <= size <= m:
        raise ValueError(f"cannot pick {size} rows from a pool of {m}")
    target = max(size / 2.0, 1.0)
    counts = np.zeros((k, 2))  # [fluent, value]: picked so far
    value_index = labels.astype(np.int64)
    available = np.ones(m, dtype=bool)
    jitter = rng.random(m) * 1e-6  # tie-break only: smaller than any deficit step
    chunk = max(1, math.ceil(size / rounds))
    picked: list[np.ndarray] = []
    n_picked = 0
    while n_picked < size:
        deficit = np.clip(target - counts, 0.0, None) / target  # [k, 2]
        score = deficit[np.arange(k), value_index].sum(axis=1) + jitter  # [m]
        score[~available] = -np.inf
        take = min(chunk, size - n_picked)
        best = np.argpartition(-score, take - 1)[:take]
        best = best[np.argsort(-score[best], kind="stable")]
        available[best] = False
        np.add.at(counts, (np.arange(k)[None, :], value_index[best]), 1.0)
        picked.append(best)
        n_picked += take
    return np.concatenate(picked) if picked else np.zeros(0, dtype=np.int64)


def _random_actions(world: Any, rng: np.random.Generator) -> np.ndarray:
    space = world.single_action_space
    n = world.num_envs
    if hasattr(space, "n") and hasattr(space, "start"):  # Discrete
        return rng.integers(int(space.start), int(space.start) + int(space.n), size=n)
    space = world.action_space
    space.seed(int(rng.integers(2**31)))
    return np.asarray(space.sample())


def _last_views(
    info: Any, ended: np.ndarray, *, n_envs: int, n_fluents: int, spec: CameraSpec
) -> tuple[np.ndarray, np.ndarray]:
    """The bolt images ``[e, H, W, C]`` and true fluents ``[e, k]`` of the states that the
    episodes of the ``ended`` rows reached, from a step's ``info["final_info"]`` (the
    world–bolt contract, :mod:`noisybolt.perception.protocols`).

    Raises:
        UnlabelledEnvError: ``final_info`` or one of its keys is missing for an ended row.
        ValueError: the images or fluents have the wrong shape or type.
    """
    final = info.get(FINAL_INFO_KEY) if isinstance(info, Mapping) else None
    if not isinstance(final, Mapping):
        final = {}
    for key in (BOLT_IMAGE_KEY, TRUE_FLUENTS_KEY):
        mask = final.get(f"_{key}")
        if key not in final or mask is None or not np.all(np.asarray(mask)[ended]):
            raise UnlabelledEnvError(
                f"the world's step ended episodes in rows {ended.tolist()} but its info has no "
                f"info[{FINAL_INFO_KEY!r}][{key!r}] for them: a vector world must put the ended "
                "episodes' last labels there (noisybolt.perception.protocols), or collect "
                "without them (final_views=False; detector.final_views=false for a run)"
            )
    images = np.asarray(final[BOLT_IMAGE_KEY])
    truth = np.asarray(final[TRUE_FLUENTS_KEY], dtype=bool)
    if images.shape != (n_envs, *spec.shape) or images.dtype != np.uint8:
        raise ValueError(
            f"info[{FINAL_INFO_KEY!r}][{BOLT_IMAGE_KEY!r}] is {images.dtype} {images.shape}, "
            f"expected uint8 {(n_envs, *spec.shape)} from the world's camera spec"
        )
    if truth.shape != (n_envs, n_fluents):
        raise ValueError(
            f"info[{FINAL_INFO_KEY!r}][{TRUE_FLUENTS_KEY!r}] has shape {truth.shape}, "
            f"expected {(n_envs, n_fluents)}"
        )
    return images[ended], truth[ended]


def _gather(batches: list[np.ndarray], rows: np.ndarray) -> np.ndarray:
    """``np.concatenate(batches)[rows]`` for sorted ``rows``, without the concatenated
    copy of every batch (the pool's images are most of collection's memory)."""
    offsets = np.cumsum([0, *(len(batch) for batch in batches)])
    which = np.searchsorted(offsets, rows, side="right") - 1
    # rows are sorted, so the parts come in their order
    parts = [batches[b][rows[which == b] - offsets[b]] for b in np.unique(which)]
    return np.concatenate(parts) if parts else batches[0][:0]


def collect_samples(
    world: BoltObservable,
    *,
    num_samples: int,
    seed: int,
    oversample: float = 2.0,
    scripted_fraction: float = 0.5,
    final_views: bool = True,
    progress: bool = False,
) -> FluentDataset:
    """Collects a balanced labelled dataset of bolt images from ``world``.

    The world is reset with ``seed``; then, for ``ceil(oversample * num_samples /
    num_envs)`` rounds, each round either steps every environment with uniformly random
    actions or (with probability ``scripted_fraction``, if the world implements
    :class:`SupportsCollectionStates`) jumps to scripted diverse states, recording the
    bolt's images and the true fluents. With ``final_views``, a random step that ends
    episodes also records the last state of each, from the step's ``info["final_info"]``:
    the world resets an ended episode in the same step, so what it shows after the step
    is the next episode's first state, and a fluent true only as an episode ends would
    never be recorded. The pool, ``oversample * num_samples`` images and one more per
    episode ended, is kept in collection order; :func:`balanced_subset` picks
    ``num_samples`` of it. The world is left in whatever state collection reached.

    Args:
        world: a vectorised world meeting ``BoltObservable`` with a Gymnasium vector API
            (``reset(seed=)``, ``step(actions)`` returning ``(obs, rewards, terminated,
            truncated, info)``, ``single_action_space``).
        num_samples: the dataset size.
        seed: seeds the world's reset, the exploration and the subset choice.
        oversample: the pool is this many times ``num_samples`` (>= 1), besides the ended
            episodes' last states; more means better balance and more memory.
        scripted_fraction: share of rounds spent on scripted states when available.
        final_views: record the ended episodes' last states too. False collects as
            noisybolt did before they were (the classifiers of runs saved then were
            trained so): the same images from the same seed.
        progress: show a tqdm progress bar.

    Returns:
        The dataset (its ``metadata`` records how it was collected, the pool's positive
        counts and how many of the pool's images are ended episodes' last states).

    Raises:
        ConfigError: on a non-positive ``num_samples``, ``oversample < 1`` or a
            ``scripted_fraction`` outside [0, 1].
        UnlabelledEnvError: with ``final_views``, a step ended episodes but its info has
            no ``final_info`` labels for them.
    """
    if num_samples < 1:
        raise ConfigError(f"num_samples must be >= 1, got {num_samples}")
    if oversample < 1.0:
        raise ConfigError(f"oversample must be >= 1, got {oversample}")
    if not 0.0 <= scripted_fraction <= 1.0:
        raise ConfigError(f"scripted_fraction must be in [0, 1], got {scripted_fraction}")
    rng = np.random.default_rng(seed)
    pool_size = math.ceil(num_samples * oversample)
    spec = world.camera_spec
    names = tuple(world.fluent_names)
    n_envs = world.num_envs
    rounds = math.ceil(pool_size / n_envs)
    # Batches in collection order: how many images the ended episodes add is not known
    # in advance, and only the chosen ones are copied out at the end.
    images: list[np.ndarray] = []
    labels: list[np.ndarray] = []
    scripted = isinstance(world, SupportsCollectionStates)
    world.reset(seed=seed)  # type: ignore[attr-defined]
    n_scripted = 0
    n_final = 0
    for _ in tqdm(range(rounds), desc="collect", unit="round", disable=not progress):
        if scripted and rng.random() < scripted_fraction:
            world.sample_collection_states(rng)  # type: ignore[attr-defined]
            n_scripted += 1
        elif not final_views:
            world.step(_random_actions(world, rng))  # type: ignore[attr-defined]
        else:
            step = world.step(_random_actions(world, rng))  # type: ignore[attr-defined]
            _, _, terminated, truncated, info = step
            ended = np.flatnonzero(np.logical_or(terminated, truncated))
            if ended.size:
                last_images, last_truth = _last_views(
                    info, ended, n_envs=n_envs, n_fluents=len(names), spec=spec
                )
                images.append(last_images)
                labels.append(last_truth)
                n_final += int(ended.size)
        batch = world.bolt_images()
        truth = world.true_fluents()
        if batch.shape != (n_envs, *spec.shape) or batch.dtype != np.uint8:
            raise ValueError(
                f"world.bolt_images() gave {batch.dtype} {batch.shape}, expected uint8 "
                f"{(n_envs, *spec.shape)} from its camera spec"
            )
        images.append(np.array(batch, copy=True))  # the world may reuse its buffer
        labels.append(np.array(truth, dtype=bool, copy=True))
    pool_labels = np.concatenate(labels)
    pool_positives = pool_labels.sum(axis=0)
    chosen = balanced_subset(pool_labels, num_samples, rng)
    chosen.sort()  # keep collection order: neighbouring samples stay neighbours
    metadata = {
        "collector": "noisybolt.perception.dataset.collect_samples",
        "oversample": oversample,
        "scripted_fraction": scripted_fraction if scripted else 0.0,
        "rounds": rounds,
        "scripted_rounds": n_scripted,
        "num_envs": n_envs,
        "final_views": final_views,
        "final_view_images": n_final,
        "pool_size": int(pool_labels.shape[0]),
        "pool_positives": {n: int(c) for n, c in zip(names, pool_positives, strict=True)},
    }
    return FluentDataset(
        images=_gather(images, chosen),
        labels=pool_labels[chosen],
        fluent_names=names,
        camera_spec=spec,
        seed=seed,
        metadata=metadata,
    )
