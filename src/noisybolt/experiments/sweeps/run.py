"""Running a sweep: validation of what is on disk, the local backend, and the results.

Backends run the pending trials and return their records: ``local`` (this process, or a
pool of ``workers`` processes, retrying a failed trial ``retries`` times) and ``ray``
(:mod:`noisybolt.experiments.sweeps.ray_tune`: Ray Tune retries, resumes and returns
the results). Either way the tables are built from the records the backend returned.
"""

from __future__ import annotations

import os
import sys
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from noisybolt.errors import ConfigError
from noisybolt.experiments.reporting import Block, Heading, Text, render_csv, render_markdown
from noisybolt.experiments.sweeps.config import SweepConfig
from noisybolt.experiments.sweeps.results import SweepResult, TrialRecord, summarise_trials
from noisybolt.experiments.sweeps.trials import (
    TrialDirectory,
    TrialTask,
    attempt,
    read_json,
    run_trial,
)
from noisybolt.io import atomic_write_json, atomic_write_text
from noisybolt.rundir import RunDirectory, config_differences

__all__ = ["BACKENDS", "SWEEP_FILE", "collect_sweep", "run_sweep", "write_results"]

BACKENDS: tuple[str, ...] = ("local", "ray")
#: Written in the sweep directory: the sweep as resolved (its config and every trial).
SWEEP_FILE = "sweep.json"
TrialRunner = Callable[[TrialTask], TrialRecord]


def _attempts(task: TrialTask, retries: int, runner: TrialRunner) -> TrialRecord:
    """The local backend's retry loop: ``retries`` more attempts after a failure."""
    for _ in range(retries + 1):
        try:
            return attempt(task, runner)
        except Exception:  # recorded in the trial's failure.json
            continue
    return TrialDirectory(task.run_dir).record(task.trial, task.final_eval_episodes)


def _run_local(
    tasks: Sequence[TrialTask], *, retries: int, workers: int, runner: TrialRunner
) -> list[TrialRecord]:
    if workers <= 1 or len(tasks) <= 1:
        return [_attempts(task, retries, runner) for task in tasks]
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor

    # spawn, not fork: torch in a forked child of a process that used threads can hang.
    context = multiprocessing.get_context("spawn")
    records = []
    with ProcessPoolExecutor(max_workers=workers, mp_context=context) as pool:
        futures = [pool.submit(_attempts, task, retries, runner) for task in tasks]
        for task, future in zip(tasks, futures, strict=True):
            try:
                records.append(future.result())
            except Exception as error:  # the worker process itself died (killed, OOM)
                folder = TrialDirectory(task.run_dir)
                folder.record_failure(error)
                folder.write_outcome("failed", 0.0)
                records.append(folder.record(task.trial, task.final_eval_episodes))
    return records


def _check_clashes(sweep: SweepConfig, trials_dir: Path) -> None:
    """Refuses trial directories holding runs with other settings (frames aside)."""
    from noisybolt.agents.training import RESUMABLE_KEYS

    clashes = []
    for trial in sweep.trials:
        saved = read_json(trials_dir / trial.trial_id / "config.json")
        diffs = saved and config_differences(saved, trial.config.to_dict(), ignore=RESUMABLE_KEYS)
        if diffs:
            clashes.append(f"{trial.trial_id} ({', '.join(sorted(diffs))})")
    if clashes:
        raise ConfigError(
            f"{trials_dir.parent} holds trials trained with other settings: "
            f"{'; '.join(clashes[:5])}; use another output directory, or delete those trials"
        )


def _prepare_detectors(sweep: SweepConfig, log: Callable[[str], None]) -> None:
    """Trains each cached classifier once, before trials run in parallel."""
    from noisybolt.agents.training import make_detector
    from noisybolt.envs import make_world

    seen = set()
    for trial in sweep.trials:
        c = trial.config
        if c.detector.kind != "classifier" or c.detector.path:
            continue
        key = repr((c.world, sorted(c.world_kwargs.items()), c.detector))
        if key not in seen:
            seen.add(key)
            probe = make_world(c.world, num_envs=1, seed=c.seed, **c.world_kwargs)
            make_detector(
                c.detector,
                world=c.world,
                world_kwargs=c.world_kwargs,
                fluent_names=tuple(probe.fluent_names),
                camera_spec=probe.camera_spec,
                progress=False,
                log=log,
            )


