"""Sweeps: a grid of training runs (rows x settings x seeds) from one YAML file.

A sweep config is base training settings, named *rows* that override them, seeds, and
optional *settings* axes crossed with both::

    name: edge-algorithms          # optional; default: the file's name
    base:                          # shared by every trial; any TrainConfig setting
      world: gridworld
      world_kwargs: {noise: regional}
      detector: {kind: classifier}
      frames: 60k                  # frame counts may be written 60k, 1.5m
      eval_freq: 5000
    rows:                          # each a named set of settings over the base
      - {name: edge-ppo, specs: [edge], algo: ppo}
      - name: edge-a2c
        specs: [edge]
        algo: a2c
        hyperparams: {learning_rate: 0.0007}   # overrides of the built-in hyperparameters
    seeds: 3                       # or a list: [0, 1, 2]
    settings:                      # optional axes (dotted keys reach into mappings)
      world_kwargs.noise: [none, regional]
    retries: 1                     # extra attempts of a trial that crashes
    final_eval_episodes: 100       # 0: report each run's last periodic evaluation
    resources: {cpus: 1}           # per trial (Ray backend)

Trial settings are ``world``, ``world_kwargs``, ``specs``, ``algo``, ``hyperparams``,
``n_envs``, ``detector``, ``frames``, ``eval_freq``, ``eval_episodes``, ``eval_envs``,
``eval_deterministic``, ``success_threshold``, ``checkpoint_freq``, ``thresholds``,
``cost_mode``, ``bolted``, ``keep_best`` and ``progress_bar`` (off by default in
sweeps); mappings merge key by key (base, then row, then settings axis), everything else
is replaced. The seed of
a trial seeds its world, agent and evaluation; the detector keeps its own seed (0 unless
set), so every trial of a sweep shares one cached classifier.

Everything is validated before anything runs: unknown keys, wrong types, unknown worlds,
algorithms, hyperparameters, noise models or fluents, missing classifier files, and trial
directories that hold a run with other settings are :class:`~noisybolt.errors.ConfigError`.

Trials have deterministic ids, ``ROW[/AXIS=VALUE,...]/seed-N`` (an axis is named by its
last dotted part, ``noise`` for ``world_kwargs.noise``), and each trains into its own
run directory (:func:`noisybolt.agents.training.train`) under the sweep directory::

    sweep.json        the sweep as resolved: its config and every trial (id, settings)
    command.txt       the exact command
    trials/<id>/      one run directory per trial (config.json, metrics.json, summary.json,
                      checkpoints, ...), plus failure.json (every failed attempt's error
                      and traceback) and trial.json (status, attempts, seconds)
    results.json      every trial's record and every group's summary
    results.md        the table (mean ± std over seeds)
    results.csv       the same, one line per group

Running a sweep again resumes it: a finished trial (``summary.json``, and the final
evaluation when asked for) is reused untouched; an interrupted one resumes from its last
checkpoint (``train(resume=True)``); a failed one is tried again. A trial that raises is
retried ``retries`` times and then recorded as failed, while the other trials go on.

Backends: ``local`` (no Ray; ``workers`` processes, default 1, each on one torch thread)
and ``ray`` (Ray Tune, see :mod:`noisybolt.experiments.ray_backend`).

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

import csv
import io
import itertools
import json
import math
import os
import re
import sys
import time
import traceback
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import asdict, dataclass, field, replace
from importlib import resources
from pathlib import Path
from typing import TYPE_CHECKING, Any, NamedTuple, cast

import numpy as np
import yaml

from noisybolt.errors import ConfigError, NoisyboltError

if TYPE_CHECKING:  # training pulls in torch: imported only where trials are built
    from noisybolt.agents.training import TrainConfig

__all__ = [
    "BACKENDS",
    "TRIAL_SETTINGS",
    "GroupSummary",
    "Stat",
    "SweepConfig",
    "SweepResult",
    "Trial",
    "TrialRecord",
    "TrialTask",
    "builtin_sweeps",
    "collect_sweep",
    "execute_trial",
    "format_frames",
    "format_results_csv",
    "format_results_markdown",
    "load_sweep",
    "n_frames_text",
    "read_trial_record",
    "run_sweep",
    "summarise_trials",
]

BACKENDS: tuple[str, ...] = ("local", "ray")

#: Settings a sweep's base, rows and axes may set, with the types they take.
TRIAL_SETTINGS: dict[str, tuple[type, ...]] = {
    "world": (str,),
    "world_kwargs": (dict,),
    "specs": (list, str),
    "algo": (str,),
    "hyperparams": (dict,),
    "n_envs": (int,),
    "detector": (dict,),
    "frames": (int, str),
    "eval_freq": (int, str),
    "eval_episodes": (int,),
    "eval_envs": (int,),
    "eval_deterministic": (bool,),
    "success_threshold": (float, int),
    "checkpoint_freq": (int, str),
    "thresholds": (dict,),
    "cost_mode": (str,),
    "reward": (str,),
    "reward_scale": (float, int),
    "shaping": (bool,),
    "bolted": (bool,),
    "keep_best": (bool,),
    "progress_bar": (bool,),
}
_MAPPINGS = frozenset({"world_kwargs", "hyperparams", "detector", "thresholds"})
_FRAME_KEYS = frozenset({"frames", "eval_freq", "checkpoint_freq"})
_TOP_KEYS = frozenset(
    {"name", "base", "rows", "seeds", "settings", "retries", "final_eval_episodes", "resources"}
)
_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9._+-]*")
_UNSAFE = re.compile(r"[^A-Za-z0-9._+=-]")
_SUFFIX = {"": 1, "k": 1_000, "m": 1_000_000}

#: Written in each trial's directory.
FAILURE_FILE, TRIAL_FILE = "failure.json", "trial.json"
#: Written in the sweep directory.
SWEEP_FILE = "sweep.json"


# ---------------------------------------------------------------------- config
@dataclass(frozen=True)
class Trial:
    """One training run of a sweep.

    Attributes:
        trial_id: ``ROW[/AXIS=VALUE,...]/seed-N``; also its directory under ``trials/``.
        group: the trial id without the seed: trials of one group are averaged.
        row: the row's name.
        seed: the trial's seed.
        settings: the values the settings axes give this trial (dotted key -> value).
        config: the resolved training config.
    """

    trial_id: str
    group: str
    row: str
    seed: int
    settings: dict[str, Any]
    config: TrainConfig

    def to_dict(self) -> dict[str, Any]:
        """JSON-able description (``sweep.json`` lists these)."""
        return {
            "id": self.trial_id,
            "group": self.group,
            "row": self.row,
            "seed": self.seed,
            "settings": dict(self.settings),
            "config": self.config.to_dict(),
        }


@dataclass(frozen=True)
class SweepConfig:
    """A validated sweep: every trial's training config, resolved.

    Build one with :meth:`from_dict` or :func:`load_sweep`.

    Attributes:
        name: the sweep's name.
        trials: every trial, rows outermost, then settings, then seeds.
        rows: row names, in order.
        seeds: the seeds.
        axes: the settings axes, ``(dotted key, values)``, in order.
        retries: extra attempts of a trial that raises.
        final_eval_episodes: episodes of a final evaluation of each finished trial
            (``evaluation.json``); 0 reports the run's last periodic evaluation.
        cpus_per_trial: CPUs reserved per trial (Ray backend).
        source: the config as given (normalised), saved in ``sweep.json``.
    """

    name: str
    trials: tuple[Trial, ...]
    rows: tuple[str, ...]
    seeds: tuple[int, ...]
    axes: tuple[tuple[str, tuple[Any, ...]], ...] = ()
    retries: int = 1
    final_eval_episodes: int = 0
    cpus_per_trial: float = 1.0
    source: dict[str, Any] = field(default_factory=dict, compare=False, repr=False)

    @classmethod
    def from_dict(
        cls, data: Mapping[str, Any], *, name: str | None = None, check_worlds: bool = True
    ) -> SweepConfig:
        """Validates a sweep config (see the module docstring for its keys).

        Args:
            data: the parsed YAML.
            name: the sweep's name when ``data`` has none.
            check_worlds: also build every world once and compile every spec over its
                fluents (cheap; catches unknown noise models and fluents up front).

        Raises:
            ConfigError: unknown keys, wrong types or impossible values, naming the row.
        """
        if not isinstance(data, Mapping):
            raise ConfigError(f"a sweep config must be a mapping, got {type(data).__name__}")
        unknown = sorted(set(data) - _TOP_KEYS)
        if unknown:
            raise ConfigError(
                f"unknown sweep key(s) {unknown}; known: {sorted(_TOP_KEYS)} "
                f"(training settings go under 'base' or a row: {sorted(TRIAL_SETTINGS)})"
            )
        sweep_name = str(data.get("name") or name or "sweep")
        if not _NAME.fullmatch(sweep_name):
            raise ConfigError(f"sweep name {sweep_name!r} must match {_NAME.pattern}")
        base = _settings_block(data.get("base") or {}, "base")
        rows = _rows(data.get("rows"))
        seeds = _seeds(data.get("seeds", 1))
        axes = _axes(data.get("settings") or {})
        retries = _nonnegative_int(data.get("retries", 1), "retries")
        final_eval = _nonnegative_int(data.get("final_eval_episodes", 0), "final_eval_episodes")
        cpus = _resources(data.get("resources") or {})

        trials: list[Trial] = []
        seen: dict[str, str] = {}
        axis_values = [values for _, values in axes] or [()]
        combos = list(itertools.product(*axis_values)) if axes else [()]
        labels = _axis_labels([key for key, _ in axes])
        for row in rows:
            row_name = row.pop("name")
            for combo in combos:
                assignment = {key: value for (key, _), value in zip(axes, combo, strict=True)}
                merged = _merge(_merge(base, row), _expand(assignment))
                label = ",".join(f"{labels[k]}={_slug(v)}" for k, v in assignment.items())
                group = f"{row_name}/{label}" if label else row_name
                where = f"row {row_name!r}" + (f" with {label}" if label else "")
                for seed in seeds:
                    trial_id = f"{group}/seed-{seed}"
                    if trial_id in seen:
                        raise ConfigError(
                            f"two trials would share the id {trial_id!r} ({seen[trial_id]} and "
                            f"{where}): make the settings values distinct"
                        )
                    seen[trial_id] = where
                    config = _train_config(merged, seed, where)
                    trials.append(Trial(trial_id, group, row_name, seed, assignment, config))
        sweep = cls(
            name=sweep_name,
            trials=tuple(trials),
            rows=tuple(r for r in dict.fromkeys(t.row for t in trials)),
            seeds=seeds,
            axes=axes,
            retries=retries,
            final_eval_episodes=final_eval,
            cpus_per_trial=cpus,
            source=json.loads(json.dumps(dict(data), default=str)),
        )
        if check_worlds:
            _check_worlds(sweep)
        return sweep

    def to_dict(self) -> dict[str, Any]:
        """What ``sweep.json`` holds: the config as given and every trial."""
        return {
            "name": self.name,
            "config": self.source,
            "retries": self.retries,
            "final_eval_episodes": self.final_eval_episodes,
            "cpus_per_trial": self.cpus_per_trial,
            "trials": [t.to_dict() for t in self.trials],
        }

    def select(self, trial_ids: Iterable[str]) -> SweepConfig:
        """The same sweep restricted to some trials (in the sweep's order)."""
        wanted = set(trial_ids)
        unknown = sorted(wanted - {t.trial_id for t in self.trials})
        if unknown:
            raise ConfigError(f"unknown trial id(s) {unknown}")
        trials = tuple(t for t in self.trials if t.trial_id in wanted)
        return SweepConfig(
            name=self.name,
            trials=trials,
            rows=tuple(dict.fromkeys(t.row for t in trials)),
            seeds=self.seeds,
            axes=self.axes,
            retries=self.retries,
            final_eval_episodes=self.final_eval_episodes,
            cpus_per_trial=self.cpus_per_trial,
            source=self.source,
        )


def builtin_sweeps() -> tuple[str, ...]:
    """Names of the sweep configs shipped in ``noisybolt/configs/sweeps``.

    Example:
        >>> "edge_algorithms" in builtin_sweeps()
        True
    """
    folder = resources.files("noisybolt.configs").joinpath("sweeps")
    return tuple(
        sorted(p.name.removesuffix(".yaml") for p in folder.iterdir() if p.name.endswith(".yaml"))
    )


def load_sweep(path: str | os.PathLike[str], *, check_worlds: bool = True) -> SweepConfig:
    """Reads and validates a sweep config file (YAML), or a built-in one by name.

    Args:
        path: a YAML file, or the name of a built-in sweep (:func:`builtin_sweeps`).
        check_worlds: see :meth:`SweepConfig.from_dict`.

    Raises:
        ConfigError: the file is missing, is not YAML, or is not a valid sweep config.
    """
    path = Path(path)
    if not path.exists() and str(path) in builtin_sweeps():
        folder = resources.files("noisybolt.configs").joinpath("sweeps")
        text = folder.joinpath(f"{path}.yaml").read_text()
        return _parse_sweep(text, str(path), check_worlds=check_worlds)
    try:
        text = path.read_text()
    except FileNotFoundError:
        raise ConfigError(
            f"no sweep config at {path} (built-in sweeps: {list(builtin_sweeps())})"
        ) from None
    except OSError as error:
        raise ConfigError(f"cannot read the sweep config {path}: {error}") from None
    return _parse_sweep(text, str(path), check_worlds=check_worlds)


def _parse_sweep(text: str, where: str, *, check_worlds: bool) -> SweepConfig:
    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as error:
        raise ConfigError(f"{where} is not valid YAML: {error}") from None
    if data is None:
        raise ConfigError(f"{where} is empty: a sweep config needs at least 'rows'")
    stem = _UNSAFE.sub("_", Path(where).stem)
    return SweepConfig.from_dict(data, name=stem, check_worlds=check_worlds)


def _settings_block(block: Any, where: str) -> dict[str, Any]:
    if not isinstance(block, Mapping):
        raise ConfigError(f"{where} must be a mapping of training settings, got {block!r}")
    result: dict[str, Any] = {}
    for key, value in block.items():
        if key == "seed":
            raise ConfigError(f"{where}: 'seed' is not a setting here; list seeds under 'seeds'")
        if key not in TRIAL_SETTINGS:
            raise ConfigError(f"{where}: unknown setting {key!r}; known: {sorted(TRIAL_SETTINGS)}")
        result[key] = _check_value(key, value, where)
    return result


def _check_value(key: str, value: Any, where: str) -> Any:
    types = TRIAL_SETTINGS[key]
    bad_bool = isinstance(value, bool) and bool not in types
    if bad_bool or not isinstance(value, types):
        names = " or ".join(t.__name__ for t in types)
        raise ConfigError(f"{where}: {key} must be {names}, got {value!r}")
    if key in _FRAME_KEYS and isinstance(value, str):
        return _frame_count(value, f"{where}: {key}")
    value = cast(Any, value)  # isinstance above narrowed it to object
    if key == "specs":
        specs = [value] if isinstance(value, str) else list(value)
        if not specs:
            raise ConfigError(f"{where}: specs is empty; give at least one spec")
        for spec in specs:
            if not isinstance(spec, str | Mapping):
                raise ConfigError(
                    f"{where}: a spec is a name, a formula or a mapping, got {spec!r}"
                )
        return specs
    if key in _MAPPINGS:
        return dict(value)
    return value


def _frame_count(text: str, where: str) -> int:
    match = re.fullmatch(r"\s*(\d+(?:\.\d+)?)\s*([kKmM]?)\s*", text)
    if not match:
        raise ConfigError(f"{where}: not a frame count: {text!r} (e.g. 60000, 60k, 1.5m)")
    return int(float(match.group(1)) * _SUFFIX[match.group(2).lower()])


def _rows(rows: Any) -> list[dict[str, Any]]:
    if not isinstance(rows, list) or not rows:
        raise ConfigError("a sweep needs 'rows': a non-empty list of named settings")
    result = []
    names: set[str] = set()
    for index, row in enumerate(rows):
        if not isinstance(row, Mapping):
            raise ConfigError(f"rows[{index}] must be a mapping with a name, got {row!r}")
        name = row.get("name")
        if not isinstance(name, str) or not _NAME.fullmatch(name):
            raise ConfigError(
                f"rows[{index}] needs a 'name' matching {_NAME.pattern} (used in trial ids), "
                f"got {name!r}"
            )
        if name in names:
            raise ConfigError(f"two rows are named {name!r}")
        names.add(name)
        settings = _settings_block({k: v for k, v in row.items() if k != "name"}, f"row {name!r}")
        result.append({"name": name, **settings})
    return result


def _seeds(value: Any) -> tuple[int, ...]:
    if isinstance(value, int) and not isinstance(value, bool):
        if value < 1:
            raise ConfigError(f"seeds must be >= 1 (a count) or a list of seeds, got {value}")
        return tuple(range(value))
    if isinstance(value, list) and value:
        if not all(isinstance(s, int) and not isinstance(s, bool) and s >= 0 for s in value):
            raise ConfigError(f"seeds must be non-negative integers, got {value!r}")
        if len(set(value)) != len(value):
            raise ConfigError(f"seeds repeat: {value!r}")
        return tuple(value)
    raise ConfigError(f"seeds must be a count >= 1 or a non-empty list of seeds, got {value!r}")


def _axes(settings: Any) -> tuple[tuple[str, tuple[Any, ...]], ...]:
    if not isinstance(settings, Mapping):
        raise ConfigError(f"settings must map setting names to lists of values, got {settings!r}")
    axes = []
    for key, values in settings.items():
        head, _, rest = str(key).partition(".")
        if head == "seed":
            raise ConfigError("settings: vary seeds with 'seeds', not a settings axis")
        if head not in TRIAL_SETTINGS:
            raise ConfigError(
                f"settings: unknown setting {head!r} in {key!r}; known: {sorted(TRIAL_SETTINGS)}"
            )
        if rest and head not in _MAPPINGS:
            raise ConfigError(f"settings: {head!r} is not a mapping, so {key!r} cannot reach in")
        if not isinstance(values, list) or not values:
            raise ConfigError(f"settings: {key!r} needs a non-empty list of values")
        if not rest:
            values = [_check_value(head, v, f"settings {key!r}") for v in values]
        if len({json.dumps(v, sort_keys=True, default=str) for v in values}) != len(values):
            raise ConfigError(f"settings: {key!r} lists a value twice")
        axes.append((str(key), tuple(values)))
    return tuple(axes)


def _nonnegative_int(value: Any, key: str) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or value < 0:
        raise ConfigError(f"{key} must be an integer >= 0, got {value!r}")
    return value


def _resources(value: Any) -> float:
    if not isinstance(value, Mapping):
        raise ConfigError(f"resources must be a mapping like {{cpus: 1}}, got {value!r}")
    unknown = sorted(set(value) - {"cpus"})
    if unknown:
        raise ConfigError(f"resources: unknown key(s) {unknown}; known: ['cpus']")
    cpus = value.get("cpus", 1)
    if isinstance(cpus, bool) or not isinstance(cpus, int | float) or not cpus > 0:
        raise ConfigError(f"resources.cpus must be a number > 0, got {cpus!r}")
    return float(cpus)


def _expand(assignment: Mapping[str, Any]) -> dict[str, Any]:
    """Dotted axis keys as nested settings (``hyperparams`` keeps dotted override keys)."""
    result: dict[str, Any] = {}
    for key, value in assignment.items():
        head, _, rest = key.partition(".")
        if not rest:
            result[head] = value
        elif head == "hyperparams":
            result.setdefault(head, {})[rest] = value
        else:
            node = result.setdefault(head, {})
            *parents, leaf = rest.split(".")
            for part in parents:
                node = node.setdefault(part, {})
            node[leaf] = value
    return result


def _merge(base: Mapping[str, Any], over: Mapping[str, Any]) -> dict[str, Any]:
    merged = {k: v for k, v in base.items()}
    for key, value in over.items():
        if key in _MAPPINGS and isinstance(merged.get(key), Mapping):
            merged[key] = _deep_merge(merged[key], value)
        else:
            merged[key] = value
    return merged


def _deep_merge(base: Mapping[str, Any], over: Mapping[str, Any]) -> dict[str, Any]:
    merged = dict(base)
    for key, value in over.items():
        if isinstance(value, Mapping) and isinstance(merged.get(key), Mapping):
            merged[key] = _deep_merge(merged[key], value)
        else:
            merged[key] = value
    return merged


def _axis_labels(keys: Sequence[str]) -> dict[str, str]:
    """Each axis's name in trial ids: its last dotted part, unless two axes share it."""
    leaves = [key.rsplit(".", 1)[-1] for key in keys]
    return {
        key: leaf if leaves.count(leaf) == 1 else key
        for key, leaf in zip(keys, leaves, strict=True)
    }


def _slug(value: Any) -> str:
    text = value if isinstance(value, str) else json.dumps(value, separators=(",", ":"))
    return _UNSAFE.sub("_", text) or "_"


def _train_config(settings: Mapping[str, Any], seed: int, where: str) -> TrainConfig:
    from noisybolt.agents.training import DetectorConfig, TrainConfig
    from noisybolt.envs.registry import DEFAULT_WORLD
    from noisybolt.experiments.checks import with_exact_scale

    values = dict(settings)
    if "specs" not in values:
        raise ConfigError(f"{where}: no specs (set 'specs' in the row or in 'base')")
    values.setdefault("progress_bar", False)
    detector_fields = dict(values.pop("detector", {}) or {})
    known = set(DetectorConfig.__dataclass_fields__)
    unknown = sorted(set(detector_fields) - known)
    if unknown:
        raise ConfigError(f"{where}: unknown detector setting(s) {unknown}; known: {sorted(known)}")
    try:
        detector = DetectorConfig(**detector_fields)
        scale_given = values.get("reward_scale") is not None
        config = TrainConfig.create(
            world=values.pop("world", DEFAULT_WORLD),
            specs=values.pop("specs"),
            algo=values.pop("algo", "ppo"),
            overrides=values.pop("hyperparams", None),
            n_envs=values.pop("n_envs", None),
            detector=detector,
            seed=seed,
            **values,
        )
        # What `noisybolt train` would choose: the compliance scale computed on the
        # world's product where it can be explored.
        return config if scale_given else with_exact_scale(config, log=None)
    except NoisyboltError as error:
        raise ConfigError(f"{where}: {error}") from None
    except (TypeError, ValueError) as error:
        raise ConfigError(f"{where}: {error}") from None


def _check_worlds(sweep: SweepConfig) -> None:
    """Builds each distinct world once and compiles each trial's specs over its fluents."""
    from noisybolt.envs import make_world
    from noisybolt.logic import compile_ltlf

    fluents_of: dict[str, tuple[str, ...]] = {}
    checked: set[str] = set()
    for trial in sweep.trials:
        config = trial.config
        where = f"trial {trial.trial_id!r}"
        key = json.dumps([config.world, config.world_kwargs], sort_keys=True, default=str)
        try:
            if key not in fluents_of:
                world = make_world(config.world, num_envs=1, seed=0, **config.world_kwargs)
                fluents_of[key] = tuple(world.fluent_names)
                close = getattr(world, "close", None)
                if callable(close):
                    close()
            spec_key = json.dumps([key, config.specs], sort_keys=True, default=str)
            if spec_key not in checked:
                for spec in config.spec_objects():
                    compile_ltlf(spec.formula, fluents_of[key])
                checked.add(spec_key)
        except NoisyboltError as error:
            raise ConfigError(f"{where}: {error}") from None
        except TypeError as error:
            raise ConfigError(f"{where}: bad world settings: {error}") from None
        path = config.detector.path
        if config.detector.kind == "classifier" and path and not Path(path).exists():
            raise ConfigError(f"{where}: no classifier file at {path}")


# ---------------------------------------------------------------------- records
class Stat(NamedTuple):
    """Mean and standard deviation (numpy's, ddof=0) over ``n`` values."""

    mean: float
    std: float
    n: int

    @classmethod
    def of(cls, values: Iterable[float]) -> Stat | None:
        """The statistic of ``values``; None when there are none.

        Example:
            >>> Stat.of([1.0, 3.0])
            Stat(mean=2.0, std=1.0, n=2)
        """
        array = np.asarray(list(values), dtype=np.float64)
        if array.size == 0:
            return None
        return cls(float(array.mean()), float(array.std()), int(array.size))


@dataclass(frozen=True)
class TrialRecord:
    """A trial's state and results, read from its run directory.

    Attributes:
        trial_id: the trial's id.
        group: its group (the id without the seed).
        row: its row.
        seed: its seed.
        settings: its settings axes' values.
        run_dir: its run directory.
        status: ``"done"``, ``"failed"`` or ``"pending"`` (not run, or interrupted).
        algo: its algorithm.
        spec_names: its specs' names (formulas where unnamed).
        final: the evaluation the tables report (``evaluation.json`` when the sweep asked
            for a final evaluation, else the run's last periodic one); None unless done.
        frames: frames trained.
        frames_to_comply: N_frames (None if never reached).
        failed_attempts: attempts that raised (across every run of the sweep).
        error: the last error's one-line message, if any.
        seconds: wall time of the attempt that finished it.
    """

    trial_id: str
    group: str
    row: str
    seed: int
    settings: dict[str, Any]
    run_dir: Path
    status: str
    algo: str
    spec_names: tuple[str, ...]
    final: dict[str, Any] | None = None
    frames: int | None = None
    frames_to_comply: int | None = None
    failed_attempts: int = 0
    error: str | None = None
    seconds: float | None = None

    def to_dict(self) -> dict[str, Any]:
        """JSON-able form."""
        data = asdict(self)
        data["run_dir"] = str(self.run_dir)
        data["spec_names"] = list(self.spec_names)
        return data


@dataclass(frozen=True)
class GroupSummary:
    """A group's trials (one row of the results table), over seeds.

    Attributes:
        group: the group (row, plus settings when the sweep has axes).
        row: the row.
        settings: the settings axes' values.
        algo: the algorithm.
        spec_names: the specs.
        n_trials: trials (seeds) in the group.
        n_done: finished trials.
        n_failed: trials that failed (after their retries).
        env_return: R_π: the final evaluation's mean environment return, over seeds.
        length: N_steps: the final evaluation's mean episode length, over seeds.
        goal_rate: share of final evaluation episodes reaching the goal, over seeds.
        success_rate: share reaching the goal while complying with every spec.
        compliance: per spec, its compliance rate, over seeds.
        compliance_min: per spec, the lowest compliance rate of any seed.
        frames_to_comply: N_frames over the seeds that reached it.
        n_reached: seeds that reached N_frames.
        frames: frames trained, over seeds.
    """

    group: str
    row: str
    settings: dict[str, Any]
    algo: str
    spec_names: tuple[str, ...]
    n_trials: int
    n_done: int
    n_failed: int
    env_return: Stat | None
    length: Stat | None
    goal_rate: Stat | None
    success_rate: Stat | None
    compliance: dict[str, Stat]
    compliance_min: dict[str, float]
    frames_to_comply: Stat | None
    n_reached: int
    frames: Stat | None

    def to_dict(self) -> dict[str, Any]:
        """JSON-able form (statistics as ``{"mean", "std", "n"}``)."""

        def stat(value: Stat | None) -> dict[str, Any] | None:
            return None if value is None else value._asdict()

        return {
            "group": self.group,
            "row": self.row,
            "settings": dict(self.settings),
            "algo": self.algo,
            "spec_names": list(self.spec_names),
            "n_trials": self.n_trials,
            "n_done": self.n_done,
            "n_failed": self.n_failed,
            "env_return": stat(self.env_return),
            "length": stat(self.length),
            "goal_rate": stat(self.goal_rate),
            "success_rate": stat(self.success_rate),
            "compliance": {k: stat(v) for k, v in self.compliance.items()},
            "compliance_min": dict(self.compliance_min),
            "frames_to_comply": stat(self.frames_to_comply),
            "n_reached": self.n_reached,
            "frames": stat(self.frames),
        }


@dataclass(frozen=True)
class SweepResult:
    """A sweep's trials and table.

    Attributes:
        sweep_dir: the sweep directory.
        name: the sweep's name.
        records: every trial's record, in the sweep's order.
        groups: the table: one summary per group, in the sweep's order.
        files: files written (label -> path).
    """

    sweep_dir: Path
    name: str
    records: tuple[TrialRecord, ...]
    groups: tuple[GroupSummary, ...]
    files: dict[str, Path] = field(default_factory=dict)

    @property
    def n_failed(self) -> int:
        """Trials that failed."""
        return sum(r.status == "failed" for r in self.records)

    @property
    def n_done(self) -> int:
        """Trials that finished."""
        return sum(r.status == "done" for r in self.records)

    def to_dict(self) -> dict[str, Any]:
        """What ``results.json`` holds."""
        return {
            "name": self.name,
            "groups": [g.to_dict() for g in self.groups],
            "trials": [r.to_dict() for r in self.records],
        }


def _spec_names(config: Mapping[str, Any]) -> tuple[str, ...]:
    return tuple(str(s.get("name") or s.get("formula")) for s in config.get("specs", ()))


def _read_json(path: Path) -> Any:
    try:
        return json.loads(path.read_text())
    except (FileNotFoundError, json.JSONDecodeError, UnicodeDecodeError):
        return None


def _finished(run_dir: Path, final_eval_episodes: int, frames: int | None = None) -> bool:
    """Whether a trial is complete: trained (to ``frames`` at least) and evaluated."""
    if not (run_dir / "summary.json").exists():
        return False
    if frames is not None and _needs_more_frames(run_dir, frames):
        return False
    if final_eval_episodes <= 0:
        return True
    evaluation = _read_json(run_dir / "evaluation.json")
    return isinstance(evaluation, dict) and evaluation.get("episodes") == final_eval_episodes


def read_trial_record(
    trial: Mapping[str, Any], run_dir: str | os.PathLike[str], *, final_eval_episodes: int = 0
) -> TrialRecord:
    """A trial's record from its run directory.

    Args:
        trial: the trial's entry of ``sweep.json`` (``id``, ``group``, ``row``, ``seed``,
            ``settings``, ``config``).
        run_dir: its run directory.
        final_eval_episodes: the sweep's final evaluation size (0: none).
    """
    path = Path(run_dir)
    config = trial.get("config") or _read_json(path / "config.json") or {}
    failure = _read_json(path / FAILURE_FILE) or {}
    attempts = list(failure.get("attempts", [])) if isinstance(failure, dict) else []
    info = _read_json(path / TRIAL_FILE) or {}
    record = TrialRecord(
        trial_id=str(trial["id"]),
        group=str(trial["group"]),
        row=str(trial["row"]),
        seed=int(trial["seed"]),
        settings=dict(trial.get("settings") or {}),
        run_dir=path,
        status="pending",
        algo=str(config.get("algo", "?")),
        spec_names=_spec_names(config),
        failed_attempts=len(attempts),
        error=attempts[-1]["message"] if attempts else None,
    )
    if _finished(path, final_eval_episodes, config.get("frames")):
        summary = _read_json(path / "summary.json") or {}
        final = summary.get("final")
        if final_eval_episodes > 0:
            final = _read_json(path / "evaluation.json")
        return replace(
            record,
            status="done",
            final=final,
            frames=summary.get("frames"),
            frames_to_comply=summary.get("frames_to_comply"),
            seconds=info.get("seconds") if isinstance(info, dict) else None,
        )
    if isinstance(info, dict) and info.get("status") == "failed":
        return replace(record, status="failed")
    return record


def summarise_trials(records: Sequence[TrialRecord]) -> tuple[GroupSummary, ...]:
    """One :class:`GroupSummary` per group, in first-seen order (statistics over seeds).

    Example:
        >>> rec = lambda seed, ret: TrialRecord(
        ...     f"a/seed-{seed}", "a", "a", seed, {}, Path("."), "done", "ppo", ("edge",),
        ...     final={"env_return_mean": ret, "length_mean": 7.0, "goal_rate": 1.0,
        ...            "success_rate": 1.0, "compliance": {"edge": 1.0}},
        ...     frames=2000, frames_to_comply=1000)
        >>> (group,) = summarise_trials([rec(0, 80.0), rec(1, 90.0)])
        >>> group.env_return, group.n_reached
        (Stat(mean=85.0, std=5.0, n=2), 2)
    """
    groups: dict[str, list[TrialRecord]] = {}
    for record in records:
        groups.setdefault(record.group, []).append(record)
    summaries = []
    for group, members in groups.items():
        done = [r for r in members if r.status == "done" and r.final]
        finals = [r.final for r in done if r.final is not None]
        spec_names = members[0].spec_names
        compliance: dict[str, Stat] = {}
        compliance_min: dict[str, float] = {}
        for name in spec_names:
            rates = [float(f["compliance"].get(name, math.nan)) for f in finals]
            stat = Stat.of(rates)
            if stat is not None:
                compliance[name] = stat
                compliance_min[name] = float(min(rates))
        reached = [r.frames_to_comply for r in done if r.frames_to_comply is not None]
        summaries.append(
            GroupSummary(
                group=group,
                row=members[0].row,
                settings=dict(members[0].settings),
                algo=members[0].algo,
                spec_names=spec_names,
                n_trials=len(members),
                n_done=len(done),
                n_failed=sum(r.status == "failed" for r in members),
                env_return=Stat.of(f["env_return_mean"] for f in finals),
                length=Stat.of(f["length_mean"] for f in finals),
                goal_rate=Stat.of(f["goal_rate"] for f in finals),
                success_rate=Stat.of(f["success_rate"] for f in finals),
                compliance=compliance,
                compliance_min=compliance_min,
                frames_to_comply=Stat.of(float(v) for v in reached),
                n_reached=len(reached),
                frames=Stat.of(float(r.frames) for r in done if r.frames is not None),
            )
        )
    return tuple(summaries)


# ---------------------------------------------------------------------- formatting
def _pm(stat: Stat | None, digits: int = 2) -> str:
    if stat is None:
        return "—"
    return f"{stat.mean:.{digits}f} ± {stat.std:.{digits}f}"


def _pct(stat: Stat | None) -> str:
    return "—" if stat is None else f"{stat.mean:.0%}"


def format_frames(value: float | None) -> str:
    """``12345`` -> ``12.3k``; None -> ``—``.

    Example:
        >>> format_frames(12345), format_frames(2_500_000), format_frames(None)
        ('12.3k', '2.5M', '—')
    """
    if value is None:
        return "—"
    if value >= 1_000_000:
        return f"{value / 1_000_000:.1f}M"
    if value >= 1_000:
        return f"{value / 1_000:.1f}k"
    return f"{value:.0f}"


def n_frames_text(group: GroupSummary) -> str:
    """N_frames as the tables show it: the mean over seeds that reached it, with a count
    when some did not (``12.0k``, ``12.0k (2/3)``, ``— (0/3)``)."""
    value = format_frames(group.frames_to_comply.mean if group.frames_to_comply else None)
    if group.n_done and group.n_reached == group.n_done:
        return value
    return f"{value} ({group.n_reached}/{group.n_done})"


def format_results_markdown(groups: Sequence[GroupSummary]) -> str:
    """The results table in Markdown (mean ± std over each group's finished seeds)."""
    header = [
        "group",
        "algo",
        "specs",
        "seeds done",
        "failed",
        "R_π (env return)",
        "N_steps",
        "goal rate",
        "compliance",
        "goal & compliant",
        "N_frames",
    ]
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    for g in groups:
        compliance = ", ".join(f"{k} {v.mean:.0%}" for k, v in g.compliance.items()) or "—"
        cells = [
            g.group,
            g.algo,
            ", ".join(g.spec_names),
            f"{g.n_done}/{g.n_trials}",
            str(g.n_failed),
            _pm(g.env_return),
            _pm(g.length, 1),
            _pct(g.goal_rate),
            compliance,
            _pct(g.success_rate),
            n_frames_text(g),
        ]
        lines.append("| " + " | ".join(c.replace("|", "\\|") for c in cells) + " |")
    return "\n".join(lines) + "\n"


def format_results_csv(groups: Sequence[GroupSummary]) -> str:
    """The results table as CSV: one line per group, means and stds in their own columns."""
    spec_names = list(dict.fromkeys(name for g in groups for name in g.spec_names))
    stats = ("env_return", "length", "goal_rate", "success_rate", "frames_to_comply", "frames")
    header = ["group", "row", "settings", "algo", "specs", "n_trials", "n_done", "n_failed"]
    for name in stats:
        header += [f"{name}_mean", f"{name}_std"]
    header.append("n_reached")
    for name in spec_names:
        header += [f"compliance_{name}_mean", f"compliance_{name}_min"]
    out = io.StringIO()
    writer = csv.writer(out, lineterminator="\n")
    writer.writerow(header)
    for g in groups:
        row: list[Any] = [
            g.group,
            g.row,
            json.dumps(g.settings, sort_keys=True),
            g.algo,
            ";".join(g.spec_names),
            g.n_trials,
            g.n_done,
            g.n_failed,
        ]
        for name in stats:
            stat = getattr(g, name)
            row += ["", ""] if stat is None else [f"{stat.mean:.6g}", f"{stat.std:.6g}"]
        row.append(g.n_reached)
        for name in spec_names:
            stat = g.compliance.get(name)
            row += (
                ["", ""] if stat is None else [f"{stat.mean:.6g}", f"{g.compliance_min[name]:.6g}"]
            )
        writer.writerow(row)
    return out.getvalue()


# ---------------------------------------------------------------------- running
@dataclass(frozen=True)
class TrialTask:
    """What a worker needs to run one trial (plain data, so it pickles to any process).

    Attributes:
        trial_id: the trial's id.
        config: the training config as a dict (``TrainConfig.to_dict()``).
        run_dir: the trial's run directory (absolute).
        retries: extra attempts after a failure (the Ray backend passes 0 and lets Ray
            retry).
        final_eval_episodes: episodes of the final evaluation (0: none).
        argv: the sweep's command line, saved as each run's ``command.txt``.
    """

    trial_id: str
    config: dict[str, Any]
    run_dir: str
    retries: int = 1
    final_eval_episodes: int = 0
    argv: tuple[str, ...] = ()

    def to_dict(self) -> dict[str, Any]:
        """JSON-able form."""
        data = asdict(self)
        data["argv"] = list(self.argv)
        return data

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> TrialTask:
        """Reads :meth:`to_dict`'s output back."""
        values = dict(data)
        values["argv"] = tuple(values.get("argv", ()))
        return cls(**values)


def _record_failure(run_dir: Path, attempt: int, error: BaseException) -> str:
    from noisybolt.io import atomic_write_json

    path = run_dir / FAILURE_FILE
    data = _read_json(path)
    attempts = list(data.get("attempts", [])) if isinstance(data, dict) else []
    message = f"{type(error).__name__}: {error}".splitlines()[0]
    attempts.append(
        {
            "attempt": attempt,
            "time": time.strftime("%Y-%m-%dT%H:%M:%S"),
            "error": type(error).__name__,
            "message": message,
            "traceback": "".join(traceback.format_exception(error)),
        }
    )
    run_dir.mkdir(parents=True, exist_ok=True)
    atomic_write_json(path, {"attempts": attempts})
    return message


def execute_trial(
    task: TrialTask,
    *,
    reraise: bool = False,
    log: Callable[[str], None] | None = None,
) -> dict[str, Any]:
    """Runs one trial to completion, retrying on errors; safe to call again to resume.

    A finished trial is left untouched. Otherwise the run trains (resuming from its last
    checkpoint when its directory already holds the run), then is evaluated when the
    sweep asks for a final evaluation. Every failed attempt is appended to the trial's
    ``failure.json`` (with its traceback); ``trial.json`` records the outcome.

    Args:
        task: the trial.
        reraise: raise the last error instead of recording the trial as failed (the Ray
            backend does, so that Ray's own retries apply).
        log: receives progress lines (default: appended to the run's ``log.txt``).

    Returns:
        ``{"id", "status": "done"|"reused"|"failed", "attempts", "seconds", "error"}``.
    """
    import torch

    from noisybolt.io import atomic_write_json

    torch.set_num_threads(1)
    run_dir = Path(task.run_dir)
    if _finished(run_dir, task.final_eval_episodes, task.config.get("frames")):
        return {"id": task.trial_id, "status": "reused", "attempts": 0, "seconds": 0.0}

    def write_log(line: str) -> None:
        run_dir.mkdir(parents=True, exist_ok=True)
        with open(run_dir / "log.txt", "a", encoding="utf-8") as handle:
            handle.write(line.rstrip("\n") + "\n")

    sink = log or write_log
    start = time.perf_counter()
    error_message: str | None = None
    attempts = 0
    for attempt in range(1, task.retries + 2):
        attempts = attempt
        try:
            _train_and_evaluate(task, run_dir, sink)
        except Exception as error:
            error_message = _record_failure(run_dir, attempt, error)
            sink(f"attempt {attempt} of {task.trial_id} failed: {error_message}")
            if reraise:
                raise
            continue
        seconds = time.perf_counter() - start
        outcome = {"id": task.trial_id, "status": "done", "attempts": attempts, "seconds": seconds}
        atomic_write_json(run_dir / TRIAL_FILE, outcome)
        return outcome
    seconds = time.perf_counter() - start
    outcome = {
        "id": task.trial_id,
        "status": "failed",
        "attempts": attempts,
        "seconds": seconds,
        "error": error_message,
    }
    atomic_write_json(run_dir / TRIAL_FILE, outcome)
    return outcome


def _train_and_evaluate(task: TrialTask, run_dir: Path, log: Callable[[str], None]) -> None:
    from noisybolt.agents.training import TrainConfig, train

    config = TrainConfig.from_dict(task.config)
    if not (run_dir / "summary.json").exists() or _needs_more_frames(run_dir, config.frames):
        resume = (run_dir / "config.json").exists()
        train(config, run_dir, resume=resume, argv=list(task.argv) or None, log=log)
    if task.final_eval_episodes > 0:
        from noisybolt.agents.run_evaluation import evaluate_run

        evaluate_run(run_dir, episodes=task.final_eval_episodes)


def _needs_more_frames(run_dir: Path, frames: int) -> bool:
    saved = _read_json(run_dir / "config.json") or {}
    return int(saved.get("frames", frames)) < frames


def _check_existing_runs(sweep: SweepConfig, trials_dir: Path) -> None:
    """Refuses trial directories holding runs with other settings (except frames)."""
    from noisybolt.agents.training import RESUMABLE_KEYS
    from noisybolt.rundir import config_differences

    clashes = []
    for trial in sweep.trials:
        saved = _read_json(trials_dir / trial.trial_id / "config.json")
        if saved is None:
            continue
        diffs = config_differences(saved, trial.config.to_dict(), ignore=RESUMABLE_KEYS)
        if diffs:
            clashes.append(f"{trial.trial_id} ({', '.join(sorted(diffs))})")
    if clashes:
        raise ConfigError(
            f"{trials_dir.parent} holds trials trained with other settings: "
            f"{'; '.join(clashes[:5])}{' ...' if len(clashes) > 5 else ''}; use another "
            "output directory, or delete those trials to retrain them"
        )


def _prepare_detectors(sweep: SweepConfig, log: Callable[[str], None]) -> None:
    """Trains (or checks) each cached classifier once, before trials run in parallel."""
    from noisybolt.agents.training import make_detector
    from noisybolt.envs import make_world

    done: set[str] = set()
    for trial in sweep.trials:
        config = trial.config
        if config.detector.kind != "classifier" or config.detector.path:
            continue
        key = json.dumps(
            [config.world, config.world_kwargs, asdict(config.detector)],
            sort_keys=True,
            default=str,
        )
        if key in done:
            continue
        done.add(key)
        probe = make_world(config.world, num_envs=1, seed=config.seed, **config.world_kwargs)
        make_detector(
            config.detector,
            world=config.world,
            world_kwargs=config.world_kwargs,
            fluent_names=tuple(probe.fluent_names),
            camera_spec=probe.camera_spec,
            progress=False,
            log=log,
        )


def _tasks(sweep: SweepConfig, trials_dir: Path, argv: Sequence[str]) -> list[TrialTask]:
    return [
        TrialTask(
            trial_id=t.trial_id,
            config=t.config.to_dict(),
            run_dir=str((trials_dir / t.trial_id).resolve()),
            retries=sweep.retries,
            final_eval_episodes=sweep.final_eval_episodes,
            argv=tuple(argv),
        )
        for t in sweep.trials
    ]


def _worker_init() -> None:
    os.environ["OMP_NUM_THREADS"] = "1"
    import torch

    torch.set_num_threads(1)


def _run_local(
    tasks: Sequence[TrialTask], *, workers: int, log: Callable[[str], None]
) -> list[dict[str, Any]]:
    outcomes: list[dict[str, Any]] = []
    total = len(tasks)

    def report(outcome: dict[str, Any]) -> None:
        outcomes.append(outcome)
        tail = f": {outcome['error']}" if outcome.get("error") else ""
        log(
            f"[{len(outcomes)}/{total}] {outcome['id']}: {outcome['status']} after "
            f"{outcome['attempts']} attempt(s), {outcome['seconds']:.0f} s{tail}"
        )

    if workers <= 1 or len(tasks) <= 1:
        for task in tasks:
            report(execute_trial(task))
        return outcomes
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor, as_completed

    # spawn, not fork: torch in a forked child of a process that used threads can hang.
    context = multiprocessing.get_context("spawn")
    with ProcessPoolExecutor(
        max_workers=workers, mp_context=context, initializer=_worker_init
    ) as pool:
        futures = {pool.submit(execute_trial, task): task for task in tasks}
        try:
            for future in as_completed(futures):
                task = futures[future]
                try:
                    report(future.result())
                except Exception as error:  # the worker process itself died
                    message = _record_failure(Path(task.run_dir), 0, error)
                    report(
                        {
                            "id": task.trial_id,
                            "status": "failed",
                            "attempts": 1,
                            "seconds": 0.0,
                            "error": message,
                        }
                    )
        except BaseException:
            pool.shutdown(wait=False, cancel_futures=True)
            raise
    return outcomes


def run_sweep(
    sweep: SweepConfig,
    out_dir: str | os.PathLike[str],
    *,
    backend: str = "local",
    workers: int | None = None,
    address: str | None = None,
    argv: Sequence[str] | None = None,
    log: Callable[[str], None] = print,
) -> SweepResult:
    """Runs (or resumes) every trial of a sweep and writes the results table.

    Args:
        sweep: the validated sweep.
        out_dir: the sweep directory (created; re-running into it resumes).
        backend: ``"local"`` (no Ray) or ``"ray"``.
        workers: local: processes running trials at once (default 1: one after the other,
            in this process); Ray: the most trials at once (default 0: as many as the
            cluster's CPUs allow).
        address: Ray cluster address (``ray`` backend only; None starts a local Ray).
        argv: the command line saved in ``command.txt`` (default: this process's).
        log: receives progress lines.

    Returns:
        The collected :class:`SweepResult` (also written as ``results.*``).

    Raises:
        ConfigError: an unknown backend, ``address`` without Ray, or trial directories
            holding runs with other settings; raised before any trial runs.
        BackendUnavailableError: ``backend="ray"`` and Ray is not installed.
    """
    from noisybolt.io import atomic_write_json
    from noisybolt.rundir import RunDirectory

    if backend not in BACKENDS:
        raise ConfigError(f"unknown backend {backend!r}; known backends: {list(BACKENDS)}")
    if address is not None and backend != "ray":
        raise ConfigError("--address names a Ray cluster: use it with --backend ray")
    if workers is None:
        workers = 1 if backend == "local" else 0
    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 0:
        raise ConfigError(f"workers must be an integer >= 0, got {workers!r}")
    if backend == "ray":
        from noisybolt.experiments.ray_backend import require_ray

        require_ray()
    sweep_dir = Path(out_dir)
    trials_dir = sweep_dir / "trials"
    _check_existing_runs(sweep, trials_dir)

    argv = list(sys.argv if argv is None else argv)
    if argv and Path(argv[0]).name in ("noisybolt", "__main__.py"):
        argv[0] = "noisybolt"
    sweep_dir.mkdir(parents=True, exist_ok=True)
    atomic_write_json(sweep_dir / SWEEP_FILE, sweep.to_dict())
    RunDirectory(sweep_dir).write_command(argv)
    tasks = _tasks(sweep, trials_dir, argv)
    pending = [
        t
        for t in tasks
        if not _finished(Path(t.run_dir), t.final_eval_episodes, t.config.get("frames"))
    ]
    log(
        f"sweep {sweep.name}: {len(tasks)} trials, {len(tasks) - len(pending)} already "
        f"finished, {len(pending)} to run ({backend} backend) in {sweep_dir}"
    )
    start = time.perf_counter()
    if pending:
        _prepare_detectors(sweep.select(t.trial_id for t in pending), log)
        if backend == "ray":
            from noisybolt.experiments.ray_backend import run_trials_ray

            run_trials_ray(
                pending,
                sweep_dir=sweep_dir,
                name=sweep.name,
                address=address,
                cpus_per_trial=sweep.cpus_per_trial,
                retries=sweep.retries,
                max_concurrent=workers,
                log=log,
            )
        else:
            _run_local(pending, workers=max(1, workers), log=log)
    result = collect_sweep(sweep_dir)
    elapsed = time.perf_counter() - start
    log(
        f"sweep {sweep.name}: {result.n_done} done, {result.n_failed} failed of "
        f"{len(result.records)} in {elapsed:.0f} s; table in {result.files['markdown']}"
    )
    return result


def collect_sweep(sweep_dir: str | os.PathLike[str], *, write: bool = True) -> SweepResult:
    """Reads every trial of a sweep directory and (re)writes ``results.json/md/csv``.

    Raises:
        ConfigError: the directory holds no sweep (no ``sweep.json``).
    """
    from noisybolt.io import atomic_write_json, atomic_write_text

    sweep_dir = Path(sweep_dir)
    data = _read_json(sweep_dir / SWEEP_FILE)
    if not isinstance(data, dict) or "trials" not in data:
        raise ConfigError(f"{sweep_dir} holds no sweep (no readable {SWEEP_FILE})")
    final_eval = int(data.get("final_eval_episodes", 0))
    records = tuple(
        read_trial_record(t, sweep_dir / "trials" / t["id"], final_eval_episodes=final_eval)
        for t in data["trials"]
    )
    groups = summarise_trials(records)
    result = SweepResult(
        sweep_dir=sweep_dir, name=str(data.get("name")), records=records, groups=groups
    )
    if write:
        files = {
            "json": sweep_dir / "results.json",
            "markdown": sweep_dir / "results.md",
            "csv": sweep_dir / "results.csv",
        }
        atomic_write_json(files["json"], result.to_dict())
        command_file = sweep_dir / "command.txt"
        command = command_file.read_text().strip() if command_file.exists() else ""
        text = f"# Sweep {result.name}\n\n"
        if command:
            text += f"Command: `{command}`\n\n"
        text += (
            "Mean ± std over each group's finished seeds of the final evaluation; "
            "N_frames: first evaluation with ≥ 95% of episodes reaching the goal while "
            "complying with every spec (ground truth), mean over the seeds that reached it.\n\n"
        )
        text += format_results_markdown(groups)
        failed = [r for r in records if r.status == "failed"]
        if failed:
            text += "\nFailed trials:\n\n" + "".join(
                f"- `{r.trial_id}`: {r.error}\n" for r in failed
            )
        atomic_write_text(files["markdown"], text)
        atomic_write_text(files["csv"], format_results_csv(groups))
        result.files.update(files)
    return result
