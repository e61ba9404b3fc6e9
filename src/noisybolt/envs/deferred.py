"""Batched ``info`` values computed when first read, for the shipped vector worlds.

A world puts what its bolt camera sees into ``info`` at every reset and step
(:data:`~noisybolt.perception.protocols.BOLT_IMAGE_KEY`). Rendering and noising those
images is most of a step's cost, and the noise draws from the world's seeded generator:
a world stepped by someone who never looks (an agent without a bolt, the random play that
estimates a world's letters) should neither pay for the camera nor draw its noise.
:class:`DeferredArray` is such a value: it *is* the batched array for anyone who reads it
(``np.asarray(info["bolt_image"])``, indexing, ``len``, ``shape``, ``dtype``) and it
computes it once, on the first read. It is valid until the world's next reset or step,
which :meth:`DeferredArray.expire` s it: a first read after that raises
:class:`~noisybolt.errors.StaleInfoError` instead of showing a later state.

Example:
    >>> calls = []
    >>> def render() -> np.ndarray:
    ...     calls.append(1)
    ...     return np.zeros((2, 4, 4, 3), np.uint8)
    >>> images = DeferredArray(render, shape=(2, 4, 4, 3), dtype=np.uint8)
    >>> images.shape, len(calls)
    ((2, 4, 4, 3), 0)
    >>> np.asarray(images).shape, images[1].shape, len(calls)
    ((2, 4, 4, 3), (4, 4, 3), 1)
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from noisybolt.errors import StaleInfoError

__all__ = ["DeferredArray"]


class DeferredArray(np.lib.mixins.NDArrayOperatorsMixin):
    """An array computed by ``compute()`` on its first read (see the module docs).

    NumPy's functions and the arithmetic and comparison operators read it as its array
    (``images == 0``, ``images.max()`` through ``np.asarray``).

    Args:
        compute: returns the array; called at most once.
        shape: the array's shape, known without computing it.
        dtype: the array's dtype.
    """

    __slots__ = ("_compute", "_expired", "_value", "dtype", "shape")

    def __init__(
        self, compute: Callable[[], np.ndarray], *, shape: tuple[int, ...], dtype: Any
    ) -> None:
        self._compute: Callable[[], np.ndarray] | None = compute
        self._value: np.ndarray | None = None
        self._expired = False
        # Made every step by the shipped worlds: skip conversions that are not needed.
        self.shape = shape if type(shape) is tuple else tuple(shape)
        self.dtype = dtype if isinstance(dtype, np.dtype) else np.dtype(dtype)

    @property
    def expired(self) -> bool:
        """Whether the world moved on before anyone read it (it can no longer be computed)."""
        return self._expired

    @property
    def computed(self) -> bool:
        """Whether the array has been computed (someone read it)."""
        return self._value is not None

    @property
    def value(self) -> np.ndarray:
        """The array (computed now if nobody has read it yet).

        Raises:
            StaleInfoError: first read after the world's next reset or step.
        """
        if self._value is None:
            if self._expired or self._compute is None:
                raise StaleInfoError(
                    "this info value belongs to a reset or step the world has moved on from; "
                    "read it (np.asarray) before the next step"
                )
            self._value = self._compute()
            self._compute = None
        return self._value

    def expire(self) -> None:
        """The world has moved on: an unread value can no longer be computed."""
        if self._value is None:
            self._expired = True
            self._compute = None

    def __array__(self, dtype: Any = None, copy: bool | None = None) -> np.ndarray:
        value = self.value
        if dtype is not None and np.dtype(dtype) != value.dtype:
            return value.astype(dtype)
        return value.copy() if copy else value

    def __array_ufunc__(self, ufunc: Any, method: str, *inputs: Any, **kwargs: Any) -> Any:
        inputs = tuple(x.value if isinstance(x, DeferredArray) else x for x in inputs)
        return getattr(ufunc, method)(*inputs, **kwargs)

    def __len__(self) -> int:
        return self.shape[0]

    def __getitem__(self, index: Any) -> Any:
        return self.value[index]

    def __repr__(self) -> str:
        state = "computed" if self.computed else ("expired" if self._expired else "deferred")
        return f"DeferredArray(shape={self.shape}, dtype={self.dtype}, {state})"
