"""Noise models for the bolt's camera: seeded, composable, vectorised over a batch.

A noise model is a frozen description (its parameters) with one method,
``apply(images, rng)``: uint8 ``[n, H, W, C]`` in, a new uint8 array of the same shape out,
all randomness drawn from the ``np.random.Generator`` passed in, in a fixed order, so the
same generator state gives the same noise. Models are JSON-describable
(:meth:`NoiseModel.describe`, stored in :class:`~noisybolt.perception.protocols.CameraSpec`)
and built back by name with :func:`make_noise`.

Spec formats accepted by :func:`make_noise` (from Python, YAML or the command line):

- a name: ``"gaussian"`` (default parameters), ``"none"``;
- a mapping: ``{"name": "gaussian", "sigma": 12}``;
- a list of those, applied in order: ``[{"name": "blur", "sigma": 0.5}, "gaussian"]``;
- command-line text (:func:`parse_noise`): ``"gaussian:sigma=12+salt_pepper:amount=0.01"``
  or the JSON of any of the above.

Example:
    >>> import numpy as np
    >>> model = make_noise("gaussian:sigma=10+salt_pepper:amount=0.02")
    >>> model.describe()["name"]
    'compose'
    >>> images = np.full((2, 4, 4, 3), 128, dtype=np.uint8)
    >>> a = model.apply(images, np.random.default_rng(0))
    >>> b = model.apply(images, np.random.default_rng(0))
    >>> bool((a == b).all()), a.shape, a.dtype
    (True, (2, 4, 4, 3), dtype('uint8'))
"""

from __future__ import annotations

import json
import math
from abc import ABC, abstractmethod
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, fields
from functools import lru_cache
from statistics import NormalDist
from typing import Any, ClassVar, TypeAlias

import numpy as np

from noisybolt.errors import ConfigError, UnknownNameError

__all__ = [
    "DEFAULT_REGION",
    "Blur",
    "Compose",
    "GaussianNoise",
    "NoNoise",
    "NoiseModel",
    "NoiseSpec",
    "OcclusionPatches",
    "RegionalDegradation",
    "SaltPepperNoise",
    "known_noises",
    "make_noise",
    "parse_noise",
    "standard_normal",
]

#: Anything :func:`make_noise` accepts.
NoiseSpec: TypeAlias = "NoiseModel | str | Mapping[str, Any] | Sequence[Any] | None"


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
        _check_generators(images, rngs)
        if not len(images):
            return images.copy()
        return np.concatenate(
            [np.asarray(self.apply(images[i : i + 1], rng)) for i, rng in enumerate(rngs)]
        )

    def describe(self) -> dict[str, Any]:
        """A JSON-able mapping that :func:`make_noise` turns back into this model."""
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


def _number(model: str, name: str, value: Any, low: float, high: float) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float | np.number):
        raise ConfigError(f"{model}: {name} must be a number in [{low}, {high}], got {value!r}")
    if not (math.isfinite(float(value)) and low <= float(value) <= high):
        raise ConfigError(f"{model}: {name} must be in [{low}, {high}], got {value!r}")
    return float(value)


def _integer(model: str, name: str, value: Any, low: int, high: int) -> int:
    if isinstance(value, bool) or not isinstance(value, int | np.integer):
        raise ConfigError(f"{model}: {name} must be an integer in [{low}, {high}], got {value!r}")
    if not low <= int(value) <= high:
        raise ConfigError(f"{model}: {name} must be in [{low}, {high}], got {value!r}")
    return int(value)


def _check_generators(images: np.ndarray, rngs: Sequence[np.random.Generator]) -> None:
    """:meth:`NoiseModel.apply_each`'s input: images as :func:`_check_images` wants them,
    one generator each."""
    _check_images(images)
    if len(rngs) != len(images):
        raise ValueError(f"{len(images)} images need as many generators, got {len(rngs)}")


def _check_images(images: np.ndarray) -> None:
    if images.ndim != 4 or images.dtype != np.uint8:
        raise ValueError(f"images must be uint8 [n, H, W, C], got {images.dtype} {images.shape}")


