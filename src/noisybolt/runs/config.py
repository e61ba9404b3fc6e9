"""The description of a training run: one nested, frozen schema.

A run is described by a :class:`TrainConfig` alone, made of sections::

    seed, frames, checkpoint_freq, progress_bar    the run itself
    world       WorldConfig        name or factory path, kwargs, n_envs, Atari conventions
    bolt        BoltConfig         specs, reward scheme and scale, shaping, tracking, bands
    detector    DetectorConfig     the bolt's fluent detector
    algorithm   AlgorithmConfig    the SB3 algorithm and its resolved hyperparameters
    evaluation  EvaluationConfig   periodic evaluation, success threshold, stopping, keep best

``config.json`` holds :meth:`TrainConfig.to_dict` (nested, with ``"schema": 2``), and
:meth:`TrainConfig.from_dict` reads it back strictly: an unknown key or a value of the
wrong type is refused with the key's path (``bolt.tracking``,
``algorithm.hyperparams.gamma``). The flat ``config.json`` of runs saved before the schema
was nested still loads (:func:`nested_config`), what it lacks read through
:data:`LEGACY_DEFAULTS`.

Every other description of a run is a set of overrides of this schema, by dotted path:
``noisybolt train``'s flags and ``--set PATH=VALUE``, sweep files, and the ``reproduce``
commands (:meth:`TrainConfig.build` for a new run; :meth:`TrainConfig.override` changes a
resolved one). The types of the paths are the dataclasses' annotations: there is no
second type table.

Each section validates itself at construction (values, ranges, names); ``TrainConfig``
validates what spans sections (specs under the reward scheme, schedules against the
budget); none of it builds a world. What only the world can tell (the compliance scale,
exact on a tabular product or from the world's return bounds; whether a user's world's
images are small integers) is decided by :func:`noisybolt.runs.resolution.resolve`, the
one resolver that :func:`noisybolt.runs.training.train`, ``noisybolt train``,
``noisybolt check``, sweeps and ``reproduce`` all call: a config is data, and building one
plays no world. What needs things built (the model on the env's
spaces, the detector against the world) is checked by
:func:`noisybolt.runs.training.train` before it writes anything.

Example:
    >>> config = TrainConfig.build({"bolt.specs": ["edge"], "bolt.reward": "paper"})
    >>> config.bolt.tracking, config.algorithm.name, config.world_config.n_envs
    ('threshold', 'ppo', 8)
    >>> config.override({"bolt.tracking": "belief"}).bolt.tracking
    'belief'
    >>> config.override({"bolt.trackin": "belief"})  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    noisybolt.errors.ConfigError: unknown config key bolt.trackin; known in bolt: [...]
"""

from __future__ import annotations

import dataclasses
import os
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any

from noisybolt.agents.hyperparams import (
    WORLD_KEYS,
    check_budget,
    check_hyperparameter_values,
    frame_schedules,
    load_hyperparams,
)
from noisybolt.bolt import BeliefSettings, RewardScheme, Spec
from noisybolt.envs import DEFAULT_WORLD
from noisybolt.errors import (
    ConfigError,
    NoEvaluationWarning,
)
from noisybolt.runs.legacy import FLAT_PATHS, SCHEMA_VERSION, nested_config
from noisybolt.runs.schema import (
    FrozenDict,
    check,
    defaults,
    dump,
    flatten,
    leaf_paths,
    load,
    parse_text,
    section_types,
    set_path,
)
from noisybolt.runs.sections import (
    DETECTORS,
    AlgorithmConfig,
    BoltConfig,
    DetectorConfig,
    EvaluationConfig,
    WorldConfig,
    check_count,
    check_given_settings,
)
from noisybolt.runs.specs import parsed_spec, spec_fields

__all__ = [
    "DETECTORS",
    "RESUMABLE_KEYS",
    "AlgorithmConfig",
    "BoltConfig",
    "DetectorConfig",
    "EvaluationConfig",
    "FrozenDict",
    "TrainConfig",
    "WorldConfig",
    "check_hyperparameter_values",
    "checked_value",
    "override_paths",
    "schema_paths",
    "value_from_text",
]

