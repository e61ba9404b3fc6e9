"""Reports of runs and sweeps: Markdown and self-contained HTML, viewable offline.

* :func:`run_report` writes ``report.md`` and ``report.html`` in a run directory: the
  exact command, the final evaluation, learning curves, any GIFs and trajectory heat-maps
  saved in the run directory, every periodic evaluation, and the resolved config.
* :func:`sweep_report` writes the same pair in a sweep directory: the results table, one
  learning-curve figure per group (every seed drawn), the sections that experiments
  registered (Table 1, case 4) when their files are there, and every trial with a link to
  its own run report.
* :func:`write_report` picks the right one for a directory (``noisybolt report DIR``); a
  directory that holds only a registered section's files (a committed ``results/table1``)
  has that section's files regenerated from its JSON, and a report of it.

This module knows no experiment: experiments call :func:`register_section` when they are
imported (the CLI imports them), so the dependency points from them to here. Blocks and
renderers are :mod:`noisybolt.experiments.reporting`; figures are
:mod:`noisybolt.experiments.plotting`.
"""

from __future__ import annotations

import json
import os
import re
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, NamedTuple

from noisybolt.errors import ConfigError
from noisybolt.experiments.plotting import plot_learning_curves
from noisybolt.experiments.reporting import (
    Block,
    Code,
    Heading,
    Image,
    Link,
    Table,
    Text,
    format_frames,
    percent,
    render_html,
    render_markdown,
)
from noisybolt.experiments.sweeps import SWEEP_FILE, TrialDirectory, collect_sweep
from noisybolt.io import atomic_write_text, read_json
from noisybolt.runs.rundir import CLASSIFIER_STAGES, RunDirectory

__all__ = [
    "ReportFiles",
    "ReportSection",
    "evaluation_table",
    "group_curves",
    "register_section",
    "run_report",
    "sweep_report",
    "write_report",
]


class ReportFiles(NamedTuple):
    """The two files a report is written as."""

    markdown: Path
    html: Path


@dataclass(frozen=True)
class ReportSection:
    """An experiment's part of a report, found by a file it writes.

    Attributes:
        name: the section's name (one section per name).
        marker: the file (in a sweep or results directory) whose presence adds the section.
        blocks: the section's blocks from the directory, and per sweep group a return to
            draw on its learning curves (e.g. R^c_max).
        regenerate: rewrites the section's own files (tables) from its JSON, if it has any.
    """

    name: str
    marker: str
    blocks: Callable[[Path], tuple[list[Block], dict[str, float | None]]]
    regenerate: Callable[[Path], object] | None = None


_SECTIONS: dict[str, ReportSection] = {}


def register_section(section: ReportSection) -> ReportSection:
    """Adds an experiment's section to the reports of directories holding its marker."""
    _SECTIONS[section.name] = section
    return section


def _write(blocks: Sequence[Block], folder: Path, title: str, *, write_html: bool) -> ReportFiles:
    files = ReportFiles(folder / "report.md", folder / "report.html")
    atomic_write_text(files.markdown, render_markdown(blocks))
    if write_html:
        atomic_write_text(files.html, render_html(blocks, base_dir=folder, title=title))
    return files


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
    root = Path(sweep_dir)
    by_group: dict[str, dict[str, list[dict[str, Any]]]] = {}
    for record in collect_sweep(root, write=False).records:
        metrics = RunDirectory(record.run_dir).read_metrics()
        by_group.setdefault(record.group, {})[f"seed {record.seed}"] = metrics
    paths = {}
    for group, curves in by_group.items():
        if any(curves.values()):
            name = re.sub(r"[^A-Za-z0-9._=+-]+", "_", group).strip("_") or "group"
            reference = (references or {}).get(group)
            paths[group] = plot_learning_curves(
                curves, root / folder / f"{name}.png", title=group, reference_return=reference
            )
    return paths


