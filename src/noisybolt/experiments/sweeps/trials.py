"""One trial: its run directory's files, and running it (train, evaluate, record)."""

from __future__ import annotations

import json
import time
import traceback
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

from noisybolt.experiments.sweeps.results import TrialRecord
from noisybolt.io import atomic_write_json
from noisybolt.rundir import RunDirectory

if TYPE_CHECKING:
    from noisybolt.agents.config import TrainConfig

__all__ = ["TrialDirectory", "TrialTask", "attempt", "read_json", "run_trial"]


def read_json(path: Path) -> Any:
    """A JSON file's content; None when it is missing or unreadable (not yet written)."""
    try:
        return json.loads(path.read_text())
    except (FileNotFoundError, json.JSONDecodeError, UnicodeDecodeError):
        return None


class TrialDirectory(RunDirectory):
    """A sweep trial's run directory: the run's files, plus ``failure.json`` (every failed
    attempt's error and traceback) and ``trial.json`` (how the last attempt ended)."""

    def failures(self) -> list[dict[str, Any]]:
        """Every failed attempt recorded here, oldest first."""
        data = read_json(self.file("failure.json"))
        return list(data.get("attempts", [])) if isinstance(data, dict) else []

    def end(self, seconds: float, error: BaseException | None = None) -> None:
        """Records how an attempt ended: done, or failed with ``error``."""
        if error is not None:
            failure = {
                "time": time.strftime("%Y-%m-%dT%H:%M:%S"),
                "error": type(error).__name__,
                "message": f"{type(error).__name__}: {error}".splitlines()[0],
                "traceback": "".join(traceback.format_exception(error)),
            }
            self.path.mkdir(parents=True, exist_ok=True)
            atomic_write_json(self.file("failure.json"), {"attempts": [*self.failures(), failure]})
        status = "done" if error is None else "failed"
        atomic_write_json(self.file("trial.json"), {"status": status, "seconds": seconds})

    def trained(self, frames: int) -> bool:
        """Whether the run trained to ``frames`` at least (and wrote its summary)."""
        saved = read_json(self.config_path) or {}
        return self.file("summary.json").exists() and int(saved.get("frames", 0)) >= frames

    def evaluated(self, episodes: int) -> bool:
        """Whether the final evaluation of ``episodes`` episodes is written (0: none asked)."""
        evaluation = read_json(self.file("evaluation.json")) or {}
        return episodes <= 0 or evaluation.get("episodes") == episodes


@dataclass(frozen=True)
class TrialTask:
    """A trial as a worker runs it (plain data: it pickles to any process): its entry of
    ``sweep.json``, its run directory, the final evaluation's episodes (0: none) and the
    sweep's command line (each run's ``command.txt``)."""

    trial: dict[str, Any]
    run_dir: str
    final_eval_episodes: int = 0
    argv: tuple[str, ...] = ()

    @property
    def trial_id(self) -> str:
        """The trial's id."""
        return str(self.trial["id"])

    @property
    def config(self) -> TrainConfig:
        """The trial's training config."""
        from noisybolt.agents.config import TrainConfig

        return TrainConfig.from_dict(self.trial["config"])

    def finished(self) -> bool:
        """Whether the trial trained to its frames and has its final evaluation."""
        folder = TrialDirectory(self.run_dir)
        return folder.trained(self.config.frames) and folder.evaluated(self.final_eval_episodes)

    def record(self) -> TrialRecord:
        """The trial's record, read from its directory."""
        folder, config, trial = TrialDirectory(self.run_dir), self.config, self.trial
        failures, outcome = folder.failures(), read_json(folder.file("trial.json")) or {}
        record = TrialRecord(
            trial_id=self.trial_id,
            group=trial["group"],
            row=trial["row"],
            seed=trial["seed"],
            settings=dict(trial.get("settings") or {}),
            run_dir=folder.path,
            status="failed" if outcome.get("status") == "failed" else "pending",
            algo=config.algo,
            spec_names=tuple(str(s.get("name") or s.get("formula")) for s in config.specs),
            failed_attempts=len(failures),
            error=failures[-1]["message"] if failures else None,
        )
        if not self.finished():
            return record
        summary = read_json(folder.file("summary.json")) or {}
        final_eval = self.final_eval_episodes and read_json(folder.file("evaluation.json"))
        return replace(
            record,
            status="done",
            final=final_eval or summary.get("final"),
            frames=summary.get("frames"),
            frames_to_comply=summary.get("frames_to_comply"),
            seconds=outcome.get("seconds"),
        )


def attempt(task: TrialTask, runner: Callable[[TrialTask], TrialRecord]) -> TrialRecord:
    """One attempt at a trial by ``runner`` (:func:`run_trial`): what it raises is recorded
    in the trial's ``failure.json`` and raised again, for whoever retries (the local
    backend, or Ray Tune)."""
    start = time.perf_counter()
    try:
        return runner(task)
    except Exception as error:
        TrialDirectory(task.run_dir).end(time.perf_counter() - start, error)
        raise


def run_trial(task: TrialTask, *, log: Callable[[str], None] | None = None) -> TrialRecord:
    """Runs a trial to its end (safe to call again: it resumes): trains, resuming from the
    run's last checkpoint, then evaluates when the sweep asks for a final evaluation. A
    finished trial is left untouched."""
    import torch

    from noisybolt.agents import run_evaluation, training

    torch.set_num_threads(1)  # one thread per trial: parallel trials share the cores
    folder, config = TrialDirectory(task.run_dir), task.config
    if task.finished():
        return task.record()
    start = time.perf_counter()

    def to_file(line: str) -> None:
        folder.path.mkdir(parents=True, exist_ok=True)
        with open(folder.file("log.txt"), "a", encoding="utf-8") as handle:
            handle.write(line.rstrip("\n") + "\n")

    if not folder.trained(config.frames):
        # A trial stopped before its first checkpoint has nothing to resume: start over.
        resume = folder.exists() and folder.file("checkpoints/latest.json").exists()
        argv, out = list(task.argv) or None, log or to_file
        restart = folder.exists() and not resume
        training.train(config, folder.path, resume=resume, restart=restart, argv=argv, log=out)
    if task.final_eval_episodes > 0:
        run_evaluation.evaluate_run(folder.path, episodes=task.final_eval_episodes)
    folder.end(time.perf_counter() - start)
    return task.record()
