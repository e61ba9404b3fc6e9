"""The bottom layer of reports: blocks (what a report says) and renderers (Markdown,
self-contained HTML, CSV, plain text). Results build their tables as :class:`Table` once;
every format is rendered from it. Imports nothing else of noisybolt."""

from __future__ import annotations

from noisybolt.experiments.reporting.blocks import Block, Code, Heading, Image, Link, Table, Text
from noisybolt.experiments.reporting.numbers import (
    format_frames,
    format_number,
    mark,
    percent,
    pm,
)
from noisybolt.experiments.reporting.render import (
    render_csv,
    render_html,
    render_markdown,
    render_text,
)

__all__ = [
    "Block",
    "Code",
    "Heading",
    "Image",
    "Link",
    "Table",
    "Text",
    "format_frames",
    "format_number",
    "mark",
    "percent",
    "pm",
    "render_csv",
    "render_html",
    "render_markdown",
    "render_text",
]
