"""Reports of runs and sweeps: Markdown and self-contained HTML, viewable offline.

* :func:`run_report` writes ``report.md`` and ``report.html`` in a run directory: the
  exact command, the final evaluation, learning curves (``curves.png``, drawn from
  ``metrics.json``), any GIFs and trajectory heat-maps saved in the run directory
  (``noisybolt evaluate RUN --gif RUN/episode.gif --heatmap RUN/heatmap.png``), every
  periodic evaluation, and the resolved config.
* :func:`sweep_report` writes the same pair in a sweep directory: the results table
  (mean ± std over seeds), one learning-curve figure per group (every seed drawn), the
  reproduced Table 1 or case-4 measurement when the sweep is one of those, every trial
  with a link to its own run report, and the failures with their errors.
* :func:`write_report` picks the right one for a directory (``noisybolt report DIR``).

The Markdown links its pictures relatively (view it in place); the HTML embeds them as
``data:`` URIs, so the one file can be copied anywhere and opened without a network.

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
"""

from __future__ import annotations

import base64
import html
import io
import json
import os
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, NamedTuple

from noisybolt.errors import ConfigError
from noisybolt.io import atomic_write_bytes, atomic_write_text

__all__ = [
    "Block",
    "Code",
    "Heading",
    "Image",
    "Link",
    "ReportFiles",
    "Table",
    "Text",
    "group_curves",
    "plot_learning_curves",
    "render_html",
    "render_markdown",
    "run_report",
    "sweep_report",
    "write_report",
]


# ---------------------------------------------------------------------- document model
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
    """A table of text cells (or :class:`Link` s)."""

    header: tuple[str, ...]
    rows: tuple[tuple[str | Link, ...], ...]


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


Block = Heading | Text | Table | Code | Image


class ReportFiles(NamedTuple):
    """The two files a report is written as."""

    markdown: Path
    html: Path


def _md_cell(cell: str | Link) -> str:
    text = f"[{cell.text}]({cell.stem}.md)" if isinstance(cell, Link) else cell
    return text.replace("|", "\\|").replace("\n", " ")


def render_markdown(blocks: Sequence[Block]) -> str:
    """The blocks as Markdown (pictures linked relatively)."""
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
            rows = []
            for row in block.rows:
                cells = []
                for cell in row:
                    if isinstance(cell, Link):
                        href = html.escape(cell.stem + ".html")
                        cells.append(f'<td><a href="{href}">{html.escape(cell.text)}</a></td>')
                    else:
                        cells.append(f"<td>{_inline_html(cell)}</td>")
                rows.append("<tr>" + "".join(cells) + "</tr>")
            body.append(
                f"<table><thead><tr>{head}</tr></thead><tbody>{''.join(rows)}</tbody></table>"
            )
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


def _write(blocks: Sequence[Block], folder: Path, title: str, *, write_html: bool) -> ReportFiles:
    markdown = folder / "report.md"
    page = folder / "report.html"
    atomic_write_text(markdown, render_markdown(blocks))
    if write_html:
        atomic_write_text(page, render_html(blocks, base_dir=folder, title=title))
    return ReportFiles(markdown=markdown, html=page)


# ---------------------------------------------------------------------- learning curves
_SEED_COLOURS = ("#0072b2", "#e69f00", "#009e73", "#cc79a7", "#56b4e9", "#d55e00", "#f0e442")


