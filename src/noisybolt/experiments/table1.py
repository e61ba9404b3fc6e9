"""``noisybolt reproduce table1``: the paper's gridworld rows of Table 1, measured.

Eight rows (spec x algorithm), as in the paper: ``G(on_edge)`` with PPO, A2C and DQN;
``!F(top_right_corner)`` with A2C and DQN; ``F(t & X(!F(t)))`` with PPO and A2C; the
exclusive one-visit corner spec with A2C. Each trains over several seeds (default 3)
under the bolt with the trained noisy classifier (camera noise ``"regional"`` by
default), through the sweep machinery (:mod:`noisybolt.experiments.sweeps`), so it
resumes when run again and runs on Ray with ``backend="ray"``.

Frames per row: ``max(30k, 2 x the paper's N_frames)`` -- 30k for the DQN rows (the
paper's 4k), 40k (A2C, exclusive corner), 50k (PPO ``G(e)``), 160k (A2C ``G(e)``), 100k (A2C
``!F(t)``), 266k and 330k (PPO and A2C on ``F(t & X(!F(t)))``); about 1.0M frames per seed.
On one core of the 2-core reference machine, with the classifier bolt, PPO trains ~1.5k,
A2C ~1.7k and DQN ~170 frames/s (one gradient step per frame), so the table takes about 25
minutes with two workers. Twice the paper's budget leaves room for seeds that learn later
than the paper's one run did, and the floor covers DQN's replay warm-up and exploration
schedule (3k frames: ``exploration_fraction`` 0.1 of 30k). N_frames is
measured, not the budget: it is the first periodic evaluation at which at least 95% of
the evaluation episodes reach the goal while complying (ground truth), so a row that
learns faster reports fewer frames. Evaluations come every ``clip(paper N_frames / 10,
1k, 10k)`` frames (rounded down to thousands: 1k for the DQN rows, 2k for the
20k-25k rows), the resolution of N_frames. ``frames_scale`` scales both.

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
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import asdict, dataclass, field, fields
from pathlib import Path
from typing import Any

from noisybolt.bolt.belief import check_tracking
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

#: Default frames per row: ``max(FRAMES_FLOOR, FRAMES_FACTOR * paper N_frames)``.
FRAMES_FACTOR = 2
FRAMES_FLOOR = 30_000
#: Compliance a seed needs for the row to count as followed.
FOLLOWED_THRESHOLD = 0.95


@dataclass(frozen=True)
class PaperNumbers:
    """One row of the paper's Table 1, as printed."""

    rc_max: float
    r_pi: float
    n_steps: float
    n_frames: int
    followed: bool = True


