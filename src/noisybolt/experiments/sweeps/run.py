"""Running a sweep: the trial directories checked, the pending trials run (one after the
other in this process, or in parallel on Ray Tune: :mod:`~.ray_tune`), the tables
written from the trials' records."""

from __future__ import annotations

import contextlib
import os
import sys
import time
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

from noisybolt.errors import ConfigError
from noisybolt.experiments.sweeps.config import SweepConfig
from noisybolt.experiments.sweeps.results import SweepResult, TrialRecord
from noisybolt.experiments.sweeps.trials import TrialDirectory, TrialTask, attempt, run_trial
from noisybolt.io import atomic_write_json, read_json
from noisybolt.runs.rundir import RunDirectory

__all__ = ["BACKENDS", "SWEEP_FILE", "collect_sweep", "longest_first", "run_sweep"]

BACKENDS: tuple[str, ...] = ("local", "ray")
#: Written in the sweep directory: the sweep as resolved (its config and every trial).
SWEEP_FILE = "sweep.json"


def run_sweep(
    sweep: SweepConfig,
    out_dir: str | os.PathLike[str],
    *,
    backend: str = "local",
    workers: int | None = None,
    address: str | None = None,
    argv: Sequence[str] | None = None,
    log: Callable[[str], None] = print,
    runner: Callable[[TrialTask], TrialRecord] = run_trial,
    callbacks: Sequence[Any] = (),
) -> SweepResult:
    """Runs (or resumes) every trial of a sweep into ``out_dir`` and writes its tables.

    ``workers``: trials at once. ``local``: 1 (the default) runs them one after the other
    in this process, more run on Ray Tune on a local Ray of that many trials' CPUs;
    ``ray``: at most that many on the Ray at ``address`` (None: a local one; default 0:
    as its CPUs allow). ``argv``: the command saved in ``command.txt`` (default: this
    process's). ``runner`` runs one attempt at a trial (a test may inject failures);
    ``callbacks``: Tune's.

    Raises:
        ConfigError: an unknown backend, Ray options without Ray, or a trial directory
            holding a run with other settings; raised before any trial runs.
        BackendUnavailableError: Ray is needed (``ray``, or ``workers > 1``) and not installed.
    """
    from noisybolt.runs.training import check_same_config

    if backend not in BACKENDS:
        raise ConfigError(f"unknown backend {backend!r}; known backends: {list(BACKENDS)}")
    if (address is not None or callbacks) and backend != "ray":
        raise ConfigError("--address (a Ray cluster) and Tune callbacks need --backend ray")
    workers = (1 if backend == "local" else 0) if workers is None else workers
    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 0:
        raise ConfigError(f"workers must be an integer >= 0, got {workers!r}")
    on_ray = backend == "ray" or workers > 1
    if on_ray:
        from noisybolt.experiments.sweeps.ray_tune import require_ray, run_ray

        require_ray()
    argv, sweep_dir = list(sys.argv if argv is None else argv), Path(out_dir)
    tasks = _tasks(sweep_dir.resolve(), sweep.to_dict(), argv)
    for task in tasks:  # a run with other settings (its frames aside) is refused
        if RunDirectory(task.run_dir).exists():
            check_same_config(RunDirectory(task.run_dir), task.config)
        else:  # and a new trial's budget it cannot keep, before any trial runs
            task.config.check_budget()
    sweep_dir.mkdir(parents=True, exist_ok=True)
    atomic_write_json(sweep_dir / SWEEP_FILE, sweep.to_dict())
    RunDirectory(sweep_dir).write_command(argv)
    pending = [t for t in tasks if not t.finished()]
    resumed = sum(TrialDirectory(t.run_dir).checkpoint_frames() is not None for t in pending)
    where = f"Ray Tune, {workers or 'as many as the CPUs allow'} at once" if on_ray else "here"
    log(
        f"sweep {sweep.name}: {len(tasks)} trials, {len(tasks) - len(pending)} already "
        f"finished, {len(pending)} to run ({where}"
        f"{f'; {resumed} from their checkpoints' if resumed else ''}) in {sweep_dir}"
    )
    start, ran = time.perf_counter(), []
    if not on_ray:
        for task in pending:  # one after the other, each with its retries
            for _ in range(sweep.retries + 1):
                with contextlib.suppress(Exception):  # recorded in the trial's trial.json
                    attempt(task, runner)
                    break
    elif pending:
        _prepare_detectors(pending, log)
        ran = run_ray(
            sweep, sweep_dir, tasks, [t.trial_id for t in longest_first(pending)], address=address,
            workers=workers, local_cpus=workers if backend == "local" else None,
            runner=runner, callbacks=callbacks, log=log,
        )  # fmt: skip
    records = {t.trial_id: t.record() for t in tasks} | {r.trial_id: r for r in ran}
    result = SweepResult.of(sweep_dir, sweep.name, list(records.values()))
    result.write()
    unfinished = len(tasks) - result.n_done - result.n_failed
    log(
        f"sweep {sweep.name}: {result.n_done} done, {result.n_failed} failed"
        + (f", {unfinished} unfinished (run again to resume)" if unfinished else "")
        + f" of {len(tasks)} in {time.perf_counter() - start:.0f} s; table in "
        + str(result.files["markdown"])
    )
    return result


def longest_first(tasks: Sequence[TrialTask]) -> list[TrialTask]:
    """The trials in the order parallel workers should start them: the largest frame budget
    first (stable: grid order among equals). Trials started in grid order leave the long
    ones (Table 1's A2C rows train up to 330k frames, its DQN rows 30k) to the end, where
    one worker trains alone while the others idle; longest-first bounds that tail by the
    shortest trials instead (the LPT rule). The budget is an upper bound where a trial
    stops when solved, the only cost known before it runs."""
    return sorted(tasks, key=lambda task: task.config.frames, reverse=True)


def collect_sweep(sweep_dir: str | os.PathLike[str], *, write: bool = True) -> SweepResult:
    """Reads every trial of a sweep directory; (re)writes ``results.json/md/csv``.

    Raises:
        ConfigError: the directory holds no sweep (no ``sweep.json``).
    """
    root = Path(sweep_dir)
    data = read_json(root / SWEEP_FILE, default=None)
    if not isinstance(data, dict) or "trials" not in data:
        raise ConfigError(f"{root} holds no sweep (no readable {SWEEP_FILE})")
    result = SweepResult.of(root, str(data.get("name")), [t.record() for t in _tasks(root, data)])
    if write:
        result.write()
    return result


def _tasks(root: Path, sweep: Mapping[str, Any], argv: Sequence[str] = ()) -> list[TrialTask]:
    """The trials of a sweep (``sweep.json``'s content) in the sweep directory ``root``."""
    episodes, argv = int(sweep.get("final_eval_episodes", 0)), tuple(argv)
    return [TrialTask(t, str(root / "trials" / t["id"]), episodes, argv) for t in sweep["trials"]]


def _prepare_detectors(tasks: Sequence[TrialTask], log: Callable[[str], None]) -> None:
    """Trains each cached classifier once, before trials run in parallel."""
    from noisybolt.runs.environments import prepare_bolt

    configs = [t.config for t in tasks]
    for c in {
        repr((c.world_config.name, c.world_config.kwargs, c.detector)): c for c in configs
    }.values():
        if c.detector.kind == "classifier" and not c.detector.path:
            prepare_bolt(c, seed=c.seed, log=log)
