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
images are small integers) is decided by :func:`resolve`, the one resolver that
:meth:`TrainConfig.build`, :func:`noisybolt.runs.training.train`, ``noisybolt check``,
sweeps and ``reproduce`` all call. What needs things built (the model on the env's
spaces, the detector against the world) is checked by
:func:`noisybolt.runs.training.train` before it writes anything.

Example:
    >>> config = TrainConfig.build({"bolt.specs": ["edge"], "bolt.reward": "paper"})
    >>> config.bolt.tracking, config.algorithm.name, config.world_config.n_envs
    ('threshold', 'ppo', 8)
    >>> config.override({"bolt.tracking": "belief"}).tracking
    'belief'
    >>> config.override({"bolt.trackin": "belief"})  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    noisybolt.errors.ConfigError: unknown config key bolt.trackin; known in bolt: [...]
"""

from __future__ import annotations

import dataclasses
import json
import os
import warnings
from collections.abc import Callable, Mapping, Sequence
from dataclasses import asdict, dataclass, field, replace
from typing import Any, Generic, TypeVar

from noisybolt.agents.hyperparams import (
    SPLIT,
    WORLD_KEYS,
    check_hyperparameter_values,
    frame_schedules,
    load_hyperparams,
)
from noisybolt.runs.resolution import (
    SMALL_INTEGER_IMAGE_MAX,
    ScaleChoice,
    choose_compliance_scale,
    small_integer_image_top,
)
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
)
from noisybolt.runs.specs import expand_specs, resolve_spec
from noisybolt.runs.world_checks import check_world_fits
from noisybolt.bolt import BeliefSettings, RewardScheme, Spec
from noisybolt.envs import DEFAULT_WORLD
from noisybolt.envs.registry import is_factory_path
from noisybolt.errors import (
    ConfigError,
    NoEvaluationWarning,
    SmallIntegerImagesWarning,
    SpecSyntaxError,
    UnnormalizedRewardWarning,
)

__all__ = [
    "DETECTORS",
    "FLAT_PATHS",
    "LEGACY_DEFAULTS",
    "RESUMABLE_KEYS",
    "SCHEMA_VERSION",
    "AlgorithmConfig",
    "BoltConfig",
    "DetectorConfig",
    "EvaluationConfig",
    "FrozenDict",
    "TrainConfig",
    "WorldConfig",
    "check_given_settings",
    "check_hyperparameter_values",
    "checked_value",
    "compliance_scale_choice",
    "describe_scheme",
    "nested_config",
    "override_paths",
    "resolve",
    "schema_paths",
    "spec_worths",
    "value_from_text",
    "warn_of_unnormalized_rewards",
]

#: The version of the nested schema that ``config.json`` holds under ``"schema"`` (a
#: config without it is the flat form of the runs saved before: version 1).
SCHEMA_VERSION = 2
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
#: What a config saved before a setting existed meant by it, by schema path (read by
#: :func:`nested_config`: a saved config that lacks the path gets this value).
LEGACY_DEFAULTS: dict[str, Any] = {
    "bolt.reward": "paper",
    "bolt.reward_scale": None,
    "bolt.shaping": False,
    # before bolt.pay_on_change existed the compliance scheme paid at the episode's end
    "bolt.pay_on_change": False,
    "evaluation.stop_after": 0,
    # before keep_best existed a run's final model was its last
    "evaluation.keep_best": False,
    # before the constrained scheme existed no run had a cost budget
    "bolt.constraint": {},
    # before belief tracking existed every bolt tracked by threshold (Algorithm 1)
    "bolt.tracking": "threshold",
    "bolt.confidence": 0.9,
    # before bolt.min_dwell existed belief tracking assumed two steps
    "bolt.min_dwell": 2,
    # before world.workers existed every world ran in the training process
    "world.workers": 0,
    # before world.overlap existed every rollout stepped all games at once
    "world.overlap": False,
    # before world.train_kwargs existed the learner's games were the evaluation's
    "world.train_kwargs": {},
    # before algorithm.device existed every agent trained on the CPU
    "algorithm.device": "cpu",
    # before algorithm.precision existed every agent computed in float32
    "algorithm.precision": "float32",
    # before algorithm.init_from existed every agent started from random weights
    "algorithm.init_from": None,
    # before algorithm.counterfactual existed every transition was stored as gathered
    "algorithm.counterfactual": False,
    "algorithm.counterfactual_samples": 16,
    # before detector.restarts existed one classifier was trained, from detector.seed
    "detector.restarts": 1,
    # before detector.final_views existed collection never kept an episode's last state
    "detector.final_views": False,
    # before detector.kwargs existed no detector took further arguments
    "detector.kwargs": {},
}
#: Seeds numpy accepts.
SEED_RANGE = (0, 2**32 - 1)
#: The on-policy algorithms: what the ``constrained`` scheme trains (its price moves
#: between rollouts).
ON_POLICY: tuple[str, ...] = ("ppo", "a2c")


_T = TypeVar("_T")


class _Alias(Generic[_T]):
    """A read-only flat name for a setting held in a section: ``config.tracking`` is
    ``config.bolt.tracking``. One place holds the data; these are the names the code read
    before the schema was nested, and the keys of the flat ``config.json`` of older runs."""

    def __init__(self, path: str) -> None:
        self.path = path
        section, _, self.name = path.partition(".")
        self.section = _ATTRIBUTES.get(section, section)

    def __get__(self, obj: Any, owner: Any = None) -> _T:
        if obj is None:
            return self  # type: ignore[return-value]
        value: _T = getattr(getattr(obj, self.section), self.name)
        return value


#: Schema keys whose attribute has another name: ``config.world`` is the world's name
#: (what most code wants), the section is ``config.world_config``.
_ATTRIBUTES = {"world": "world_config"}


@dataclass(frozen=True, kw_only=True)
class TrainConfig:
    """Everything that defines a training run (saved as ``config.json``).

    Build a new run's config with :meth:`build` (overrides by schema path, hyperparameters
    and specs resolved), read a saved one with :meth:`from_dict`, change one with
    :meth:`override`. The flat names of the settings (``config.tracking``,
    ``config.eval_freq``, ``config.algo``, ``config.world``: the world's name) read the
    sections; :data:`FLAT_PATHS` says which path each reads.

    Attributes:
        seed: seeds the world, the agent and the evaluation.
        frames: environment steps to train for (all environments together).
        checkpoint_freq: frames between checkpoints (0: none).
        progress_bar: show a progress bar.
        world_config: the world (``world`` in ``config.json``; ``config.world`` is its name).
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

    world = _Alias[str]("world.name")
    world_kwargs = _Alias[Mapping[str, Any]]("world.kwargs")
    n_envs = _Alias[int]("world.n_envs")
    specs = _Alias[tuple[Mapping[str, Any], ...]]("bolt.specs")
    reward = _Alias[str]("bolt.reward")
    reward_scale = _Alias[float | None]("bolt.reward_scale")
    shaping = _Alias[bool]("bolt.shaping")
    pay_on_change = _Alias[bool]("bolt.pay_on_change")
    tracking = _Alias[str]("bolt.tracking")
    confidence = _Alias[float]("bolt.confidence")
    min_dwell = _Alias[int]("bolt.min_dwell")
    thresholds = _Alias[Mapping[str, float]]("bolt.thresholds")
    cost_mode = _Alias[str]("bolt.cost_mode")
    bolted = _Alias[bool]("bolt.bolted")
    algo = _Alias[str]("algorithm.name")
    hyperparams = _Alias[Mapping[str, Any]]("algorithm.hyperparams")
    device = _Alias[str]("algorithm.device")
    eval_freq = _Alias[int]("evaluation.freq")
    eval_episodes = _Alias[int]("evaluation.episodes")
    eval_envs = _Alias[int]("evaluation.envs")
    eval_deterministic = _Alias[bool]("evaluation.deterministic")
    success_threshold = _Alias[float]("evaluation.success_threshold")
    stop_after = _Alias[int]("evaluation.stop_after")
    keep_best = _Alias[bool]("evaluation.keep_best")

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
        frame_schedules(self.hyperparams, frames=self.frames)  # validates them
        if not self.specs:
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
        if self.algorithm.counterfactual and not self.bolted:
            raise ConfigError(
                "algorithm.counterfactual relabels the bolt's DFA states, and this run is "
                "unbolted (bolt.bolted false): turn one of them off"
            )
        if self.algorithm.counterfactual and self.tracking != "threshold":
            raise ConfigError(
                f"algorithm.counterfactual replays Algorithm 1 from other DFA states; under "
                f"bolt.tracking={self.tracking} the bolt pays on a belief, not on one state: "
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
        log: Callable[[str], None] | None = None,
    ) -> TrainConfig:
        """A new run's config: the schema's defaults with ``overrides`` applied, resolved.

        The overrides: specs given by name, group or formula become
        :class:`~noisybolt.bolt.Spec` fields; the hyperparameters are the world's file for
        the algorithm (or ``hp_file``) with the ``algorithm.hyperparams.*`` overrides on
        top, and the world settings the file gives (``n_envs``, the Atari conventions)
        fill the ``world`` section where no override set them; a setting the run would
        ignore is refused (``bolt.confidence`` under threshold tracking). Then
        :func:`resolve` gives what the world decides (the compliance scale, a user's
        world's small-integer images), as for every other door.

        Args:
            overrides: ``{schema path: value}``; a mapping value merges key by key
                (``{"bolt": {"tracking": "belief"}}`` is ``{"bolt.tracking": "belief"}``).
            hp_file: a YAML file of the built-in hyperparameter layout to read instead.
            log: told where the compliance scale came from when it is computed on the
                world's product (:func:`resolve`).

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
        params = load_hyperparams(world, algo, params_given, hp_file=hp_file)
        for key in sorted(WORLD_KEYS):
            value = params.pop(key, None)
            if value is not None and f"world.{key}" not in changes:
                data["world"][key] = value
        data["algorithm"]["hyperparams"] = params
        bolt = data["bolt"]
        bolt["specs"] = _resolved_specs(bolt["specs"], paper=bolt["reward"] == "paper")
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
        check_given_settings(config, changes)
        return resolve(config, log=log)

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
            params = load_hyperparams(config.world, config.algo, given, hp_file=hp_file)
            for key in WORLD_KEYS & set(params):
                value = params.pop(key)
                if value is not None and f"world.{key}" not in changes:
                    changes[f"world.{key}"] = value
            changes.update({prefix + key: value for key, value in params.items()})
        if not changes:
            return config
        config = config.override(changes)
        check_given_settings(config, changes)
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
                value = _resolved_specs(checked_value(path, value), paper=self.reward == "paper")
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
        from noisybolt.agents.hyperparams import constructor_defaults

        defaults_ = constructor_defaults(self.algo)
        params = {**defaults_, **self.hyperparams}
        if self.algo in ON_POLICY:  # one rollout of every env before an update
            steps = params["n_steps"]
            rollout = self.n_envs * steps
            if rollout > self.frames:
                fewer = (
                    f"--hp n_steps={self.frames // self.n_envs} or less"
                    if self.frames >= self.n_envs
                    else f"--n-envs {self.frames} or less"
                )
                raise ConfigError(
                    f"frames {self.frames:,} is less than one {self.algo.upper()} rollout: "
                    f"world.n_envs x algorithm.hyperparams.n_steps = {self.n_envs} x {steps} "
                    f"= {rollout:,} frames, which would be trained whole, past the budget; "
                    f"give --frames {rollout} or more, or {fewer}"
                )
            return
        starts = params.get("learning_starts")
        if isinstance(starts, int) and starts >= self.frames:
            raise ConfigError(
                f"algorithm.hyperparams.learning_starts {starts:,} >= frames {self.frames:,}: "
                f"{self.algo.upper()} would never learn; give --frames above {starts} or --hp "
                f"learning_starts={self.frames // 10}"
            )

    # ------------------------------------------------------------------ reading

    @property
    def world_settings(self) -> dict[str, Any]:
        """``world.kwargs`` plus ``fire_on_reset`` when set: what every world of the run
        is built with."""
        settings = dict(self.world_kwargs)
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
        if self.reward != "paper" and self.reward_scale is None:
            raise ConfigError(
                f"the {self.reward} scheme's scale (bolt.reward_scale) is not resolved yet: "
                "resolve(config) computes it from the world (TrainConfig.build and train() "
                "call it), or give one"
            )
        return self.bolt.scheme

    @property
    def progress_gamma(self) -> float | None:
        """The discount of the compliance scheme's progress terms (None under the paper
        scheme or unbolted): 1, the scheme's objective being undiscounted (see
        :mod:`noisybolt.bolt.shaping`)."""
        if not self.bolted or self.reward == "paper":
            return None
        return 1.0

    @property
    def belief_settings(self) -> BeliefSettings | None:
        """The bolt's belief-tracking settings (None under threshold tracking)."""
        if self.tracking != "belief":
            return None
        return BeliefSettings(confidence=self.confidence, min_dwell=self.min_dwell)

    def spec_objects(self) -> list[Spec]:
        """The specs as :class:`~noisybolt.bolt.Spec` (zero rewards when not bolted).

        Raises:
            ConfigError: the scheme's scale is not resolved yet (:func:`resolve`).
        """
        return self._spec_objects(self.scheme)

    def _spec_objects(self, scheme: RewardScheme) -> list[Spec]:
        specs = []
        for fields in self.specs:
            fields = dict(fields)
            scale = fields.pop("reward_scale", None)
            specs.append(scheme.apply(_parsed_spec(fields), scale=scale))
        if not self.bolted:
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


