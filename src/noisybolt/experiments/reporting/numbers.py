"""How numbers are shown in every table (one place, so tables agree)."""

from __future__ import annotations

from typing import Any

__all__ = ["format_frames", "format_number", "mark", "percent", "pm"]


def pm(stat: Any, digits: int = 2) -> str:
    """``mean ± std`` of anything with ``mean`` and ``std`` (a ``Stat``); ``—`` for None.

    Example:
        >>> from types import SimpleNamespace
        >>> pm(SimpleNamespace(mean=89.44, std=0.081)), pm(None)
        ('89.44 ± 0.08', '—')
    """
    return "—" if stat is None else f"{stat.mean:.{digits}f} ± {stat.std:.{digits}f}"


def percent(value: float | None) -> str:
    """``0.95`` -> ``95%``; None -> ``—``."""
    return "—" if value is None else f"{value:.0%}"


def format_number(value: float | None) -> str:
    """Shortest form (``89.5``, ``94``); None -> ``—``."""
    return "—" if value is None else f"{value:g}"


def mark(value: bool | None) -> str:
    """✓, ✗, or ``?`` when undecided."""
    return {True: "✓", False: "✗", None: "?"}[value]


def format_frames(value: float | None) -> str:
    """``12345`` -> ``12.3k``; None -> ``—``.

    Example:
        >>> format_frames(12345), format_frames(2_500_000), format_frames(None)
        ('12.3k', '2.5M', '—')
    """
    if value is None:
        return "—"
    if value >= 1_000_000:
        return f"{value / 1_000_000:.1f}M"
    if value >= 1_000:
        return f"{value / 1_000:.1f}k"
    return f"{value:.0f}"
