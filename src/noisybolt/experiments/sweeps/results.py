"""A sweep's results: one record per trial, one summary per group, and their table."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from noisybolt.experiments.reporting import (
    Block,
    Heading,
    Stat,
    Table,
    Text,
    frames_reached,
    percent,
    pm,
    render_csv,
    render_markdown,
    summarise,
)
from noisybolt.io import atomic_write_json, atomic_write_text

__all__ = ["GroupSummary", "SweepResult", "TrialRecord"]


@dataclass(frozen=True)
class TrialRecord:
    """A trial's state and results. ``status``: ``done``, ``failed``, ``interrupted``
    (stopped mid-run with a checkpoint at ``checkpoint_frames``: the sweep's command
    resumes it) or ``pending`` (not started, or stopped before its first checkpoint);
    ``final``: the evaluation the tables report (None unless done); ``frames_to_comply``:
    N_frames; ``failed_attempts``: attempts that raised, over every run of the sweep,
    ``error`` the last one's message; ``seconds``: the finishing attempt's.
    """

    trial_id: str
    group: str  # the id without the seed: a group's trials are averaged
    row: str
    seed: int
    settings: dict[str, Any]  # the settings axes' values
    run_dir: Path
    status: str
    algo: str
    spec_names: tuple[str, ...]
    final: dict[str, Any] | None = None
    frames: int | None = None
    frames_to_comply: int | None = None
    failed_attempts: int = 0
    error: str | None = None
    seconds: float | None = None
    checkpoint_frames: int | None = None

    def to_dict(self) -> dict[str, Any]:
        """JSON-able form."""
        return {**asdict(self), "run_dir": str(self.run_dir), "spec_names": list(self.spec_names)}

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> TrialRecord:
        """Reads :meth:`to_dict`'s output back."""
        return cls(
            **{**data, "run_dir": Path(data["run_dir"]), "spec_names": tuple(data["spec_names"])}
        )


@dataclass(frozen=True)
class GroupSummary:
    """A group's trials over seeds: a row of the table. ``stats`` holds the mean ± std over
    its finished seeds (:func:`~noisybolt.experiments.reporting.summarise`) of the final
    evaluations' ``env_return`` (R_π), ``length`` (N_steps), ``goal_rate``,
    ``success_rate`` (goal and compliant) and ``compliance_<spec>``, of ``frames`` trained,
    and of ``frames_to_comply`` (N_frames) over the seeds that reached it (its ``n``); a
    statistic no seed has is left out."""

    group: str
    row: str
    settings: dict[str, Any]
    algo: str
    specs: tuple[str, ...]
    n_trials: int
    n_done: int
    n_failed: int
    stats: dict[str, Stat]

    @classmethod
    def of(cls, members: Sequence[TrialRecord]) -> GroupSummary:
        """The summary of one group's trials."""
        first, done = members[0], [r for r in members if r.status == "done" and r.final]
        stats = summarise(
            {
                "env_return": f["env_return_mean"],
                "length": f["length_mean"],
                "goal_rate": f["goal_rate"],
                "success_rate": f["success_rate"],
                "frames_to_comply": r.frames_to_comply,
                "frames": r.frames,
                **{f"compliance_{s}": f["compliance"].get(s) for s in first.spec_names},
            }
            for r in done
            if (f := r.final)
        )
        return cls(
            group=first.group, row=first.row, settings=first.settings, algo=first.algo,
            specs=first.spec_names, n_trials=len(members), n_done=len(done),
            n_failed=sum(r.status == "failed" for r in members), stats=stats,
        )  # fmt: skip

    def to_dict(self) -> dict[str, Any]:
        """The group in ``results.json``: its statistics as ``{"mean", "std", "n"}`` beside
        its counts; flattened, the CSV's row."""
        data = {k: v for k, v in self.__dict__.items() if k != "stats"}
        return data | {"specs": list(self.specs)} | {k: s._asdict() for k, s in self.stats.items()}

    def cells(self) -> tuple[str, ...]:
        """The row as the table shows it."""
        stat, ftc = self.stats.get, self.stats.get("frames_to_comply")
        compliance = [f"{s} {c.mean:.0%}" for s in self.specs if (c := stat(f"compliance_{s}"))]
        return (
            self.group, self.algo, ", ".join(self.specs), f"{self.n_done}/{self.n_trials}",
            str(self.n_failed), pm(stat("env_return")), pm(stat("length"), 1),
            percent(stat("goal_rate")), ", ".join(compliance) or "—", percent(stat("success_rate")),
            frames_reached(ftc, ftc.n if ftc else 0, self.n_done),
        )  # fmt: skip


