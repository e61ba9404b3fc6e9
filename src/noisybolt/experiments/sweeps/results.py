"""A sweep's results: one record per trial, one summary per group, and their table."""

from __future__ import annotations

import json
import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np

from noisybolt.experiments.reporting import (
    Block,
    Heading,
    Table,
    Text,
    format_frames,
    percent,
    pm,
    render_csv,
    render_markdown,
)
from noisybolt.io import atomic_write_json, atomic_write_text

__all__ = ["GroupSummary", "Stat", "SweepResult", "TrialRecord", "summarise_trials"]


class Stat(NamedTuple):
    """Mean and standard deviation (numpy's, ddof=0) over ``n`` values."""

    mean: float
    std: float
    n: int

    @classmethod
    def of(cls, values: Iterable[float]) -> Stat | None:
        """The statistic of ``values``; None when there are none.

        Example:
            >>> Stat.of([1.0, 3.0])
            Stat(mean=2.0, std=1.0, n=2)
        """
        a = np.asarray(list(values), dtype=np.float64)
        return cls(float(a.mean()), float(a.std()), a.size) if a.size else None

    @classmethod
    def from_dict(cls, data: Mapping[str, Any] | None) -> Stat | None:
        """Reads ``_asdict()``'s output back (None stays None)."""
        if data is None:
            return None
        return cls(float(data["mean"]), float(data["std"]), int(data["n"]))


@dataclass(frozen=True)
class TrialRecord:
    """A trial's state and results. ``status``: ``done``, ``failed`` or ``pending`` (not
    run, or interrupted); ``final``: the evaluation the tables report (None unless done);
    ``frames_to_comply``: N_frames; ``failed_attempts``: attempts that raised, over every
    run of the sweep, ``error`` the last one's message; ``seconds``: the finishing attempt's.
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

    def to_dict(self) -> dict[str, Any]:
        """JSON-able form."""
        return {**asdict(self), "run_dir": str(self.run_dir), "spec_names": list(self.spec_names)}

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> TrialRecord:
        """Reads :meth:`to_dict`'s output back."""
        return cls(
            **{**data, "run_dir": Path(data["run_dir"]), "spec_names": tuple(data["spec_names"])}
        )


#: GroupSummary's statistics over seeds, in the CSV's order.
_STATS = ("env_return", "length", "goal_rate", "success_rate", "frames_to_comply", "frames")
#: Its means over the final evaluations: statistic -> the evaluation's key.
_FINAL_MEANS = {
    "env_return": "env_return_mean",
    "length": "length_mean",
    "goal_rate": "goal_rate",
    "success_rate": "success_rate",
}


@dataclass(frozen=True)
class GroupSummary:
    """A group's trials over seeds (one row of the table): the means of the final
    evaluations' ``env_return`` (R_π), ``length`` (N_steps), ``goal_rate``,
    ``success_rate`` (goal and compliant) and per-spec ``compliance``; ``compliance_min``:
    the lowest seed's; ``frames_to_comply``: N_frames over the ``n_reached`` seeds that
    reached it; ``frames``: frames trained.
    """

    group: str
    row: str
    settings: dict[str, Any]
    algo: str
    spec_names: tuple[str, ...]
    n_trials: int
    n_done: int
    n_failed: int
    env_return: Stat | None
    length: Stat | None
    goal_rate: Stat | None
    success_rate: Stat | None
    compliance: dict[str, Stat]
    compliance_min: dict[str, float]
    frames_to_comply: Stat | None
    n_reached: int
    frames: Stat | None

    @classmethod
    def of(cls, members: Sequence[TrialRecord]) -> GroupSummary:
        """The summary of one group's trials."""
        done = [r for r in members if r.status == "done" and r.final]
        finals = [r.final for r in done if r.final is not None]
        first, reached = members[0], [r.frames_to_comply for r in done if r.frames_to_comply]
        rates = {s: [f["compliance"].get(s, math.nan) for f in finals] for s in first.spec_names}
        means = {k: Stat.of(f[key] for f in finals) for k, key in _FINAL_MEANS.items()}
        return cls(
            **means,
            group=first.group,
            row=first.row,
            settings=dict(first.settings),
            algo=first.algo,
            spec_names=first.spec_names,
            n_trials=len(members),
            n_done=len(done),
            n_failed=sum(r.status == "failed" for r in members),
            compliance={s: stat for s, v in rates.items() if (stat := Stat.of(v))},
            compliance_min={s: min(v) for s, v in rates.items() if v},
            frames_to_comply=Stat.of(reached),
            n_reached=len(reached),
            frames=Stat.of(r.frames for r in done if r.frames is not None),
        )

    def n_frames_text(self) -> str:
        """N_frames, with a count unless every finished seed reached it (``12.0k (2/3)``)."""
        value = format_frames(self.frames_to_comply and self.frames_to_comply.mean)
        full = self.n_done and self.n_reached == self.n_done
        return value if full else f"{value} ({self.n_reached}/{self.n_done})"

    def to_dict(self) -> dict[str, Any]:
        """JSON-able form (statistics as ``{"mean", "std", "n"}``)."""
        data = {k: v._asdict() if isinstance(v, Stat) else v for k, v in self.__dict__.items()}
        data["compliance"] = {k: v._asdict() for k, v in self.compliance.items()}
        return {**data, "spec_names": list(self.spec_names)}

    def cells(self) -> tuple[str, ...]:
        """The row as the table shows it."""
        return (
            self.group,
            self.algo,
            ", ".join(self.spec_names),
            f"{self.n_done}/{self.n_trials}",
            str(self.n_failed),
            pm(self.env_return),
            pm(self.length, 1),
            percent(self.goal_rate and self.goal_rate.mean),
            ", ".join(f"{k} {v.mean:.0%}" for k, v in self.compliance.items()) or "—",
            percent(self.success_rate and self.success_rate.mean),
            self.n_frames_text(),
        )

    def data(self, specs: Sequence[str]) -> tuple[Any, ...]:
        """The row as the CSV holds it (raw numbers; a mean and a std per statistic)."""
        settings = json.dumps(self.settings, sort_keys=True)
        row: list[Any] = [self.group, self.row, settings, self.algo, ";".join(self.spec_names)]
        row += [self.n_trials, self.n_done, self.n_failed]
        for s in (getattr(self, name) for name in _STATS):
            row += ["", ""] if s is None else [f"{s.mean:.6g}", f"{s.std:.6g}"]
        row.append(self.n_reached)
        for name in specs:
            s, low = self.compliance.get(name), self.compliance_min.get(name)
            row += ["", ""] if s is None else [f"{s.mean:.6g}", f"{low:.6g}"]
        return tuple(row)