#: The flat name of each setting held in a section (``tracking`` -> ``bolt.tracking``):
#: the attributes that read them, the keys of the flat ``config.json`` of older runs and
#: :meth:`TrainConfig.create`'s keywords.
FLAT_PATHS: dict[str, str] = {
    name: alias.path for name, alias in vars(TrainConfig).items() if isinstance(alias, _Alias)
}


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


def nested_config(data: Mapping[str, Any]) -> dict[str, Any]:
    """A saved config's data in today's nested form, with its schema version: the flat
    ``config.json`` of a run saved before the schema was nested converted (its keys are
    :data:`FLAT_PATHS`; world settings among its hyperparameters moved to ``world``), and
    every path of
    :data:`LEGACY_DEFAULTS` it lacks filled in. Nothing is validated here.

    Raises:
        ConfigError: not a mapping, or a schema version this noisybolt does not read.

    Example:
        >>> nested = nested_config({"algo": "dqn", "eval_freq": 500, "hyperparams": {"n_envs": 2}})
        >>> nested["algorithm"], nested["evaluation"]["freq"], nested["world"]["n_envs"]
        ({'name': 'dqn', 'hyperparams': {}, 'device': 'cpu', 'precision': 'float32', \
'init_from': None, 'counterfactual': False, 'counterfactual_samples': 16}, 500, 2)
        >>> nested["bolt"]["tracking"]  # runs saved before belief tracking tracked by threshold
        'threshold'
    """
    if not isinstance(data, Mapping):
        raise ConfigError(f"a training config is a mapping, got {type(data).__name__}")
    raw: dict[str, Any] = json.loads(json.dumps(dict(data)))
    version = raw.pop("schema", None)
    nested_form = version is not None or any(
        isinstance(raw.get(k), Mapping) for k in ("world", "bolt", "algorithm", "evaluation")
    )
    if version is not None and version != SCHEMA_VERSION:
        raise ConfigError(
            f"config schema {version!r}: this noisybolt reads schema {SCHEMA_VERSION} (and the "
            "flat configs of older runs); use the noisybolt version that wrote it"
        )
    out: dict[str, Any] = raw if nested_form else {}
    if not nested_form:
        for key, value in raw.items():
            if key == "hyperparams" and isinstance(value, Mapping):
                value = dict(value)
                for name in sorted(WORLD_KEYS & set(value)):
                    setting = value.pop(name)
                    if setting is not None:
                        set_path(out, f"world.{name}", setting)
            set_path(out, FLAT_PATHS.get(key, key), value)
    for path, value in LEGACY_DEFAULTS.items():
        section, key = path.split(".")
        if not isinstance(out.get(section), dict):
            out.setdefault(section, {})  # a section of the wrong type is refused by loading
        if isinstance(out[section], dict) and key not in out[section]:
            out[section][key] = value
    return {"schema": SCHEMA_VERSION, **out}