def evaluation_table(
    final: Mapping[str, Any],
    *,
    frames: int | None = None,
    frames_to_comply: int | None = None,
    greedy: bool | None = None,
) -> Table:
    """An evaluation's summary (``EvalResult.to_dict()``) as a metric/value table: what
    ``train`` and ``evaluate`` print and what a run's report shows. ``greedy``: whether
    the policy's actions were its most likely ones or sampled (None: not said); the same
    policy can comply greedily and not when sampled, so the table says which."""
    from noisybolt.runs.evaluation import describe_false_acceptance

    episodes = str(final.get("n_episodes", "?"))
    if greedy is not None:
        episodes += " (greedy actions)" if greedy else " (sampled actions)"
    rows: list[tuple[str, str]] = [
        ("episodes", episodes),
        (
            "env return R_π",
            f"{final['env_return_mean']:.2f} ± {final.get('env_return_std', 0.0):.2f}",
        ),
        (
            "bolt return (its rewards, shaping included)",
            f"{final.get('bolt_return_mean', 0.0):.2f}",
        ),
        ("episode length N_steps", f"{final['length_mean']:.1f}"),
        *((f"compliance [{k}]", percent(v)) for k, v in final.get("compliance", {}).items()),
    ]
    # A world without a goal (goal_rate None) counts compliance alone as success.
    has_goal = final.get("goal_rate") is not None
    if has_goal:
        rows.insert(4, ("goal rate", percent(final["goal_rate"])))
        rows.append(("goal and compliant", percent(final["success_rate"])))
    elif len(final.get("compliance", {})) > 1:
        rows.append(("compliant with every spec", percent(final["success_rate"])))
    falsely = describe_false_acceptance(final)
    if falsely is not None:
        rows.append(("bolt falsely accepting (episodes)", falsely))
    if frames is not None:
        rows.append(("frames trained", f"{frames:,}"))
    if frames is not None or frames_to_comply is not None:
        reached = "not reached" if frames_to_comply is None else f"{frames_to_comply:,}"
        at_goal = " at goal" if has_goal else ""
        rows.append((f"N_frames (first >= 95% compliant{at_goal})", reached))
    return Table(("metric", "value"), tuple(rows))


