"""``noisybolt reproduce table1``: the paper's gridworld rows of Table 1, measured.

Eight rows (spec x algorithm), each trained over several seeds under the bolt with the
trained noisy classifier (the rows, their frames and the sweep:
:mod:`noisybolt.experiments.table1_rows`, whose names this module re-exports), through the
sweep machinery (:mod:`noisybolt.experiments.sweeps`), so it resumes when run again and
runs on Ray with ``backend="ray"``. This module runs that sweep, builds the table from its
trials and writes it.

Outputs, in the output directory (which is also the sweep directory):
``table1.md``, ``table1.csv``, ``table1.json`` and ``curves/<row>.png`` (environment return
and compliance against frames, every seed), beside the sweep's own files.

Columns: R^c_max is exact (:func:`noisybolt.experiments.optimal.optimal_constrained_return`);
R_π and N_steps are the mean ± std over seeds of the final evaluation's mean environment
return and episode length (every episode, ``final_eval_episodes`` of them, default 100);
N_frames is the mean over the seeds that reached it, with a count when not all did;
compliance and goal rate are means over seeds; *followed* is ✓ when compliance is at
least 95% in every seed, ✗ when some seed is below, and ``?`` while seeds are missing.
The paper's numbers stand beside ours.

Example:
    >>> [row.name for row in select_rows(["edge"])]
    ['edge-ppo', 'edge-a2c', 'edge-dqn']
    >>> table1_table([]).header[:3]
    ('LTLf spec', 'algo', 'R^c_max')
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import asdict, dataclass, field, fields
from pathlib import Path
from typing import Any

from noisybolt.errors import ConfigError
from noisybolt.experiments.report import ReportSection, group_curves, register_section
from noisybolt.experiments.reporting import (
    Block,
    Heading,
    Stat,
    Table,
    Text,
    format_frames,
    format_number,
    frames_reached,
    mark,
    percent,
    pm,
    render_csv,
    render_markdown,
)
from noisybolt.experiments.sweeps import collect_sweep
from noisybolt.experiments.table1_rows import (
    FRAMES_FACTOR,
    FRAMES_FLOOR,
    TABLE1_ROWS,
    PaperNumbers,
    Table1Row,
    select_rows,
    table1_sweep,
)
from noisybolt.io import read_json

__all__ = [
    "FRAMES_FACTOR",
    "FRAMES_FLOOR",
    "TABLE1_ROWS",
    "PaperNumbers",
    "Table1Entry",
    "Table1Result",
    "Table1Row",
    "build_table1",
    "regenerate_table1",
    "reproduce_table1",
    "select_rows",
    "table1_sweep",
    "table1_table",
    "write_table1",
]

#: Compliance a seed needs for the row to count as followed.
FOLLOWED_THRESHOLD = 0.95


@dataclass(frozen=True)
class Table1Entry:
    """One reproduced row, beside the paper's.

    Attributes:
        row: the row (with the paper's numbers).
        rc_max: our exact R^c_max for the spec (None if no episode complies).
        r_pi: R_π over seeds (None when no seed finished).
        n_steps: N_steps (mean episode length) over seeds.
        n_frames: N_frames over the seeds that reached it.
        n_reached: seeds that reached N_frames.
        compliance: compliance rate over seeds.
        compliance_min: the lowest seed's compliance.
        goal_rate: goal rate over seeds.
        followed: ✓ (True), ✗ (False) or undecided (None: seeds missing, none below).
        n_seeds: seeds asked for.
        n_done: seeds finished.
        n_failed: seeds failed.
        frames: the row's frame budget per seed.
        frames_trained: frames each seed trained (over the finished seeds): below the
            budget where stop-when-solved ended it.
    """

    row: Table1Row
    rc_max: float | None
    r_pi: Stat | None
    n_steps: Stat | None
    n_frames: Stat | None
    n_reached: int
    compliance: Stat | None
    compliance_min: float | None
    goal_rate: Stat | None
    followed: bool | None
    n_seeds: int
    n_done: int
    n_failed: int
    frames: int
    frames_trained: Stat | None = None

    def to_dict(self) -> dict[str, Any]:
        """JSON-able form (statistics as ``{"mean", "std", "n"}``)."""
        row, data = self.row, {f.name: getattr(self, f.name) for f in fields(self)}
        stats = {k: v._asdict() if isinstance(v, Stat) else v for k, v in data.items()}
        names = {"row": row.name, "spec": row.spec, "formula": row.formula, "algo": row.algo}
        return stats | names | {"paper": asdict(row.paper)}

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> Table1Entry:
        """Reads :meth:`to_dict`'s output back (a committed ``table1.json``'s rows)."""
        row = Table1Row(data["row"], data["spec"], data["algo"], PaperNumbers(**data["paper"]))
        values: dict[str, Any] = {f.name: data.get(f.name) for f in fields(cls)}
        for key in ("r_pi", "n_steps", "n_frames", "compliance", "goal_rate", "frames_trained"):
            values[key] = Stat.from_dict(values[key])
        return cls(**values | {"row": row})


@dataclass(frozen=True)
class Table1Result:
    """The reproduced table and where it was written.

    Attributes:
        entries: one per row, in the paper's order.
        sweep: the sweep's result (every trial).
        files: label -> path (``markdown``, ``csv``, ``json``, and one ``curves:<row>``
            per row).
    """

    entries: tuple[Table1Entry, ...]
    sweep: Any = None
    files: dict[str, Path] = field(default_factory=dict)

    def to_table(self) -> Table:
        """The table (see :func:`table1_table`)."""
        return table1_table(self.entries)


def _rc_max(formula: str, world_kwargs: dict[str, Any]) -> float | None:
    from noisybolt.experiments.optimal import optimal_constrained_return

    keys = ("size", "max_steps", "step_reward", "goal_reward")
    kwargs = {k: world_kwargs[k] for k in keys if k in world_kwargs}
    return optimal_constrained_return([formula], **kwargs).value


def build_table1(sweep_result: Any) -> tuple[Table1Entry, ...]:
    """The table's entries from a collected sweep (rows in the paper's order)."""
    from noisybolt.runs.legacy import nested_config  # flat configs of older runs too

    by_group = {g.group: g for g in sweep_result.groups}
    entries = []
    for row in TABLE1_ROWS:
        group = by_group.get(row.name)
        if group is None:
            continue
        members = [r for r in sweep_result.records if r.group == row.name]
        config = nested_config(read_json(members[0].run_dir / "config.json", default={}))
        world_kwargs = dict(config.get("world", {}).get("kwargs") or {})
        rates = [
            float((r.final or {}).get("compliance", {}).get(row.spec, 0.0))
            for r in members
            if r.status == "done"
        ]
        if any(rate < FOLLOWED_THRESHOLD for rate in rates):
            followed: bool | None = False
        elif rates and len(rates) == group.n_trials:
            followed = True
        else:
            followed = None
        stats = group.stats
        entries.append(
            Table1Entry(
                row=row,
                rc_max=_rc_max(row.formula, world_kwargs),
                r_pi=stats.get("env_return"),
                n_steps=stats.get("length"),
                n_frames=stats.get("frames_to_comply"),
                n_reached=n_frames.n if (n_frames := stats.get("frames_to_comply")) else 0,
                compliance=stats.get(f"compliance_{row.spec}"),
                compliance_min=min(rates) if rates else None,
                goal_rate=stats.get("goal_rate"),
                followed=followed,
                n_seeds=group.n_trials,
                n_done=group.n_done,
                n_failed=group.n_failed,
                frames=int(config.get("frames") or 0),
                frames_trained=stats.get("frames"),
            )
        )
    return tuple(entries)


TABLE1_HEADER: tuple[str, ...] = (
    "LTLf spec",
    "algo",
    "R^c_max",
    "paper R^c_max",
    "R_π",
    "paper R_π",
    "N_steps",
    "paper N_steps",
    "N_frames",
    "paper N_frames",
    "compliance",
    "goal rate",
    "followed",
    "paper",
    "frames trained / budget",
    "seeds",
)
_CSV_HEADER = (
    "row", "formula", "algo", "rc_max", "paper_rc_max", "r_pi_mean", "r_pi_std",
    "paper_r_pi", "n_steps_mean", "n_steps_std", "paper_n_steps", "n_frames_mean",
    "n_frames_reached", "paper_n_frames", "compliance_mean", "compliance_min",
    "goal_rate_mean", "followed", "paper_followed", "frames", "n_seeds", "n_done",
    "n_failed", "frames_trained_mean",
)  # fmt: skip


def table1_table(entries: Sequence[Table1Entry]) -> Table:
    """The reproduced Table 1 beside the paper's numbers: the cells shown (Markdown, HTML)
    and, for CSV, every mean and std in a column of its own."""

    def num(stat: Any, part: str) -> str:
        return "" if stat is None else f"{getattr(stat, part):.6g}"

    rows, data = [], []
    for e in entries:
        paper = e.row.paper
        seeds = f"{e.n_done}/{e.n_seeds}" + (f", {e.n_failed} failed" if e.n_failed else "")
        rows.append(
            (
                f"`{e.row.formula}`", e.row.algo.upper(), format_number(e.rc_max),
                format_number(paper.rc_max), pm(e.r_pi), format_number(paper.r_pi),
                pm(e.n_steps, 1), format_number(paper.n_steps),
                frames_reached(e.n_frames, e.n_reached, e.n_done),
                format_frames(paper.n_frames), percent(e.compliance),
                percent(e.goal_rate), mark(e.followed), mark(paper.followed),
                f"{format_frames(e.frames_trained and e.frames_trained.mean)} / "
                f"{format_frames(e.frames)}", seeds,
            )
        )  # fmt: skip
        data.append(
            (
                e.row.name, e.row.formula, e.row.algo, format_number(e.rc_max).replace("—", ""),
                paper.rc_max, num(e.r_pi, "mean"), num(e.r_pi, "std"), paper.r_pi,
                num(e.n_steps, "mean"), num(e.n_steps, "std"), paper.n_steps,
                num(e.n_frames, "mean"), e.n_reached, paper.n_frames,
                num(e.compliance, "mean"),
                "" if e.compliance_min is None else f"{e.compliance_min:.6g}",
                num(e.goal_rate, "mean"), "" if e.followed is None else int(e.followed),
                int(paper.followed), e.frames, e.n_seeds, e.n_done, e.n_failed,
                num(e.frames_trained, "mean"),
            )
        )  # fmt: skip
    return Table(TABLE1_HEADER, tuple(rows), _CSV_HEADER, tuple(data))


NOTES = (
    "R^c_max: exact, by backward induction on the product of the gridworld and the spec's "
    "DFA (`noisybolt.experiments.optimal`), with the paper's stated rewards (-1.5 per step, "
    "+100 at the goal, so R_max = 89.5); the paper's own values (94, 92, 82) do not follow "
    "from those rewards, so compare R_π with our R^c_max.",
    "R_π, N_steps: mean ± std over seeds of the final evaluation's mean environment return "
    "and episode length (every episode, ground truth; PPO and A2C sample their actions, "
    "DQN acts greedily).",
    "N_frames: first periodic evaluation at which ≥ 95% of the episodes reach the goal while "
    "complying; mean over the seeds that reached it, (k/n) when not all did. It does not "
    "depend on the budget: the schedules that decide when a policy first acts surely are "
    "fixed in frames (A2C's entropy bonus falls from 0.05 to 0 over its first 50k frames, "
    "DQN's epsilon over its first 3k), and a seed stops once 3 evaluations in a row reach "
    "95% (stop when solved), or at its budget.",
    "followed: ✓ when the final evaluation's compliance (ground truth, never by looking) is "
    "≥ 95% in every seed, ✗ when some seed is below, ? while seeds are missing.",
)


def _settings_text(settings: Mapping[str, Any]) -> str:
    model = (
        "each seed's model from its periodic evaluation with the best shaped return "
        "(environment + bolt rewards as the bolt sees them; ground truth never chooses)."
        if settings.get("keep_best")
        else "each seed's last model."
    )
    tracking = settings.get("tracking", "threshold")  # runs before it was recorded: threshold
    tracking = "" if tracking == "threshold" else f"bolt DFA tracking: `{tracking}`; "
    text = (
        f"Seeds: {settings['seeds']}; detector: `{settings['detector']}`; bolt camera noise: "
        f"`{settings['noise']}`; "
        + tracking
        + f"final evaluation: {settings['final_eval_episodes']} episodes "
        f"per seed, of {model}"
    )
    if settings.get("wall_seconds") is not None:
        text += (
            f" Wall time {settings['wall_seconds'] / 60:.1f} min with "
            f"{settings.get('workers')} worker(s) on {settings.get('cpus')} CPUs (load "
            f"average {settings.get('load_average_at_start')} at the start)."
        )
    return text


def _write_tables(root: Path, data: Mapping[str, Any]) -> dict[str, Path]:
    """Writes ``table1.md`` and ``table1.csv`` from what ``table1.json`` holds."""
    from noisybolt.io import atomic_write_text

    table = table1_table([Table1Entry.from_dict(row) for row in data["rows"]])
    notes = [*data.get("notes", NOTES), "Learning curves per row: `curves/<row>.png`."]
    blocks: list[Block] = [Heading("Table 1 (gridworld), reproduced")]
    if data.get("command"):
        blocks.append(Text(f"Command: `{data['command']}`"))
    blocks += [
        Text(_settings_text(data["settings"])),
        table,
        Text("\n".join(f"- {n}" for n in notes)),
    ]
    files = {"markdown": root / "table1.md", "csv": root / "table1.csv"}
    atomic_write_text(files["markdown"], render_markdown(blocks))
    atomic_write_text(files["csv"], render_csv(table))
    return files


def regenerate_table1(results_dir: str | os.PathLike[str]) -> dict[str, Path]:
    """Rewrites ``table1.md`` and ``table1.csv`` from ``table1.json`` alone (no trials
    needed: ``noisybolt report results/table1``).

    Raises:
        ConfigError: the directory has no readable ``table1.json``.
    """
    root = Path(results_dir)
    data = read_json(root / "table1.json", default=None)
    if not isinstance(data, dict) or "rows" not in data:
        raise ConfigError(f"{root} holds no readable table1.json (noisybolt reproduce table1)")
    return _write_tables(root, data)


def write_table1(
    sweep_dir: str | os.PathLike[str], *, settings: dict[str, Any] | None = None
) -> Table1Result:
    """Collects a Table 1 sweep and writes ``table1.md/csv/json`` and ``curves/<row>.png``.

    Args:
        sweep_dir: the output directory of :func:`reproduce_table1`.
        settings: what to print above the table (``seeds``, ``detector``, ``noise``,
            ``final_eval_episodes``); default: read back from ``table1.json`` or the
            trials.
    """
    from noisybolt.io import atomic_write_json

    root = Path(sweep_dir)
    result = collect_sweep(root)
    entries = build_table1(result)
    if not entries:
        raise ConfigError(f"{root} holds no Table 1 rows")
    if settings is None:
        previous = read_json(root / "table1.json", default={})
        settings = previous.get("settings") or _settings_from(root, result)
    command_file = root / "command.txt"
    command = command_file.read_text().strip() if command_file.exists() else ""
    data = {
        "command": command,
        "settings": settings,
        "notes": list(NOTES),
        "rows": [e.to_dict() for e in entries],
    }
    atomic_write_json(root / "table1.json", data)
    files = {**_write_tables(root, data), "json": root / "table1.json"}
    references = {e.row.name: e.rc_max for e in entries}
    for group, path in group_curves(root, references=references).items():
        files[f"curves:{group}"] = path
    return Table1Result(entries=entries, sweep=result, files=files)


def _settings_from(root: Path, result: Any) -> dict[str, Any]:
    from noisybolt.runs.legacy import nested_config

    sweep = read_json(root / "sweep.json", default={})
    trials = sweep.get("trials") or [{}]
    config = nested_config(trials[0].get("config", {}))
    return {
        "seeds": sorted({r.seed for r in result.records}),
        "detector": config.get("detector", {}).get("kind"),
        "noise": config.get("world", {}).get("kwargs", {}).get("noise", "none"),
        "final_eval_episodes": sweep.get("final_eval_episodes", 0),
    }


def reproduce_table1(
    out_dir: str | os.PathLike[str],
    *,
    backend: str = "local",
    workers: int | None = None,
    address: str | None = None,
    argv: Sequence[str] | None = None,
    log: Callable[[str], None] = print,
    **options: Any,
) -> Table1Result:
    """Trains every chosen row over seeds (or resumes), then writes the table.

    ``options`` are those of :func:`table1_sweep`, the others those of
    :func:`~noisybolt.experiments.sweeps.run_sweep`.
    """
    from noisybolt.experiments.sweeps import run_sweep

    sweep = table1_sweep(**options)
    # The wall time of this invocation (a resumed sweep counts only what it ran), with the
    # machine's CPUs and load beside it: on a shared machine the load says what it meant.
    started, load = time.perf_counter(), os.getloadavg()[0]
    run_sweep(sweep, out_dir, backend=backend, workers=workers, address=address, argv=argv, log=log)
    first = sweep.trials[0].config  # the base's settings, as every trial holds them
    settings = {
        "seeds": list(sweep.seeds),
        "detector": first.detector.kind,
        "noise": first.world_config.kwargs["noise"],
        "tracking": first.bolt.tracking,
        "final_eval_episodes": sweep.final_eval_episodes,
        "eval_episodes": first.evaluation.episodes,
        "keep_best": first.evaluation.keep_best,
        "stop_after": first.evaluation.stop_after,
        "frames_scale": options.get("frames_scale", 1.0),
        "frames": {t.row: t.config.frames for t in sweep.trials},
        "eval_freq": {t.row: t.config.evaluation.freq for t in sweep.trials},
        "backend": backend,
        "workers": (1 if backend == "local" else 0) if workers is None else workers,
        "cpus": os.cpu_count(),
        "load_average_at_start": round(load, 2),
        "wall_seconds": round(time.perf_counter() - started, 1),
    }
    return write_table1(out_dir, settings=settings)


def _report_section(sweep_dir: Path) -> tuple[list[Block], dict[str, float | None]]:
    """The Table 1 section of a report, and R^c_max per row for the learning curves."""
    data = read_json(sweep_dir / "table1.json", default={})
    entries = [Table1Entry.from_dict(row) for row in data.get("rows", [])]
    blocks: list[Block] = [
        Heading("Table 1, reproduced", 2),
        Text(
            f"{_settings_text(data['settings'])} Files: `table1.md`, `table1.csv`, `table1.json`."
        ),
        table1_table(entries),
        Text("\n".join(f"- {note}" for note in data.get("notes", NOTES))),
    ]
    return blocks, {e.row.name: e.rc_max for e in entries}


register_section(ReportSection("table1", "table1.json", _report_section, regenerate_table1))
