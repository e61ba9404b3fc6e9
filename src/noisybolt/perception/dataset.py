"""Labelled bolt images: collecting them from a world, and saving them to one file.

A :class:`FluentDataset` holds uint8 images ``[n, H, W, C]`` from a bolt camera, their
ground-truth fluents ``[n, k]``, the fluent names and the :class:`CameraSpec` they came
from. :func:`collect_samples` gathers one from any world meeting
:class:`~noisybolt.perception.protocols.BoltObservable`: it explores with random actions
and, where the world offers it (:class:`SupportsCollectionStates`), with scripted jumps to
diverse states, then picks a subset balanced between positives and negatives of every
fluent as far as the pool allows. Random play keeps the state each step reaches and, for
an episode the step ends, its last state too (read from the step's ``final_info``: a
vector world has already moved on to the next episode), so that a fluent true only as an
episode ends (a goal reached, a hole fallen in) is shown to the classifier.

File format (``.npz``, zip-deflated, written atomically): ``images`` (uint8 ``[n,H,W,C]``),
``labels`` (bool ``[n,k]``) and ``header``, the UTF-8 bytes (uint8 array) of a JSON object
with ``format`` (``"noisybolt.fluent_dataset"``), ``version`` (1), ``fluent_names``,
``camera_spec``, ``seed`` and ``metadata``. Nothing is pickled.

Example:
    >>> import numpy as np, tempfile, pathlib
    >>> from noisybolt.perception.protocols import CameraSpec
    >>> data = FluentDataset(
    ...     images=np.zeros((2, 4, 4, 3), np.uint8), labels=np.array([[True], [False]]),
    ...     fluent_names=("t",), camera_spec=CameraSpec("toy", 4, 4))
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "d.npz"
    >>> save_dataset(data, path)
    >>> load_dataset(path).labels[:, 0].tolist()
    [True, False]
"""

from __future__ import annotations

import io
import json
import math
import warnings
import zipfile
import zlib
from collections.abc import Collection, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, NamedTuple, Protocol, runtime_checkable

import numpy as np
from tqdm.auto import tqdm

