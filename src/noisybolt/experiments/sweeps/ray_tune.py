"""The ``ray`` backend: Ray Tune runs the trials, retries them, resumes them, and returns
their results.

Each pending trial is one Tune trial of a grid over trial ids; the trainable runs
:func:`~noisybolt.experiments.sweeps.trials.run_trial` on one torch thread with the CPUs
of ``resources: {cpus: N}``. Tune owns the rest:

* retries: ``FailureConfig(max_failures=retries)``; an attempt resumes from the run's own
  last checkpoint, in its run directory;
* resume: the experiment's state lives in ``<sweep>/ray/``; running the sweep again after
  an interruption (Ctrl-C, a lost driver) calls ``Tuner.restore(..., resume_errored=True)``;
* results: each trial reports its record, and the ``ResultGrid`` becomes the tables.

Without ``address`` a local Ray is started (and shut down) for the sweep, unless this
process already joined one; with ``--address auto`` (or ``ray://host:10001``) the trials
go to a running cluster. Run directories and Tune's files are written at the sweep
directory's absolute path, so on several machines that directory must be on storage
every node shares (see the README's section on sweeps).
"""

from __future__ import annotations

import json
import os
import time
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

from noisybolt.errors import BackendUnavailableError
from noisybolt.experiments.sweeps.results import TrialRecord
from noisybolt.experiments.sweeps.trials import TrialDirectory, TrialTask, attempt, read_json
from noisybolt.io import atomic_write_json

__all__ = ["require_ray", "run_ray"]


def require_ray() -> Any:
    """Imports Ray (with Tune), or says how to install it.

    Raises:
        BackendUnavailableError: Ray Tune is not installed.
    """
    try:
        import ray
        from ray import tune  # noqa: F401
    except ImportError as error:
        raise BackendUnavailableError(
            f'the ray backend needs Ray Tune ({error}): pip install "noisybolt[ray]" '
            '(or "ray[tune]"; not ray[rllib], which downgrades Gymnasium), or use '
            "--backend local"
        ) from None
    return ray


def _trainable(
    config: dict[str, Any],
    *,
    tasks: Mapping[str, TrialTask],
    runner: Callable[[TrialTask], TrialRecord],
) -> None:
    """One Tune trial: one attempt at a sweep trial; what it raises, Tune retries."""
    from ray import tune

    os.environ.setdefault("OMP_NUM_THREADS", "1")
    record = attempt(tasks[config["trial"]], runner)
    tune.report({"record": json.dumps(record.to_dict())})


def _dirname(trial_id: str) -> str:
    return trial_id.replace("/", "__")[:120]


def _short(trial: Any) -> str:
    return _dirname(str(trial.config["trial"]))


def run_ray(
    tasks: Sequence[TrialTask],
    pending: Sequence[str],
    *,
    sweep_dir: Path,
    name: str,
    address: str | None,
    cpus_per_trial: float,
    retries: int,
    max_concurrent: int,
    runner: Callable[[TrialTask], TrialRecord],
    callbacks: Sequence[Any] = (),
    log: Callable[[str], None] = print,
) -> list[TrialRecord]:
    """Runs the ``pending`` trials with Ray Tune, or resumes their interrupted experiment;
    returns the records of the experiment's ``ResultGrid``."""
    ray = require_ray()
    from ray import tune

    started_here = not ray.is_initialized()
    if started_here:
        ray.init(
            address=address, include_dashboard=False, log_to_driver=False, logging_level="error"
        )
    by_id = {t.trial_id: t for t in tasks}
    trainable = tune.with_resources(
        tune.with_parameters(_trainable, tasks=by_id, runner=runner), {"cpu": cpus_per_trial}
    )
    # The experiment this sweep directory started last: restored when it holds every
    # pending trial (an interrupted run), else a new one (the sweep grew, or it finished).
    state = read_json(sweep_dir / "ray.json") or {}
    path = state.get("experiment")
    # Tune's newer console output ignores verbose=0: our own progress lines say what matters.
    ours = "RAY_AIR_NEW_OUTPUT" not in os.environ
    os.environ.setdefault("RAY_AIR_NEW_OUTPUT", "0")
    try:
        if path and set(pending) <= set(state.get("trials", ())) and tune.Tuner.can_restore(path):
            log(f"ray: resuming the interrupted experiment {path}")
            tuner = tune.Tuner.restore(path, trainable=trainable, resume_errored=True)
        else:
            experiment = f"{name}-{time.strftime('%Y%m%d-%H%M%S')}"
            storage = (sweep_dir / "ray").resolve()
            tuner = tune.Tuner(
                trainable,
                param_space={"trial": tune.grid_search(list(pending))},
                tune_config=tune.TuneConfig(
                    max_concurrent_trials=max_concurrent or None,
                    trial_name_creator=_short,
                    trial_dirname_creator=_short,
                ),
                run_config=tune.RunConfig(
                    name=experiment,
                    storage_path=str(storage),
                    failure_config=tune.FailureConfig(max_failures=retries),
                    callbacks=list(callbacks),
                    verbose=0,
                ),
            )
            path = str(storage / experiment)
            atomic_write_json(sweep_dir / "ray.json", {"experiment": path, "trials": list(pending)})
        log(
            f"ray: {len(pending)} trials on {ray.cluster_resources().get('CPU', 0):.0f} CPUs "
            f"({cpus_per_trial:g} per trial, {retries} retries by Tune)"
        )
        grid = tuner.fit()
    finally:
        if ours:
            os.environ.pop("RAY_AIR_NEW_OUTPUT", None)
        if started_here:
            ray.shutdown()
    records = []
    for index in range(len(grid)):
        result = grid[index]
        # A trial that never started reports no config: its directory names it.
        task = {_dirname(i): t for i, t in by_id.items()}[Path(result.path).name]
        metrics = result.metrics or {}
        if "record" in metrics and result.error is None:
            records.append(TrialRecord.from_dict(json.loads(metrics["record"])))
        else:  # Tune gave up on it (result.error), or it never ran (interrupted)
            records.append(
                TrialDirectory(task.run_dir).record(task.trial, task.final_eval_episodes)
            )
        record = records[-1]
        log(
            f"ray: {record.trial_id}: {record.status}"
            + (f": {record.error}" if record.error else "")
        )
    return records