def _resolved_specs(items: Sequence[Any], *, paper: bool) -> list[dict[str, Any]]:
    """Specs given by name, group, formula or mapping, as :class:`Spec` fields (plus a
    spec's own ``reward_scale``)."""
    resolved = []
    for item in expand_specs(list(items)):
        scale = None
        if isinstance(item, Mapping):
            item = dict(item)
            scale = item.pop("reward_scale", None)
            paid_by_paper = sorted({"terminal_reward", "reward_timing"} & set(item))
            if paid_by_paper and not paper:
                raise ConfigError(
                    f"spec {item.get('name') or item.get('formula')!r} sets "
                    f"{paid_by_paper}, which only the paper reward scheme pays; under the "
                    "compliance scheme set reward_scale instead, or use --reward paper"
                )
        fields = asdict(_parsed_spec(item))
        if scale is not None:
            fields["reward_scale"] = scale
        resolved.append(json.loads(json.dumps(fields)))
    return resolved


def _parsed_spec(fields: str | Mapping[str, Any]) -> Spec:
    """:func:`resolve_spec`, with a formula nested beyond Python's recursion limit (which
    the parser recurses through) refused by name rather than by traceback."""
    try:
        return resolve_spec(fields)
    except RecursionError:
        formula = str(fields if isinstance(fields, str) else fields.get("formula", ""))
        raise SpecSyntaxError(
            f"formula {formula[:40]!r}... is nested too deeply to parse; write it with fewer "
            "nested operators (e.g. G(a & b) instead of G(a) & G(b) nested)",
            formula=formula,
        ) from None