@dataclass(frozen=True)
class SweepResult:
    """A sweep's trials (``records``) and groups, in the sweep's order; ``files``: the
    files written (label -> path)."""

    sweep_dir: Path
    name: str
    records: tuple[TrialRecord, ...]
    groups: tuple[GroupSummary, ...]
    files: dict[str, Path] = field(default_factory=dict)

    @classmethod
    def of(cls, sweep_dir: Path, name: str, records: Sequence[TrialRecord]) -> SweepResult:
        """The result of a sweep's trials: a group for each group id, in first-seen order."""
        groups: dict[str, list[TrialRecord]] = {}
        for record in records:
            groups.setdefault(record.group, []).append(record)
        return cls(sweep_dir, name, tuple(records), tuple(map(GroupSummary.of, groups.values())))

    @property
    def n_failed(self) -> int:
        """Trials that failed."""
        return sum(r.status == "failed" for r in self.records)

    @property
    def n_done(self) -> int:
        """Trials that finished."""
        return sum(r.status == "done" for r in self.records)

    def to_table(self) -> Table:
        """The results table: a row per group (mean ± std over its finished seeds)."""
        header = ("group", "algo", "specs", "seeds done", "failed", "R_π (env return)",
                  "N_steps", "goal rate", "compliance", "goal & compliant", "N_frames")  # fmt: skip
        groups = self.groups
        return Table.of(header, tuple(g.cells() for g in groups), [g.to_dict() for g in groups])

    def to_dict(self) -> dict[str, Any]:
        """What ``results.json`` holds."""
        groups = [g.to_dict() for g in self.groups]
        return {"name": self.name, "groups": groups, "trials": [r.to_dict() for r in self.records]}

    def blocks(self) -> list[Block]:
        """What ``results.md`` says: the sweep's command, its table and the failed trials'
        errors (a sweep's report opens with them)."""
        command = self.sweep_dir / "command.txt"
        failed = [f"- `{r.trial_id}`: {r.error}" for r in self.records if r.status == "failed"]
        return [
            Heading(f"Sweep {self.name}"),
            *([Text(f"Command: `{command.read_text().strip()}`")] if command.exists() else []),
            Text(
                "Mean ± std (the population standard deviation, ddof 0) over each group's "
                "finished seeds of the final evaluation; "
                "N_frames: first evaluation with ≥ 95% of episodes reaching the goal while "
                "complying with every spec (ground truth), mean over the seeds that reached "
                "it; in a world without a goal (goal rate —), complying with every spec is "
                "what counts."
            ),
            self.to_table(),
            *([Text("Failed trials:"), Text("\n".join(failed))] if failed else []),
        ]

    def write(self) -> None:
        """Writes ``results.json``, ``results.md`` (:meth:`blocks`) and ``results.csv`` in
        the sweep directory."""
        suffixes = {"json": "json", "markdown": "md", "csv": "csv"}
        self.files.update({k: self.sweep_dir / f"results.{s}" for k, s in suffixes.items()})
        atomic_write_json(self.files["json"], self.to_dict())
        atomic_write_text(self.files["markdown"], render_markdown(self.blocks()))
        atomic_write_text(self.files["csv"], render_csv(self.to_table()))
