"""The Ray backend, run for real on a local Ray instance (2 CPUs).

Four tiny trials; one fails on its first attempt and Tune retries it (``FailureConfig``);
the sweep is interrupted as Ctrl-C interrupts it (SIGINT to the driver, after the first
trial finishes) and resumed by running it again (``Tuner.restore(resume_errored=True)``);
the tables built from Tune's ``ResultGrid`` are the local backend's, cell for cell.
"""

from __future__ import annotations

import json
import os
import signal
import sys
import time
from pathlib import Path
from typing import Any

import pytest
import ray
from ray import cloudpickle, tune

from noisybolt.experiments.reporting import render_csv, render_markdown
from noisybolt.experiments.sweeps import SweepConfig, TrialTask, run_sweep, run_trial

SWEEP: dict[str, Any] = {
    "name": "ray-grid",
    "base": {
        "detector": {"kind": "oracle"},
        "frames": 512,
        "eval_freq": 256,
        "eval_episodes": 4,
        "checkpoint_freq": 256,
        "specs": ["edge"],
    },
    "rows": [
        {"name": "a2c", "algo": "a2c"},
        {"name": "ppo", "algo": "ppo", "hyperparams": {"n_steps": 64}},
    ],
    "seeds": 2,
    "retries": 1,
}
#: The first trial of the grid: it starts at once, so it fails before the interruption.
FLAKY = "a2c/seed-0"


def flaky_runner(task: TrialTask) -> Any:
    """run_trial, except that FLAKY's first attempt dies (pickled by value into workers)."""
    marker = Path(task.run_dir).with_name(Path(task.run_dir).name + ".failed-once")
    if task.trial_id == FLAKY and not marker.exists():
        marker.parent.mkdir(parents=True, exist_ok=True)
        marker.touch()
        raise RuntimeError("injected: the first attempt dies")
    return run_trial(task)


class InterruptOnce(tune.Callback):
    """Sends the driver SIGINT (what Ctrl-C sends) when the first trial completes."""

    def __init__(self, marker: Path) -> None:
        self.marker = marker

    def on_trial_complete(self, iteration: int, trials: list[Any], trial: Any, **info: Any) -> None:
        if not self.marker.exists():
            self.marker.touch()
            os.kill(os.getpid(), signal.SIGINT)


@pytest.fixture(scope="module")
def local_ray() -> Any:
    cloudpickle.register_pickle_by_value(sys.modules[__name__])
    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False, logging_level="error")
    yield ray
    ray.shutdown()
    cloudpickle.unregister_pickle_by_value(sys.modules[__name__])


def test_ray_sweep_retries_resumes_and_tabulates_like_the_local_backend(
    local_ray: Any, tmp_path: Path
) -> None:
    start = time.perf_counter()
    sweep = SweepConfig.from_dict(SWEEP)
    out = tmp_path / "ray"
    lines: list[str] = []
    interrupt = InterruptOnce(tmp_path / "interrupted")
    first = run_sweep(
        sweep, out, backend="ray", runner=flaky_runner, callbacks=[interrupt], log=lines.append
    )
    assert (tmp_path / "interrupted").exists(), lines
    # Interrupted: some trials finished, some never ran (FLAKY may show its failed attempt).
    assert first.n_done >= 1 and first.n_done + first.n_failed < 4, lines
    state = json.loads((out / "ray.json").read_text())
    assert Path(state["experiment"]).is_dir() and tune.Tuner.can_restore(state["experiment"])
    finished = [r for r in first.records if r.status == "done"]
    stamps = {r.trial_id: (r.run_dir / "summary.json").stat().st_mtime_ns for r in finished}

    lines.clear()
    second = run_sweep(sweep, out, backend="ray", runner=flaky_runner, log=lines.append)
    assert any("resuming the interrupted experiment" in line for line in lines), lines
    assert second.n_done == 4, lines
    for record in second.records:
        assert record.status == "done" and record.final is not None
        # The failed first attempt is on record; the retry (Tune's) finished the trial.
        assert record.failed_attempts == (record.trial_id == FLAKY), record
    flaky = next(r for r in second.records if r.trial_id == FLAKY)
    failure = json.loads((flaky.run_dir / "trial.json").read_text())["attempts"]
    assert [a["message"] for a in failure] == ["RuntimeError: injected: the first attempt dies"]
    for trial_id, stamp in stamps.items():  # finished before the interruption: not retrained
        assert (out / "trials" / trial_id / "summary.json").stat().st_mtime_ns == stamp
    ray_seconds = time.perf_counter() - start

    local = run_sweep(sweep, tmp_path / "local", log=lambda _: None)
    assert render_markdown([second.to_table()]) == render_markdown([local.to_table()])
    assert render_csv(second.to_table()) == render_csv(local.to_table())
    assert [r.final for r in second.records] == [r.final for r in local.records]
    print(f"ray sweep (interrupted and resumed): {ray_seconds:.1f} s")