# --------------------------------------------------------------------------- resolution


def resolve(config: TrainConfig, *, log: Callable[[str], None] | None = None) -> TrainConfig:
    """``config`` with what only its world can tell decided: the one resolver every door
    calls.

    ``train()``, ``noisybolt train``, ``noisybolt check``, sweeps and ``reproduce`` resolve
    a config here (:meth:`TrainConfig.build` calls it), so a config is paid the same
    whichever door it came in by. What is decided:

    - the scale of a scheme that pays one (``bolt.reward_scale``, where None): on a
      tabular world (the gridworld), exact on the product of the world and the specs'
      DFAs, else from the world's return bounds (declared, or estimated by random play);
      the specs and spaces are checked against the world before anything costly
      (:func:`compliance_scale_choice`);
    - for a user's world (a factory path) whose uint8 images are small integers,
      ``algorithm.hyperparams.policy_kwargs.normalize_images`` false (with a
      :class:`~noisybolt.errors.SmallIntegerImagesWarning`), unless the hyperparameters
      name it.

    Idempotent: what a config names (a scale, ``normalize_images``) is kept, so a resolved
    config comes back unchanged. A config is data; this is where the world is played.

    Args:
        log: told where a scale computed on the product came from.

    Example:
        >>> both = "F(top_right_corner) & F(bottom_left_corner)"
        >>> config = TrainConfig.build({"bolt.specs": [both]})  # the gridworld: exact
        >>> round(config.reward_scale, 2), resolve(config) is config
        (58.45, True)
    """
    params = config.hyperparams
    policy_kwargs = dict(params.get("policy_kwargs") or {})
    if is_factory_path(config.world) and "normalize_images" not in policy_kwargs:
        top = small_integer_image_top(config.world, config.world_kwargs)
        if top is not None and top <= SMALL_INTEGER_IMAGE_MAX:
            kept = {**policy_kwargs, "normalize_images": False}
            algorithm = replace(config.algorithm, hyperparams={**params, "policy_kwargs": kept})
            config = replace(config, algorithm=algorithm)
            warnings.warn(
                f"the {config.world!r} world's image observations are small integers (at "
                f"most {top} in random play, like MiniGrid's symbolic grid), not pixels: "
                "they reach the network as they are (policy_kwargs.normalize_images=false; "
                "pass --hp policy_kwargs.normalize_images=true to divide them by 255 after "
                "all)",
                SmallIntegerImagesWarning,
                stacklevel=3,
            )
    if config.reward != "paper" and config.reward_scale is None:
        choice = compliance_scale_choice(config)
        config = replace(config, bolt=replace(config.bolt, reward_scale=choice.scale))
        if choice.exact and log is not None:
            log(
                f"compliance scale computed on the {config.world}'s product: {choice.scale:g} "
                f"(the bound from its return range: {choice.bound:g})"
            )
    return config