@dataclass(frozen=True)
class SweepResult:
    """A sweep's trials (``records``) and groups, in the sweep's order; ``files``: the
    files written (label -> path)."""

    sweep_dir: Path
    name: str
    records: tuple[TrialRecord, ...]
    groups: tuple[GroupSummary, ...]
    files: dict[str, Path] = field(default_factory=dict)

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
        specs = list(dict.fromkeys(s for g in self.groups for s in g.spec_names))
        header = ("group", "algo", "specs", "seeds done", "failed", "R_π (env return)",
                  "N_steps", "goal rate", "compliance", "goal & compliant", "N_frames")  # fmt: skip
        data = ["group", "row", "settings", "algo", "specs", "n_trials", "n_done", "n_failed"]
        data += [f"{s}_{part}" for s in _STATS for part in ("mean", "std")] + ["n_reached"]
        data += [f"compliance_{s}_{part}" for s in specs for part in ("mean", "min")]
        rows = tuple(g.cells() for g in self.groups)
        return Table(header, rows, tuple(data), tuple(g.data(specs) for g in self.groups))

    def to_dict(self) -> dict[str, Any]:
        """What ``results.json`` holds."""
        groups = [g.to_dict() for g in self.groups]
        return {"name": self.name, "groups": groups, "trials": [r.to_dict() for r in self.records]}

    def write(self) -> None:
        """Writes ``results.json``, ``results.md`` (with the sweep's command and the failed
        trials' errors) and ``results.csv`` in the sweep directory."""
        files = {k: self.sweep_dir / f"results.{k}" for k in ("json", "md", "csv")}
        command = self.sweep_dir / "command.txt"
        table, failed = self.to_table(), [r for r in self.records if r.status == "failed"]
        blocks: list[Block] = [
            Heading(f"Sweep {self.name}"),
            *([Text(f"Command: `{command.read_text().strip()}`")] if command.exists() else []),
            Text(
                "Mean ± std over each group's finished seeds of the final evaluation; "
                "N_frames: first evaluation with ≥ 95% of episodes reaching the goal while "
                "complying with every spec (ground truth), mean over the seeds that reached "
                "it."
            ),
            table,
            *([Text("Failed trials:")] if failed else []),
            *([Text("\n".join(f"- `{r.trial_id}`: {r.error}" for r in failed))] if failed else []),
        ]
        atomic_write_json(files["json"], self.to_dict())
        atomic_write_text(files["md"], render_markdown(blocks))
        atomic_write_text(files["csv"], render_csv(table))
        self.files.update(json=files["json"], markdown=files["md"], csv=files["csv"])


def summarise_trials(records: Sequence[TrialRecord]) -> tuple[GroupSummary, ...]:
    """One :class:`GroupSummary` per group, in first-seen order (statistics over seeds).

    Example:
        >>> rec = lambda seed, ret: TrialRecord(
        ...     f"a/seed-{seed}", "a", "a", seed, {}, Path("."), "done", "ppo", ("edge",),
        ...     final={"env_return_mean": ret, "length_mean": 7.0, "goal_rate": 1.0,
        ...            "success_rate": 1.0, "compliance": {"edge": 1.0}},
        ...     frames=2000, frames_to_comply=1000)
        >>> (group,) = summarise_trials([rec(0, 80.0), rec(1, 90.0)])
        >>> group.env_return, group.n_reached
        (Stat(mean=85.0, std=5.0, n=2), 2)
    """
    groups: dict[str, list[TrialRecord]] = {}
    for record in records:
        groups.setdefault(record.group, []).append(record)
    return tuple(GroupSummary.of(members) for members in groups.values())
