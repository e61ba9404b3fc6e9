"""A sweep's grid: named rows and settings axes, each an override of one ``TrainConfig``.

The settings a sweep may set are :class:`~noisybolt.agents.training.TrainConfig`'s own
fields (``seed`` aside: seeds are an axis of their own), plus ``n_envs`` (a
hyperparameter); their types are read from the dataclass, so the schema is written once.
"""

from __future__ import annotations

import itertools
import json
import os
import re
import types
import typing
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field, fields, replace
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
_FRAME_KEYS = ("frames", "eval_freq", "checkpoint_freq")


def sweep_settings() -> dict[str, Any]:
    """The settings a sweep may set, with their types (from ``TrainConfig``'s fields).

    Example:
        >>> settings = sweep_settings()
        >>> settings["frames"], "seed" in settings, "n_envs" in settings
        (<class 'int'>, False, True)
    """
    from noisybolt.agents.training import TrainConfig

    hints = typing.get_type_hints(TrainConfig)
    types = {f.name: hints[f.name] for f in fields(TrainConfig) if f.name != "seed"}
    return {**types, "n_envs": int}


def _check(key: str, value: Any, kind: Any, where: str) -> Any:
    """``value`` as setting ``key`` of type ``kind`` takes it, or a ConfigError."""
    if key in _FRAME_KEYS and isinstance(value, str):
        match = _FRAMES.fullmatch(value)
        if not match:
            raise ConfigError(f"{where}: {key}: not a frame count: {value!r} (e.g. 60000, 60k)")
        return int(float(match.group(1)) * {"": 1, "k": 1_000, "m": 1_000_000}[match[2].lower()])
    if key == "specs":
        specs = [value] if isinstance(value, str) else value
        if not isinstance(specs, list) or not specs:
            raise ConfigError(f"{where}: specs must be a non-empty list of names or formulas")
        return specs
    union = typing.get_origin(kind) in (typing.Union, types.UnionType)
    allowed = [typing.get_origin(a) or a for a in (typing.get_args(kind) if union else (kind,))]
    if value is None and type(None) in allowed:
        return None
    if isinstance(value, bool):
        fits = bool in allowed
    elif isinstance(value, int):
        fits = int in allowed or float in allowed
    elif isinstance(value, Mapping):
        fits = dict in allowed or key == "detector"
    else:
        fits = isinstance(value, tuple(a for a in allowed if isinstance(a, type)))
    if not fits:
        names = " or ".join(getattr(a, "__name__", str(a)) for a in allowed)
        raise ConfigError(f"{where}: {key} must be {names}, got {value!r}")
    return dict(value) if isinstance(value, Mapping) else value


def _block(block: Any, where: str, settings: Mapping[str, Any]) -> dict[str, Any]:
    if not isinstance(block, Mapping):
        raise ConfigError(f"{where} must be a mapping of training settings, got {block!r}")
    out = {}
    for key, value in block.items():
        if key == "seed":
            raise ConfigError(f"{where}: 'seed' is not a setting here; list seeds under 'seeds'")
        if key not in settings:
            raise ConfigError(f"{where}: unknown setting {key!r}; known: {sorted(settings)}")
        out[key] = _check(key, value, settings[key], where)
    return out


def _merge(base: Mapping[str, Any], over: Mapping[str, Any]) -> dict[str, Any]:
    """``over`` on ``base``: mappings merge key by key, everything else is replaced."""
    merged = dict(base)
    for key, value in over.items():
        old = merged.get(key)
        both = isinstance(value, Mapping) and isinstance(old, Mapping)
        merged[key] = _merge(old, value) if both else value  # type: ignore[arg-type]
    return merged


def _nested(key: str, value: Any) -> dict[str, Any]:
    """A dotted axis key as a nested override (hyperparameter names keep their dots)."""
    head, _, rest = key.partition(".")
    if not rest:
        return {head: value}
    return {head: {rest: value} if head == "hyperparams" else _nested(rest, value)}


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
        settings = sweep_settings()
        unknown = sorted(set(data) - set(_TOP_KEYS))
        if unknown:
            raise ConfigError(
                f"unknown sweep key(s) {unknown}; known: {sorted(_TOP_KEYS)} "
                f"(training settings go under 'base' or a row: {sorted(settings)})"
            )
        sweep_name = str(data.get("name") or name or "sweep")
        if not _NAME.fullmatch(sweep_name):
            raise ConfigError(f"sweep name {sweep_name!r} must match {_NAME.pattern}")
        base = _block(data.get("base") or {}, "base", settings)
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
        axes = _axes(data.get("settings") or {}, settings)
        cpus = _cpus(data.get("resources") or {})
        labels = [k.rsplit(".", 1)[-1] for k, _ in axes]
        labels = [
            lb if labels.count(lb) == 1 else k for lb, (k, _) in zip(labels, axes, strict=True)
        ]
        trials: list[Trial] = []
        for row, row_name in zip(rows, names, strict=True):
            assert isinstance(row_name, str)
            over = _block(
                {k: v for k, v in row.items() if k != "name"}, f"row {row_name!r}", settings
            )
            for combo in itertools.product(*(values for _, values in axes)):
                assignment = {k: v for (k, _), v in zip(axes, combo, strict=True)}
                merged = _merge(base, over)
                for key, value in assignment.items():
                    merged = _merge(merged, _nested(key, value))
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


def _axes(axes: Any, settings: Mapping[str, Any]) -> list[tuple[str, tuple[Any, ...]]]:
    if not isinstance(axes, Mapping):
        raise ConfigError(f"settings must map setting names to lists of values, got {axes!r}")
    out = []
    for key, values in axes.items():
        head, _, rest = str(key).partition(".")
        if head == "seed":
            raise ConfigError("settings: vary seeds with 'seeds', not a settings axis")
        if head not in settings:
            raise ConfigError(
                f"settings: unknown setting {head!r} in {key!r}; known: {sorted(settings)}"
            )
        if rest and typing.get_origin(settings[head]) is not dict and head != "detector":
            raise ConfigError(f"settings: {head!r} is not a mapping, so {key!r} cannot reach in")
        if not isinstance(values, list) or not values:
            raise ConfigError(f"settings: {key!r} needs a non-empty list of values")
        if not rest:
            values = [_check(head, v, settings[head], f"settings {key!r}") for v in values]
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
    from noisybolt.agents.training import DetectorConfig, TrainConfig
    from noisybolt.envs.registry import DEFAULT_WORLD
    from noisybolt.experiments.checks import with_exact_scale

    values = {"progress_bar": False, **settings}
    if "specs" not in values:
        raise ConfigError(f"{where}: no specs (set 'specs' in the row or in 'base')")
    detector = dict(values.pop("detector", {}) or {})
    unknown = sorted(set(detector) - set(DetectorConfig.__dataclass_fields__))
    if unknown:
        known = sorted(DetectorConfig.__dataclass_fields__)
        raise ConfigError(f"{where}: unknown detector setting(s) {unknown}; known: {known}")
    try:
        config = TrainConfig.create(
            world=values.pop("world", DEFAULT_WORLD),
            specs=values.pop("specs"),
            algo=values.pop("algo", "ppo"),
            overrides=values.pop("hyperparams", None),
            n_envs=values.pop("n_envs", None),
            detector=DetectorConfig(**detector),
            seed=seed,
            **values,
        )
        # What `noisybolt train` would choose: the compliance scale computed on the
        # world's product where it can be explored.
        return (
            config if values.get("reward_scale") is not None else with_exact_scale(config, log=None)
        )
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