def compliance_scale_choice(config: TrainConfig) -> ScaleChoice:
    """The scale :func:`resolve` gives ``config`` where it names none (whatever it names),
    with the bound from the world's returns beside it; the run's cheap checks
    (:func:`~noisybolt.runs.world_checks.check_world_fits`: spaces, specs over the
    world's fluents) come first.

    Raises:
        ConfigError, UnknownFluentError, UnsatisfiableSpecError, SpecSyntaxError: as
            :func:`~noisybolt.runs.world_checks.check_world_fits`.
    """
    return choose_compliance_scale(
        config.world,
        config.world_settings,
        formulas=[str(spec["formula"]) for spec in config.specs],
        gamma=float(config.hyperparams.get("gamma", 0.99)),
        pay_on_change=config.pay_on_change,
        clipped=config.world_config.clip_reward,
        check=lambda world: check_world_fits(config, world),
    )


def check_given_settings(config: TrainConfig, given: Mapping[str, Any]) -> None:
    """Refuses a setting that was given (``given``: ``{schema path: value}``, as
    :meth:`TrainConfig.build` and :meth:`TrainConfig.resumed` take them) where ``config``
    would ignore it: a rule on what a user asked for, not on the values (a saved config
    holds every setting, its defaults too).

    Raises:
        ConfigError: ``bolt.confidence`` or ``bolt.min_dwell`` without belief tracking,
            ``bolt.shaping`` under the paper scheme; naming the path and its flag.

    Example:
        >>> TrainConfig.build({"bolt.specs": ["edge"], "bolt.confidence": 0.8})
        Traceback (most recent call last):
        ...
        noisybolt.errors.ConfigError: bolt.confidence 0.8 (--confidence) sets how belief \
tracking reads the detector; with threshold tracking it would be ignored: set bolt.tracking \
belief (--tracking belief), or leave it out
    """
    for path, flag in (("bolt.confidence", "--confidence"), ("bolt.min_dwell", "--min-dwell")):
        if path in given and config.tracking != "belief":
            raise ConfigError(
                f"{path} {given[path]} ({flag}) sets how belief tracking reads the detector; "
                f"with {config.tracking} tracking it would be ignored: set bolt.tracking "
                "belief (--tracking belief), or leave it out"
            )
    if "bolt.shaping" in given and config.reward == "paper":
        raise ConfigError(
            "bolt.shaping (--no-shaping) turns off the compliance scheme's progress shaping; "
            "the paper scheme has none, so it would be ignored: set bolt.reward compliance "
            "(--reward compliance), or leave it out"
        )


