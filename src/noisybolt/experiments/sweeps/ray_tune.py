"""Parallel trials, on Ray Tune: a Tune trial per pending sweep trial (with the sweep's
``resources: {cpus: N}``). Tune retries a failed attempt and replaces a worker that died
(``FailureConfig``; the retry resumes from the run's last checkpoint), resumes an
interrupted sweep (``Tuner.restore(..., resume_errored=True)`` on the experiment in
``<sweep>/ray/``) and returns the records of its ``ResultGrid``. A trial whose worker
kept dying is left unfinished (no ``trial.json`` status): running the sweep again resumes it.

Without ``address`` a local Ray is started for the sweep and shut down after it (unless
this process joined one); with one (``auto``, ``HOST:PORT``) the trials go to that
cluster. Everything is written at the sweep directory's absolute path: on several
machines, storage every node mounts there.
"""

from __future__ import annotations

import json
import math
import os
import time
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

from noisybolt.errors import BackendUnavailableError
from noisybolt.experiments.sweeps.config import SweepConfig
from noisybolt.experiments.sweeps.results import TrialRecord
from noisybolt.experiments.sweeps.trials import TrialTask, attempt
from noisybolt.io import atomic_write_json, read_json

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
            f"trials in parallel (--workers > 1, --backend ray) run on Ray Tune ({error}): "
            'pip install "noisybolt[ray]" (not ray[rllib], which downgrades Gymnasium), '
            "or run them one after the other: --backend local --workers 1"
        ) from None
    return ray


def _trainable(config: dict[str, Any], *, tasks: Mapping[str, TrialTask], runner: Any) -> None:
    """A Tune trial: one attempt at a sweep trial, reporting its record."""
    from ray import tune

    os.environ.setdefault("OMP_NUM_THREADS", "1")
    record = attempt(tasks[config["trial"]], runner)
    tune.report({"record": json.dumps(record.to_dict())})


def run_ray(
    sweep: SweepConfig,
    sweep_dir: Path,
    tasks: Sequence[TrialTask],
    pending: Sequence[str],
    *,
    address: str | None,
    workers: int,
    local_cpus: int | None,
    runner: Callable[[TrialTask], TrialRecord],
    callbacks: Sequence[Any] = (),
    log: Callable[[str], None] = print,
) -> list[TrialRecord]:
    """Runs the ``pending`` trials with Ray Tune, ``workers`` at most at once (0: as the
    CPUs allow), or resumes their interrupted experiment; a Ray started here gets the
    CPUs of ``local_cpus`` trials (None: the machine's). Returns the records in its
    ``ResultGrid`` (the trials that finished)."""
    ray = require_ray()
    from ray import tune

    started_here = not ray.is_initialized()
    if started_here:
        cpus = None if local_cpus is None else math.ceil(local_cpus * sweep.cpus_per_trial)
        ray.init(
            address=address, num_cpus=cpus, include_dashboard=False, log_to_driver=False,
            logging_level="error",
        )  # fmt: skip
    trainable = tune.with_resources(
        tune.with_parameters(_trainable, tasks={t.trial_id: t for t in tasks}, runner=runner),
        {"cpu": sweep.cpus_per_trial},
    )
    # The experiment started last is resumed when it holds every pending trial (it was
    # interrupted); otherwise the sweep grew, or finished: a new experiment.
    state, ours = (
        read_json(sweep_dir / "ray.json", default={}),
        "RAY_AIR_NEW_OUTPUT" not in os.environ,
    )
    path = state.get("experiment")
    os.environ.setdefault("RAY_AIR_NEW_OUTPUT", "0")  # the newer console output ignores verbose=0
    try:
        if path and set(pending) <= set(state.get("trials", ())) and tune.Tuner.can_restore(path):
            log(f"ray: resuming the interrupted experiment {path}")
            tuner = tune.Tuner.restore(path, trainable=trainable, resume_errored=True)
        else:
            path = sweep_dir.resolve() / "ray" / f"{sweep.name}-{time.strftime('%Y%m%d-%H%M%S')}"
            retries = tune.FailureConfig(max_failures=sweep.retries)
            tuner = tune.Tuner(
                trainable,
                param_space={"trial": tune.grid_search(list(pending))},
                tune_config=tune.TuneConfig(max_concurrent_trials=workers or None),
                run_config=tune.RunConfig(
                    name=path.name, storage_path=str(path.parent), failure_config=retries,
                    callbacks=list(callbacks), verbose=0,
                ),
            )  # fmt: skip
            atomic_write_json(sweep_dir / "ray.json", {"experiment": str(path), "trials": pending})
        cpus = ray.cluster_resources().get("CPU", 0)
        log(f"ray: {len(pending)} trials on {cpus:.0f} CPUs, {sweep.cpus_per_trial:g} per trial")
        grid = tuner.fit()
    finally:
        if ours:
            os.environ.pop("RAY_AIR_NEW_OUTPUT", None)
        if started_here:
            ray.shutdown()
    metrics = [grid[i].metrics or {} for i in range(len(grid)) if grid[i].error is None]
    return [TrialRecord.from_dict(json.loads(m["record"])) for m in metrics if "record" in m]
