"""A sweep's grid: named rows and settings axes, each a set of overrides of one run config.

The settings of ``base``, a row or an axis are paths of the run's config schema
(:mod:`noisybolt.runs.config`: ``bolt.tracking``, ``world.kwargs.noise``,
``algorithm.hyperparams.gamma``), given dotted or as nested mappings; the flat names of
older sweep files (``eval_freq``, ``world_kwargs.noise``, ``algo``) read as their paths.
The schema types and checks them, and the sweep file's own keys are a frozen dataclass
loaded by the same strict loader (:mod:`noisybolt.runs.schema`): no type table here.
Seeds are an axis of their own (``seeds``), not a setting.
"""

from __future__ import annotations

import itertools
import json
import os
import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import TYPE_CHECKING, Any

import yaml

from noisybolt.errors import ConfigError, NoisyboltError

if TYPE_CHECKING:  # training pulls in torch: imported only where trials are built
    from noisybolt.runs.config import TrainConfig

__all__ = ["SweepConfig", "Trial", "builtin_sweeps", "load_sweep"]

_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9._+-]*")
_UNSAFE = re.compile(r"[^A-Za-z0-9._+=-]")
_FRAMES = re.compile(r"\s*(\d+(?:\.\d+)?)\s*([kKmM]?)\s*")  # 60k, 1.5M
_FRAME_PATHS = ("frames", "evaluation.freq", "checkpoint_freq")


@dataclass(frozen=True, kw_only=True)
class _Resources:
    cpus: float = 1.0  # per trial, on Ray

    def __post_init__(self) -> None:
        if not self.cpus > 0:
            raise ConfigError(f"resources.cpus must be a number > 0, got {self.cpus!r}")


@dataclass(frozen=True, kw_only=True)
class _SweepFile:
    """A sweep file's keys (see :mod:`noisybolt.experiments.sweeps`)."""

    name: str | None = None
    base: dict[str, Any] = field(default_factory=dict)
    rows: tuple[dict[str, Any], ...] = ()
    seeds: int | tuple[int, ...] = 1
    settings: dict[str, Any] = field(default_factory=dict)
    retries: int = 1
    final_eval_episodes: int = 0
    resources: _Resources = field(default_factory=_Resources)

    def __post_init__(self) -> None:
        for key in ("retries", "final_eval_episodes"):
            if getattr(self, key) < 0:
                raise ConfigError(f"{key} must be an integer >= 0, got {getattr(self, key)!r}")
        seeds = self.seeds
        if (isinstance(seeds, int) and seeds < 1) or seeds == ():
            raise ConfigError(f"seeds must be >= 1 (a count) or a non-empty list, got {seeds!r}")
        if isinstance(seeds, tuple) and (min(seeds) < 0 or len(set(seeds)) != len(seeds)):
            raise ConfigError(f"seeds must be distinct non-negative integers, got {list(seeds)}")
        if not self.rows:
            raise ConfigError("a sweep needs 'rows': a non-empty list of named settings")
        names = [row.get("name") for row in self.rows]
        for index, name in enumerate(names):
            if not isinstance(name, str) or not _NAME.fullmatch(name):
                raise ConfigError(f"rows[{index}] needs a 'name' matching {_NAME.pattern}")
            if names.count(name) > 1:
                raise ConfigError(f"two rows are named {name!r}")
        for key, values in self.settings.items():
            if key.partition(".")[0] == "seed":
                raise ConfigError("settings: vary seeds with 'seeds', not a settings axis")
            if not isinstance(values, list) or not values:
                raise ConfigError(f"settings: {key!r} needs a non-empty list of values")
            if len({json.dumps(v, sort_keys=True, default=str) for v in values}) < len(values):
                raise ConfigError(f"settings: {key!r} lists a value twice")


