"""A sweep's results: one record per trial, one summary per group, and their table."""

from __future__ import annotations

import json
import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np

from noisybolt.experiments.reporting import Table, format_frames, percent, pm

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
        array = np.asarray(list(values), dtype=np.float64)
        return None if array.size == 0 else cls(float(array.mean()), float(array.std()), array.size)

    @classmethod
    def from_dict(cls, data: Mapping[str, Any] | None) -> Stat | None:
        """Reads ``_asdict()``'s output back (None stays None)."""
        return (
            None if data is None else cls(float(data["mean"]), float(data["std"]), int(data["n"]))
        )


@dataclass(frozen=True)
class TrialRecord:
    """A trial's state and results.

    Attributes:
        trial_id: the trial's id.
        group: its group (the id without the seed).
        row: its row.
        seed: its seed.
        settings: its settings axes' values.
        run_dir: its run directory.
        status: ``"done"``, ``"failed"`` or ``"pending"`` (not run, or interrupted).
        algo: its algorithm.
        spec_names: its specs' names (formulas where unnamed).
        final: the evaluation the tables report; None unless done.
        frames: frames trained.
        frames_to_comply: N_frames (None if never reached).
        failed_attempts: attempts that raised (across every run of the sweep).
        error: the last error's one-line message, if any.
        seconds: wall time of the attempt that finished it.
    """

    trial_id: str
    group: str
    row: str
    seed: int
    settings: dict[str, Any]
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
        """Reads :meth:`to_dict`'s output back (how a Ray trial reports its record)."""
        return cls(
            **{**data, "run_dir": Path(data["run_dir"]), "spec_names": tuple(data["spec_names"])}
        )


@dataclass(frozen=True)
class GroupSummary:
    """A group's trials (one row of the results table), over seeds.

    ``env_return`` (R_π), ``length`` (N_steps), ``goal_rate``, ``success_rate`` (goal and
    compliant), per-spec ``compliance``: the final evaluations' means, over seeds;
    ``compliance_min``: the lowest seed's compliance per spec; ``frames_to_comply``:
    N_frames over the ``n_reached`` seeds that reached it.
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

    def n_frames_text(self) -> str:
        """N_frames as tables show it: with a count when not every finished seed reached it
        (``12.0k``, ``12.0k (2/3)``, ``— (0/3)``)."""
        value = format_frames(self.frames_to_comply.mean if self.frames_to_comply else None)
        if self.n_done and self.n_reached == self.n_done:
            return value
        return f"{value} ({self.n_reached}/{self.n_done})"

    def to_dict(self) -> dict[str, Any]:
        """JSON-able form (statistics as ``{"mean", "std", "n"}``)."""
        data = {k: v._asdict() if isinstance(v, Stat) else v for k, v in self.__dict__.items()}
        data["compliance"] = {k: v._asdict() for k, v in self.compliance.items()}
        data["spec_names"] = list(self.spec_names)
        return data


_STATS = ("env_return", "length", "goal_rate", "success_rate", "frames_to_comply", "frames")


def groups_table(groups: Sequence[GroupSummary]) -> Table:
    """The results table: one row per group (mean ± std over its finished seeds); its
    CSV form has each mean and std in a column of its own."""
    header = (
        "group", "algo", "specs", "seeds done", "failed", "R_π (env return)", "N_steps",
        "goal rate", "compliance", "goal & compliant", "N_frames",
    )  # fmt: skip
    rows = tuple(
        (
            g.group,
            g.algo,
            ", ".join(g.spec_names),
            f"{g.n_done}/{g.n_trials}",
            str(g.n_failed),
            pm(g.env_return),
            pm(g.length, 1),
            percent(g.goal_rate and g.goal_rate.mean),
            ", ".join(f"{k} {v.mean:.0%}" for k, v in g.compliance.items()) or "—",
            percent(g.success_rate and g.success_rate.mean),
            g.n_frames_text(),
        )
        for g in groups
    )
    specs = list(dict.fromkeys(name for g in groups for name in g.spec_names))
    data_header = ["group", "row", "settings", "algo", "specs", "n_trials", "n_done", "n_failed"]
    data_header += [f"{s}_{part}" for s in _STATS for part in ("mean", "std")] + ["n_reached"]
    data_header += [f"compliance_{s}_{part}" for s in specs for part in ("mean", "min")]
    data_rows = []
    for g in groups:
        row: list[Any] = [g.group, g.row, json.dumps(g.settings, sort_keys=True), g.algo]
        row += [";".join(g.spec_names), g.n_trials, g.n_done, g.n_failed]
        for name in _STATS:
            stat = getattr(g, name)
            row += ["", ""] if stat is None else [f"{stat.mean:.6g}", f"{stat.std:.6g}"]
        row.append(g.n_reached)
        for s in specs:
            stat = g.compliance.get(s)
            row += ["", ""] if stat is None else [f"{stat.mean:.6g}", f"{g.compliance_min[s]:.6g}"]
        data_rows.append(tuple(row))
    return Table(header, rows, tuple(data_header), tuple(data_rows))


@dataclass(frozen=True)
class SweepResult:
    """A sweep's trials and table.

    Attributes:
        sweep_dir: the sweep directory.
        name: the sweep's name.
        records: every trial's record, in the sweep's order.
        groups: one summary per group, in the sweep's order.
        files: files written (label -> path).
    """

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
        """The results table (see :func:`groups_table`)."""
        return groups_table(self.groups)

    def to_dict(self) -> dict[str, Any]:
        """What ``results.json`` holds."""
        groups = [g.to_dict() for g in self.groups]
        return {"name": self.name, "groups": groups, "trials": [r.to_dict() for r in self.records]}


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
    summaries = []
    for group, members in groups.items():
        done = [r for r in members if r.status == "done" and r.final]
        finals = [r.final for r in done if r.final is not None]
        first = members[0]
        rates = {
            s: [float(f["compliance"].get(s, math.nan)) for f in finals] for s in first.spec_names
        }
        reached = [float(r.frames_to_comply) for r in done if r.frames_to_comply is not None]
        summaries.append(
            GroupSummary(
                group=group,
                row=first.row,
                settings=dict(first.settings),
                algo=first.algo,
                spec_names=first.spec_names,
                n_trials=len(members),
                n_done=len(done),
                n_failed=sum(r.status == "failed" for r in members),
                env_return=Stat.of(f["env_return_mean"] for f in finals),
                length=Stat.of(f["length_mean"] for f in finals),
                goal_rate=Stat.of(f["goal_rate"] for f in finals),
                success_rate=Stat.of(f["success_rate"] for f in finals),
                compliance={s: stat for s, v in rates.items() if (stat := Stat.of(v)) is not None},
                compliance_min={s: float(min(v)) for s, v in rates.items() if v},
                frames_to_comply=Stat.of(reached),
                n_reached=len(reached),
                frames=Stat.of(float(r.frames) for r in done if r.frames is not None),
            )
        )
    return tuple(summaries)
