"""The ``ray`` sweep backend: trials as Ray Tune trials, locally or on a cluster.

Each pending trial becomes one Tune trial of a grid search whose only parameter is the
trial itself. The trainable runs :func:`noisybolt.experiments.sweep.execute_trial` on one
torch thread, with the CPUs of ``tune.with_resources`` (``resources: {cpus: N}`` in the
sweep config, default 1). Tune's ``FailureConfig(max_failures=retries)`` retries a trial
that raises; every retry resumes from the run's own last checkpoint, so Tune's
checkpointing is not needed. After its last attempt a failed trial is marked failed in its
``trial.json`` and the other trials' results are kept.

Without ``address`` a local Ray is started (and shut down) for the sweep; with an
address (``ray://host:10001`` or ``auto``) the trials go to that cluster. Run directories
are written by the workers at the sweep directory's absolute path, so on a multi-node
cluster that directory must be on a shared file system; each node trains its own copy of
an on-the-fly classifier unless the sweep names a classifier file.

Ray is optional (``pip install "noisybolt[ray]"``): this module imports it only when used.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from noisybolt.errors import BackendUnavailableError
from noisybolt.experiments.sweep import (
    FAILURE_FILE,
    TRIAL_FILE,
    TrialTask,
    _read_json,
    execute_trial,
)
from noisybolt.io import atomic_write_json

__all__ = ["require_ray", "run_trials_ray"]


def require_ray() -> Any:
    """Imports Ray Tune, or says how to install it.

    Raises:
        BackendUnavailableError: Ray (with Tune) is not installed.
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


def _trainable(config: dict[str, Any]) -> None:
    """One Tune trial: runs a sweep trial once; raising lets Tune retry it."""
    import torch
    from ray import tune

    os.environ.setdefault("OMP_NUM_THREADS", "1")
    torch.set_num_threads(1)
    task = TrialTask.from_dict(config["task"])
    outcome = execute_trial(task, reraise=True)
    tune.report({"done": 1, "attempts": int(outcome["attempts"])})


def run_trials_ray(
    tasks: Sequence[TrialTask],
    *,
    sweep_dir: Path,
    name: str,
    address: str | None = None,
    cpus_per_trial: float = 1.0,
    retries: int = 1,
    max_concurrent: int = 0,
    log: Callable[[str], None] = print,
) -> list[dict[str, Any]]:
    """Runs sweep trials with Ray Tune; returns one outcome per trial.

    Args:
        tasks: the trials to run (finished ones are filtered out by the caller).
        sweep_dir: the sweep directory; Tune's own files go to ``sweep_dir/ray``.
        name: the Tune experiment's name.
        address: a Ray cluster's address; None starts a local Ray for this call.
        cpus_per_trial: CPUs reserved per trial.
        retries: Tune's ``max_failures`` per trial.
        max_concurrent: most trials at once (0: as resources allow).
        log: receives progress lines.

    Raises:
        BackendUnavailableError: Ray is not installed.
    """
    ray = require_ray()
    from ray import tune

    started_here = False
    if not ray.is_initialized():
        init: dict[str, Any] = {
            "include_dashboard": False,
            "log_to_driver": False,
            "configure_logging": True,
            "logging_level": "error",
        }
        ray.init(address=address, **init)
        started_here = True
    try:
        log(
            f"ray: {len(tasks)} trials on {ray.cluster_resources().get('CPU', 0):.0f} CPUs "
            f"({cpus_per_trial:g} per trial, {retries} retries)"
        )
        # Retries are Tune's; each attempt runs once in the worker.
        payload = [dict(task.to_dict(), retries=0) for task in tasks]
        trainable = tune.with_resources(_trainable, {"cpu": cpus_per_trial})
        tuner = tune.Tuner(
            trainable,
            param_space={"task": tune.grid_search(payload)},
            tune_config=tune.TuneConfig(
                num_samples=1,
                max_concurrent_trials=max_concurrent or None,
                trial_name_creator=lambda trial: _short(trial.config["task"]["trial_id"]),
                trial_dirname_creator=lambda trial: _short(trial.config["task"]["trial_id"]),
            ),
            run_config=tune.RunConfig(
                name=name,
                storage_path=str((sweep_dir / "ray").resolve()),
                failure_config=tune.FailureConfig(max_failures=retries),
                verbose=0,
            ),
        )
        # Tune's newer console output ignores verbose=0; the older one honours it. Our own
        # progress lines say what matters; RAY_AIR_NEW_OUTPUT=1 brings Tune's tables back.
        previous = os.environ.get("RAY_AIR_NEW_OUTPUT")
        os.environ.setdefault("RAY_AIR_NEW_OUTPUT", "0")
        try:
            grid = tuner.fit()
        finally:
            if previous is None:
                os.environ.pop("RAY_AIR_NEW_OUTPUT", None)
        outcomes = []
        for index in range(len(grid)):
            result = grid[index]
            task = TrialTask.from_dict((result.config or {})["task"])
            outcomes.append(_outcome(task, result))
        for outcome in outcomes:
            tail = f": {outcome['error']}" if outcome.get("error") else ""
            log(f"ray: {outcome['id']}: {outcome['status']}{tail}")
        return outcomes
    finally:
        if started_here:
            ray.shutdown()


def _short(trial_id: str) -> str:
    return trial_id.replace("/", "__")[:120]


def _outcome(task: TrialTask, result: Any) -> dict[str, Any]:
    """The trial's outcome; a trial Tune gave up on is marked failed in ``trial.json``."""
    run_dir = Path(task.run_dir)
    if result.error is None:
        return {"id": task.trial_id, "status": "done", **(_read_json(run_dir / TRIAL_FILE) or {})}
    failures = _read_json(run_dir / FAILURE_FILE) or {}
    attempts = failures.get("attempts", []) if isinstance(failures, dict) else []
    message = attempts[-1]["message"] if attempts else str(result.error).splitlines()[0]
    outcome = {
        "id": task.trial_id,
        "status": "failed",
        "attempts": len(attempts),
        "seconds": 0.0,
        "error": message,
    }
    run_dir.mkdir(parents=True, exist_ok=True)
    atomic_write_json(run_dir / TRIAL_FILE, outcome)
    return outcome
