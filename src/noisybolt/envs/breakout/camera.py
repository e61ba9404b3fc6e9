"""The bolt's camera on Breakout: the colour frame resized, and the camera's noise.

The camera sees the ALE's colour frame (210x160) resized to ``camera_size`` squared with
``cv2.INTER_AREA`` (:func:`camera_resize`; :func:`area_resize_84` for the usual 84), then
the camera's own seeded noise (:func:`resolve_noise` turns a noise spec, model or callable
into the function that adds it), each game's from its own generator (so a game looks the
same in any shard of the world: ``shard``, for
:class:`~noisybolt.envs.worker_world.WorkerWorld`).

Example:
    >>> frames = [np.zeros((210, 160, 3), np.uint8)] * 2
    >>> camera_resize(frames, 84).shape, camera_resize(frames, 32).shape
    ((2, 84, 84, 3), (2, 32, 32, 3))
    >>> resolve_noise(None)
    (None, {'name': 'none'})
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from typing import Any

import cv2
import numpy as np

from noisybolt.errors import ConfigError
from noisybolt.perception.noise import make_noise

__all__ = ["NoiseFn", "area_resize_84", "camera_resize", "resolve_noise"]

NoiseFn = Callable[[np.ndarray, np.random.Generator], np.ndarray]
"""A camera noise model: uint8 images ``[n, H, W, C]`` and a generator -> noisy images."""

_AREA_84_SIZE = 84


def area_resize_84(frames: np.ndarray) -> np.ndarray:
    """ALE frames uint8 ``[n, 210, 160, 3]`` resized to ``[n, 84, 84, 3]`` by area
    averaging: ``cv2.INTER_AREA``'s pixels, in half its time for a batch of 4.

    OpenCV's area resize takes its general path for factors that are not integers (2.5
    down, 40/21 across: 0.16 ms a frame here, a tenth of a Breakout training frame's CPU).
    Down, every 5 rows make 2, the averages (r0 + r1 + r2/2) / 2.5 and (r2/2 + r3 + r4)
    / 2.5, kept as the exact sums 2r0 + 2r1 + r2 and r2 + 2r3 + 2r4 (5 times the average,
    in float32); across, OpenCV's own area resize of those sums (the frames stacked, one
    call, factor 1 down), then a fifth of it, rounded. The same pixels as
    ``cv2.resize(frame, (84, 84), interpolation=cv2.INTER_AREA)`` on every frame of
    Breakout play tested; on random images a value on an exact half may round the other
    way (under 0.1 % of values, one level apart).

    Example:
        >>> frame = np.random.default_rng(0).integers(0, 256, (1, 210, 160, 3), np.uint8)
        >>> ours = area_resize_84(frame)[0].astype(int)
        >>> theirs = cv2.resize(frame[0], (84, 84), interpolation=cv2.INTER_AREA).astype(int)
        >>> ours.shape, int(abs(ours - theirs).max()) <= 1
        ((84, 84, 3), True)
    """
    n = frames.shape[0]
    if frames.shape[1:] != (210, 160, 3) or frames.dtype != np.uint8:
        raise ValueError(f"expected uint8 ALE frames [n, 210, 160, 3], got {frames.shape}")
    rows = frames.reshape(n, 42, 5, 160 * 3)
    sums = np.empty((n, 42, 2, 160 * 3), np.float32)  # 2x(row0 + row1) + row2, row2 + 2x(...)
    np.add(rows[:, :, 0], rows[:, :, 1], out=sums[:, :, 0], dtype=np.float32)
    np.add(rows[:, :, 3], rows[:, :, 4], out=sums[:, :, 1], dtype=np.float32)
    sums *= 2
    sums += rows[:, :, 2, None]
    tall = sums.reshape(n * 84, 160, 3)  # the frames one above the other: factor 1 down
    out = np.asarray(cv2.resize(tall, (84, n * 84), interpolation=cv2.INTER_AREA), np.float32)
    out *= np.float32(0.2)
    np.rint(out, out=out)
    return out.astype(np.uint8).reshape(n, 84, 84, 3)


def resolve_noise(noise: Any) -> tuple[NoiseFn | None, dict[str, Any]]:
    """The camera's noise function and its JSON description (for :class:`CameraSpec`).

    Accepts None (clean), a :mod:`noisybolt.perception.noise` model or any object with
    ``apply(images, rng)`` (and ideally ``describe()``), a spec that
    :func:`~noisybolt.perception.noise.make_noise` reads (a name or command-line text such
    as ``"gaussian:sigma=12"``, a mapping, a list), or a plain ``noise(images, rng)``
    callable.

    Raises:
        ConfigError: for anything else (and, through ``make_noise``, for bad specs;
            ``UnknownNameError`` for unknown noise names).
    """
    if noise is None:
        return None, {"name": "none"}  # what NoNoise().describe() says
    if isinstance(noise, str | Mapping | list | tuple):
        noise = make_noise(noise)
    apply = getattr(noise, "apply", None)
    if callable(apply):
        describe = getattr(noise, "describe", None)
        description = describe() if callable(describe) else {"name": type(noise).__name__}
        if description.get("name") == "none":
            return None, description
        return apply, description
    if callable(noise):
        return noise, {"name": getattr(noise, "__name__", type(noise).__name__)}
    raise ConfigError(
        f"noise must be a noise spec, a noise model or a callable noise(images, rng), got {noise!r}"
    )


def camera_resize(frames: Sequence[np.ndarray], side: int) -> np.ndarray:
    """ALE colour frames (each uint8 ``[210, 160, 3]``) resized to uint8 ``[n, side,
    side, 3]`` with ``cv2.INTER_AREA``: through :func:`area_resize_84` for ``side`` 84."""
    size = (side, side)
    if side == _AREA_84_SIZE:
        return area_resize_84(np.stack(frames))
    return np.stack([cv2.resize(f, size, interpolation=cv2.INTER_AREA) for f in frames])
