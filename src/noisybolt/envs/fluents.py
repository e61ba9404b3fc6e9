"""Choosing a world's fluents: the bolt's vocabulary is a subset of what the world offers."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from noisybolt.errors import ConfigError, UnknownFluentError

__all__ = ["select_fluents"]


def select_fluents(
    world: str, available: Sequence[str], fluents: Sequence[str] | str | None
) -> tuple[tuple[str, ...], np.ndarray]:
    """Checks a fluent selection; returns it with its columns among ``available``.

    Args:
        world: the world's name, for messages.
        available: every fluent the world computes, in its column order.
        fluents: the names wanted, in the order wanted (a single name may be a string);
            None for all of them.

    Raises:
        UnknownFluentError: a name the world does not have (the message lists them).
        ConfigError: a repeated name.

    Example:
        >>> select_fluents("toy", ("a", "b", "c"), ["c", "a"])
        (('c', 'a'), array([2, 0]))
    """
    available = tuple(available)
    if fluents is None:
        return available, np.arange(len(available), dtype=np.intp)
    names = (fluents,) if isinstance(fluents, str) else tuple(fluents)
    unknown = tuple(n for n in names if n not in available)
    if unknown:
        raise UnknownFluentError(
            f"unknown {world} fluent(s) {', '.join(map(repr, unknown))}; known: "
            f"{', '.join(available)}",
            unknown=unknown,
            known=available,
        )
    if len(set(names)) != len(names):
        raise ConfigError(f"fluents must not repeat a name, got {names}")
    return names, np.array([available.index(n) for n in names], dtype=np.intp)