def _to_uint8(values: np.ndarray) -> np.ndarray:
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
def _rounded_quantiles(sigma: float) -> np.ndarray:
    """``round(sigma * quantiles)`` as int16: integer pixel noise of spread ``sigma``."""
    table = np.rint(sigma * _normal_quantiles().astype(np.float64)).astype(np.int16)
    table.setflags(write=False)
    return table


@lru_cache(maxsize=64)
def _scaled_quantiles(sigma: float) -> np.ndarray:
    """``sigma * _normal_quantiles()`` in float32, exactly as that product rounds."""
    table = np.float32(sigma) * _normal_quantiles()
    table.setflags(write=False)
    return table


def _uniform16(rng: np.random.Generator, shape: tuple[int, ...]) -> np.ndarray:
    count = math.prod(shape)
    return np.frombuffer(rng.bytes(2 * count), dtype=np.uint16).reshape(shape)


def standard_normal(rng: np.random.Generator, shape: tuple[int, ...]) -> np.ndarray:
    """Fast standard-normal float32 draws by inverse-CDF lookup of 16-bit uniforms.

    Each value is one of 65536 exact Gaussian quantiles (tails cut at about 4.3 sigma);
    for pixel noise that is rounded to integers anyway this is indistinguishable from
    ``rng.standard_normal`` and about four times faster here.
    """
    return np.take(_normal_quantiles(), _uniform16(rng, shape))


