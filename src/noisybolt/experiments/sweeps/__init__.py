"""Sweeps: a grid of training runs (rows x settings x seeds) from one YAML file.

A sweep is base training settings, named *rows* that override them, seeds, and optional
*settings* axes crossed with both; every setting is a field of
:class:`~noisybolt.agents.training.TrainConfig` (the run's one schema)::

    name: edge-algorithms          # optional; default: the file's name
    base:                          # shared by every trial
      world: gridworld
      world_kwargs: {noise: regional}
      detector: {kind: classifier}
      frames: 60k                  # frame counts may be written 60k, 1.5m
    rows:                          # each a named override of the base
      - {name: edge-ppo, specs: [edge], algo: ppo}
      - {name: edge-a2c, specs: [edge], algo: a2c, hyperparams: {learning_rate: 0.0007}}
    seeds: 3                       # or a list: [0, 1, 2]
    settings:                      # optional axes (dotted keys reach into mappings)
      world_kwargs.noise: [none, regional]
    retries: 1                     # extra attempts of a trial that raises
    final_eval_episodes: 100       # 0: report each run's last periodic evaluation
    resources: {cpus: 1}           # per trial (Ray backend)

Mappings merge key by key (base, then row, then axis); everything else is replaced.
Everything is validated before anything runs (:class:`~noisybolt.errors.ConfigError`).
A trial's seed seeds its world, agent and evaluation; the detector keeps its own seed,
so every trial shares one cached classifier. Trial ids are ``ROW[/AXIS=VALUE,...]/seed-N``
(an axis named by its last dotted part); each trial trains into ``trials/<id>/`` under the
sweep directory, beside ``sweep.json``, ``command.txt`` and ``results.json/md/csv``.

Running a sweep again resumes it: finished trials are reused untouched, interrupted ones
resume from their last checkpoint, failed ones are tried again.

Example:
    >>> sweep = SweepConfig.from_dict({
    ...     "base": {"detector": {"kind": "oracle"}, "frames": "2k"},
    ...     "rows": [{"name": "edge-ppo", "specs": ["edge"], "algo": "ppo"},
    ...              {"name": "edge-a2c", "specs": ["edge"], "algo": "a2c"}],
    ...     "seeds": 2,
    ... }, name="demo")
    >>> [t.trial_id for t in sweep.trials]
    ['edge-ppo/seed-0', 'edge-ppo/seed-1', 'edge-a2c/seed-0', 'edge-a2c/seed-1']
    >>> sweep.trials[1].config.seed, sweep.trials[1].config.frames
    (1, 2000)
"""

from __future__ import annotations

from noisybolt.experiments.sweeps.config import SweepConfig, Trial, builtin_sweeps, load_sweep
from noisybolt.experiments.sweeps.results import (
    GroupSummary,
    Stat,
    SweepResult,
    TrialRecord,
    summarise_trials,
)
from noisybolt.experiments.sweeps.run import BACKENDS, SWEEP_FILE, collect_sweep, run_sweep
from noisybolt.experiments.sweeps.trials import TrialDirectory, TrialTask, run_trial

__all__ = [
    "BACKENDS",
    "SWEEP_FILE",
    "GroupSummary",
    "Stat",
    "SweepConfig",
    "SweepResult",
    "Trial",
    "TrialDirectory",
    "TrialRecord",
    "TrialTask",
    "builtin_sweeps",
    "collect_sweep",
    "load_sweep",
    "run_sweep",
    "run_trial",
    "summarise_trials",
]