def _block(block: Mapping[str, Any], where: str) -> dict[str, Any]:
    """Settings as ``{schema path: value}``, each checked against its path's type."""
    from noisybolt.runs.config import checked_value, override_paths

    try:
        paths = override_paths(block)
        if "seed" in paths:
            raise ConfigError("'seed' is not a setting here; list seeds under 'seeds'")
        for key in (k for k in _FRAME_PATHS if isinstance(paths.get(k), str)):
            if not (match := _FRAMES.fullmatch(paths[key])):
                raise ConfigError(f"{key}: not a frame count: {paths[key]!r} (e.g. 60k)")
            paths[key] = int(float(match[1]) * {"": 1, "k": 1e3, "m": 1e6}[match[2].lower()])
        return {path: checked_value(path, value) for path, value in paths.items()}
    except ConfigError as error:
        raise ConfigError(f"{where}: {error}") from None


@dataclass(frozen=True)
class Trial:
    """One training run of a sweep: ``trial_id`` is ``ROW[/AXIS=VALUE,...]/seed-N`` (its
    directory under ``trials/``), ``group`` the id without the seed (a group's trials are
    averaged), ``settings`` the values the axes give it, ``config`` its resolved config."""

    trial_id: str
    group: str
    row: str
    seed: int
    settings: dict[str, Any]
    config: TrainConfig

    def to_dict(self) -> dict[str, Any]:
        """JSON-able description (``sweep.json`` lists these)."""
        fields = {k: getattr(self, k) for k in ("group", "row", "seed", "settings")}
        return {"id": self.trial_id, **fields, "config": self.config.to_dict()}


@dataclass(frozen=True)
class SweepConfig:
    """A validated sweep: its trials (rows outermost, then settings, then seeds), each with
    its training config resolved; ``retries``: extra attempts of a trial that raises;
    ``final_eval_episodes``: episodes of a final evaluation of each finished trial
    (``evaluation.json``; 0: the run's last periodic evaluation is reported);
    ``cpus_per_trial``: on Ray; ``source``: the config as given (``sweep.json``)."""

    name: str
    trials: tuple[Trial, ...]
    seeds: tuple[int, ...]
    retries: int = 1
    final_eval_episodes: int = 0
    cpus_per_trial: float = 1.0
    source: dict[str, Any] = field(default_factory=dict, compare=False, repr=False)

    @classmethod
    def from_dict(
        cls, data: Mapping[str, Any], *, name: str | None = None, check_worlds: bool = True
    ) -> SweepConfig:
        """Validates a sweep config (the parsed YAML; ``name`` when it has none). With
        ``check_worlds``, builds every world once and compiles every spec over its fluents
        (cheap; unknown noise models and fluents are found before anything runs).

        Raises:
            ConfigError: unknown keys, wrong types or impossible values, naming the row.
        """
        from noisybolt.runs.schema import load

        sweep = load(_SweepFile, data)
        sweep_name = sweep.name or name or "sweep"
        if not _NAME.fullmatch(sweep_name):
            raise ConfigError(f"sweep name {sweep_name!r} must match {_NAME.pattern}")
        seeds = tuple(range(sweep.seeds)) if isinstance(sweep.seeds, int) else sweep.seeds
        base, trials, keys = _block(sweep.base, "base"), [], list(sweep.settings)
        # Each axis value with its overrides (checked once here, so a bad one is named).
        axes = [[(v, _block({k: v}, f"settings {k!r}")) for v in sweep.settings[k]] for k in keys]
        labels = [k.rsplit(".", 1)[-1] for k in keys]
        labels = [lb if labels.count(lb) == 1 else k for lb, k in zip(labels, keys, strict=True)]
        for row in sweep.rows:
            row_name = str(row["name"])
            over = _block({k: v for k, v in row.items() if k != "name"}, f"row {row_name!r}")
            for combo in itertools.product(*axes):
                values = [v for v, _ in combo]
                settings = dict(zip(keys, values, strict=True))
                label = ",".join(f"{lb}={_slug(v)}" for lb, v in zip(labels, values, strict=True))
                group = f"{row_name}/{label}" if label else row_name
                merged = {**base, **over, **{p: x for _, paths in combo for p, x in paths.items()}}
                where = f"row {row_name!r}" + (f" with {label}" if label else "")
                for seed in seeds:
                    config = _train_config(merged, seed, where)
                    trials.append(
                        Trial(f"{group}/seed-{seed}", group, row_name, seed, settings, config)
                    )
        ids = [t.trial_id for t in trials]
        if len(set(ids)) != len(ids):
            twice = sorted({i for i in ids if ids.count(i) > 1})
            raise ConfigError(f"two trials would share the id(s) {twice}: make the values distinct")
        result = cls(
            name=sweep_name, trials=tuple(trials), seeds=seeds, retries=sweep.retries,
            final_eval_episodes=sweep.final_eval_episodes, cpus_per_trial=sweep.resources.cpus,
            source=json.loads(json.dumps(dict(data), default=str)),
        )  # fmt: skip
        if check_worlds:
            from noisybolt.experiments import checks

            checks.check_worlds({f"trial {t.trial_id!r}": t.config for t in result.trials})
        return result

    def to_dict(self) -> dict[str, Any]:
        """What ``sweep.json`` holds: the config as given and every trial."""
        fields = ("name", "retries", "final_eval_episodes", "cpus_per_trial")
        trials = [t.to_dict() for t in self.trials]
        return {k: getattr(self, k) for k in fields} | {"config": self.source, "trials": trials}