from noisybolt.errors import (
    ConfigError,
    CorruptFileError,
    RareFluentWarning,
    UnknownFluentError,
    UnlabelledEnvError,
    UnseenFluentError,
)
from noisybolt.io import atomic_write_bytes
from noisybolt.perception.compat import (
    camera_spec_from_dict,
    camera_spec_to_dict,
    check_compatible,
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

DATASET_FORMAT = "noisybolt.fluent_dataset"
DATASET_VERSION = 1


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


class LabelCounts(NamedTuple):
    """How many images a dataset holds and in how many of them each fluent is true.

    A classifier saves them with its ``training`` notes
    (:func:`noisybolt.perception.training.train_classifier`), so that a cached one can be
    checked, when used again, for fluents it never saw true or never saw false.
    """

    images: int
    positives: dict[str, int]

    @classmethod
    def of(cls, dataset: FluentDataset) -> LabelCounts:
        """The counts of ``dataset``."""
        return cls(images=len(dataset), positives=dataset.positives)

    def negatives(self, fluent: str) -> int:
        """Images in which ``fluent`` was false."""
        return self.images - self.positives[fluent]

    def to_dict(self) -> dict[str, Any]:
        """The JSON-able form kept in a classifier's ``training`` notes."""
        return {"images": self.images, "positives": dict(self.positives)}

    @classmethod
    def from_dict(cls, data: Any, fluent_names: Sequence[str]) -> LabelCounts | None:
        """The counts :meth:`to_dict` wrote for ``fluent_names``; None where ``data`` is
        not such a form (absent from a file written before the counts were saved)."""
        if not isinstance(data, dict):
            return None
        images, positives = data.get("images"), data.get("positives")
        if (
            not isinstance(images, int)
            or not isinstance(positives, dict)
            or set(positives) != set(fluent_names)
            or not all(isinstance(n, int) and 0 <= n <= images for n in positives.values())
        ):
            return None
        return cls(images=images, positives={name: positives[name] for name in fluent_names})


#: A fluent some spec uses that is true, or false, in fewer than this many of the images a
#: classifier learns from gets a :class:`~noisybolt.errors.RareFluentWarning`. Why 20: a
#: fifth of them are its validation part (``TrainingConfig.validation_fraction``), so
#: fewer leave about four or fewer there, and the validation table's accuracy and AUROC
#: for the fluent rest on a handful of images; the held-out accuracy that restarts compare
#: counts both values alike, so a classifier that reads 10 positives in 4,000 images all
#: as false still scores 0.9975 on that fluent.
RARE_FLUENT_IMAGES = 20


def check_fluents_shown(
    counts: LabelCounts,
    spec_fluents: Collection[str],
    *,
    source: str,
    what_to_do: str,
    if_rare: str,
) -> None:
    """Refuses images to learn a classifier from in which a fluent some spec uses is never
    true, or never false; warns where it is true or false in only a few of them.

    Args:
        counts: the images and each fluent's positives among them.
        spec_fluents: the fluents the run's specs depend on; no other is checked (a world
            may name fluents its specs do not need).
        source: what the images are, for the messages ("the 4,000 images collected ...").
        what_to_do: the refusal's advice, in the caller's terms (command-line options or
            keyword arguments).
        if_rare: the warning's advice, likewise.

    Raises:
        UnseenFluentError: naming every such fluent, the images and what to do.

    Warns:
        RareFluentWarning: a spec's fluent true, or false, in fewer than
            :data:`RARE_FLUENT_IMAGES` of the images.

    Example:
        >>> counts = LabelCounts(images=800, positives={"has_key": 401, "at_goal": 0})
        >>> advice = {"what_to_do": "Collect more.", "if_rare": "collect more"}
        >>> check_fluents_shown(counts, ["has_key"], source="the images", **advice)
        >>> check_fluents_shown(counts, ["at_goal"], source="the images", **advice)
        Traceback (most recent call last):
        ...
        noisybolt.errors.UnseenFluentError: the images never show 'at_goal' true, and a spec ...
    """
    refuse_unseen(counts, spec_fluents, source=source, what_to_do=what_to_do)
    rare = [
        name
        for name in spec_fluents
        if min(counts.positives[name], counts.negatives(name)) < RARE_FLUENT_IMAGES
    ]
    if rare:
        shown = ", ".join(
            f"{name!r} true in {counts.positives[name]:,} and false in {counts.negatives(name):,}"
            for name in rare
        )
        warnings.warn(
            f"{source} show {shown}: fewer than {RARE_FLUENT_IMAGES} of one value, so the "
            "classifier's accuracy on it rests on a handful of images and the bolt may "
            f"misread it; {if_rare}",
            RareFluentWarning,
            stacklevel=2,
        )


def refuse_unseen(
    counts: LabelCounts, spec_fluents: Collection[str], *, source: str, what_to_do: str
) -> None:
    """The refusal of :func:`check_fluents_shown` alone (no warning), for images collected
    before a classifier is chosen: its warnings wait for the classifier kept."""
    unknown = tuple(name for name in spec_fluents if name not in counts.positives)
    if unknown:
        raise UnknownFluentError(
            f"spec fluent(s) {list(unknown)} are not among the classifier's "
            f"{sorted(counts.positives)}",
            unknown=unknown,
            known=tuple(counts.positives),
        )
    unseen = {
        name: "true" if counts.positives[name] == 0 else "false"
        for name in spec_fluents
        if counts.positives[name] == 0 or counts.negatives(name) == 0
    }
    if not unseen:
        return
    one = len(unseen) == 1
    them, they = ("it", "it holds") if one else ("them", "they hold")
    raise UnseenFluentError(
        f"{source} never show "
        + " or ".join(f"{name!r} {value}" for name, value in unseen.items())
        + f", and a spec uses {them}: the classifier could not learn to tell when {they}, "
        f"so the bolt would read {them} the same whatever the agent does and the spec "
        f"could not steer it. {what_to_do}",
        fluents=tuple(unseen),
        images=counts.images,
    )


class DatasetSplit(NamedTuple):
    """A dataset cut in two disjoint parts."""

    train: FluentDataset
    validation: FluentDataset


@dataclass(frozen=True, eq=False)
class FluentDataset:
    """Bolt images with their ground-truth fluents.

    Attributes:
        images: uint8 ``[n, H, W, C]`` bolt images (noise included).
        labels: bool ``[n, k]`` ground-truth fluents.
        fluent_names: the ``k`` fluent names, in column order.
        camera_spec: the camera the images come from; ``(H, W, C)`` must match its shape.
        seed: the seed the samples were collected with, if known.
        metadata: JSON-able notes on how the dataset was made.
    """

    images: np.ndarray
    labels: np.ndarray
    fluent_names: tuple[str, ...]
    camera_spec: CameraSpec
    seed: int | None = None
    metadata: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        object.__setattr__(self, "fluent_names", tuple(self.fluent_names))
        images, labels = self.images, self.labels
        if not isinstance(images, np.ndarray) or images.dtype != np.uint8 or images.ndim != 4:
            raise ValueError("images must be a uint8 array [n, H, W, C]")
        if not isinstance(labels, np.ndarray) or labels.dtype != np.bool_ or labels.ndim != 2:
            raise ValueError("labels must be a bool array [n, k]")
        if labels.shape[0] != images.shape[0]:
            raise ValueError(f"{images.shape[0]} images but {labels.shape[0]} label rows")
        if labels.shape[1] != len(self.fluent_names):
            raise ValueError(
                f"labels have {labels.shape[1]} columns for {len(self.fluent_names)} fluents"
            )
        if len(set(self.fluent_names)) != len(self.fluent_names):
            raise ValueError(f"fluent names repeat: {self.fluent_names}")
        if images.shape[1:] != self.camera_spec.shape:
            raise ValueError(
                f"images are {images.shape[1:]} but the camera spec says {self.camera_spec.shape}"
            )

    def __len__(self) -> int:
        return int(self.images.shape[0])

    @property
    def positives(self) -> dict[str, int]:
        """Number of positive samples of each fluent."""
        counts = self.labels.sum(axis=0)
        return {name: int(c) for name, c in zip(self.fluent_names, counts, strict=True)}

    def subset(self, indices: np.ndarray) -> FluentDataset:
        """The samples at ``indices`` (same names, camera, seed and metadata)."""
        return FluentDataset(
            images=self.images[indices],
            labels=self.labels[indices],
            fluent_names=self.fluent_names,
            camera_spec=self.camera_spec,
            seed=self.seed,
            metadata=dict(self.metadata),
        )

    def split(self, validation_fraction: float, *, seed: int) -> DatasetSplit:
        """A seeded random split into training and validation parts.

        Raises:
            ConfigError: if ``validation_fraction`` is not in (0, 1) or a part is empty.
        """
        if not 0.0 < validation_fraction < 1.0:
            raise ConfigError(f"validation_fraction must be in (0, 1), got {validation_fraction}")
        n_val = round(len(self) * validation_fraction)
        if n_val < 1 or n_val >= len(self):
            raise ConfigError(
                f"a validation fraction of {validation_fraction} leaves an empty part of "
                f"{len(self)} samples; collect more samples"
            )
        order = np.random.default_rng(seed).permutation(len(self))
        return DatasetSplit(self.subset(order[n_val:]), self.subset(order[:n_val]))

    def check_compatible(
        self, *, fluent_names: Sequence[str], camera_spec: CameraSpec, what: str = "dataset"
    ) -> None:
        """Raises :class:`~noisybolt.errors.IncompatibleError` unless made for this world."""
        check_compatible(
            what,
            fluent_names=self.fluent_names,
            camera_spec=self.camera_spec,
            expected_fluents=fluent_names,
            expected_camera=camera_spec,
        )


def save_dataset(dataset: FluentDataset, path: str | Path) -> None:
    """Writes ``dataset`` to ``path`` as a compressed ``.npz``, atomically.

    Example: see the module docstring.
    """
    header = {
        "format": DATASET_FORMAT,
        "version": DATASET_VERSION,
        "fluent_names": list(dataset.fluent_names),
        "camera_spec": camera_spec_to_dict(dataset.camera_spec),
        "seed": dataset.seed,
        "metadata": dataset.metadata,
        "n_samples": len(dataset),
    }
    header_bytes = np.frombuffer(json.dumps(header, sort_keys=True).encode("utf-8"), np.uint8)
    buffer = io.BytesIO()
    np.savez_compressed(buffer, images=dataset.images, labels=dataset.labels, header=header_bytes)
    atomic_write_bytes(path, buffer.getvalue())


def load_dataset(
    path: str | Path,
    *,
    world: BoltObservable | None = None,
    fluent_names: Sequence[str] | None = None,
    camera_spec: CameraSpec | None = None,
) -> FluentDataset:
    """Reads a dataset written by :func:`save_dataset`.

    Args:
        path: the ``.npz`` file.
        world: the world it will be used with; the same as passing its ``fluent_names``
            and ``camera_spec``.
        fluent_names: if given with ``camera_spec``, the world's fluents: the dataset must
            have been collected for exactly these fluents and camera.
        camera_spec: the world's camera.

    Raises:
        FileNotFoundError: if there is no such file.
        CorruptFileError: if the file is truncated, corrupt or not a noisybolt dataset.
        IncompatibleError: if the dataset does not match the given fluents and camera.
    """
    if world is not None:
        if fluent_names is not None or camera_spec is not None:
            raise ValueError("give world, or fluent_names and camera_spec, not both")
        fluent_names, camera_spec = tuple(world.fluent_names), world.camera_spec
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"no dataset file at {path}")
    try:
        with np.load(path, allow_pickle=False) as archive:
            if set(archive.files) != {"images", "labels", "header"}:
                raise ValueError(f"unexpected members {sorted(archive.files)}")
            header = json.loads(archive["header"].tobytes().decode("utf-8"))
            images = archive["images"]
            labels = archive["labels"]
        if not isinstance(header, dict) or header.get("format") != DATASET_FORMAT:
            raise ValueError("not a noisybolt fluent dataset")
        if header.get("version") != DATASET_VERSION:
            raise ValueError(f"unsupported version {header.get('version')!r}")
        if header.get("n_samples") != images.shape[0]:
            raise ValueError(
                f"header says {header.get('n_samples')} samples, file has {images.shape[0]}"
            )
        dataset = FluentDataset(
            images=images,
            labels=labels,
            fluent_names=tuple(header["fluent_names"]),
            camera_spec=camera_spec_from_dict(header["camera_spec"]),
            seed=header["seed"],
            metadata=header["metadata"],
        )
    except (
        OSError,
        EOFError,
        ValueError,
        KeyError,
        TypeError,
        zipfile.BadZipFile,
        zlib.error,
        UnicodeDecodeError,
    ) as error:
        raise CorruptFileError(
            f"dataset file {path} is truncated or corrupt ({type(error).__name__}: {error}); "
            "collect it again (noisybolt classifiers collect)"
        ) from error
    if (fluent_names is None) != (camera_spec is None):
        raise ValueError("give both fluent_names and camera_spec, or neither")
    if fluent_names is not None and camera_spec is not None:
        dataset.check_compatible(
            fluent_names=fluent_names, camera_spec=camera_spec, what=f"dataset {path}"
        )
    return dataset


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
