"""One trial: its run directory's files, its record, and running it (train, evaluate)."""

from __future__ import annotations

import time
import traceback
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from noisybolt.errors import CorruptFileError, NoCheckpointError
from noisybolt.experiments.sweeps.results import TrialRecord
from noisybolt.io import atomic_write_json, read_json
from noisybolt.runs.rundir import RunDirectory

if TYPE_CHECKING:
    from noisybolt.runs.config import TrainConfig

__all__ = ["TrialDirectory", "TrialTask", "attempt", "run_trial"]


class TrialDirectory(RunDirectory):
    """A sweep trial's run directory: the run's files, and ``trial.json``: how the last
    attempt ended (``status``: ``done`` or ``failed``; ``seconds``) and every failed
    attempt (``attempts``: its error, message and traceback), oldest first."""

    def outcome(self) -> dict[str, Any]:
        """``trial.json`` (``{"attempts": []}`` before an attempt ends); runs written
        before it held the attempts kept them in ``failure.json``, read from there."""
        old = read_json(self.file("failure.json"), default={}, kind=dict)
        new = read_json(self.file("trial.json"), default={}, kind=dict)
        return {"attempts": old.get("attempts", []), **new}

    def end(self, seconds: float, error: BaseException | None = None) -> None:
        """Records how an attempt ended: done, or failed with ``error``."""
        attempts = self.outcome()["attempts"]
        if error is not None:
            name = type(error).__name__
            message = f"{name}: {error}".splitlines()[0]
            trace = "".join(traceback.format_exception(error))
            when = time.strftime("%Y-%m-%dT%H:%M:%S")
            attempts.append({"time": when, "error": name, "message": message, "traceback": trace})
        self.path.mkdir(parents=True, exist_ok=True)
        status = "done" if error is None else "failed"
        atomic_write_json(
            self.file("trial.json"), {"status": status, "seconds": seconds, "attempts": attempts}
        )

    def finished(self, frames: int, episodes: int = 0) -> bool:
        """Whether the run trained to ``frames`` at least (and wrote its summary) and has
        its final evaluation of ``episodes`` episodes (0: none asked)."""
        trained = read_json(self.config_path, default={}).get("frames", 0) >= frames
        evaluation = read_json(self.file("evaluation.json"), default={})
        evaluated = episodes <= 0 or evaluation.get("episodes") == episodes
        return trained and self.file("summary.json").exists() and evaluated

    def checkpoint_frames(self) -> int | None:
        """The frames of the run's latest checkpoint (None: it has none): a trial stopped
        mid-run (a signal, a lost machine) resumes from there when the sweep runs again."""
        from noisybolt.runs.checkpoints import latest_checkpoint

        try:
            return latest_checkpoint(self).frames
        except (NoCheckpointError, CorruptFileError):  # nothing a resume could start from
            return None


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
        from noisybolt.runs.config import TrainConfig

        return TrainConfig.from_dict(self.trial["config"])

    def finished(self) -> bool:
        """Whether the trial trained to its frames and has its final evaluation."""
        folder = TrialDirectory(self.run_dir)
        return folder.finished(self.config.frames, self.final_eval_episodes)

    def record(self) -> TrialRecord:
        """The trial's record, read from its directory."""
        folder, trial, finished = TrialDirectory(self.run_dir), self.trial, self.finished()
        outcome = folder.outcome()
        attempts = outcome["attempts"]
        summary = read_json(folder.file("summary.json"), default={}) if finished else {}
        if finished and self.final_eval_episodes:  # the final evaluation, not the last periodic
            summary["final"] = read_json(folder.file("evaluation.json"))
        failed = outcome.get("status") == "failed"
        checkpoint = None if finished or failed else folder.checkpoint_frames()
        status = (
            "done" if finished else "failed" if failed
            else "pending" if checkpoint is None else "interrupted"
        )  # fmt: skip
        return TrialRecord(
            trial_id=self.trial_id, group=trial["group"], row=trial["row"], seed=trial["seed"],
            settings=dict(trial.get("settings") or {}), run_dir=folder.path,
            status=status, algo=self.config.algorithm.name,
            spec_names=tuple(
                str(s.get("name") or s.get("formula")) for s in self.config.bolt.specs
            ),
            final=summary.get("final"), frames=summary.get("frames"),
            frames_to_comply=summary.get("frames_to_comply"), failed_attempts=len(attempts),
            checkpoint_frames=checkpoint,
            error=attempts[-1]["message"] if attempts else None,
            seconds=outcome.get("seconds") if finished else None,
        )  # fmt: skip


def attempt(task: TrialTask, runner: Callable[[TrialTask], TrialRecord]) -> TrialRecord:
    """One attempt at a trial by ``runner`` (:func:`run_trial`): what it raises is recorded
    in the trial's ``trial.json`` and raised again, for whoever retries (the local
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
    finished trial is left untouched; ``log`` defaults to the run's ``log.txt``."""
    import torch

    from noisybolt.runs import run_evaluation, training

    torch.set_num_threads(1)  # one thread per trial: parallel trials share the cores
    folder, config, start = TrialDirectory(task.run_dir), task.config, time.perf_counter()
    if task.finished():
        return task.record()

    def to_file(line: str) -> None:
        folder.path.mkdir(parents=True, exist_ok=True)
        with open(folder.file("log.txt"), "a", encoding="utf-8") as handle:
            handle.write(line.rstrip("\n") + "\n")

    if not folder.finished(config.frames):  # not trained yet
        # A trial stopped before its first checkpoint has nothing to resume: start over.
        resume = folder.exists() and folder.file("checkpoints/latest.json").exists()
        argv, restart = list(task.argv) or None, folder.exists() and not resume
        training.train(
            config, folder.path, resume=resume, restart=restart, argv=argv, log=log or to_file
        )
    if task.final_eval_episodes > 0:
        # The run's config is the sweep's own (checked equal to it before any trial ran):
        # the code it names is the sweep's author's, given in the sweep file.
        run_evaluation.evaluate_run(folder.path, episodes=task.final_eval_episodes, trust_code=True)
    folder.end(time.perf_counter() - start)
    return task.record()