def builtin_sweeps() -> tuple[str, ...]:
    """Names of the sweep configs shipped in ``noisybolt/configs/sweeps``.

    Example:
        >>> "edge_algorithms" in builtin_sweeps()
        True
    """
    folder = resources.files("noisybolt.configs").joinpath("sweeps")
    return tuple(sorted(p.name[:-5] for p in folder.iterdir() if p.name.endswith(".yaml")))


def load_sweep(path: str | os.PathLike[str], *, check_worlds: bool = True) -> SweepConfig:
    """Reads and validates a sweep config file (YAML), or a built-in one by name.

    Raises:
        ConfigError: the file is missing, is not YAML, or is not a valid sweep config.
    """
    path, builtin = Path(path), resources.files("noisybolt.configs") / f"sweeps/{path}.yaml"
    try:
        file = builtin if not path.exists() and str(path) in builtin_sweeps() else path
        data = yaml.safe_load(file.read_text())
    except FileNotFoundError:
        known = list(builtin_sweeps())
        raise ConfigError(f"no sweep config at {path} (built-in sweeps: {known})") from None
    except (OSError, yaml.YAMLError) as error:
        raise ConfigError(
            f"{path} is not a readable sweep config (not valid YAML?): {error}"
        ) from None
    if data is None:
        raise ConfigError(f"{path} is empty: a sweep config needs at least 'rows'")
    return SweepConfig.from_dict(data, name=_UNSAFE.sub("_", path.stem), check_worlds=check_worlds)


def _slug(value: Any) -> str:
    text = value if isinstance(value, str) else json.dumps(value, separators=(",", ":"))
    return _UNSAFE.sub("_", text) or "_"


def _train_config(settings: Mapping[str, Any], seed: int, where: str) -> TrainConfig:
    """A trial's config, resolved as every door resolves one
    (:func:`~noisybolt.runs.resolution.resolve`: the compliance scale a ``noisybolt train``
    of the same settings pays, exact on a tabular product, unless the settings give one)."""
    from noisybolt.runs.config import TrainConfig
    from noisybolt.runs.resolution import resolve

    if "bolt.specs" not in settings:
        raise ConfigError(f"{where}: no specs (set 'bolt.specs' in the row or in 'base')")
    try:
        return resolve(TrainConfig.build({"progress_bar": False, **settings, "seed": seed}))
    except (NoisyboltError, TypeError, ValueError) as error:
        raise ConfigError(f"{where}: {error}") from None
