"""Renderers: blocks as Markdown, self-contained HTML, CSV or plain text.

Example:
    >>> blocks = [Heading("Run"), Text("Command: `noisybolt train`"),
    ...           Table(("metric", "value"), (("R_π", "89.5"),))]
    >>> print(render_markdown(blocks))
    # Run
    <BLANKLINE>
    Command: `noisybolt train`
    <BLANKLINE>
    | metric | value |
    |---|---|
    | R_π | 89.5 |
    <BLANKLINE>
    >>> print(render_text(blocks[2:]))
    R_π  89.5
"""

from __future__ import annotations

import base64
import csv
import html
import io
import re
from collections.abc import Sequence
from pathlib import Path

from noisybolt.experiments.reporting.blocks import Block, Code, Heading, Link, Table, Text

__all__ = ["render_csv", "render_html", "render_markdown", "render_text"]


def _md_cell(cell: str | Link) -> str:
    text = f"[{cell.text}]({cell.stem}.md)" if isinstance(cell, Link) else cell
    return text.replace("|", "\\|").replace("\n", " ")


def render_markdown(blocks: Sequence[Block]) -> str:
    """The blocks as Markdown (pictures linked relatively), a blank line between blocks."""
    parts: list[str] = []
    for block in blocks:
        if isinstance(block, Heading):
            parts.append(f"{'#' * block.level} {block.text}\n")
        elif isinstance(block, Text):
            parts.append(block.text + "\n")
        elif isinstance(block, Table):
            lines = ["| " + " | ".join(_md_cell(h) for h in block.header) + " |"]
            lines.append("|" + "---|" * len(block.header))
            lines += ["| " + " | ".join(_md_cell(c) for c in row) + " |" for row in block.rows]
            parts.append("\n".join(lines) + "\n")
        elif isinstance(block, Code):
            parts.append(f"```{block.lang}\n{block.text.rstrip()}\n```\n")
        else:
            parts.append(f"![{block.alt}]({block.path})\n")
    return "\n".join(parts)


def render_text(blocks: Sequence[Block]) -> str:
    """The blocks as plain text for a terminal: tables as aligned columns, no header row
    for a two-column table (a list of ``name  value`` lines)."""
    parts: list[str] = []
    for block in blocks:
        if isinstance(block, Table):
            rows = [tuple(c.text if isinstance(c, Link) else c for c in r) for r in block.rows]
            if len(block.header) != 2:
                rows.insert(0, block.header)
            widths = [max(len(r[i]) for r in rows) for i in range(len(block.header))]
            parts.append(
                "\n".join(
                    "  ".join(c.ljust(w) for c, w in zip(r, widths, strict=True)).rstrip()
                    for r in rows
                )
            )
        elif isinstance(block, Heading | Text | Code):
            parts.append(block.text.rstrip())
        else:
            parts.append(f"[picture: {block.path}]")
    return "\n\n".join(parts)


def render_csv(table: Table) -> str:
    """A table's machine-readable form as CSV (``\\n`` line ends)."""
    header, rows = table.data()
    out = io.StringIO()
    writer = csv.writer(out, lineterminator="\n")
    writer.writerow(header)
    writer.writerows(rows)
    return out.getvalue()


_INLINE = re.compile(r"`([^`]+)`|\*\*([^*]+)\*\*|\[([^\]]+)\]\(([^)\s]+)\)")


def _inline_html(text: str) -> str:
    out, last = [], 0
    for match in _INLINE.finditer(text):
        out.append(html.escape(text[last : match.start()]))
        code, bold, label, href = match.groups()
        if code is not None:
            out.append(f"<code>{html.escape(code)}</code>")
        elif bold is not None:
            out.append(f"<strong>{html.escape(bold)}</strong>")
        else:
            if href.endswith(".md"):
                href = href[:-3] + ".html"
            out.append(f'<a href="{html.escape(href)}">{html.escape(label)}</a>')
        last = match.end()
    out.append(html.escape(text[last:]))
    return "".join(out)


_MIME = {".png": "image/png", ".gif": "image/gif", ".jpg": "image/jpeg", ".svg": "image/svg+xml"}
_STYLE = """
body { font-family: system-ui, sans-serif; max-width: 78rem; margin: 2rem auto; padding: 0 1rem;
       color: #222; line-height: 1.45; }
table { border-collapse: collapse; margin: 0.8rem 0; font-size: 0.92rem; }
th, td { border: 1px solid #ccc; padding: 0.25rem 0.55rem; text-align: left; }
th { background: #f3f3f3; }
tr:nth-child(even) td { background: #fafafa; }
pre { background: #f6f8fa; padding: 0.8rem; overflow-x: auto; font-size: 0.85rem; }
code { background: #f6f8fa; padding: 0 0.2rem; }
img { max-width: 100%; border: 1px solid #eee; margin: 0.4rem 0; }
"""


def _html_cell(cell: str | Link) -> str:
    if isinstance(cell, Link):
        return f'<td><a href="{html.escape(cell.stem + ".html")}">{html.escape(cell.text)}</a></td>'
    return f"<td>{_inline_html(cell)}</td>"


def render_html(blocks: Sequence[Block], *, base_dir: Path, title: str) -> str:
    """The blocks as one self-contained HTML page (pictures embedded as ``data:`` URIs)."""
    body: list[str] = []
    for block in blocks:
        if isinstance(block, Heading):
            level = min(max(block.level, 1), 6)
            body.append(f"<h{level}>{html.escape(block.text)}</h{level}>")
        elif isinstance(block, Text):
            body.append(f"<p>{_inline_html(block.text)}</p>")
        elif isinstance(block, Table):
            head = "".join(f"<th>{_inline_html(h)}</th>" for h in block.header)
            rows = "".join("<tr>" + "".join(map(_html_cell, r)) + "</tr>" for r in block.rows)
            body.append(f"<table><thead><tr>{head}</tr></thead><tbody>{rows}</tbody></table>")
        elif isinstance(block, Code):
            body.append(f"<pre><code>{html.escape(block.text.rstrip())}</code></pre>")
        else:
            path = base_dir / block.path
            mime = _MIME.get(path.suffix.lower(), "application/octet-stream")
            if path.exists():
                data = base64.b64encode(path.read_bytes()).decode("ascii")
                body.append(f'<img src="data:{mime};base64,{data}" alt="{html.escape(block.alt)}">')
            else:
                body.append(f"<p><em>missing picture: {html.escape(block.path)}</em></p>")
    return (
        '<!DOCTYPE html>\n<html lang="en"><head><meta charset="utf-8">'
        f"<title>{html.escape(title)}</title><style>{_STYLE}</style></head><body>\n"
        + "\n".join(body)
        + "\n</body></html>\n"
    )
