"""Statistics over seeds (mean ± std), and how every table shows numbers (one place, so
tables agree)."""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from typing import Any, NamedTuple

import numpy as np

__all__ = [
    "Stat", "format_frames", "format_number", "frames_reached", "mark", "percent", "pm",
    "summarise",
]  # fmt: skip


class Stat(NamedTuple):
    """Mean and standard deviation (numpy's, ddof=0) over ``n`` values."""

    mean: float
    std: float
    n: int

    @classmethod
    def of(cls, values: Iterable[float]) -> Stat | None:
        """The statistic of ``values``; None when there are none.

        Example:
            >>> Stat.of([1.0, 3.0])
            Stat(mean=2.0, std=1.0, n=2)
        """
        a = np.asarray(list(values), dtype=np.float64)
        return cls(float(a.mean()), float(a.std()), a.size) if a.size else None

    @classmethod
    def from_dict(cls, data: Mapping[str, Any] | None) -> Stat | None:
        """Reads ``_asdict()``'s output back (None stays None)."""
        return (
            None if data is None else cls(float(data["mean"]), float(data["std"]), int(data["n"]))
        )


def summarise(rows: Iterable[Mapping[str, float | None]]) -> dict[str, Stat]:
    """Mean ± std of each key over the rows that give it a value (not None), in the order
    keys first appear: one group's row of a results table (e.g. a row per seed).

    Example:
        >>> summarise([{"r": 1.0, "n": None}, {"r": 3.0, "n": 5.0}])
        {'r': Stat(mean=2.0, std=1.0, n=2), 'n': Stat(mean=5.0, std=0.0, n=1)}
    """
    values: dict[str, list[float]] = {}
    for row in rows:
        for key, value in row.items():
            values.setdefault(key, []).extend([] if value is None else [value])
    return {key: stat for key, v in values.items() if (stat := Stat.of(v))}


def pm(stat: Stat | None, digits: int = 2) -> str:
    """``mean ± std``; ``—`` for None.

    Example:
        >>> pm(Stat(89.44, 0.081, 3)), pm(None)
        ('89.44 ± 0.08', '—')
    """
    return "—" if stat is None else f"{stat.mean:.{digits}f} ± {stat.std:.{digits}f}"


def percent(value: float | Stat | None) -> str:
    """``0.95`` -> ``95%`` (a statistic: its mean); None -> ``—``."""
    value = value.mean if isinstance(value, Stat) else value
    return "—" if value is None else f"{value:.0%}"


def format_number(value: float | None) -> str:
    """Shortest form (``89.5``, ``94``); None -> ``—``."""
    return "—" if value is None else f"{value:g}"


def mark(value: bool | None) -> str:
    """✓, ✗, or ``?`` when undecided."""
    return {True: "✓", False: "✗", None: "?"}[value]


def frames_reached(stat: Stat | None, n_reached: int, n_done: int) -> str:
    """N_frames: the mean over the ``n_reached`` seeds that reached it, with a count unless
    every one of the ``n_done`` finished seeds did.

    Example:
        >>> frames_reached(Stat(12_000.0, 0.0, 2), 2, 3), frames_reached(None, 0, 0)
        ('12.0k (2/3)', '— (0/0)')
    """
    text = format_frames(stat.mean if stat else None)
    return text if n_done and n_reached == n_done else f"{text} ({n_reached}/{n_done})"


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