def describe_scheme(config: TrainConfig) -> str:
    """One line saying how the run's bolt pays (the scale chosen, for ``compliance``)."""
    if not config.bolted:
        return "unbolted: the specs are tracked for compliance only, with no rewards"
    if config.reward == "paper":
        return "reward scheme: paper (each spec's terminal reward on every accepting step)"
    if config.reward == "constrained":
        limit = config.bolt.cost_limit
        return (
            f"reward scheme: constrained, the world's return subject to at most "
            f"{limit.cost_limit:g} unsatisfied spec(s) an episode on average (as the bolt "
            f"sees them; --cost-limit to change it): the specs are paid as under the "
            f"compliance scheme ({'with' if config.shaping else 'without'} progress "
            f"shaping), at a learned multiplier (0 to 1, from {limit.initial:g}) times "
            f"{spec_worths(config)} (scale {config.reward_scale:g}), which rises only while "
            "the episodes' cost exceeds the budget"
        )
    shaping = "with" if config.shaping else "without"
    when = (
        "as soon as it accepts (taken back if it stops; nothing where an episode starts)"
        if config.pay_on_change
        else "at the episode's end"
    )
    text = (
        f"reward scheme: compliance, {shaping} progress shaping; complying is worth, {when}, "
        f"{spec_worths(config)} (scale {config.reward_scale:g}; "
        "--reward-scale, or a spec's own reward_scale, to change it)"
    )
    if config.hyperparams.get("normalize_reward") == SPLIT:
        weight = config.hyperparams.get("bolt_weight")
        text += (
            "; the learner sees the bolt's rewards normalised apart from the world's "
            "(normalize_reward split): the scale does not change what it learns, and "
            "complying is traded against the world's return rather than put first, "
            + (
                "the two weighed equally (--hp bolt_weight to weigh the bolt's more)"
                if weight is None
                else f"the bolt's weighed {weight:g} times the world's (bolt_weight; the "
                "learner's rewards keep their size, their mix changes)"
            )
        )
    return text