@dataclass(frozen=True)
class NoNoise(NoiseModel):
    """The identity: a perfect camera."""

    name: ClassVar[str] = "none"

    def apply(self, images: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """Return ``images`` unchanged (no copy)."""
        _check_images(images)
        return images


@dataclass(frozen=True)
class GaussianNoise(NoiseModel):
    """Independent Gaussian noise on every pixel and channel.

    Attributes:
        sigma: standard deviation in pixel levels, in [0, 255].
    """

    name: ClassVar[str] = "gaussian"
    sigma: float = 8.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "sigma", _number(self.name, "sigma", self.sigma, 0, 255))

    def apply(self, images: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """Add ``N(0, sigma^2)`` per value (see :func:`standard_normal`), round, saturate."""
        _check_images(images)
        return self._grain(images, _uniform16(rng, images.shape))

    def apply_each(self, images: np.ndarray, rngs: Sequence[np.random.Generator]) -> np.ndarray:
        """As :meth:`NoiseModel.apply_each` (the same values), each image's draws from its
        own generator and the arithmetic once for the batch."""
        _check_generators(images, rngs)
        draws = np.empty(images.shape, np.uint16)
        for i, rng in enumerate(rngs):
            draws[i] = _uniform16(rng, (1, *images.shape[1:]))[0]
        return self._grain(images, draws)

    def _grain(self, images: np.ndarray, draws: np.ndarray) -> np.ndarray:
        """``images`` plus the grain of uniform 16-bit ``draws`` (one per value)."""
        # round(x + sigma*z) == x + round(sigma*z) for integer x: integer arithmetic is exact.
        values = np.take(_rounded_quantiles(self.sigma), draws)
        values += images
        np.clip(values, 0, 255, out=values)
        return values.astype(np.uint8)


@dataclass(frozen=True)
class SaltPepperNoise(NoiseModel):
    """Pixels (all channels together) forced to white or black.

    Attributes:
        amount: fraction of pixels hit, in [0, 1].
        salt_ratio: fraction of the hits that turn white, in [0, 1].
    """

    name: ClassVar[str] = "salt_pepper"
    amount: float = 0.02
    salt_ratio: float = 0.5

    def __post_init__(self) -> None:
        object.__setattr__(self, "amount", _number(self.name, "amount", self.amount, 0, 1))
        object.__setattr__(
            self, "salt_ratio", _number(self.name, "salt_ratio", self.salt_ratio, 0, 1)
        )

    def apply(self, images: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """Draw one uniform per pixel: below ``amount*salt_ratio`` white, then black."""
        _check_images(images)
        u = rng.random(images.shape[:3], dtype=np.float32)
        out = images.copy()
        salt_below = self.amount * self.salt_ratio
        out[u < salt_below] = 255
        out[(u >= salt_below) & (u < self.amount)] = 0
        return out


@lru_cache(maxsize=64)
def _blur_matrix(length: int, sigma: float) -> np.ndarray:
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
    blurred = np.matmul(np.matmul(_blur_matrix(h, sigma), planes), _blur_matrix(w, sigma).T)
    return np.ascontiguousarray(blurred.transpose(0, 2, 3, 1), dtype=np.float32)


@dataclass(frozen=True)
class Blur(NoiseModel):
    """Gaussian blur of the whole image (an out-of-focus camera).

    Attributes:
        sigma: standard deviation of the kernel in pixels, in [0, 32]; 0 is no blur.
    """

    name: ClassVar[str] = "blur"
    sigma: float = 1.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "sigma", _number(self.name, "sigma", self.sigma, 0, 32))

    def apply(self, images: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """Blur; draws nothing from ``rng``."""
        _check_images(images)
        return _to_uint8(gaussian_blur(images.astype(np.float32), self.sigma))


@dataclass(frozen=True)
class OcclusionPatches(NoiseModel):
    """Random grey squares occluding parts of each image (dirt, a passing hand).

    Attributes:
        count: patches per image, in [0, 64].
        size: side of a patch as a fraction of the image's smaller side, in (0, 1].
        value: grey level of the patches, in [0, 255].
        probability: chance that each patch is drawn at all, in [0, 1].
    """

    name: ClassVar[str] = "occlusion"
    count: int = 1
    size: float = 0.2
    value: int = 128
    probability: float = 1.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "count", _integer(self.name, "count", self.count, 0, 64))
        size = _number(self.name, "size", self.size, 0, 1)
        if size == 0:
            raise ConfigError(f"{self.name}: size must be in (0, 1], got {self.size!r}")
        object.__setattr__(self, "size", size)
        object.__setattr__(self, "value", _integer(self.name, "value", self.value, 0, 255))
        object.__setattr__(
            self, "probability", _number(self.name, "probability", self.probability, 0, 1)
        )

    def apply(self, images: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """Draw, per patch and image, whether it shows and its top-left corner."""
        _check_images(images)
        n, h, w, _ = images.shape
        side = max(1, round(self.size * min(h, w)))
        out = images.copy()
        rows = np.arange(h)[None, :, None]
        cols = np.arange(w)[None, None, :]
        for _ in range(self.count):
            shown = np.less(rng.random(size=(n,)), self.probability)
            top = rng.integers(0, h - side + 1, size=n)[:, None, None]
            left = rng.integers(0, w - side + 1, size=n)[:, None, None]
            mask = (rows >= top) & (rows < top + side) & (cols >= left) & (cols < left + side)
            mask &= shown[:, None, None]
            out[mask] = self.value
        return out


#: The default box of :class:`RegionalDegradation`, ``[top, left, bottom, right]`` as
#: fractions of the image: in the 6x6 gridworld, the bottom row of floor from the
#: bottom-left corner cell up to (not including) the goal, cells (1, 4), (2, 4), (3, 4).
DEFAULT_REGION: tuple[tuple[float, float, float, float], ...] = ((4 / 6, 1 / 6, 5 / 6, 4 / 6),)


def _boxes(model: str, boxes: Any) -> tuple[tuple[float, float, float, float], ...]:
    try:
        parsed = tuple(tuple(float(v) for v in box) for box in boxes)
    except (TypeError, ValueError):
        raise ConfigError(
            f"{model}: boxes must be a list of [top, left, bottom, right] fractions, got {boxes!r}"
        ) from None
    if not parsed:
        raise ConfigError(f"{model}: boxes must hold at least one box")
    for box in parsed:
        if len(box) != 4:
            raise ConfigError(f"{model}: boxes must be [top, left, bottom, right], got {box}")
        top, left, bottom, right = box
        if not (0 <= top < bottom <= 1 and 0 <= left < right <= 1):
            raise ConfigError(
                f"{model}: boxes must satisfy 0 <= top < bottom <= 1 and "
                f"0 <= left < right <= 1, got {list(box)}"
            )
    return parsed  # type: ignore[return-value]


@dataclass(frozen=True)
class RegionalDegradation(NoiseModel):
    """A warped, smudged pane over part of the image: what shows through it is displaced,
    blurred, dimmed and grainy; the rest of the image is untouched.

    Inside each box, in order: the content is rolled circularly along the box's longer side
    by a random number of pixels, uniform in ``[0, shift * length)``; blurred (Gaussian,
    ``blur`` times the box's shorter side); pulled towards the box's mean colour, keeping
    ``contrast`` of its deviation; given Gaussian noise ``sigma``; and mixed with the clean
    picture by ``strength`` (1 shows only the smudge, 0 leaves the image as it was; in
    between, a faint undisplaced copy shows through and soon gives the position away).

    Why a displacement and a box wider than the corner cell: the agent is always somewhere
    in the room, so when a classifier sees it nowhere in the clear part of the image it
    *knows* the agent is under the smudge, however destroyed the smudged cell is. Only
    uncertainty about *where* under the smudge survives that reasoning. The default box
    (:data:`DEFAULT_REGION`) covers the bottom-left corner cell and its two floor
    neighbours along the bottom wall, cells that share every other fluent's value
    (``on_edge`` true, ``top_right_corner`` false); with ``shift=1`` the three are
    indistinguishable, so a classifier can say ``bottom_left_corner`` only with the
    confidence its training prior gives (about 0.875 with per-fluent balanced samples and
    uniform negatives: the low band), while the agent's heading and everything else stay
    clear. In two quick checks (a small CNN, 800 steps of batch 64, half the samples in
    the corner, negatives uniform) 97-98 % of true ``bottom_left_corner`` images fell in
    the low band and none below 0.5, while the other six fluents were high-band on 89-100 %
    of their positives; the price is that the two neighbours are also called
    ``bottom_left_corner`` with low confidence (13 % of all negatives). With
    ``shift=0`` the same smudge leaves the position readable and the classifier was
    confident again (100 % high band); so was it with the corner cell alone smudged to a
    flat grey (it learnt "the agent is nowhere else").

    Attributes:
        boxes: ``[top, left, bottom, right]`` image fractions, one per smudged rectangle
            (each is degraded on its own); default :data:`DEFAULT_REGION`.
        strength: mix of the smudge into the picture, in [0, 1].
        blur: Gaussian sigma as a fraction of the box's shorter side, in [0, 2].
        contrast: fraction of the deviation from the box's mean colour kept, in [0, 1].
        sigma: Gaussian noise inside the box in pixel levels, in [0, 255].
        shift: largest random displacement as a fraction of the box's longer side, in
            [0, 1] (1: uniform over the whole box).
    """

    name: ClassVar[str] = "regional"
    boxes: tuple[tuple[float, float, float, float], ...] = DEFAULT_REGION
    strength: float = 1.0
    blur: float = 0.1
    contrast: float = 0.6
    sigma: float = 12.0
    shift: float = 1.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "boxes", _boxes(self.name, self.boxes))
        for attr, high in (
            ("strength", 1.0),
            ("blur", 2.0),
            ("contrast", 1.0),
            ("sigma", 255.0),
            ("shift", 1.0),
        ):
            object.__setattr__(self, attr, _number(self.name, attr, getattr(self, attr), 0, high))

    def pixel_boxes(self, height: int, width: int) -> list[tuple[int, int, int, int]]:
        """The boxes in pixels (``top, left, bottom, right``; at least one pixel each)."""
        out = []
        for top, left, bottom, right in self.boxes:
            r0, c0 = round(top * height), round(left * width)
            r1 = max(r0 + 1, round(bottom * height))
            c1 = max(c0 + 1, round(right * width))
            out.append((min(r0, height - 1), min(c0, width - 1), min(r1, height), min(c1, width)))
        return out

    def apply(self, images: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """Smudge every box of every image (noise drawn box by box)."""
        _check_images(images)
        h, w = images.shape[1:3]
        out = images.copy()
        for r0, c0, r1, c1 in self.pixel_boxes(h, w):
            clean = images[:, r0:r1, c0:c1]
            smudge = self._displace_and_blur(clean, rng)  # [n, C, h, w], contiguous
            n, channels, bh, bw = smudge.shape
            mean = smudge.reshape(n * channels, bh * bw).mean(axis=1)
            smudge *= self.contrast
            smudge += ((1.0 - self.contrast) * mean).reshape(n, channels, 1, 1)
            # Every later step is per pixel, so it runs in this channels-first layout
            # (contiguous passes; on a transposed view each pass took about twice as
            # long) and only the uint8 result is transposed back. The grain is drawn in
            # the images' own [n, h, w, C] order, so it stays the same draw for a seed.
            if self.sigma > 0:  # sigma * standard_normal(rng, shape), one pass fewer
                draws = _uniform16(rng, clean.shape).transpose(0, 3, 1, 2)
                smudge += _scaled_quantiles(self.sigma).take(draws)
            if self.strength < 1.0:
                faint = clean.transpose(0, 3, 1, 2).astype(np.float32)
                smudge = (1.0 - self.strength) * faint + self.strength * smudge
            out[:, r0:r1, c0:c1] = _to_uint8(smudge).transpose(0, 2, 3, 1)
        return out

    def _displace_and_blur(self, clean: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """float32 ``[n, C, h, w]``: the box rolled circularly along its longer side and blurred.

        Both are linear maps along each axis, so they are applied as two matrix products
        per image: the roll along the longer side folded into that side's blur matrix,
        one precomputed matrix per roll distance. A box is a few thousand values: the cost
        of the separate gather, blur and transposes was per-call overhead, not arithmetic.
        """
        n, h, w, _ = clean.shape
        planes = clean.transpose(0, 3, 1, 2).astype(np.float32)  # [n, C, h, w]
        sigma = self.blur * min(h, w)
        along_width = w >= h
        length = w if along_width else h
        if self.shift > 0:
            steps = rng.integers(0, max(1, round(self.shift * length)), size=n)
        else:
            steps = np.zeros(n, dtype=np.int64)
        rolled = _rolled_blur_matrices(length, sigma)[steps][:, None]  # [n, 1, L, L]
        if along_width:
            return np.matmul(np.matmul(_blur_or_identity(h, sigma), planes), rolled)
        # Rolling a column is rolling the transposed row: the same matrices, transposed.
        left = rolled.swapaxes(-1, -2)
        return np.matmul(np.matmul(left, planes), _blur_or_identity(w, sigma).T)


@lru_cache(maxsize=64)
def _blur_or_identity(length: int, sigma: float) -> np.ndarray:
    """:func:`_blur_matrix`, or the identity for ``sigma <= 0`` (no blur)."""
    if sigma <= 0:
        out = np.eye(length, dtype=np.float32)
        out.setflags(write=False)
        return out
    return _blur_matrix(length, sigma)


@lru_cache(maxsize=64)
def _rolled_blur_matrices(length: int, sigma: float) -> np.ndarray:
    """``[length, length, length]``: for each roll ``s``, the matrix ``M`` with
    ``x @ M = blur(np.roll(x, s))`` for a row vector ``x``;
    ``M.T @ X`` does the same to the columns of ``X``.
    """
    blur = _blur_or_identity(length, sigma)
    out = np.empty((length, length, length), dtype=np.float32)
    for s in range(length):
        roll = np.roll(np.eye(length, dtype=np.float32), s, axis=1)  # x @ roll = roll(x, s)
        out[s] = roll @ blur.T
    out.setflags(write=False)
    return out


@dataclass(frozen=True)
class Compose(NoiseModel):
    """Several models applied in order, sharing one generator.

    Attributes:
        models: the models, first applied first.
    """

    name: ClassVar[str] = "compose"
    models: tuple[NoiseModel, ...] = ()

    def __post_init__(self) -> None:
        models = tuple(self.models)
        for m in models:
            if not isinstance(m, NoiseModel):
                raise ConfigError(f"compose: models must be noise models, got {m!r}")
        object.__setattr__(self, "models", models)

    def apply(self, images: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """Apply each model to the previous one's output."""
        _check_images(images)
        for model in self.models:
            images = model.apply(images, rng)
        return images


_REGISTRY: dict[str, type[NoiseModel]] = {
    cls.name: cls
    for cls in (
        NoNoise,
        GaussianNoise,
        SaltPepperNoise,
        Blur,
        OcclusionPatches,
        RegionalDegradation,
    )
}


def known_noises() -> tuple[str, ...]:
    """Names :func:`make_noise` understands (``"compose"`` is spelled as a list)."""
    return (*sorted(_REGISTRY), Compose.name)


def _from_mapping(spec: Mapping[str, Any]) -> NoiseModel:
    if "name" not in spec:
        raise ConfigError(f"a noise spec mapping needs a 'name', got {dict(spec)!r}")
    name = spec["name"]
    params = {k: v for k, v in spec.items() if k != "name"}
    if name == Compose.name:
        unknown = set(params) - {"models"}
        if unknown:
            raise ConfigError(f"compose: unknown parameter(s) {sorted(unknown)}; known: models")
        return Compose(models=tuple(make_noise(m) for m in params.get("models", ())))
    cls = _REGISTRY.get(name) if isinstance(name, str) else None
    if cls is None:
        raise UnknownNameError(
            f"unknown noise model {name!r}; known: {', '.join(known_noises())}",
            name=str(name),
            known=known_noises(),
        )
    allowed = {f.name for f in fields(cls)}  # type: ignore[arg-type]
    unknown = set(params) - allowed
    if unknown:
        raise ConfigError(
            f"{name}: unknown parameter(s) {sorted(unknown)}; known: {', '.join(sorted(allowed))}"
        )
    return cls(**params)


def make_noise(spec: NoiseSpec = None) -> NoiseModel:
    """Build a noise model from any spec format (see the module docstring).

    Args:
        spec: a model, a name or command-line text, a ``{"name": ..., **params}``
            mapping, a list of specs (composed in order), or None (no noise).

    Returns:
        The model; a list of one spec gives that model, not a one-element ``Compose``.

    Raises:
        UnknownNameError: for a name outside :func:`known_noises` (listing them).
        ConfigError: for an unknown or out-of-range parameter (naming it).

    Example:
        >>> make_noise({"name": "gaussian", "sigma": 4})
        GaussianNoise(sigma=4.0)
        >>> make_noise("regional").describe()["boxes"][0][0]  # fractions of the image
        0.6666666666666666
    """
    if spec is None:
        return NoNoise()
    if isinstance(spec, NoiseModel):
        return spec
    if isinstance(spec, str):
        return parse_noise(spec)
    if isinstance(spec, Mapping):
        return _from_mapping(spec)
    if isinstance(spec, Sequence):
        models = tuple(make_noise(s) for s in spec)
        return models[0] if len(models) == 1 else Compose(models=models)
    raise ConfigError(f"a noise spec must be a name, mapping or list, got {spec!r}")


def _parse_value(text: str) -> Any:
    try:
        return json.loads(text)
    except json.JSONDecodeError:
        return text


def parse_noise(text: str) -> NoiseModel:
    """Build a noise model from command-line text.

    Forms: ``"none"``, ``"gaussian"``, ``"gaussian:sigma=12"``,
    ``"blur:sigma=0.5+gaussian:sigma=6"`` (``+`` composes in order; values are read as
    JSON, so ``boxes=[[0.5,0,1,0.5]]`` works), or JSON text of any spec.

    Raises:
        UnknownNameError: for an unknown model name.
        ConfigError: for malformed text or a bad parameter.
    """
    text = text.strip()
    if text.startswith(("[", "{")):
        try:
            return make_noise(json.loads(text))
        except json.JSONDecodeError as exc:
            raise ConfigError(f"noise spec is not valid JSON: {exc}") from None
    specs: list[dict[str, Any]] = []
    for part in text.split("+"):
        name, _, args = part.strip().partition(":")
        spec: dict[str, Any] = {"name": name.strip()}
        if args.strip():
            for item in _split_args(args):
                key, eq, value = item.partition("=")
                if not eq or not key.strip():
                    raise ConfigError(
                        f"noise spec {part!r}: expected name:key=value,key=value, got {item!r}"
                    )
                spec[key.strip()] = _parse_value(value.strip())
        specs.append(spec)
    return make_noise(specs)


def _split_args(args: str) -> list[str]:
    """Split ``a=1,b=[1,2]`` on the commas that are outside brackets."""
    items, depth, start = [], 0, 0
    for i, ch in enumerate(args):
        if ch in "[{":
            depth += 1
        elif ch in "]}":
            depth -= 1
        elif ch == "," and depth == 0:
            items.append(args[start:i])
            start = i + 1
    items.append(args[start:])
    return [s for s in (item.strip() for item in items) if s]
