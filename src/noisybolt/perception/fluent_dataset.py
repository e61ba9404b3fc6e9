"""Labelled bolt images: :class:`FluentDataset`, and saving it to one file.

A :class:`FluentDataset` holds uint8 images ``[n, H, W, C]`` from a bolt camera, their
ground-truth fluents ``[n, k]``, the fluent names and the :class:`CameraSpec` they came
from (:func:`noisybolt.perception.dataset.collect_samples` gathers one from a world).

File format (``.npz``, zip-deflated, written atomically): ``images`` (uint8 ``[n,H,W,C]``),
``labels`` (bool ``[n,k]``) and ``header``, the UTF-8 bytes (uint8 array) of a JSON object
with ``format`` (``"noisybolt.fluent_dataset"``), ``version`` (1), ``fluent_names``,
``camera_spec``, ``seed`` and ``metadata``. Nothing is pickled.

Example:
    >>> import numpy as np, tempfile, pathlib
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
import zipfile
import zlib
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np

from noisybolt.errors import ConfigError, CorruptFileError
from noisybolt.io import atomic_write_bytes
from noisybolt.perception.compat import (
    camera_spec_from_dict,
    camera_spec_to_dict,
    check_compatible,
)
from noisybolt.perception.protocols import BoltObservable, CameraSpec

__all__ = [
    "DATASET_FORMAT",
    "DATASET_VERSION",
    "DatasetSplit",
    "FluentDataset",
    "load_dataset",
    "save_dataset",
]

DATASET_FORMAT = "noisybolt.fluent_dataset"
DATASET_VERSION = 1


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
