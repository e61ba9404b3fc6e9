"""Sweeps: a grid of training runs (rows x settings x seeds) from one YAML file.

A sweep is base settings, named *rows* overriding them, seeds, and optional *settings*
axes, each setting a path of the run's config schema (:mod:`~.config`; the README's
section on sweeps). Each trial trains into ``trials/<trial id>/`` of the sweep directory
(its run, and ``trial.json``: how its attempts ended), beside ``sweep.json``,
``command.txt`` and ``results.json/md/csv``.
Trials run one after the other in this process, or in parallel on Ray Tune
(:mod:`~.ray_tune`). Running a sweep again resumes it: finished trials are kept,
interrupted ones resume from their last checkpoint, failed ones are tried again.

Example:
    >>> sweep = SweepConfig.from_dict({
    ...     "base": {"detector": {"kind": "oracle"}, "frames": "2k", "specs": ["edge"]},
    ...     "rows": [{"name": "ppo", "algo": "ppo"}, {"name": "a2c", "algo": "a2c"}],
    ...     "seeds": 2,
    ... }, name="demo")
    >>> [t.trial_id for t in sweep.trials]
    ['ppo/seed-0', 'ppo/seed-1', 'a2c/seed-0', 'a2c/seed-1']
    >>> sweep.trials[1].config.seed, sweep.trials[1].config.frames
    (1, 2000)
"""

from __future__ import annotations

from noisybolt.experiments.sweeps.config import SweepConfig, Trial, builtin_sweeps, load_sweep
from noisybolt.experiments.sweeps.results import GroupSummary, SweepResult, TrialRecord
from noisybolt.experiments.sweeps.run import BACKENDS, SWEEP_FILE, collect_sweep, run_sweep
from noisybolt.experiments.sweeps.trials import TrialDirectory, TrialTask, run_trial

__all__ = [
    "BACKENDS", "SWEEP_FILE", "GroupSummary", "SweepConfig", "SweepResult", "Trial",
    "TrialDirectory", "TrialRecord", "TrialTask", "builtin_sweeps", "collect_sweep",
    "load_sweep", "run_sweep", "run_trial",
]  # fmt: skip
