"""One trial: its directory's protocol, and running it (train, evaluate, record)."""

from __future__ import annotations

import json
import time
import traceback
from collections.abc import Callable, Mapping
from dataclasses import asdict, dataclass, replace
from pathlib import Path
from typing import Any

from noisybolt.experiments.sweeps.results import TrialRecord
from noisybolt.io import atomic_write_json
from noisybolt.rundir import RunDirectory

__all__ = ["TrialDirectory", "TrialTask", "attempt", "run_trial"]


def read_json(path: Path) -> Any:
    """A JSON file's content; None when it is missing or unreadable (not yet written)."""
    try:
        return json.loads(path.read_text())
    except (FileNotFoundError, json.JSONDecodeError, UnicodeDecodeError):
        return None


class TrialDirectory(RunDirectory):
    """A sweep trial's run directory: the run's own files, plus ``failure.json`` (every
    failed attempt's error and traceback) and ``trial.json`` (its last outcome)."""

    def failures(self) -> list[dict[str, Any]]:
        """Every failed attempt recorded here, oldest first."""
        data = read_json(self.file("failure.json"))
        return list(data.get("attempts", [])) if isinstance(data, dict) else []

    def record_failure(self, error: BaseException) -> str:
        """Appends a failed attempt (with its traceback); returns its one-line message."""
        message = f"{type(error).__name__}: {error}".splitlines()[0]
        attempt = {
            "time": time.strftime("%Y-%m-%dT%H:%M:%S"),
            "error": type(error).__name__,
            "message": message,
            "traceback": "".join(traceback.format_exception(error)),
        }
        self.path.mkdir(parents=True, exist_ok=True)
        atomic_write_json(self.file("failure.json"), {"attempts": [*self.failures(), attempt]})
        return message

    def write_outcome(self, status: str, seconds: float) -> None:
        """Records how the trial's last attempt ended (``done`` or ``failed``)."""
        atomic_write_json(self.file("trial.json"), {"status": status, "seconds": seconds})

    def finished(self, final_eval_episodes: int, frames: int | None = None) -> bool:
        """Whether the trial is complete: trained (to ``frames`` at least) and evaluated."""
        saved = read_json(self.config_path) or {}
        if not self.file("summary.json").exists() or int(saved.get("frames", 0)) < (frames or 0):
            return False
        evaluation = read_json(self.file("evaluation.json"))
        return final_eval_episodes <= 0 or (
            isinstance(evaluation, dict) and evaluation.get("episodes") == final_eval_episodes
        )

    def record(self, trial: Mapping[str, Any], final_eval_episodes: int = 0) -> TrialRecord:
        """The trial's record, read from here (``trial``: its entry of ``sweep.json``)."""
        config = trial.get("config") or read_json(self.config_path) or {}
        failures = self.failures()
        outcome = read_json(self.file("trial.json")) or {}
        record = TrialRecord(
            trial_id=str(trial["id"]),
            group=str(trial["group"]),
            row=str(trial["row"]),
            seed=int(trial["seed"]),
            settings=dict(trial.get("settings") or {}),
            run_dir=self.path,
            status="failed" if outcome.get("status") == "failed" else "pending",
            algo=str(config.get("algo", "?")),
            spec_names=tuple(
                str(s.get("name") or s.get("formula")) for s in config.get("specs", ())
            ),
            failed_attempts=len(failures),
            error=failures[-1]["message"] if failures else None,
        )
        if not self.finished(final_eval_episodes, config.get("frames")):
            return record
        summary = read_json(self.file("summary.json")) or {}
        final = (
            read_json(self.file("evaluation.json")) if final_eval_episodes else summary.get("final")
        )
        return replace(
            record,
            status="done",
            final=final,
            frames=summary.get("frames"),
            frames_to_comply=summary.get("frames_to_comply"),
            seconds=outcome.get("seconds"),
        )


@dataclass(frozen=True)
class TrialTask:
    """What a worker needs to run one trial (plain data, so it pickles to any process).

    Attributes:
        trial: the trial's entry of ``sweep.json`` (id, group, row, seed, settings, config).
        run_dir: the trial's run directory (absolute).
        final_eval_episodes: episodes of the final evaluation (0: none).
        argv: the sweep's command line, saved as each run's ``command.txt``.
    """

    trial: dict[str, Any]
    run_dir: str
    final_eval_episodes: int = 0
    argv: tuple[str, ...] = ()

    @property
    def trial_id(self) -> str:
        """The trial's id."""
        return str(self.trial["id"])

    def to_dict(self) -> dict[str, Any]:
        """JSON-able form."""
        return {**asdict(self), "argv": list(self.argv)}


def attempt(task: TrialTask, runner: Callable[[TrialTask], TrialRecord]) -> TrialRecord:
    """One attempt at a trial by ``runner`` (:func:`run_trial`): what it raises is recorded
    in the trial's ``failure.json`` and raised again, so that whoever retries (the local
    loop, or Ray Tune) decides what comes next."""
    start = time.perf_counter()
    try:
        return runner(task)
    except Exception as error:
        folder = TrialDirectory(task.run_dir)
        folder.record_failure(error)
        folder.write_outcome("failed", time.perf_counter() - start)
        raise


def run_trial(task: TrialTask, *, log: Callable[[str], None] | None = None) -> TrialRecord:
    """Runs a trial to its end; safe to call again to resume.

    A finished trial is left untouched. Otherwise the run trains (resuming from its last
    checkpoint when its directory holds the run), then is evaluated when the sweep asks
    for a final evaluation.
    """
    import torch

    from noisybolt.agents import run_evaluation, training

    torch.set_num_threads(1)  # one thread per trial: parallel trials share the cores
    folder = TrialDirectory(task.run_dir)
    if not folder.finished(task.final_eval_episodes, task.trial["config"]["frames"]):
        start = time.perf_counter()

        def to_file(line: str) -> None:
            folder.path.mkdir(parents=True, exist_ok=True)
            with open(folder.file("log.txt"), "a", encoding="utf-8") as handle:
                handle.write(line.rstrip("\n") + "\n")

        config = training.TrainConfig.from_dict(task.trial["config"])
        if not folder.finished(0, config.frames):
            # A trial stopped before its first checkpoint has nothing to resume: start over.
            started = folder.exists()
            resume = started and folder.file("checkpoints/latest.json").exists()
            argv = list(task.argv) or None
            training.train(
                config,
                folder.path,
                resume=resume,
                restart=started and not resume,
                argv=argv,
                log=log or to_file,
            )
        if task.final_eval_episodes > 0:
            run_evaluation.evaluate_run(folder.path, episodes=task.final_eval_episodes)
        folder.write_outcome("done", time.perf_counter() - start)
    return folder.record(task.trial, task.final_eval_episodes)