def _metrics_table(records: Sequence[Mapping[str, Any]]) -> Table:
    specs = list(records[0].get("compliance", {})) if records else []
    header = ("frames", "R_π", "N_steps", "goal", *[f"compliance [{s}]" for s in specs], "success")
    rows = tuple(
        (
            f"{r['frames']:,}",
            f"{r['env_return_mean']:.2f}",
            f"{r['length_mean']:.1f}",
            percent(r["goal_rate"]),
            *[percent(r["compliance"].get(s, float("nan"))) for s in specs],
            percent(r["success_rate"]),
        )
        for r in records
    )
    return Table(header, rows)


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
    saved = read_json(run / "config.json", default=None)
    from noisybolt.runs.legacy import nested_config  # the flat configs of older runs too

    config = dict(saved if isinstance(saved, dict) else config or {})
    if not config:
        raise ConfigError(f"{run} holds no run (no readable config.json)")
    config = nested_config(config)
    world = config.get("world", {})
    specs = ", ".join(_spec_label(s) for s in config["bolt"].get("specs", []))
    blocks: list[Block] = [
        Heading(f"Run {run.name}"),
        Text(
            f"**{str(config.get('algorithm', {}).get('name', '?')).upper()}** on "
            f"`{world.get('name')}` ({json.dumps(world.get('kwargs', {}))}), detector "
            f"`{config.get('detector', {}).get('kind')}`, seed {config.get('seed')}; specs: "
            f"{specs}."
        ),
    ]
    if (run / "command.txt").exists():
        blocks.append(Text(f"Command: `{(run / 'command.txt').read_text().strip()}`"))
    # A damaged result is refused by name, not reported as "not finished" (CorruptFileError).
    summary = read_json(run / "summary.json", default=None, kind=dict)
    evaluation = read_json(run / "evaluation.json", default=None, kind=dict)
    blocks.append(Heading("Final evaluation", 2))
    if isinstance(evaluation, dict):
        blocks.append(
            Text(
                f"`evaluation.json`: {evaluation.get('episodes')} episodes, "
                f"{'greedy' if evaluation.get('deterministic') else 'sampled'} actions, "
                "compliance from ground truth."
            )
        )
        blocks.append(evaluation_table(evaluation))
    elif isinstance(summary, dict) and summary.get("final"):
        blocks.append(Text("The run's last periodic evaluation (`summary.json`)."))
        blocks.append(evaluation_table(summary["final"]))
    else:
        blocks.append(Text("The run has not finished (no `summary.json`)."))
    # `evaluate` with other settings (--noise ...) keeps each beside, named by a digest.
    for other in sorted(run.glob("evaluation-*.json")):
        changed = read_json(other, default=None, kind=dict)
        if not isinstance(changed, dict):
            continue
        blocks.append(Heading(f"Evaluated with {json.dumps(changed.get('overrides', {}))}", 3))
        blocks.append(
            Text(
                f"`{other.name}`: {changed.get('episodes')} episodes, "
                f"{'greedy' if changed.get('deterministic') else 'sampled'} actions."
            )
        )
        blocks.append(evaluation_table(changed))
    if isinstance(summary, dict):
        reached = summary.get("frames_to_comply")
        threshold = config["evaluation"].get("success_threshold", 0.95)
        final = summary.get("final")
        has_goal = not isinstance(final, dict) or final.get("goal_rate") is not None
        blocks.append(
            Text(
                f"Frames trained: {summary.get('frames', 0):,}. N_frames (first evaluation with "
                f"≥ {threshold:.0%} of episodes {'at the goal and ' if has_goal else ''}"
                f"compliant): {f'{reached:,}' if reached is not None else 'not reached'}."
            )
        )
    metrics = RunDirectory(run).read_metrics()
    if metrics:
        plot_learning_curves(
            {f"seed {config.get('seed')}": metrics}, run / "curves.png", title=run.name
        )
        blocks += [Heading("Learning curves", 2), Image("curves.png", "learning curves")]
    pictures = sorted(run.glob("*.gif")) + sorted(
        p for p in run.glob("*.png") if "heatmap" in p.name
    )
    if pictures:
        blocks += [Heading("Policy", 2), *(Image(p.name, p.stem) for p in pictures)]
    if metrics:
        blocks += [Heading("Evaluations during training", 2), _metrics_table(metrics)]
    attempts = TrialDirectory(run).outcome()["attempts"]  # a sweep trial's failed attempts
    if attempts:
        blocks += [
            Heading("Failed attempts", 2),
            Text(f"{len(attempts)} failed attempt(s); the last: `{attempts[-1]['message']}`"),
            Code(attempts[-1].get("traceback", "")),
        ]
    blocks += [Heading("Config", 2), Code(json.dumps(config, indent=2, sort_keys=True), "json")]
    return _write(blocks, run, f"noisybolt run {run.name}", write_html=html_page)


def _sections(root: Path) -> tuple[list[Block], dict[str, float | None]]:
    blocks: list[Block] = []
    references: dict[str, float | None] = {}
    for section in _SECTIONS.values():
        if (root / section.marker).exists():
            more, refs = section.blocks(root)
            blocks += more
            references.update(refs)
    return blocks, references


