"""The regional noise: a warped, smudged pane over part of the camera's image
(:class:`RegionalDegradation`, the paper's case-4 camera), and its default box.

Example:
    >>> import numpy as np
    >>> model = RegionalDegradation()
    >>> images = np.full((1, 6, 6, 3), 200, np.uint8)
    >>> model.pixel_boxes(6, 6)
    [(4, 1, 5, 4)]
    >>> out = model.apply(images, np.random.default_rng(0))
    >>> bool((out[:, :4] == images[:, :4]).all())  # untouched outside the box
    True
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
from typing import Any, ClassVar

import numpy as np

from noisybolt.errors import ConfigError
from noisybolt.perception.noise_base import (
    NoiseModel,
    blur_matrix,
    check_images,
    checked_number,
    scaled_quantiles,
    to_uint8,
    uniform16,
)

__all__ = ["DEFAULT_REGION", "RegionalDegradation"]

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
            object.__setattr__(
                self, attr, checked_number(self.name, attr, getattr(self, attr), 0, high)
            )

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
        check_images(images)
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
                draws = uniform16(rng, clean.shape).transpose(0, 3, 1, 2)
                smudge += scaled_quantiles(self.sigma).take(draws)
            if self.strength < 1.0:
                faint = clean.transpose(0, 3, 1, 2).astype(np.float32)
                smudge = (1.0 - self.strength) * faint + self.strength * smudge
            out[:, r0:r1, c0:c1] = to_uint8(smudge).transpose(0, 2, 3, 1)
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
    """:func:`blur_matrix`, or the identity for ``sigma <= 0`` (no blur)."""
    if sigma <= 0:
        out = np.eye(length, dtype=np.float32)
        out.setflags(write=False)
        return out
    return blur_matrix(length, sigma)


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
