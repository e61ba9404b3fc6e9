"""A sweep's grid: named rows and settings axes, each a set of overrides of one run config.

The settings of ``base``, a row or an axis are paths of the run's config schema
(:mod:`noisybolt.agents.config`: ``bolt.tracking``, ``world.kwargs.noise``,
``algorithm.hyperparams.gamma``), given dotted or as nested mappings; the flat names of
older sweep files (``eval_freq``, ``world_kwargs.noise``, ``algo``) read as their paths.
The schema types and checks them: a sweep holds no type table of its own. Seeds are an
axis of their own (``seeds``), not a setting.
"""

from __future__ import annotations

import itertools
import json
import os
import re
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field, replace
from importlib import resources
from pathlib import Path
from typing import TYPE_CHECKING, Any, cast

import yaml

from noisybolt.errors import ConfigError, NoisyboltError

if TYPE_CHECKING:  # training pulls in torch: imported only where trials are built
    from noisybolt.agents.training import TrainConfig

__all__ = ["SweepConfig", "Trial", "builtin_sweeps", "load_sweep", "sweep_settings"]

_TOP_KEYS = (
    "name",
    "base",
    "rows",
    "seeds",
    "settings",
    "retries",
    "final_eval_episodes",
    "resources",
)
_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9._+-]*")
_UNSAFE = re.compile(r"[^A-Za-z0-9._+=-]")
_FRAMES = re.compile(r"\s*(\d+(?:\.\d+)?)\s*([kKmM]?)\s*")
_FRAME_PATHS = ("frames", "evaluation.freq", "checkpoint_freq")


def sweep_settings() -> tuple[str, ...]:
    """The settings a sweep may set: every path of the run's config schema but ``seed``.

    Example:
        >>> settings = sweep_settings()
        >>> "bolt.tracking" in settings, "seed" in settings, "world.n_envs" in settings
        (True, False, True)
    """
    from noisybolt.agents.config import schema_paths

    return tuple(path for path in schema_paths() if path != "seed")


def _block(block: Any, where: str) -> dict[str, Any]:
    """A block of settings as ``{schema path: value}`` (frame counts such as ``60k`` read),
    each value checked against the schema's type."""
    from noisybolt.agents.config import checked_value, override_paths

    if not isinstance(block, Mapping):
        raise ConfigError(f"{where} must be a mapping of training settings, got {block!r}")
    try:
        paths = override_paths(block)
    except ConfigError as error:
        raise ConfigError(f"{where}: {error}") from None
    if "seed" in paths:
        raise ConfigError(f"{where}: 'seed' is not a setting here; list seeds under 'seeds'")
    for key in _FRAME_PATHS:
        value = paths.get(key)
        if isinstance(value, str):
            match = _FRAMES.fullmatch(value)
            if not match:
                raise ConfigError(f"{where}: {key}: not a frame count: {value!r} (e.g. 60k)")
            scale = {"": 1, "k": 1_000, "m": 1_000_000}[match[2].lower()]
            paths[key] = int(float(match[1]) * scale)
    try:
        return {path: checked_value(path, value) for path, value in paths.items()}
    except ConfigError as error:
        raise ConfigError(f"{where}: {error}") from None