#: Settings (schema paths) that may change when a run is resumed.
RESUMABLE_KEYS: tuple[str, ...] = (
    "frames",
    "progress_bar",
    "evaluation.stop_after",
    "world.workers",  # where the world runs, not what it plays (the same games either way)
    "world.overlap",  # how rollouts are collected, not which games they play
    "algorithm.device",  # where the network trains, not what it learns
    "algorithm.precision",  # how the extractor's products are rounded, not its weights
)
#: Seeds numpy accepts.
SEED_RANGE = (0, 2**32 - 1)
#: The on-policy algorithms: what the ``constrained`` scheme trains (its price moves
#: between rollouts).
ON_POLICY: tuple[str, ...] = ("ppo", "a2c")


#: Schema keys whose attribute has another name: the ``world`` section is
#: ``config.world_config`` (``config.world`` was the world's name in schema 1).
_ATTRIBUTES = {"world": "world_config"}


@dataclass(frozen=True, kw_only=True)
class TrainConfig:
    """Everything that defines a training run (saved as ``config.json``).

    Build a new run's config with :meth:`build` (overrides by schema path, hyperparameters
    and specs resolved), read a saved one with :meth:`from_dict`, change one with
    :meth:`override`. Settings are read by their schema paths (``config.bolt.tracking``,
    ``config.evaluation.freq``, ``config.algorithm.name``; the world's name is
    ``config.world_config.name``). The flat names of schema 1 (``config.tracking``, ...:
    :data:`FLAT_PATHS`) still read them for one release, with a ``DeprecationWarning``.

    Attributes:
        seed: seeds the world, the agent and the evaluation.
        frames: environment steps to train for (all environments together).
        checkpoint_freq: frames between checkpoints (0: none).
        progress_bar: show a progress bar.
        world_config: the world (``world`` in ``config.json``; ``world_config.name``: its name).
        bolt: the bolt's specs and reward.
        detector: the bolt's fluent detector.
        algorithm: the learner and its hyperparameters.
        evaluation: evaluation during training, stopping and the model kept.
    """

    seed: int = 0
    frames: int = 100_000
    checkpoint_freq: int = 20_000
    progress_bar: bool = True
    world_config: WorldConfig = field(default_factory=WorldConfig, metadata={"key": "world"})
    bolt: BoltConfig = field(default_factory=BoltConfig)
    detector: DetectorConfig = field(default_factory=DetectorConfig)
    algorithm: AlgorithmConfig = field(default_factory=AlgorithmConfig)
    evaluation: EvaluationConfig = field(default_factory=EvaluationConfig)

    if not TYPE_CHECKING:  # type checkers see only the paths, so no flat read slips in

        def __getattr__(self, name: str) -> Any:
            # Called only for a name the dataclass lacks: a flat name of schema 1 reads its
            # section for one more release (loading old files does not need this: it
            # converts them, nested_config).
            path = FLAT_PATHS.get(name)
            if path is None:
                raise AttributeError(f"'TrainConfig' object has no attribute {name!r}")
            section, _, key = path.partition(".")
            attribute = _ATTRIBUTES.get(section, section)
            warnings.warn(
                f"TrainConfig.{name} is deprecated: read config.{attribute}.{key} (the "
                f"config.json path {path}); the flat names go in the next release",
                DeprecationWarning,
                stacklevel=2,
            )
            return getattr(getattr(self, attribute), key)

    def __post_init__(self) -> None:
        for key, kind in section_types(TrainConfig).items():
            value = getattr(self, _ATTRIBUTES.get(key, key))
            if not isinstance(value, kind):
                raise ConfigError(f"config key {key} must be a {kind.__name__}, got {value!r}")
        if isinstance(self.seed, bool) or not isinstance(self.seed, int):
            raise ConfigError(f"seed must be an integer, got {self.seed!r}")
        if not SEED_RANGE[0] <= self.seed <= SEED_RANGE[1]:
            raise ConfigError(
                f"seed must be in [{SEED_RANGE[0]}, {SEED_RANGE[1]}] (what numpy accepts), "
                f"got {self.seed}"
            )
        check_count("frames", self.frames, 1)
        check_count("checkpoint_freq", self.checkpoint_freq, 0)
        if not isinstance(self.progress_bar, bool):
            raise ConfigError(f"progress_bar must be true or false, got {self.progress_bar!r}")
        frame_schedules(self.algorithm.hyperparams, frames=self.frames)  # validates them
        if not self.bolt.specs:
            raise ConfigError("give at least one spec (--spec NAME or --spec FORMULA: bolt.specs)")
        bolt = self.bolt
        # Validates reward, reward_scale and shaping. A scale left to resolve() (None) is
        # the world's to give: the rest is validated here with a stand-in.
        scale = 1.0 if bolt.reward != "paper" and bolt.reward_scale is None else None
        scheme = replace(bolt, reward_scale=scale).scheme if scale else bolt.scheme
        if (scheme.shaping, scheme.pay_on_change) != (bolt.shaping, bolt.pay_on_change):
            bolt = replace(bolt, shaping=scheme.shaping, pay_on_change=scheme.pay_on_change)
        object.__setattr__(self, "bolt", bolt)
        names = [spec.name for spec in self._spec_objects(scheme)]  # validates every spec
        repeated = sorted({name for name in names if names.count(name) > 1})
        if repeated:
            raise ConfigError(
                f"spec(s) {repeated} given twice: each spec is tracked and reported by its "
                "name; remove the repeat, or give each a name of its own (--spec-set name=...)"
            )
        if self.algorithm.counterfactual and not self.bolt.bolted:
            raise ConfigError(
                "algorithm.counterfactual relabels the bolt's DFA states, and this run is "
                "unbolted (bolt.bolted false): turn one of them off"
            )
        if self.algorithm.counterfactual and self.bolt.tracking != "threshold":
            raise ConfigError(
                f"algorithm.counterfactual replays Algorithm 1 from other DFA states; under "
                f"bolt.tracking={self.bolt.tracking} the bolt pays on a belief, not on one state: "
                "use bolt.tracking=threshold, or turn algorithm.counterfactual off"
            )
        if bolt.reward == "constrained" and self.algorithm.name not in ON_POLICY:
            raise ConfigError(
                "--reward constrained learns the bolt's price between rollouts, which "
                f"{self.algorithm.name.upper()}'s replay buffer would mix (rewards of many "
                f"prices): use it with {' or '.join(a.upper() for a in ON_POLICY)}, or "
                "--reward compliance"
            )

    # ------------------------------------------------------------------ building

    @classmethod
    def build(
        cls,
        overrides: Mapping[str, Any] | None = None,
        *,
        hp_file: str | os.PathLike[str] | None = None,
    ) -> TrainConfig:
        """A new run's config: the schema's defaults with ``overrides`` applied, as data.

        The overrides: specs given by name, group or formula become
        :class:`~noisybolt.bolt.Spec` fields; the hyperparameters are the world's file for
        the algorithm (or ``hp_file``) with the ``algorithm.hyperparams.*`` overrides on
        top, and the world settings the file gives (``n_envs``, the Atari conventions)
        fill the ``world`` section where no override set them; a setting the run would
        ignore is refused (``bolt.confidence`` under threshold tracking). Nothing is built
        or played here: what only the world can tell (the compliance scale, a user's
        world's small-integer images) is :func:`noisybolt.runs.resolve`'s, which every
        door that starts a run calls (``train()`` among them).

        Args:
            overrides: ``{schema path: value}``; a mapping value merges key by key
                (``{"bolt": {"tracking": "belief"}}`` is ``{"bolt.tracking": "belief"}``).
            hp_file: a YAML file of the built-in hyperparameter layout to read instead.

        Raises:
            ConfigError: an unknown path or a value of the wrong type (naming the path),
                or a value the schema refuses.

        Example:
            >>> config = TrainConfig.build(
            ...     {"bolt.specs": ["edge"], "bolt.reward": "paper", "algorithm.name": "dqn",
            ...      "algorithm.hyperparams.gamma": 0.9, "world.n_envs": 2})
            >>> config.algorithm.hyperparams["gamma"], config.world_config.n_envs
            (0.9, 2)
        """
        changes = override_paths(overrides or {})
        prefix = "algorithm.hyperparams."
        params_given = {k[len(prefix) :]: v for k, v in changes.items() if k.startswith(prefix)}
        data = defaults(cls)
        for path, value in changes.items():
            if not path.startswith(prefix):
                set_path(data, path, checked_value(path, value))
        world, algo = data["world"]["name"], data["algorithm"]["name"]
        if algo == "dqn" and "evaluation.deterministic" not in changes:
            # DQN's policy is its greedy one; sampling it means SB3's epsilon-exploration.
            data["evaluation"]["deterministic"] = True
        if "bolt.reward" not in changes and algo in ON_POLICY:
            # The default scheme: compliance as a constraint for the on-policy learners,
            # which learn its price between rollouts (DQN keeps `compliance`: its replay
            # buffer would mix prices). Measured on the world suite (task kept 25/30
            # against 7/17 for `compliance`) and the gridworld's spec suite (PPO 23/24,
            # A2C 22/24 followed; `compliance` 22/24 and 24/24): benchmarks/README.md.
            data["bolt"]["reward"] = "constrained"
        params = load_hyperparams(world, algo, params_given, hp_file=hp_file)
        for key in sorted(WORLD_KEYS):
            value = params.pop(key, None)
            if value is not None and f"world.{key}" not in changes:
                data["world"][key] = value
        data["algorithm"]["hyperparams"] = params
        bolt = data["bolt"]
        bolt["specs"] = spec_fields(bolt["specs"], paper=bolt["reward"] == "paper")
        config = load(cls, data)
        freq = changes.get("evaluation.freq")
        if isinstance(freq, int) and freq > config.frames:  # chosen, so said
            warnings.warn(
                f"evaluation.freq {freq:,} > frames {config.frames:,}: no periodic "
                "evaluation runs before the final one (give --eval-freq at most the frames, "
                "or 0 for none)",
                NoEvaluationWarning,
                stacklevel=2,
            )
        check_given_settings(config.bolt, changes)
        return config

    @classmethod
    def create(
        cls,
        *,
        world: str = DEFAULT_WORLD,
        specs: Sequence[str | Mapping[str, Any]],
        algo: str = "ppo",
        overrides: Mapping[str, Any] | None = None,
        n_envs: int | None = None,
        hp_file: str | os.PathLike[str] | None = None,
        **settings: Any,
    ) -> TrainConfig:
        """:meth:`build` with keyword arguments: ``overrides`` are hyperparameters, and
        ``settings`` flat names (:data:`FLAT_PATHS`: ``tracking``, ``eval_freq``, ...),
        run-level fields or sections (``detector=DetectorConfig(...)``, or
        ``detector="oracle"`` for a detector kind with its defaults).

        Example:
            >>> TrainConfig.create(specs=["edge"], reward="paper", tracking="belief").bolt.tracking
            'belief'
        """
        changes: dict[str, Any] = {"world.name": world, "bolt.specs": list(specs)}
        changes["algorithm.name"] = algo
        for key, value in (overrides or {}).items():
            changes[f"algorithm.hyperparams.{key}"] = value
        if n_envs is not None:
            changes["world.n_envs"] = n_envs
        for key, value in settings.items():
            if dataclasses.is_dataclass(value) and not isinstance(value, type):
                value = dump(value)
            elif key == "detector" and isinstance(value, str):
                # ``detector="oracle"``: the kind, as ``noisybolt train --detector`` takes it
                key, value = "detector.kind", value
            changes[FLAT_PATHS.get(key, key)] = value
        return cls.build(changes, hp_file=hp_file)

    @classmethod
    def resumed(
        cls,
        saved: Mapping[str, Any],
        overrides: Mapping[str, Any] | None = None,
        *,
        hp_file: str | os.PathLike[str] | None = None,
        trust_code: bool = False,
    ) -> TrainConfig:
        """The config a resumed run continues with: its saved ``config.json`` (``saved``,
        read as :meth:`from_dict` reads it) with the settings the user gives again
        (``overrides``, as :meth:`build` takes them; ``hp_file``'s hyperparameters for the
        run's world and algorithm) applied on top. A setting left out keeps the run's
        value, whatever today's default: ``noisybolt train --out RUN --resume`` continues
        RUN as it was started, and a run saved before a setting existed keeps what it
        meant by it (:data:`LEGACY_DEFAULTS`). A setting given with another value than the
        saved one is refused by the resume's check unless it may change
        (:data:`RESUMABLE_KEYS`).

        Code the saved config names (a world or detector factory path) is followed only
        with the user's word: ``trust_code``, or the same reference among ``overrides``
        (:mod:`noisybolt.runs.trust`).

        Raises:
            ConfigError: the saved config does not load, or an override is unknown or of
                the wrong type (naming the path).
            UntrustedCodeError: the saved config names code not vouched for (nothing is
                imported).

        Example:
            >>> saved = TrainConfig.create(specs=["edge"], frames=1000).to_dict()
            >>> resumed = TrainConfig.resumed(saved, {"frames": 2000})
            >>> resumed.frames, resumed.bolt.specs == TrainConfig.from_dict(saved).bolt.specs
            (2000, True)
        """
        from noisybolt.runs.trust import loading_run

        changes = override_paths(overrides or {})
        with loading_run(saved, trust_code=trust_code, given=changes):
            config = cls.from_dict(saved)
        if hp_file is not None:
            prefix = "algorithm.hyperparams."
            given = {k[len(prefix) :]: v for k, v in changes.items() if k.startswith(prefix)}
            params = load_hyperparams(
                config.world_config.name, config.algorithm.name, given, hp_file=hp_file
            )
            for key in WORLD_KEYS & set(params):
                value = params.pop(key)
                if value is not None and f"world.{key}" not in changes:
                    changes[f"world.{key}"] = value
            changes.update({prefix + key: value for key, value in params.items()})
        if not changes:
            return config
        config = config.override(changes)
        check_given_settings(config.bolt, changes)
        return config

    def override(self, changes: Mapping[str, Any]) -> TrainConfig:
        """This config with ``changes`` (``{schema path: value}``) applied, validated whole.

        It changes what the paths name and nothing else: a resolved config keeps its
        hyperparameters and compliance scale (build a new run's config with :meth:`build`
        to resolve them again; a scale set to None is left to :func:`resolve`). Specs may
        be given by name or formula.

        Raises:
            ConfigError: an unknown path or a value of the wrong type, naming the path.
        """
        data = self.to_dict()
        for path, value in override_paths(changes).items():
            if path == "bolt.specs":
                value = spec_fields(checked_value(path, value), paper=self.bolt.reward == "paper")
            set_path(data, path, checked_value(path, value))
        return TrainConfig.from_dict(data)

    def check_budget(self) -> None:
        """Refuses to start a run whose budget cannot be kept: PPO's or A2C's first
        rollout (``world.n_envs`` x ``n_steps`` frames) larger than ``frames`` (SB3 would
        train that rollout whole, past the budget), or DQN's ``learning_starts`` at or
        past ``frames`` (it would never learn).

        :func:`~noisybolt.runs.training.train` calls it for a new run before anything
        is written (so does every door that starts one: the CLI, sweeps, ``reproduce``);
        reading a saved config does not (:meth:`from_dict`), so a run saved before the
        rule still evaluates and resumes.

        Raises:
            ConfigError: giving the arithmetic and what to change.

        Example:
            >>> config = TrainConfig.build({"bolt.specs": ["edge"], "bolt.reward": "paper",
            ...                             "frames": 1000, "world.n_envs": 64})
            >>> config.check_budget()  # doctest: +ELLIPSIS
            Traceback (most recent call last):
            ...
            noisybolt.errors.ConfigError: frames 1,000 is less than one PPO rollout: ...
        """
        check_budget(
            self.algorithm.name,
            frames=self.frames,
            n_envs=self.world_config.n_envs,
            hyperparams=self.algorithm.hyperparams,
        )

    # ------------------------------------------------------------------ reading

    @property
    def world_settings(self) -> dict[str, Any]:
        """``world.kwargs`` plus ``fire_on_reset`` when set: what every world of the run
        is built with."""
        settings = dict(self.world_config.kwargs)
        if self.world_config.fire_on_reset:
            settings["fire_on_reset"] = True
        return settings

    @property
    def learner_world_settings(self) -> dict[str, Any]:
        """:attr:`world_settings` with ``world.train_kwargs`` over them: what the
        learner's games are built with."""
        return {**self.world_settings, **self.world_config.train_kwargs}

    @property
    def scheme(self) -> RewardScheme:
        """The reward scheme of the run.

        Raises:
            ConfigError: its scale is not resolved yet (:func:`resolve` gives it).
        """
        if self.bolt.reward != "paper" and self.bolt.reward_scale is None:
            raise ConfigError(
                f"the {self.bolt.reward} scheme's scale (bolt.reward_scale) is not resolved yet: "
                "noisybolt.runs.resolve(config) computes it from the world (train() and every "
                "door that starts a run call it), or give one"
            )
        return self.bolt.scheme

    @property
    def progress_gamma(self) -> float | None:
        """The discount of the compliance scheme's progress terms (None under the paper
        scheme or unbolted): 1, the scheme's objective being undiscounted (see
        :mod:`noisybolt.bolt.shaping`)."""
        if not self.bolt.bolted or self.bolt.reward == "paper":
            return None
        return 1.0

    @property
    def belief_settings(self) -> BeliefSettings | None:
        """The bolt's belief-tracking settings (None under threshold tracking)."""
        if self.bolt.tracking != "belief":
            return None
        return BeliefSettings(confidence=self.bolt.confidence, min_dwell=self.bolt.min_dwell)

    def spec_objects(self) -> list[Spec]:
        """The specs as :class:`~noisybolt.bolt.Spec` (zero rewards when not bolted).

        Raises:
            ConfigError: the scheme's scale is not resolved yet (:func:`resolve`).
        """
        return self._spec_objects(self.scheme)

    def _spec_objects(self, scheme: RewardScheme) -> list[Spec]:
        specs = []
        for fields in self.bolt.specs:
            fields = dict(fields)
            scale = fields.pop("reward_scale", None)
            specs.append(scheme.apply(parsed_spec(fields), scale=scale))
        if not self.bolt.bolted:
            specs = [replace(s, terminal_reward=0.0, low_confidence_cost=0.0) for s in specs]
        return specs

    def to_dict(self) -> dict[str, Any]:
        """JSON-able nested form (what ``config.json`` holds), with its schema version."""
        return {"schema": SCHEMA_VERSION, **dump(self)}

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> TrainConfig:
        """Reads :meth:`to_dict`'s output back strictly, or the flat form of older runs.

        A key the data lacks takes what the version that saved it meant
        (:data:`LEGACY_DEFAULTS`), else the schema's default.

        Raises:
            ConfigError: an unknown key, or a value of the wrong JSON type; the message
                names the key's path (``detector.samples``).

        Example:
            >>> TrainConfig.from_dict({"bolt": {"specs": [{"name": "edge"}]},
            ...                        "detector": {"samples": "many"}})
            Traceback (most recent call last):
            ...
            noisybolt.errors.ConfigError: config key detector.samples must be an integer, got 'many'
        """
        data = nested_config(data)
        del data["schema"]
        return load(cls, data)