def sweep_report(
    sweep_dir: str | os.PathLike[str], *, run_reports: bool = True, html_page: bool = True
) -> ReportFiles:
    """Writes ``report.md`` (and ``report.html``) in a sweep directory.

    Args:
        sweep_dir: the sweep directory (``noisybolt sweep`` or ``reproduce`` output).
        run_reports: also write every trial's run report, linked from the trials table.
        html_page: also write the self-contained HTML page.

    Raises:
        ConfigError: the directory holds no sweep.
    """
    root = Path(sweep_dir)
    result = collect_sweep(root)
    counts = {
        s: sum(r.status == s for r in result.records)
        for s in ("done", "failed", "interrupted", "pending")
    }
    sections, references = _sections(root)
    blocks: list[Block] = [
        *result.blocks(),
        Text(
            f"{len(result.records)} trials: {counts['done']} done, {counts['failed']} failed, "
            f"{counts['interrupted']} interrupted (the sweep's command resumes them from "
            f"their checkpoints), {counts['pending']} not started. Tables: `results.md`, "
            "`results.csv`, `results.json`."
        ),
        *sections,
    ]
    curves = group_curves(root, references=references)
    if curves:
        blocks.append(Heading("Learning curves", 2))
        blocks += [
            Image(p.relative_to(root).as_posix(), f"learning curves of {g}")
            for g, p in curves.items()
        ]
    configs = {t["id"]: t.get("config") for t in read_json(root / SWEEP_FILE)["trials"]}
    rows = []
    for record in result.records:
        link: str | Link = record.trial_id
        if run_reports and record.run_dir.is_dir():
            run_report(record.run_dir, html_page=html_page, config=configs.get(record.trial_id))
            link = Link(record.trial_id, f"trials/{record.trial_id}/report")
        final = record.final or {}
        rows.append(
            (
                link,
                (
                    f"interrupted at {record.checkpoint_frames:,} frames"
                    if record.status == "interrupted"
                    else record.status
                ),
                f"{final['env_return_mean']:.2f}" if final else "—",
                ", ".join(f"{k} {v:.0%}" for k, v in final.get("compliance", {}).items()) or "—",
                format_frames(record.frames_to_comply) if record.status == "done" else "—",
                str(record.failed_attempts),
                f"{record.seconds:.0f} s" if record.seconds else "—",
            )
        )
    header = ("trial", "status", "R_π", "compliance", "N_frames", "failed attempts", "time")
    blocks += [Heading("Trials", 2), Table(header, tuple(rows))]
    return _write(blocks, root, f"noisybolt sweep {result.name}", write_html=html_page)


def _refuse_classifiers_directory(folder: Path) -> None:
    """``noisybolt classifiers`` keeps its stages' settings in a ``config.json`` too
    (``{"collect": ..., "train": ...}``): such a directory is named, not read as a run
    whose files are corrupt."""
    saved = read_json(folder / "config.json", default=None)
    if isinstance(saved, dict) and saved and set(saved) <= set(CLASSIFIER_STAGES):
        stages = ", ".join(k for k in CLASSIFIER_STAGES if k in saved)
        raise ConfigError(
            f"{folder} holds fluent classifiers (noisybolt classifiers: {stages}), not a "
            f"run or a sweep; their report is noisybolt classifiers report --out {folder} "
            "(report.txt)"
        )


def write_report(path: str | os.PathLike[str], *, html_page: bool = True) -> ReportFiles:
    """The report of a run, a sweep, or a directory of a registered section's results.

    Raises:
        ConfigError: ``path`` holds none of these.
    """
    folder = Path(path)
    if not folder.is_dir():
        raise ConfigError(
            f"{folder} {'is not a directory' if folder.exists() else 'does not exist'}: give "
            "the directory that `noisybolt train`, `sweep` or `reproduce` wrote"
        )
    if (folder / SWEEP_FILE).exists():
        return sweep_report(folder, html_page=html_page)
    if (folder / "config.json").exists():
        _refuse_classifiers_directory(folder)
        return run_report(folder, html_page=html_page)
    found = [s for s in _SECTIONS.values() if (folder / s.marker).exists()]
    if not found:
        markers = ", ".join(s.marker for s in _SECTIONS.values())
        raise ConfigError(
            f"{folder} holds neither a run (config.json) nor a sweep ({SWEEP_FILE})"
            + (f" nor results ({markers})" if markers else "")
            + ": give the directory that `noisybolt train`, `sweep` or `reproduce` wrote"
        )
    for section in found:
        if section.regenerate is not None:
            section.regenerate(folder)
    blocks, _ = _sections(folder)
    return _write(blocks, folder, f"noisybolt results {folder.name}", write_html=html_page)


def _spec_label(spec: dict[str, Any]) -> str:
    """```name` = `formula``, or the formula alone where the spec has no name of its own.

    Example:
        >>> _spec_label({"name": "F(x)", "formula": "F(x)"}), _spec_label({"formula": "G(y)"})
        ('`F(x)`', '`G(y)`')
        >>> _spec_label({"name": "reach", "formula": "F(x)"})
        '`reach` = `F(x)`'
    """
    formula = spec.get("formula")
    name = spec.get("name") or formula
    return f"`{formula}`" if name == formula else f"`{name}` = `{formula}`"
