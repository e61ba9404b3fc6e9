"""Bit tricks on uint64 fluent masks shared by the engine and the augmented DFA."""

from __future__ import annotations

import numpy as np

_BYTE_POPCOUNT = np.array([bin(i).count("1") for i in range(256)], dtype=np.int64)


def popcount(masks: np.ndarray) -> np.ndarray:
    """int64 array of the number of set bits of each element of a uint64 array."""
    masks = np.asarray(masks, dtype=np.uint64)
    if hasattr(np, "bitwise_count"):  # numpy >= 2.0
        return np.bitwise_count(masks).astype(np.int64)
    as_bytes = masks[..., None].view(np.uint8)  # pragma: no cover - numpy 1.x only
    return _BYTE_POPCOUNT[as_bytes].sum(axis=-1)  # pragma: no cover


def bit_columns(masks: np.ndarray, n_bits: int) -> np.ndarray:
    """Unpacks uint64 masks ``[...]`` into a 0/1 float64 array ``[..., n_bits]``."""
    shifts = np.arange(n_bits, dtype=np.uint64)
    bits = (np.asarray(masks, dtype=np.uint64)[..., None] >> shifts) & np.uint64(1)
    return bits.astype(np.float64)


def scatter_bits(values: np.ndarray, positions: np.ndarray) -> np.ndarray:
    """Moves bit ``i`` of each value to bit ``positions[i]`` (uint64 in, uint64 out)."""
    values = np.asarray(values, dtype=np.uint64)
    out = np.zeros(values.shape, dtype=np.uint64)
    for i, pos in enumerate(np.asarray(positions, dtype=np.uint64)):
        out |= ((values >> np.uint64(i)) & np.uint64(1)) << pos
    return out
