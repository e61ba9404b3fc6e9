"""The bottom layer of reports: blocks (what a report says), renderers (Markdown,
self-contained HTML, CSV, plain text) and statistics over seeds (:class:`Stat`). Results
build their tables as :class:`Table` once; every format is rendered from it. Imports
nothing else of noisybolt."""

from __future__ import annotations

from noisybolt.experiments.reporting.blocks import (
    Block,
    Code,
    Heading,
    Image,
    Link,
    Table,
    Text,
    flat,
)  # fmt: skip
from noisybolt.experiments.reporting.numbers import (
    Stat,
    format_frames,
    format_number,
    frames_reached,
    mark,
    percent,
    pm,
    summarise,
)  # fmt: skip
from noisybolt.experiments.reporting.render import (
    render_csv,
    render_html,
    render_markdown,
    render_text,
)  # fmt: skip

__all__ = [
    "Block", "Code", "Heading", "Image", "Link", "Stat", "Table", "Text", "flat",
    "format_frames", "format_number", "frames_reached", "mark", "percent", "pm",
    "render_csv", "render_html", "render_markdown", "render_text", "summarise",
]  # fmt: skip
