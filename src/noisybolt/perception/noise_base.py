"""The noise model interface, and the pixel arithmetic its models share.

:class:`NoiseModel` is what every camera noise model is: a frozen description (its
parameters) with ``apply(images, rng)``, uint8 ``[n, H, W, C]`` in, a new uint8 array of
the same shape out, all randomness drawn from the generator passed in. Beside it, what
the models of :mod:`noisybolt.perception.noise` and
:mod:`noisybolt.perception.noise_regional` compute with: checks of their parameters and
input, Gaussian draws by table lookup (:func:`standard_normal`), rounding back to uint8
and Gaussian blur matrices.

Example:
    >>> import numpy as np
    >>> values = np.array([-3.0, 0.4, 0.5, 254.6, 300.0], np.float32)
    >>> to_uint8(values).tolist()
    [0, 0, 1, 255, 255]
    >>> standard_normal(np.random.default_rng(0), (2, 3)).shape
    (2, 3)
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from collections.abc import Sequence
from dataclasses import fields
from functools import lru_cache
from statistics import NormalDist
from typing import Any, ClassVar

import numpy as np

from noisybolt.errors import ConfigError

__all__ = [
    "NoiseModel",
    "blur_matrix",
    "check_generators",
    "check_images",
    "checked_integer",
    "checked_number",
    "gaussian_blur",
    "rounded_quantiles",
    "scaled_quantiles",
    "standard_normal",
    "to_uint8",
    "uniform16",
]


class NoiseModel(ABC):
    """A seeded, vectorised image corruption. Subclasses are frozen dataclasses."""

    #: The registry name.
    name: ClassVar[str]

    @abstractmethod
    def apply(self, images: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """Corrupt a batch.

        Args:
            images: uint8 ``[n, H, W, C]``; not modified.
            rng: the only source of randomness.

        Returns:
            A new uint8 ``[n, H, W, C]`` array (``images`` itself only for no-op models).
        """

    def apply_each(self, images: np.ndarray, rngs: Sequence[np.random.Generator]) -> np.ndarray:
        """Corrupt each image with its own generator: the same values as
        ``apply(images[i : i + 1], rngs[i])`` for every ``i``, joined (a camera whose
        games each keep their own noise stream, as Breakout's do, calls it once a step).

        Raises:
            ValueError: ``rngs`` and ``images`` of different lengths.
        """
        check_generators(images, rngs)
        if not len(images):
            return images.copy()
        return np.concatenate(
            [np.asarray(self.apply(images[i : i + 1], rng)) for i, rng in enumerate(rngs)]
        )

    def describe(self) -> dict[str, Any]:
        """A JSON-able mapping that :func:`~noisybolt.perception.noise.make_noise` turns
        back into this model."""
        out: dict[str, Any] = {"name": self.name}
        for f in fields(self):  # type: ignore[arg-type]
            value = getattr(self, f.name)
            out[f.name] = _jsonable(value)
        return out


def _jsonable(value: Any) -> Any:
    if isinstance(value, NoiseModel):
        return value.describe()
    if isinstance(value, tuple | list):
        return [_jsonable(v) for v in value]
    return value


def checked_number(model: str, name: str, value: Any, low: float, high: float) -> float:
    """``value`` as a float, if it is a finite number in ``[low, high]``.

    Raises:
        ConfigError: naming ``model`` and its parameter ``name`` otherwise.
    """
    if isinstance(value, bool) or not isinstance(value, int | float | np.number):
        raise ConfigError(f"{model}: {name} must be a number in [{low}, {high}], got {value!r}")
    if not (math.isfinite(float(value)) and low <= float(value) <= high):
        raise ConfigError(f"{model}: {name} must be in [{low}, {high}], got {value!r}")
    return float(value)


def checked_integer(model: str, name: str, value: Any, low: int, high: int) -> int:
    """``value`` as an int, if it is an integer in ``[low, high]``.

    Raises:
        ConfigError: naming ``model`` and its parameter ``name`` otherwise.
    """
    if isinstance(value, bool) or not isinstance(value, int | np.integer):
        raise ConfigError(f"{model}: {name} must be an integer in [{low}, {high}], got {value!r}")
    if not low <= int(value) <= high:
        raise ConfigError(f"{model}: {name} must be in [{low}, {high}], got {value!r}")
    return int(value)


def check_generators(images: np.ndarray, rngs: Sequence[np.random.Generator]) -> None:
    """:meth:`NoiseModel.apply_each`'s input: images as :func:`check_images` wants them,
    one generator each."""
    check_images(images)
    if len(rngs) != len(images):
        raise ValueError(f"{len(images)} images need as many generators, got {len(rngs)}")


def check_images(images: np.ndarray) -> None:
    """Raises ValueError unless ``images`` is a uint8 batch ``[n, H, W, C]``."""
    if images.ndim != 4 or images.dtype != np.uint8:
        raise ValueError(f"images must be uint8 [n, H, W, C], got {images.dtype} {images.shape}")


def to_uint8(values: np.ndarray) -> np.ndarray:
    """Round float pixel values to uint8, saturating (in place on ``values``)."""
    values += 0.5
    np.clip(values, 0.0, 255.0, out=values)
    return values.astype(np.uint8)


@lru_cache(maxsize=1)
def _normal_quantiles() -> np.ndarray:
    """The 65536 standard-normal quantiles ``Phi^-1((k + 0.5) / 65536)``, float32."""
    inv_cdf = NormalDist().inv_cdf
    table = np.array([inv_cdf((k + 0.5) / 65536) for k in range(65536)], dtype=np.float32)
    table.setflags(write=False)
    return table


@lru_cache(maxsize=64)
def rounded_quantiles(sigma: float) -> np.ndarray:
    """``round(sigma * quantiles)`` as int16: integer pixel noise of spread ``sigma``."""
    table = np.rint(sigma * _normal_quantiles().astype(np.float64)).astype(np.int16)
    table.setflags(write=False)
    return table


@lru_cache(maxsize=64)
def scaled_quantiles(sigma: float) -> np.ndarray:
    """``sigma * _normal_quantiles()`` in float32, exactly as that product rounds."""
    table = np.float32(sigma) * _normal_quantiles()
    table.setflags(write=False)
    return table


def uniform16(rng: np.random.Generator, shape: tuple[int, ...]) -> np.ndarray:
    """uint16 ``shape``: uniform 16-bit draws from ``rng``'s bytes (the index of a
    quantile table)."""
    count = math.prod(shape)
    return np.frombuffer(rng.bytes(2 * count), dtype=np.uint16).reshape(shape)


def standard_normal(rng: np.random.Generator, shape: tuple[int, ...]) -> np.ndarray:
    """Fast standard-normal float32 draws by inverse-CDF lookup of 16-bit uniforms.

    Each value is one of 65536 exact Gaussian quantiles (tails cut at about 4.3 sigma);
    for pixel noise that is rounded to integers anyway this is indistinguishable from
    ``rng.standard_normal`` and about four times faster here.
    """
    return np.take(_normal_quantiles(), uniform16(rng, shape))


@lru_cache(maxsize=64)
def blur_matrix(length: int, sigma: float) -> np.ndarray:
    """``[length, length]`` matrix of a Gaussian blur along one axis, edges repeated."""
    radius = max(1, math.ceil(3.0 * sigma))
    offsets = np.arange(-radius, radius + 1)
    kernel = np.exp(-(offsets.astype(np.float64) ** 2) / (2.0 * sigma**2))
    kernel /= kernel.sum()
    matrix = np.zeros((length, length), dtype=np.float64)
    rows = np.repeat(np.arange(length), len(offsets))
    cols = np.clip(np.arange(length)[:, None] + offsets[None, :], 0, length - 1).ravel()
    np.add.at(matrix, (rows, cols), np.tile(kernel, length))
    out = matrix.astype(np.float32)
    out.setflags(write=False)
    return out


def gaussian_blur(values: np.ndarray, sigma: float) -> np.ndarray:
    """Separable Gaussian blur of float ``[n, H, W, C]`` over H and W (edges repeated).

    Done as two small matrix products per image and channel, which BLAS runs far faster
    than a loop of shifted adds.
    """
    if sigma <= 0:
        return values.copy()
    _, h, w, _ = values.shape
    planes = values.transpose(0, 3, 1, 2)  # [n, C, H, W]
    blurred = np.matmul(np.matmul(blur_matrix(h, sigma), planes), blur_matrix(w, sigma).T)
    return np.ascontiguousarray(blurred.transpose(0, 2, 3, 1), dtype=np.float32)
