"""The blocks a report is made of: what it says, not how it is written down.

Renderers (:mod:`noisybolt.experiments.reporting.render`) turn a list of blocks into
Markdown, HTML, CSV or plain text; results build their tables once, as :class:`Table`.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

__all__ = ["Block", "Code", "Heading", "Image", "Link", "Table", "Text", "flat"]


@dataclass(frozen=True)
class Heading:
    """A section title (level 1 is the document's title)."""

    text: str
    level: int = 1


@dataclass(frozen=True)
class Text:
    """A paragraph; may hold ``code`` spans, **bold** and [links](target)."""

    text: str


@dataclass(frozen=True)
class Link:
    """A link to another report, by its path without suffix (``.md`` or ``.html`` added)."""

    text: str
    stem: str


@dataclass(frozen=True)
class Table:
    """A table: cells as people read them, and optionally as machines read them.

    Attributes:
        header: the column titles.
        rows: the displayed cells (text, or :class:`Link` s).
        data_header: the columns of the machine-readable form (CSV); empty: as shown.
        data_rows: its rows (raw numbers, one column per mean and std, ...).

    Example:
        >>> table = Table(("metric", "value"), (("R_π", "89.5 ± 0.1"),),
        ...               data_header=("metric", "mean", "std"), data_rows=(("R_π", 89.5, 0.1),))
        >>> table.data()
        (('metric', 'mean', 'std'), (('R_π', 89.5, 0.1),))
    """

    header: tuple[str, ...]
    rows: tuple[tuple[str | Link, ...], ...]
    data_header: tuple[str, ...] = ()
    data_rows: tuple[tuple[Any, ...], ...] = ()

    @classmethod
    def of(
        cls, header: tuple[str, ...], rows: tuple[tuple[str | Link, ...], ...],
        records: Sequence[Mapping[str, Any]],
    ) -> Table:  # fmt: skip
        """The table shown as ``rows`` whose machine-readable form is ``records`` (JSON
        data: one per row) flattened by :func:`flat`, a column per key any record has."""
        flats = [flat(r) for r in records]
        keys = tuple(dict.fromkeys(k for f in flats for k in f))
        return cls(header, rows, keys, tuple(tuple(f.get(k, "") for k in keys) for f in flats))

    def data(self) -> tuple[tuple[str, ...], Sequence[tuple[Any, ...]]]:
        """The machine-readable header and rows (the displayed ones when none were given)."""
        if self.data_header:
            return self.data_header, self.data_rows
        shown = tuple(tuple(c.text if isinstance(c, Link) else c for c in r) for r in self.rows)
        return self.header, shown


@dataclass(frozen=True)
class Code:
    """A preformatted block (configs, tracebacks)."""

    text: str
    lang: str = ""


@dataclass(frozen=True)
class Image:
    """A picture, by its path relative to the report."""

    path: str
    alt: str = ""


def flat(record: Mapping[str, Any], prefix: str = "") -> dict[str, Any]:
    """JSON data as one CSV row: nested keys joined by ``_``, lists by ``;``.

    Example:
        >>> flat({"group": "a", "r": {"mean": 2.0, "n": 2}, "specs": ["x", "y"]})
        {'group': 'a', 'r_mean': 2.0, 'r_n': 2, 'specs': 'x;y'}
    """
    out: dict[str, Any] = {}
    for key, value in record.items():
        if isinstance(value, Mapping):
            out.update(flat(value, f"{prefix}{key}_"))
        else:
            out[prefix + key] = ";".join(map(str, value)) if isinstance(value, list) else value
    return out


Block = Heading | Text | Table | Code | Image