def plot_learning_curves(
    curves: Mapping[str, Sequence[Mapping[str, Any]]],
    path: str | os.PathLike[str],
    *,
    title: str,
    reference_return: float | None = None,
    success_threshold: float = 0.95,
) -> Path:
    """Draws environment return and compliance against frames, one line per run.

    Args:
        curves: label (e.g. ``"seed 0"``) -> that run's ``metrics.json`` records.
        path: the PNG to write (atomically; folders are created).
        title: the figure's title.
        reference_return: drawn as a dashed line on the return panel (e.g. R^c_max).
        success_threshold: drawn on the compliance panel.

    Returns:
        ``path`` as a :class:`~pathlib.Path`.

    Raises:
        ConfigError: no run has a single evaluation.
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    if not any(curves.values()):
        raise ConfigError(f"no evaluations to plot for {title!r}")
    fig = Figure(figsize=(11.0, 3.8), dpi=100)
    FigureCanvasAgg(fig)
    ret_ax, comp_ax = fig.subplots(1, 2)
    styles = ("-", "--", ":", "-.")
    for index, (label, records) in enumerate(curves.items()):
        if not records:
            continue
        colour = _SEED_COLOURS[index % len(_SEED_COLOURS)]
        frames = [r["frames"] for r in records]
        ret_ax.plot(frames, [r["env_return_mean"] for r in records], color=colour, label=label)
        specs = list(records[0].get("compliance", {}))
        for k, spec in enumerate(specs):
            comp_ax.plot(
                frames,
                [r["compliance"].get(spec, float("nan")) for r in records],
                color=colour,
                ls=styles[k % len(styles)],
                label=f"{label}: {spec}" if len(specs) > 1 else label,
            )
        comp_ax.plot(frames, [r["success_rate"] for r in records], color=colour, lw=0.8, alpha=0.45)
    if reference_return is not None:
        ret_ax.axhline(reference_return, color="#444", ls="--", lw=1, label="R^c_max")
    comp_ax.axhline(success_threshold, color="#444", ls="--", lw=1)
    ret_ax.set_title("environment return (R_π)")
    comp_ax.set_title("compliance (thick) and goal & compliant (thin), ground truth")
    comp_ax.set_ylim(-0.03, 1.03)
    for ax in (ret_ax, comp_ax):
        ax.set_xlabel("frames")
        ax.grid(alpha=0.3)
    ret_ax.legend(fontsize=7, loc="lower right")
    fig.suptitle(title)
    fig.tight_layout()
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png")
    atomic_write_bytes(path, buffer.getvalue())
    return Path(path)


def _read_json(path: Path) -> Any:
    try:
        return json.loads(path.read_text())
    except (FileNotFoundError, json.JSONDecodeError, UnicodeDecodeError):
        return None


def _slug(text: str) -> str:
    return re.sub(r"[^A-Za-z0-9._=+-]+", "_", text).strip("_") or "group"


def group_curves(
    sweep_dir: str | os.PathLike[str],
    *,
    references: Mapping[str, float | None] | None = None,
    folder: str = "curves",
) -> dict[str, Path]:
    """One learning-curve PNG per group of a sweep (every seed drawn): group -> path.

    Args:
        sweep_dir: the sweep directory.
        references: per group, a return to draw as a dashed line (e.g. R^c_max).
        folder: where under ``sweep_dir`` the PNGs go (``<folder>/<group>.png``).
    """
    from noisybolt.experiments.sweep import collect_sweep

    sweep_dir = Path(sweep_dir)
    result = collect_sweep(sweep_dir, write=False)
    by_group: dict[str, dict[str, list[dict[str, Any]]]] = {}
    for record in result.records:
        metrics = _read_json(record.run_dir / "metrics.json") or []
        by_group.setdefault(record.group, {})[f"seed {record.seed}"] = metrics
    paths = {}
    for group, curves in by_group.items():
        if not any(curves.values()):
            continue
        path = sweep_dir / folder / f"{_slug(group)}.png"
        reference = (references or {}).get(group)
        paths[group] = plot_learning_curves(curves, path, title=group, reference_return=reference)
    return paths


# ---------------------------------------------------------------------- run reports
def _final_table(final: Mapping[str, Any]) -> Table:
    from noisybolt.agents.evaluation import describe_false_acceptance

    rows: list[tuple[str | Link, ...]] = [
        ("episodes", str(final.get("n_episodes", "?"))),
        (
            "env return R_π",
            f"{final['env_return_mean']:.2f} ± {final.get('env_return_std', 0.0):.2f}",
        ),
        ("bolt return (shaping, apart)", f"{final.get('bolt_return_mean', 0.0):.2f}"),
        ("episode length N_steps", f"{final['length_mean']:.1f}"),
        ("goal rate", f"{final['goal_rate']:.0%}"),
    ]
    for name, rate in final.get("compliance", {}).items():
        rows.append((f"compliance [{name}]", f"{rate:.0%}"))
    rows.append(("goal and compliant", f"{final['success_rate']:.0%}"))
    falsely = describe_false_acceptance(final)
    if falsely is not None:
        rows.append(("bolt falsely accepting (episodes)", falsely))
    return Table(("metric", "value"), tuple(rows))


def _metrics_table(records: Sequence[Mapping[str, Any]]) -> Table:
    specs = list(records[0].get("compliance", {})) if records else []
    header = ("frames", "R_π", "N_steps", "goal", *[f"compliance [{s}]" for s in specs], "success")
    rows = []
    for r in records:
        rows.append(
            (
                f"{r['frames']:,}",
                f"{r['env_return_mean']:.2f}",
                f"{r['length_mean']:.1f}",
                f"{r['goal_rate']:.0%}",
                *[f"{r['compliance'].get(s, float('nan')):.0%}" for s in specs],
                f"{r['success_rate']:.0%}",
            )
        )
    return Table(header, tuple(rows))


def run_report(
    run_dir: str | os.PathLike[str],
    *,
    html_page: bool = True,
    config: Mapping[str, Any] | None = None,
) -> ReportFiles:
    """Writes ``report.md`` (and ``report.html``) in a run directory.

    Args:
        run_dir: the run directory.
        html_page: also write the self-contained HTML page.
        config: the run's config when the directory has none yet (a sweep trial that
            failed before training started); ``config.json`` wins when present.

    Raises:
        ConfigError: the directory holds no run (no ``config.json``) and no config was given.
    """
    run = Path(run_dir)
    saved = _read_json(run / "config.json")
    if isinstance(saved, dict):
        config = saved
    if config is None:
        raise ConfigError(f"{run} holds no run (no readable config.json)")
    config = dict(config)
    blocks: list[Block] = [Heading(f"Run {run.name}")]
    command = (run / "command.txt").read_text().strip() if (run / "command.txt").exists() else ""
    specs = ", ".join(
        f"`{s.get('name') or s.get('formula')}` = `{s.get('formula')}`"
        for s in config.get("specs", [])
    )
    blocks.append(
        Text(
            f"**{str(config.get('algo', '?')).upper()}** on `{config.get('world')}` "
            f"({json.dumps(config.get('world_kwargs', {}))}), detector "
            f"`{config.get('detector', {}).get('kind')}`, seed {config.get('seed')}; specs: "
            f"{specs}."
        )
    )
    if command:
        blocks.append(Text(f"Command: `{command}`"))

    summary = _read_json(run / "summary.json")
    evaluation = _read_json(run / "evaluation.json")
    blocks.append(Heading("Final evaluation", 2))
    if isinstance(evaluation, dict):
        blocks.append(
            Text(
                f"`evaluation.json`: {evaluation.get('episodes')} episodes, "
                f"{'greedy' if evaluation.get('deterministic') else 'sampled'} actions, "
                "compliance from ground truth."
            )
        )
        blocks.append(_final_table(evaluation))
    elif isinstance(summary, dict) and summary.get("final"):
        blocks.append(Text("The run's last periodic evaluation (`summary.json`)."))
        blocks.append(_final_table(summary["final"]))
    else:
        blocks.append(Text("The run has not finished (no `summary.json`)."))
    if isinstance(summary, dict):
        reached = summary.get("frames_to_comply")
        blocks.append(
            Text(
                f"Frames trained: {summary.get('frames', 0):,}. N_frames (first evaluation with "
                f"≥ {config.get('success_threshold', 0.95):.0%} of episodes at the goal and "
                f"compliant): {f'{reached:,}' if reached is not None else 'not reached'}."
            )
        )

    metrics = _read_json(run / "metrics.json") or []
    if metrics:
        plot_learning_curves(
            {f"seed {config.get('seed')}": metrics}, run / "curves.png", title=run.name
        )
        blocks += [Heading("Learning curves", 2), Image("curves.png", "learning curves")]
    pictures = sorted(run.glob("*.gif")) + sorted(
        p for p in run.glob("*.png") if "heatmap" in p.name
    )
    if pictures:
        blocks.append(Heading("Policy", 2))
        blocks += [Image(p.name, p.stem) for p in pictures]
    if metrics:
        blocks += [Heading("Evaluations during training", 2), _metrics_table(metrics)]
    failure = _read_json(run / "failure.json")
    if isinstance(failure, dict) and failure.get("attempts"):
        last = failure["attempts"][-1]
        blocks += [
            Heading("Failed attempts", 2),
            Text(f"{len(failure['attempts'])} failed attempt(s); the last: `{last['message']}`"),
            Code(last.get("traceback", "")),
        ]
    blocks += [Heading("Config", 2), Code(json.dumps(config, indent=2, sort_keys=True), "json")]
    return _write(blocks, run, f"noisybolt run {run.name}", write_html=html_page)


# ---------------------------------------------------------------------- sweep reports
def sweep_report(
    sweep_dir: str | os.PathLike[str], *, run_reports: bool = True, html_page: bool = True
) -> ReportFiles:
    """Writes ``report.md`` (and ``report.html``) in a sweep directory.

    Args:
        sweep_dir: the sweep directory (``noisybolt sweep``, ``reproduce table1`` or
            ``reproduce case4`` output).
        run_reports: also write every trial's run report, linked from the trials table.
        html_page: also write the self-contained HTML page.

    Raises:
        ConfigError: the directory holds no sweep.
    """
    from noisybolt.experiments.sweep import (
        SWEEP_FILE,
        collect_sweep,
        format_frames,
        n_frames_text,
    )

    root = Path(sweep_dir)
    result = collect_sweep(root)
    blocks: list[Block] = [Heading(f"Sweep {result.name}")]
    command = (root / "command.txt").read_text().strip() if (root / "command.txt").exists() else ""
    if command:
        blocks.append(Text(f"Command: `{command}`"))
    counts = {s: sum(r.status == s for r in result.records) for s in ("done", "failed", "pending")}
    blocks.append(
        Text(
            f"{len(result.records)} trials: {counts['done']} done, {counts['failed']} failed, "
            f"{counts['pending']} pending."
        )
    )
    references: dict[str, float | None] = {}
    if (root / "table1.json").exists():
        from noisybolt.experiments.table1 import table1_report_blocks

        table_blocks, references = table1_report_blocks(root)
        blocks += table_blocks
    if (root / "case4.json").exists():
        from noisybolt.experiments.case4 import case4_report_blocks

        blocks += case4_report_blocks(root)

    blocks.append(Heading("Results", 2))
    rows = []
    for g in result.groups:
        rows.append(
            (
                g.group,
                g.algo,
                ", ".join(g.spec_names),
                f"{g.n_done}/{g.n_trials}",
                str(g.n_failed),
                "—"
                if g.env_return is None
                else f"{g.env_return.mean:.2f} ± {g.env_return.std:.2f}",
                "—" if g.length is None else f"{g.length.mean:.1f} ± {g.length.std:.1f}",
                "—" if g.goal_rate is None else f"{g.goal_rate.mean:.0%}",
                ", ".join(f"{k} {v.mean:.0%}" for k, v in g.compliance.items()) or "—",
                n_frames_text(g),
            )
        )
    blocks.append(
        Table(
            (
                "group",
                "algo",
                "specs",
                "seeds done",
                "failed",
                "R_π",
                "N_steps",
                "goal rate",
                "compliance",
                "N_frames",
            ),
            tuple(rows),
        )
    )
    blocks.append(
        Text(
            "Mean ± std over seeds of each finished trial's final evaluation; compliance and "
            "goal from ground truth. Tables: `results.md`, `results.csv`, `results.json`."
        )
    )
    curves = group_curves(root, references=references)
    if curves:
        blocks.append(Heading("Learning curves", 2))
        for group, path in curves.items():
            blocks.append(Image(path.relative_to(root).as_posix(), f"learning curves of {group}"))

    blocks.append(Heading("Trials", 2))
    trial_rows = []
    configs = {t["id"]: t.get("config") for t in _read_json(root / SWEEP_FILE)["trials"]}
    for record in result.records:
        link: str | Link = record.trial_id
        if run_reports and record.run_dir.is_dir():
            run_report(record.run_dir, html_page=html_page, config=configs.get(record.trial_id))
            link = Link(record.trial_id, (Path("trials") / record.trial_id / "report").as_posix())
        final = record.final or {}
        trial_rows.append(
            (
                link,
                record.status,
                f"{final['env_return_mean']:.2f}" if final else "—",
                ", ".join(f"{k} {v:.0%}" for k, v in final.get("compliance", {}).items()) or "—",
                format_frames(record.frames_to_comply) if record.status == "done" else "—",
                str(record.failed_attempts),
                f"{record.seconds:.0f} s" if record.seconds else "—",
            )
        )
    blocks.append(
        Table(
            ("trial", "status", "R_π", "compliance", "N_frames", "failed attempts", "time"),
            tuple(trial_rows),
        )
    )
    failed = [r for r in result.records if r.status == "failed"]
    if failed:
        blocks.append(Heading("Failures", 2))
        for record in failed:
            blocks.append(Text(f"`{record.trial_id}`: {record.error}"))
    return _write(blocks, root, f"noisybolt sweep {result.name}", write_html=html_page)


def write_report(path: str | os.PathLike[str], *, html_page: bool = True) -> ReportFiles:
    """The report of a run directory or a sweep directory, whichever ``path`` holds.

    Raises:
        ConfigError: ``path`` holds neither a run nor a sweep.
    """
    from noisybolt.experiments.sweep import SWEEP_FILE

    folder = Path(path)
    if (folder / SWEEP_FILE).exists():
        return sweep_report(folder, html_page=html_page)
    if (folder / "config.json").exists():
        return run_report(folder, html_page=html_page)
    raise ConfigError(
        f"{folder} holds neither a run (config.json) nor a sweep ({SWEEP_FILE}): give the "
        "directory that `noisybolt train`, `sweep` or `reproduce` wrote"
    )