@dataclass(frozen=True)
class Table1Row:
    """A row to reproduce: a spec of :data:`~noisybolt.runs.specs.PAPER_SPECS` and an
    algorithm, with the paper's numbers."""

    name: str
    spec: str
    algo: str
    paper: PaperNumbers

    @property
    def formula(self) -> str:
        """The spec's LTLf formula."""
        from noisybolt.runs.specs import PAPER_SPECS

        return PAPER_SPECS[self.spec]

    def frames(self, scale: float = 1.0) -> int:
        """Frames to train (``max(30k, 2 x paper N_frames)``, times ``scale``)."""
        base = max(FRAMES_FLOOR, FRAMES_FACTOR * self.paper.n_frames)
        return max(1, round(base * scale))

    def eval_freq(self, scale: float = 1.0) -> int:
        """Frames between evaluations (``clip(paper N_frames / 10, 1k, 10k)``, rounded
        down to thousands, scaled): 1k for the DQN rows, whose paper figure is 4k."""
        base = min(10_000, max(1_000, self.paper.n_frames // 10 // 1000 * 1000))
        return max(1, round(base * scale))


#: The paper's gridworld rows, in its order.
TABLE1_ROWS: tuple[Table1Row, ...] = (
    Table1Row("edge-ppo", "edge", "ppo", PaperNumbers(94, 79.48, 90, 25_000)),
    Table1Row("edge-a2c", "edge", "a2c", PaperNumbers(94, 63.64, 75, 80_000)),
    Table1Row("edge-dqn", "edge", "dqn", PaperNumbers(92, 74.42, 82, 4_000)),
    Table1Row("avoid_top_right-a2c", "avoid_top_right", "a2c", PaperNumbers(82, 80.71, 60, 50_000)),
    Table1Row("avoid_top_right-dqn", "avoid_top_right", "dqn", PaperNumbers(82, 79.0, 59, 4_000)),
    Table1Row(
        "top_right_once-ppo", "top_right_once", "ppo", PaperNumbers(92, 77.78, 87.13, 133_000)
    ),
    Table1Row(
        "top_right_once-a2c", "top_right_once", "a2c", PaperNumbers(92, 74.54, 104.2, 165_000)
    ),
    Table1Row("one_corner_once-a2c", "one_corner_once", "a2c", PaperNumbers(92, 78.42, 78, 20_000)),
)


def select_rows(names: Sequence[str] | None) -> tuple[Table1Row, ...]:
    """Rows by name (``edge-ppo``) or by spec (``edge``: all its rows); None: every row.

    Example:
        >>> [r.name for r in select_rows(["avoid_top_right", "edge-ppo"])]
        ['edge-ppo', 'avoid_top_right-a2c', 'avoid_top_right-dqn']

    Raises:
        ConfigError: a name that is neither a row nor a spec of the table.
    """
    if not names:
        return TABLE1_ROWS
    wanted = {n.strip() for n in names if n.strip()}
    known = {r.name for r in TABLE1_ROWS} | {r.spec for r in TABLE1_ROWS}
    unknown = sorted(wanted - known)
    if unknown:
        raise ConfigError(
            f"unknown Table 1 row(s) {unknown}; rows: {[r.name for r in TABLE1_ROWS]} "
            f"(or a spec name for all its rows: {sorted({r.spec for r in TABLE1_ROWS})})"
        )
    return tuple(r for r in TABLE1_ROWS if r.name in wanted or r.spec in wanted)


def table1_sweep(
    *,
    rows: Sequence[str] | None = None,
    seeds: int | Sequence[int] = 3,
    frames_scale: float = 1.0,
    frames: int | None = None,
    eval_freq: int | None = None,
    detector: str = "classifier",
    noise: str = "regional",
    eval_episodes: int = 20,
    final_eval_episodes: int = 100,
    retries: int = 1,
    cpus_per_trial: float = 1.0,
    keep_best: bool = True,
    stop_after: int = 3,
    tracking: str = "threshold",
) -> Any:
    """The sweep that reproduces Table 1 (a :class:`~noisybolt.experiments.sweeps.SweepConfig`).

    Args:
        rows: row or spec names (None: all eight rows).
        seeds: a count, or the seeds themselves.
        frames_scale: scales every row's frames and evaluation interval.
        frames: frames for every row (overrides the per-row defaults and the scale); the
            evaluation interval is then a tenth of it.
        eval_freq: frames between evaluations for every row (default: per row).
        detector: ``classifier`` (default), ``oracle`` or ``synthetic``.
        noise: the bolt camera's noise (``regional``: the paper's smudged corner).
        eval_episodes: episodes of each periodic evaluation (N_frames resolution).
        final_eval_episodes: episodes of each seed's final evaluation (the table's R_π,
            N_steps, compliance and goal rate).
        retries: extra attempts of a trial that crashes.
        cpus_per_trial: CPUs reserved per trial on Ray.
        keep_best: each seed's final model is its periodic evaluation with the best
            shaped return (env + bolt, as the bolt sees it; see
            :class:`~noisybolt.runs.training.TrainConfig`), not its last.
        stop_after: each seed stops once this many evaluations in a row have >= 95% of
            their episodes at the goal and complying (0: every seed trains its budget).
        tracking: the bolt's DFA tracking: ``threshold`` (Algorithm 1, the paper's) or
            ``belief`` (with base rates estimated in each run); the sweep is then named
            ``table1-belief``.

    Raises:
        ConfigError: unknown rows, or impossible values.
        UnknownNameError: an unknown tracking mode.
    """
    from noisybolt.envs.registry import DEFAULT_WORLD
    from noisybolt.experiments.sweeps import SweepConfig

    if not frames_scale > 0:
        raise ConfigError(f"frames_scale must be > 0, got {frames_scale}")
    if frames is not None and frames < 1:
        raise ConfigError(f"frames must be >= 1, got {frames}")
    chosen = select_rows(rows)
    # Threshold is the schema's default: its sweep file stays as it was before this option.
    tracked = {} if check_tracking(tracking) == "threshold" else {"bolt.tracking": tracking}
    sweep_rows = []
    for row in chosen:
        n = frames if frames is not None else row.frames(frames_scale)
        if eval_freq is not None:
            every = eval_freq
        elif frames is not None:
            every = max(1, n // 10)
        else:
            every = row.eval_freq(frames_scale)
        # Each row: overrides of the base below, by path of the run config schema.
        sweep_rows.append(
            {
                "name": row.name,
                "bolt.specs": [row.spec],
                "algorithm.name": row.algo,
                "frames": n,
                "evaluation.freq": every,
                "checkpoint_freq": max(every, n // 5),
                # DQN's policy is its greedy one: sampling its actions would add the
                # training schedule's epsilon, measuring exploration rather than what was
                # learned (PPO and A2C learn a distribution and are evaluated sampling it).
                "evaluation.deterministic": row.algo == "dqn",
            }
        )
    return SweepConfig.from_dict(
        {
            "name": "table1" if not tracked else f"table1-{tracking}",
            "base": {
                **tracked,
                "world.name": DEFAULT_WORLD,  # the paper's gridworld
                "world.kwargs.noise": noise,
                # Algorithm 1 as the paper pays it (every accepting step +1, cost 0.5).
                "bolt.reward": "paper",
                "detector.kind": detector,
                "evaluation.episodes": eval_episodes,
                "evaluation.keep_best": keep_best,
                "evaluation.stop_after": stop_after,
            },
            "rows": sweep_rows,
            "seeds": seeds if isinstance(seeds, int) else list(seeds),
            "retries": retries,
            "final_eval_episodes": final_eval_episodes,
            "resources": {"cpus": cpus_per_trial},
        }
    )


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
    from noisybolt.runs.config import nested_config  # flat configs of older runs too

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
    from noisybolt.runs.config import nested_config

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
        "noise": first.world_kwargs["noise"],
        "tracking": first.bolt.tracking,
        "final_eval_episodes": sweep.final_eval_episodes,
        "eval_episodes": first.eval_episodes,
        "keep_best": first.keep_best,
        "stop_after": first.stop_after,
        "frames_scale": options.get("frames_scale", 1.0),
        "frames": {t.row: t.config.frames for t in sweep.trials},
        "eval_freq": {t.row: t.config.eval_freq for t in sweep.trials},
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