def _count(value: Any, key: str) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or value < 0:
        raise ConfigError(f"{key} must be an integer >= 0, got {value!r}")
    return value


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

    Attributes:
        name: the sweep's name.
        trials: every trial, rows outermost, then settings, then seeds.
        seeds: the seeds.
        retries: extra attempts of a trial that raises.
        final_eval_episodes: episodes of a final evaluation of each finished trial
            (``evaluation.json``); 0 reports the run's last periodic evaluation.
        cpus_per_trial: CPUs reserved per trial (Ray backend).
        source: the config as given, saved in ``sweep.json``.
    """

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
        """Validates a sweep config (see :mod:`noisybolt.experiments.sweeps`).

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
        unknown = sorted(set(data) - set(_TOP_KEYS))
        if unknown:
            raise ConfigError(
                f"unknown sweep key(s) {unknown}; known: {sorted(_TOP_KEYS)} (training "
                "settings, paths of the run config schema, go under 'base' or a row)"
            )
        sweep_name = str(data.get("name") or name or "sweep")
        if not _NAME.fullmatch(sweep_name):
            raise ConfigError(f"sweep name {sweep_name!r} must match {_NAME.pattern}")
        base = _block(data.get("base") or {}, "base")
        rows = data.get("rows")
        if not isinstance(rows, list) or not rows:
            raise ConfigError("a sweep needs 'rows': a non-empty list of named settings")
        names = [r.get("name") if isinstance(r, Mapping) else None for r in rows]
        for index, row_name in enumerate(names):
            if not isinstance(row_name, str) or not _NAME.fullmatch(row_name):
                raise ConfigError(f"rows[{index}] needs a 'name' matching {_NAME.pattern}")
            if names.count(row_name) > 1:
                raise ConfigError(f"two rows are named {row_name!r}")
        seeds = _seeds(data.get("seeds", 1))
        axes = _axes(data.get("settings") or {})
        cpus = _cpus(data.get("resources") or {})
        labels = [k.rsplit(".", 1)[-1] for k, _ in axes]
        labels = [
            lb if labels.count(lb) == 1 else k for lb, (k, _) in zip(labels, axes, strict=True)
        ]
        trials: list[Trial] = []
        for row, row_name in zip(rows, names, strict=True):
            assert isinstance(row_name, str)
            over = _block({k: v for k, v in row.items() if k != "name"}, f"row {row_name!r}")
            for combo in itertools.product(*(values for _, values in axes)):
                assignment = {k: v for (k, _), v in zip(axes, combo, strict=True)}
                merged = {**base, **over}
                for key, value in assignment.items():
                    merged.update(_block({key: value}, f"settings {key!r}"))
                label = ",".join(f"{lb}={_slug(v)}" for lb, v in zip(labels, combo, strict=True))
                group = f"{row_name}/{label}" if label else row_name
                where = f"row {row_name!r}" + (f" with {label}" if label else "")
                for seed in seeds:
                    config = _train_config(merged, seed, where)
                    trials.append(
                        Trial(f"{group}/seed-{seed}", group, row_name, seed, assignment, config)
                    )
        ids = [t.trial_id for t in trials]
        if len(set(ids)) != len(ids):
            twice = sorted({i for i in ids if ids.count(i) > 1})
            raise ConfigError(f"two trials would share the id(s) {twice}: make the values distinct")
        sweep = cls(
            name=sweep_name,
            trials=tuple(trials),
            seeds=seeds,
            retries=_count(data.get("retries", 1), "retries"),
            final_eval_episodes=_count(data.get("final_eval_episodes", 0), "final_eval_episodes"),
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
        return replace(self, trials=tuple(t for t in self.trials if t.trial_id in wanted))


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
    path = Path(path)
    try:
        if not path.exists() and str(path) in builtin_sweeps():
            text = resources.files("noisybolt.configs").joinpath(f"sweeps/{path}.yaml").read_text()
        else:
            text = path.read_text()
        data = yaml.safe_load(text)
    except FileNotFoundError:
        raise ConfigError(
            f"no sweep config at {path} (built-in sweeps: {list(builtin_sweeps())})"
        ) from None
    except (OSError, yaml.YAMLError) as error:
        raise ConfigError(
            f"{path} is not a readable sweep config (not valid YAML?): {error}"
        ) from None
    if data is None:
        raise ConfigError(f"{path} is empty: a sweep config needs at least 'rows'")
    return SweepConfig.from_dict(data, name=_UNSAFE.sub("_", path.stem), check_worlds=check_worlds)


def _seeds(value: Any) -> tuple[int, ...]:
    if isinstance(value, int) and not isinstance(value, bool) and value >= 1:
        return tuple(range(value))
    if isinstance(value, list) and value:
        if not all(isinstance(s, int) and not isinstance(s, bool) and s >= 0 for s in value):
            raise ConfigError(f"seeds must be non-negative integers, got {value!r}")
        if len(set(value)) != len(value):
            raise ConfigError(f"seeds repeat: {value!r}")
        return tuple(value)
    raise ConfigError(f"seeds must be >= 1 (a count) or a non-empty list of seeds, got {value!r}")


def _axes(axes: Any) -> list[tuple[str, tuple[Any, ...]]]:
    if not isinstance(axes, Mapping):
        raise ConfigError(f"settings must map setting names to lists of values, got {axes!r}")
    out = []
    for key, values in axes.items():
        if not isinstance(values, list) or not values:
            raise ConfigError(f"settings: {key!r} needs a non-empty list of values")
        if str(key).partition(".")[0] == "seed":
            raise ConfigError("settings: vary seeds with 'seeds', not a settings axis")
        for value in values:  # an unknown key or a value of the wrong type, named
            _block({key: value}, f"settings {key!r}")
        if len({json.dumps(v, sort_keys=True, default=str) for v in values}) != len(values):
            raise ConfigError(f"settings: {key!r} lists a value twice")
        out.append((str(key), tuple(values)))
    return out


def _cpus(value: Any) -> float:
    if not isinstance(value, Mapping) or set(value) - {"cpus"}:
        raise ConfigError(f"resources: unknown key(s) in {value!r}; known: ['cpus'] ({{cpus: 1}})")
    cpus = value.get("cpus", 1)
    if isinstance(cpus, bool) or not isinstance(cpus, int | float) or not cpus > 0:
        raise ConfigError(f"resources.cpus must be a number > 0, got {cpus!r}")
    return float(cpus)


def _slug(value: Any) -> str:
    text = value if isinstance(value, str) else json.dumps(value, separators=(",", ":"))
    return _UNSAFE.sub("_", text) or "_"


def _train_config(settings: Mapping[str, Any], seed: int, where: str) -> TrainConfig:
    from noisybolt.agents.training import TrainConfig
    from noisybolt.experiments.checks import with_exact_scale

    if "bolt.specs" not in settings:
        raise ConfigError(f"{where}: no specs (set 'bolt.specs' in the row or in 'base')")
    try:
        config = TrainConfig.build({"progress_bar": False, **settings, "seed": seed})
        # What `noisybolt train` would choose: the compliance scale computed on the
        # world's product where it can be explored.
        if "bolt.reward_scale" in settings:
            return config
        return with_exact_scale(config, log=None)
    except (NoisyboltError, TypeError, ValueError) as error:
        raise ConfigError(f"{where}: {error}") from None


def _check_worlds(sweep: SweepConfig) -> None:
    """Builds each distinct world once and compiles each trial's specs over its fluents."""
    from noisybolt.envs import make_world
    from noisybolt.logic import compile_ltlf

    fluents: dict[str, tuple[str, ...]] = {}
    for trial in sweep.trials:
        config = trial.config
        key = json.dumps([config.world, config.world_kwargs], sort_keys=True, default=str)
        try:
            if key not in fluents:
                world = make_world(config.world, num_envs=1, seed=0, **config.world_kwargs)
                fluents[key] = tuple(world.fluent_names)
                cast(Any, world).close()  # the contract types what the bolt reads
            for spec in config.spec_objects():
                compile_ltlf(spec.formula, fluents[key])  # cached: cheap after the first
        except (NoisyboltError, TypeError) as error:
            raise ConfigError(f"trial {trial.trial_id!r}: {error}") from None
        path = config.detector.path
        if config.detector.kind == "classifier" and path and not Path(path).exists():
            raise ConfigError(f"trial {trial.trial_id!r}: no classifier file at {path}")