def run_sweep(
    sweep: SweepConfig,
    out_dir: str | os.PathLike[str],
    *,
    backend: str = "local",
    workers: int | None = None,
    address: str | None = None,
    argv: Sequence[str] | None = None,
    log: Callable[[str], None] = print,
    runner: TrialRunner = run_trial,
    callbacks: Sequence[Any] = (),
) -> SweepResult:
    """Runs (or resumes) every trial of a sweep and writes the results table.

    Args:
        sweep: the validated sweep.
        out_dir: the sweep directory (created; running into it again resumes).
        backend: ``"local"`` or ``"ray"``.
        workers: local: processes running trials at once (default 1: one after the other,
            in this process); Ray: the most trials at once (default 0: as the CPUs allow).
        address: a Ray cluster's address (``ray`` only; None starts a local Ray).
        argv: the command line saved in ``command.txt`` (default: this process's).
        log: receives progress lines.
        runner: runs one attempt at a trial (a test may wrap it to inject failures).
        callbacks: Ray Tune callbacks (``ray`` only).

    Raises:
        ConfigError: an unknown backend, ``address`` without Ray, or trial directories
            holding runs with other settings; raised before any trial runs.
        BackendUnavailableError: ``backend="ray"`` and Ray is not installed.
    """
    if backend not in BACKENDS:
        raise ConfigError(f"unknown backend {backend!r}; known backends: {list(BACKENDS)}")
    if (address is not None or callbacks) and backend != "ray":
        raise ConfigError("--address (a Ray cluster) and Tune callbacks need --backend ray")
    workers = (1 if backend == "local" else 0) if workers is None else workers
    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 0:
        raise ConfigError(f"workers must be an integer >= 0, got {workers!r}")
    if backend == "ray":
        from noisybolt.experiments.sweeps.ray_tune import require_ray

        require_ray()
    sweep_dir = Path(out_dir)
    trials_dir = sweep_dir / "trials"
    _check_clashes(sweep, trials_dir)
    argv = list(sys.argv if argv is None else argv)
    if argv and Path(argv[0]).name in ("noisybolt", "__main__.py"):
        argv[0] = "noisybolt"
    sweep_dir.mkdir(parents=True, exist_ok=True)
    atomic_write_json(sweep_dir / SWEEP_FILE, sweep.to_dict())
    RunDirectory(sweep_dir).write_command(argv)
    tasks = [
        TrialTask(
            t.to_dict(),
            str((trials_dir / t.trial_id).resolve()),
            sweep.final_eval_episodes,
            tuple(argv),
        )
        for t in sweep.trials
    ]
    pending = [
        t
        for t in tasks
        if not TrialDirectory(t.run_dir).finished(
            t.final_eval_episodes, t.trial["config"]["frames"]
        )
    ]
    log(
        f"sweep {sweep.name}: {len(tasks)} trials, {len(tasks) - len(pending)} already "
        f"finished, {len(pending)} to run ({backend} backend) in {sweep_dir}"
    )
    start = time.perf_counter()
    ran: dict[str, TrialRecord] = {}
    if pending:
        _prepare_detectors(sweep.select(t.trial_id for t in pending), log)
        if backend == "ray":
            from noisybolt.experiments.sweeps.ray_tune import run_ray

            records = run_ray(
                tasks,
                [t.trial_id for t in pending],
                sweep_dir=sweep_dir,
                name=sweep.name,
                address=address,
                cpus_per_trial=sweep.cpus_per_trial,
                retries=sweep.retries,
                max_concurrent=workers,
                runner=runner,
                callbacks=callbacks,
                log=log,
            )
        else:
            records = _run_local(pending, retries=sweep.retries, workers=workers, runner=runner)
        ran = {r.trial_id: r for r in records}
    records = [
        ran.get(t.trial_id) or TrialDirectory(t.run_dir).record(t.trial, t.final_eval_episodes)
        for t in tasks
    ]
    result = write_results(sweep_dir, sweep.name, records)
    n_pending = len(records) - result.n_done - result.n_failed
    log(
        f"sweep {sweep.name}: {result.n_done} done, {result.n_failed} failed"
        + (f", {n_pending} unfinished (run again to resume)" if n_pending else "")
        + f" of {len(records)} in {time.perf_counter() - start:.0f} s; "
        + f"table in {result.files['markdown']}"
    )
    return result


def write_results(
    sweep_dir: Path, name: str, records: Sequence[TrialRecord], *, write: bool = True
) -> SweepResult:
    """The sweep's result from its trials' records; writes ``results.json/md/csv``."""
    result = SweepResult(sweep_dir, name, tuple(records), summarise_trials(records))
    if not write:
        return result
    files = {kind: sweep_dir / f"results.{kind}" for kind in ("json", "md", "csv")}
    command = sweep_dir / "command.txt"
    table = result.to_table()
    blocks: list[Block] = [Heading(f"Sweep {name}")]
    if command.exists():
        blocks.append(Text(f"Command: `{command.read_text().strip()}`"))
    blocks.append(
        Text(
            "Mean ± std over each group's finished seeds of the final evaluation; N_frames: "
            "first evaluation with ≥ 95% of episodes reaching the goal while complying with "
            "every spec (ground truth), mean over the seeds that reached it."
        )
    )
    failed = [r for r in records if r.status == "failed"]
    tail = [
        Text("Failed trials:"),
        Text("".join(f"- `{r.trial_id}`: {r.error}\n" for r in failed).rstrip()),
    ]
    atomic_write_json(files["json"], result.to_dict())
    atomic_write_text(files["md"], render_markdown([*blocks, table, *(tail if failed else [])]))
    atomic_write_text(files["csv"], render_csv(table))
    result.files.update({"json": files["json"], "markdown": files["md"], "csv": files["csv"]})
    return result


def collect_sweep(sweep_dir: str | os.PathLike[str], *, write: bool = True) -> SweepResult:
    """Reads every trial of a sweep directory and (re)writes ``results.json/md/csv``.

    Raises:
        ConfigError: the directory holds no sweep (no ``sweep.json``).
    """
    root = Path(sweep_dir)
    data = read_json(root / SWEEP_FILE)
    if not isinstance(data, dict) or "trials" not in data:
        raise ConfigError(f"{root} holds no sweep (no readable {SWEEP_FILE})")
    final_eval = int(data.get("final_eval_episodes", 0))
    records = [
        TrialDirectory(root / "trials" / t["id"]).record(t, final_eval) for t in data["trials"]
    ]
    return write_results(root, str(data.get("name")), records, write=write)