#: A compliance worth above which an on-policy learner without ``normalize_reward`` is
#: warned (:func:`warn_of_unnormalized_rewards`); the learners' own rewards are ~1.
UNNORMALIZED_WORTH_LIMIT = 10.0


def warn_of_unnormalized_rewards(config: TrainConfig) -> None:
    """Warns (:class:`~noisybolt.errors.UnnormalizedRewardWarning`) where PPO or A2C is
    paid the compliance scheme's rewards, more than :data:`UNNORMALIZED_WORTH_LIMIT` a
    spec, with ``normalize_reward`` off.

    Measured (CartPole, ``F(far_left)``, scale 550, 100k frames): PPO, seeds 0 and 1,
    compliance 25 % and 44 % without it, 88 % and 88 % with it; A2C, seed 0, 0 % and
    94 %. On Breakout (scale 950) PPO's policy stood still without it (approximate KL ~0,
    value loss ~10^4). DQN is not warned: unnormalised it failed on CartPole (0 % against
    100 %) but followed 23 of the gridworld suite's 24 specs, whose world pays rewards as
    large as the scale.
    """
    if not config.bolted or config.reward == "paper" or config.algo not in ON_POLICY:
        return
    if config.hyperparams.get("normalize_reward"):
        return
    worth = max(spec.terminal_reward for spec in config.spec_objects())
    if worth <= UNNORMALIZED_WORTH_LIMIT:
        return
    warnings.warn(
        f"the compliance scheme pays up to {worth:g} a spec, and {config.algo.upper()}'s "
        "rewards are not normalised (normalize_reward false): value targets that large "
        "can swamp the policy's share of each gradient step (on CartPole and Breakout the "
        "policy barely learnt). "
        "Pass --hp normalize_reward=true (or a smaller --reward-scale)",
        UnnormalizedRewardWarning,
        stacklevel=2,
    )


def spec_worths(config: Any) -> str:
    """What complying with each spec pays: one figure when all are paid alike, else each
    spec's (one with a ``reward_scale`` of its own, from ``--spec-set`` or a specs file).

    Example:
        >>> from types import SimpleNamespace as N
        >>> spec = lambda name, worth: N(name=name, formula=name, terminal_reward=worth)
        >>> spec_worths(N(spec_objects=lambda: [spec("edge", 20.0), spec("tr", 20.0)]))
        '20 per spec'
        >>> spec_worths(N(spec_objects=lambda: [spec("edge", 20.0), spec("tr", 50.0)]))
        'edge 20, tr 50'
    """
    specs = config.spec_objects()
    worths = {spec.terminal_reward for spec in specs}
    if len(worths) == 1:
        return f"{worths.pop():g} per spec"
    return ", ".join(f"{spec.name or spec.formula} {spec.terminal_reward:g}" for spec in specs)
