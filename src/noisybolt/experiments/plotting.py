"""Every figure of the experiments' reports, drawn with matplotlib's object API.

One place sets matplotlib up: figures are made without pyplot (no global state, no
display needed) and saved atomically as PNG.
"""

from __future__ import annotations

import io
import os
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from noisybolt.errors import ConfigError
from noisybolt.io import atomic_write_bytes

__all__ = ["COLOURS", "new_figure", "plot_learning_curves", "plot_shares", "save_png"]

#: Colour-blind-safe colours (Okabe and Ito), one per run or condition.
COLOURS = ("#0072b2", "#e69f00", "#009e73", "#cc79a7", "#56b4e9", "#d55e00", "#f0e442")


def new_figure(width: float, height: float) -> Any:
    """A figure with an Agg canvas attached (no pyplot, so no GUI backend is touched)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(width, height), dpi=100)
    FigureCanvasAgg(fig)
    return fig


def save_png(fig: Any, path: str | os.PathLike[str]) -> Path:
    """Lays the figure out and writes it as a PNG, atomically (folders are created)."""
    fig.tight_layout()
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png")
    atomic_write_bytes(path, buffer.getvalue())
    return Path(path)


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
        path: the PNG to write.
        title: the figure's title.
        reference_return: drawn as a dashed line on the return panel (e.g. R^c_max).
        success_threshold: drawn on the compliance panel.

    Raises:
        ConfigError: no run has a single evaluation.
    """
    if not any(curves.values()):
        raise ConfigError(f"no evaluations to plot for {title!r}")
    fig = new_figure(11.0, 3.8)
    ret_ax, comp_ax = fig.subplots(1, 2)
    styles = ("-", "--", ":", "-.")
    for index, (label, records) in enumerate(curves.items()):
        if not records:
            continue
        colour = COLOURS[index % len(COLOURS)]
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
    comp_ax.set_title(
        "compliance (thick) and goal & compliant (thin; without a goal: every spec), ground truth",
        fontsize=9,
    )
    comp_ax.set_ylim(-0.03, 1.03)
    for ax in (ret_ax, comp_ax):
        ax.set_xlabel("frames")
        ax.grid(alpha=0.3)
    ret_ax.legend(fontsize=7, loc="lower right")
    fig.suptitle(title)
    return save_png(fig, path)


def plot_shares(
    shares: Mapping[str, Sequence[Mapping[str, float]]],
    categories: Mapping[str, str],
    path: str | os.PathLike[str],
    *,
    title: str,
    legend: str,
    ylabel: str = "share of evaluation episodes",
) -> Path:
    """Bars of each category's share per condition (pooled), with a dot per run.

    Args:
        shares: condition -> per run, ``(category -> share, "weight" -> episodes)``.
        categories: category key -> its label on the axis, in order.
        path: the PNG to write.
        title: the figure's title.
        legend: the legend's title (what the conditions are).
        ylabel: the value axis's label.
    """
    fig = new_figure(8.0, 3.8)
    ax = fig.add_subplot(1, 1, 1)
    keys = list(categories)
    width = 0.8 / max(1, len(shares))
    for c, (condition, runs) in enumerate(shares.items()):
        if not runs:
            continue
        total = sum(run["weight"] for run in runs)
        for k, key in enumerate(keys):
            xpos = k + (c - (len(shares) - 1) / 2) * width
            pooled = sum(run[key] * run["weight"] for run in runs) / total
            colour = (COLOURS[5], COLOURS[0], COLOURS[2], "#999999")[c % 4]
            ax.bar(
                xpos, pooled, width * 0.95, color=colour, alpha=0.75, label=None if k else condition
            )
            ax.scatter(
                [xpos] * len(runs), [run[key] for run in runs], color="black", s=10, zorder=3
            )
    ax.set_xticks(range(len(keys)), [categories[k] for k in keys])
    ax.set_ylabel(ylabel)
    ax.set_ylim(0, 1.05)
    ax.set_title(title)
    ax.legend(title=legend)
    ax.grid(axis="y", alpha=0.3)
    return save_png(fig, path)
