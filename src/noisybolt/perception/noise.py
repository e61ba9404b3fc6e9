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

The models: :class:`NoNoise`, :class:`GaussianNoise`, :class:`SaltPepperNoise`,
:class:`Blur`, :class:`OcclusionPatches` and :class:`Compose` here;
:class:`~noisybolt.perception.noise_regional.RegionalDegradation` (with
:data:`DEFAULT_REGION`) in :mod:`noisybolt.perception.noise_regional`; the interface
they share, :class:`~noisybolt.perception.noise_base.NoiseModel`, and their pixel
arithmetic in :mod:`noisybolt.perception.noise_base`. This module names them all.

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
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, fields
from typing import Any, ClassVar, TypeAlias

import numpy as np

from noisybolt.errors import ConfigError, UnknownNameError
from noisybolt.perception.noise_base import (
    NoiseModel,
    check_generators,
    check_images,
    checked_integer,
    checked_number,
    gaussian_blur,
    rounded_quantiles,
    standard_normal,
    to_uint8,
    uniform16,
)
from noisybolt.perception.noise_regional import DEFAULT_REGION, RegionalDegradation

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


@dataclass(frozen=True)
class NoNoise(NoiseModel):
    """The identity: a perfect camera."""

    name: ClassVar[str] = "none"

    def apply(self, images: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """Return ``images`` unchanged (no copy)."""
        check_images(images)
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
        object.__setattr__(self, "sigma", checked_number(self.name, "sigma", self.sigma, 0, 255))

    def apply(self, images: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """Add ``N(0, sigma^2)`` per value (see :func:`standard_normal`), round, saturate."""
        check_images(images)
        return self._grain(images, uniform16(rng, images.shape))

    def apply_each(self, images: np.ndarray, rngs: Sequence[np.random.Generator]) -> np.ndarray:
        """As :meth:`NoiseModel.apply_each` (the same values), each image's draws from its
        own generator and the arithmetic once for the batch."""
        check_generators(images, rngs)
        draws = np.empty(images.shape, np.uint16)
        for i, rng in enumerate(rngs):
            draws[i] = uniform16(rng, (1, *images.shape[1:]))[0]
        return self._grain(images, draws)

    def _grain(self, images: np.ndarray, draws: np.ndarray) -> np.ndarray:
        """``images`` plus the grain of uniform 16-bit ``draws`` (one per value)."""
        # round(x + sigma*z) == x + round(sigma*z) for integer x: integer arithmetic is exact.
        values = np.take(rounded_quantiles(self.sigma), draws)
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
        object.__setattr__(self, "amount", checked_number(self.name, "amount", self.amount, 0, 1))
        object.__setattr__(
            self, "salt_ratio", checked_number(self.name, "salt_ratio", self.salt_ratio, 0, 1)
        )

    def apply(self, images: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """Draw one uniform per pixel: below ``amount*salt_ratio`` white, then black."""
        check_images(images)
        u = rng.random(images.shape[:3], dtype=np.float32)
        out = images.copy()
        salt_below = self.amount * self.salt_ratio
        out[u < salt_below] = 255
        out[(u >= salt_below) & (u < self.amount)] = 0
        return out


@dataclass(frozen=True)
class Blur(NoiseModel):
    """Gaussian blur of the whole image (an out-of-focus camera).

    Attributes:
        sigma: standard deviation of the kernel in pixels, in [0, 32]; 0 is no blur.
    """

    name: ClassVar[str] = "blur"
    sigma: float = 1.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "sigma", checked_number(self.name, "sigma", self.sigma, 0, 32))

    def apply(self, images: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """Blur; draws nothing from ``rng``."""
        check_images(images)
        return to_uint8(gaussian_blur(images.astype(np.float32), self.sigma))


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
        object.__setattr__(self, "count", checked_integer(self.name, "count", self.count, 0, 64))
        size = checked_number(self.name, "size", self.size, 0, 1)
        if size == 0:
            raise ConfigError(f"{self.name}: size must be in (0, 1], got {self.size!r}")
        object.__setattr__(self, "size", size)
        object.__setattr__(self, "value", checked_integer(self.name, "value", self.value, 0, 255))
        object.__setattr__(
            self, "probability", checked_number(self.name, "probability", self.probability, 0, 1)
        )

    def apply(self, images: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """Draw, per patch and image, whether it shows and its top-left corner."""
        check_images(images)
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
        check_images(images)
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