# --------------------------------------------------------------------------- paths


def override_paths(changes: Mapping[str, Any]) -> dict[str, Any]:
    """``changes`` as ``{schema path: value}``, the form :meth:`TrainConfig.build` takes:
    nested mappings flattened, and the flat names of older files (:data:`FLAT_PATHS`:
    ``eval_freq``, ``world_kwargs.noise``, ``hyperparams.gamma``, ``world: gridworld``)
    read as their paths.

    Raises:
        ConfigError: a key that names no setting.

    Example:
        >>> override_paths({"world_kwargs.noise": "regional", "bolt": {"tracking": "belief"}})
        {'world.kwargs.noise': 'regional', 'bolt.tracking': 'belief'}
    """
    out: dict[str, Any] = {}
    for key, value in changes.items():
        head, dot, rest = str(key).partition(".")
        section = head in section_types(TrainConfig) and (dot or isinstance(value, Mapping))
        if head in FLAT_PATHS and not section:
            key = FLAT_PATHS[head] + dot + rest
        out.update(flatten(TrainConfig, {key: value}))
    return out


def checked_value(path: str, value: Any) -> Any:
    """``value`` as JSON data if the setting at ``path`` can hold it (specs: a list of
    names, formulas or mappings).

    Raises:
        ConfigError: an unknown path, or a value of the wrong type, naming the path.

    Example:
        >>> checked_value("evaluation.episodes", "many")
        Traceback (most recent call last):
        ...
        noisybolt.errors.ConfigError: config key evaluation.episodes must be an integer, got 'many'
    """
    if path != "bolt.specs":
        return check(TrainConfig, path, value)
    specs = [value] if isinstance(value, str) else value  # resolved after the overrides
    if not isinstance(specs, (list, tuple)) or not all(
        isinstance(s, (str, Mapping)) for s in specs
    ):
        raise ConfigError(
            f"config key bolt.specs must be a list of spec names, formulas or mappings, "
            f"got {value!r}"
        )
    return list(specs)


def schema_paths() -> tuple[str, ...]:
    """Every setting's path (a mapping-typed setting's keys are free below it).

    Example:
        >>> "bolt.tracking" in schema_paths(), "algorithm.hyperparams" in schema_paths()
        (True, True)
    """
    return leaf_paths(TrainConfig)


def value_from_text(path: str, text: str) -> Any:
    """The value a command line's ``PATH=TEXT`` means for the setting at ``path``: the
    text itself for a string setting, else ``text`` read as YAML (``[32, 32]``, ``true``,
    ``null``; ``3e-4`` as the number a user means).

    Example:
        >>> value_from_text("bolt.tracking", "belief"), value_from_text("frames", "5000")
        ('belief', 5000)
        >>> value_from_text("algorithm.hyperparams.learning_rate", "3e-4")
        0.0003
    """
    return parse_text(TrainConfig, path, text)
