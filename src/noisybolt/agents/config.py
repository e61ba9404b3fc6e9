"""The description of a training run: :class:`TrainConfig` and its :class:`DetectorConfig`.

A config is frozen through and through (its mappings are :class:`FrozenDict`), and it is
validated whole at construction: world, algorithm and its hyperparameters' values, specs
(syntax, nesting, duplicates), seed range, counts and the reward scheme. What cannot be
checked without building things (the model on the env's spaces, the detector against the
world) is checked by :func:`noisybolt.agents.training.train` before it writes anything.
"""

from __future__ import annotations

import copy
import inspect
import json
import os
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass, field, replace
from typing import Any, NoReturn

import gymnasium as gym
import numpy as np

from noisybolt.agents.hyperparams import (
    META_KEYS,
    algorithm_class,
    frame_schedules,
    load_hyperparams,
)
from noisybolt.agents.specs import expand_specs, resolve_spec
from noisybolt.bolt import (
    COST_MODES,
    BeliefSettings,
    RewardScheme,
    Spec,
    Thresholds,
    compliance_scale,
)
from noisybolt.bolt.belief import check_tracking
from noisybolt.envs import DEFAULT_WORLD, check_world, make_world
from noisybolt.envs.bounds import estimate_return_bounds, world_return_bounds
from noisybolt.envs.registry import is_factory_path
from noisybolt.errors import (
    ConfigError,
    EstimatedBoundsWarning,
    SmallIntegerImagesWarning,
    SpecSyntaxError,
    UnknownNameError,
)

__all__ = [
    "DETECTORS",
    "LEGACY_DEFAULTS",
    "RESUMABLE_KEYS",
    "DetectorConfig",
    "FrozenDict",
    "TrainConfig",
    "check_hyperparameter_values",
]

DETECTORS: tuple[str, ...] = ("classifier", "oracle", "synthetic")
#: Settings that may change when a run is resumed.
RESUMABLE_KEYS: tuple[str, ...] = ("frames", "progress_bar", "stop_after")
#: What a config saved before a setting existed meant by it (read on resume).
LEGACY_DEFAULTS: dict[str, Any] = {
    "reward": "paper",
    "reward_scale": None,
    "shaping": False,
    "stop_after": 0,
    # before keep_best existed a run's final model was its last
    "keep_best": False,
    # before belief tracking existed every bolt tracked by threshold (Algorithm 1)
    "tracking": "threshold",
    "confidence": 0.9,
}
#: Seeds numpy accepts.
SEED_RANGE = (0, 2**32 - 1)


class FrozenDict(dict):
    """A ``dict`` that refuses changes: the mappings a frozen config holds.

    It is still a ``dict`` (JSON, ``**`` and ``dict(...)`` work); change a config with
    :func:`dataclasses.replace` instead.

    Example:
        >>> d = FrozenDict({"truth": 0.5})
        >>> d["truth"] = 0.7
        Traceback (most recent call last):
        ...
        TypeError: a config's mappings are frozen: build a new config with dataclasses.replace
    """

    def _refuse(self, *args: Any, **kwargs: Any) -> NoReturn:
        raise TypeError(
            "a config's mappings are frozen: build a new config with dataclasses.replace"
        )

    __setitem__ = __delitem__ = __ior__ = _refuse
    clear = pop = popitem = setdefault = update = _refuse

    def __reduce__(self) -> tuple[Any, ...]:
        return (FrozenDict, (dict(self),))

    def __deepcopy__(self, memo: dict[int, Any]) -> FrozenDict:
        return FrozenDict({k: copy.deepcopy(v, memo) for k, v in self.items()})


def _frozen(value: Any) -> Any:
    """``value`` with every mapping inside it frozen (lists stay lists: JSON's form)."""
    if isinstance(value, Mapping):
        return FrozenDict({k: _frozen(v) for k, v in value.items()})
    if isinstance(value, list):
        return [_frozen(v) for v in value]
    return value


def _thaw(value: Any) -> Any:
    if isinstance(value, Mapping):
        return {k: _thaw(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_thaw(v) for v in value]
    return value


#: Ranges of the SB3 hyperparameters whose bad values would otherwise pass construction
#: and fail (or silently misbehave) mid-run: ``(low, high, low_open, high_open)``.
_RANGES: dict[str, tuple[float, float, bool, bool]] = {
    "gamma": (0.0, 1.0, True, False),
    "gae_lambda": (0.0, 1.0, False, False),
    "learning_rate": (0.0, float("inf"), True, True),
    "n_steps": (1, float("inf"), False, True),
    "batch_size": (1, float("inf"), False, True),
    "n_epochs": (1, float("inf"), False, True),
    "buffer_size": (1, float("inf"), False, True),
    "learning_starts": (0, float("inf"), False, True),
    "target_update_interval": (1, float("inf"), False, True),
    "gradient_steps": (-1, float("inf"), False, True),
    "tau": (0.0, 1.0, True, False),
    "ent_coef": (0.0, float("inf"), False, True),
    "ent_coef_final": (0.0, float("inf"), False, True),
    "ent_coef_frames": (1, float("inf"), False, True),
    "exploration_frames": (1, float("inf"), False, True),
    "vf_coef": (0.0, float("inf"), False, True),
    "max_grad_norm": (0.0, float("inf"), True, True),
    "clip_range": (0.0, float("inf"), True, True),
    "exploration_fraction": (0.0, 1.0, False, False),
    "exploration_initial_eps": (0.0, 1.0, False, False),
    "exploration_final_eps": (0.0, 1.0, False, False),
    "n_envs": (1, float("inf"), False, True),
    "image_features": (1, float("inf"), False, True),
}
_INTEGERS = frozenset({"n_envs", "image_features", "ent_coef_frames", "exploration_frames"})


def check_hyperparameter_values(algo: str, params: Mapping[str, Any]) -> None:
    """Refuses hyperparameter values of the wrong type or out of range.

    A number's type is the SB3 constructor default's (an int where SB3 counts, a float
    where it weighs); the ranges are those of ``_RANGES`` (``gamma`` in (0, 1], counts
    >= 1, ...). What only the model's construction can tell is left to it.

    Raises:
        ConfigError: naming the key, the value and what is expected.

    Example:
        >>> check_hyperparameter_values("ppo", {"gamma": 2})
        Traceback (most recent call last):
        ...
        noisybolt.errors.ConfigError: hyperparameter gamma=2 is out of range: it must be in (0, 1]
    """
    defaults = {
        name: p.default
        for name, p in inspect.signature(algorithm_class(algo).__init__).parameters.items()
    }
    for key, value in params.items():
        default = defaults.get(key, inspect.Parameter.empty)
        numeric_default = isinstance(default, (int, float)) and not isinstance(default, bool)
        if key == "train_freq" and isinstance(value, (list, tuple)):
            continue
        if value is None and key in META_KEYS:  # noisybolt's own settings: null is unset
            continue
        if key in _RANGES or numeric_default:
            wants_int = key in _INTEGERS or (isinstance(default, int) and numeric_default)
            number = isinstance(value, (int, float)) and not isinstance(value, bool)
            if not number or (wants_int and not isinstance(value, int)):
                kind = "an integer" if wants_int else "a number"
                raise ConfigError(f"hyperparameter {key}={value!r} must be {kind}")
        elif isinstance(default, bool) and not isinstance(value, bool):
            raise ConfigError(f"hyperparameter {key}={value!r} must be true or false")
        if key in _RANGES:
            low, high, low_open, high_open = _RANGES[key]
            below = value <= low if low_open else value < low
            above = value >= high if high_open else value > high
            if below or above:
                top = "inf" if high == float("inf") else f"{high:g}"
                interval = f"{'(' if low_open else '['}{low:g}, {top}{')' if high_open else ']'}"
                raise ConfigError(
                    f"hyperparameter {key}={value!r} is out of range: it must be in {interval}"
                )


@dataclass(frozen=True)
class DetectorConfig:
    """Which fluent detector the bolt uses.

    Attributes:
        kind: ``"classifier"`` (a trained CNN on the bolt's noisy camera), ``"oracle"``
            (ground truth as 0/1) or ``"synthetic"`` (ground truth through seeded Beta noise).
        path: the classifier file; None uses a cached one for this world and camera,
            trained on the fly if missing.
        low_confidence: fluents the synthetic detector sees with low confidence.
        samples: images collected to train a classifier on the fly.
        epochs: epochs to train it.
        seed: seeds the synthetic detector and on-the-fly classifier training.
    """

    kind: str = "classifier"
    path: str | None = None
    low_confidence: tuple[str, ...] = ()
    samples: int = 4000
    epochs: int = 30
    seed: int = 0

    def __post_init__(self) -> None:
        if self.kind not in DETECTORS:
            raise UnknownNameError(
                f"unknown detector {self.kind!r}; known detectors: {list(DETECTORS)}",
                name=self.kind,
                known=DETECTORS,
            )
        object.__setattr__(self, "low_confidence", tuple(self.low_confidence))


@dataclass(frozen=True)
class TrainConfig:
    """Everything that defines a training run (saved as ``config.json``).

    Attributes:
        world: registry name of the world, or a factory path ``package.module:factory``
            returning a labelled env (see :mod:`noisybolt.envs.registry`).
        world_kwargs: passed to :func:`noisybolt.envs.make_world` (e.g. ``noise``).
        specs: the bolt's specs as dicts of :class:`~noisybolt.bolt.Spec` fields, plus an
            optional ``reward_scale`` (this spec's scale under the ``compliance`` scheme).
        algo: ``ppo``, ``a2c`` or ``dqn``.
        hyperparams: resolved hyperparameters (see :mod:`noisybolt.agents.hyperparams`).
        detector: the fluent detector.
        frames: environment steps to train for (all environments together).
        seed: seeds the world, the agent and the evaluation.
        eval_freq: frames between evaluations (0: only at the end).
        eval_episodes: episodes per evaluation.
        eval_envs: environments used to evaluate.
        eval_deterministic: evaluate the greedy policy; by default actions are sampled, as
            the paper's code base (rl-starter-files) evaluates: a half-trained greedy policy
            on a grid often loops (turning on the spot) where its sampled one does not.
        success_threshold: the share of evaluation episodes that must reach the goal and
            comply with every spec for the run to count as compliant (N_frames).
        stop_after: stop when solved: end training once this many periodic evaluations
            in a row reach ``success_threshold``
            (:class:`~noisybolt.agents.stopping.StopWhenSolved`); 0 trains the whole
            ``frames`` budget.
        checkpoint_freq: frames between checkpoints (0: none).
        thresholds: ``{"truth": 0.5, "high": 0.9}`` of eq. 1.
        cost_mode: ``"count"`` or ``"proportional"``.
        tracking: how the bolt tracks its DFAs: ``"threshold"`` (Algorithm 1, the
            default, what ``reproduce`` uses) or ``"belief"`` (a distribution over each
            spec's DFA states, :mod:`noisybolt.bolt.belief`; the agent sees the beliefs).
        confidence: ``belief`` only: the probability of the paid-for condition at which a
            spec counts as accepting and is paid, in (0.5, 1).
        reward: the reward scheme (:mod:`noisybolt.bolt.schemes`): ``"compliance"``
            (default: compliance first, then the world's return) or ``"paper"`` (each
            spec's own terminal reward every accepting step: what ``reproduce`` uses).
        reward_scale: ``compliance`` only: what a spec's acceptance is worth. None
            computes it from the world's declared return bounds
            (:func:`~noisybolt.bolt.compliance_scale`); the config holds the value used.
        shaping: ``compliance`` only: potential-based progress shaping over each DFA
            (:mod:`noisybolt.bolt.shaping`), for the learner's ``gamma``.
        bolted: False trains the same agent without a bolt (for comparison): specs are
            still tracked for compliance metrics, with zero rewards.
        keep_best: the run's final model is the one of the periodic evaluation with the
            highest mean *shaped* return (environment + bolt rewards, as the bolt sees
            them through its detector), not the last one, as RL Zoo keeps
            ``best_model.zip``. Ground truth never chooses: compliance is measured on the
            kept model afterwards. It guards a result against late drift (a policy that
            complied for 200k frames and then found an equally short route past the spec
            is not what the training signal prefers).
        progress_bar: show a progress bar.
    """

    world: str = DEFAULT_WORLD
    world_kwargs: dict[str, Any] = field(default_factory=dict)
    specs: tuple[dict[str, Any], ...] = ()
    algo: str = "ppo"
    hyperparams: dict[str, Any] = field(default_factory=dict)
    detector: DetectorConfig = field(default_factory=DetectorConfig)
    frames: int = 100_000
    seed: int = 0
    eval_freq: int = 10_000
    eval_episodes: int = 20
    eval_envs: int = 4
    eval_deterministic: bool = False
    success_threshold: float = 0.95
    stop_after: int = 0
    checkpoint_freq: int = 20_000
    thresholds: dict[str, float] = field(default_factory=lambda: {"truth": 0.5, "high": 0.9})
    cost_mode: str = "count"
    tracking: str = "threshold"
    confidence: float = 0.9
    reward: str = "compliance"
    reward_scale: float | None = None
    shaping: bool = True
    bolted: bool = True
    keep_best: bool = False
    progress_bar: bool = True

    def __post_init__(self) -> None:
        check_world(self.world)  # a registered name or an importable factory path
        algorithm_class(self.algo)
        for name in ("world_kwargs", "hyperparams", "thresholds"):
            object.__setattr__(self, name, _frozen(getattr(self, name)))
        check_hyperparameter_values(
            self.algo, {k: v for k, v in self.hyperparams.items() if k != "policy_kwargs"}
        )
        frame_schedules(self.hyperparams, frames=int(self.frames))  # validates them
        if isinstance(self.seed, bool) or not isinstance(self.seed, int):
            raise ConfigError(f"seed must be an integer, got {self.seed!r}")
        if not SEED_RANGE[0] <= self.seed <= SEED_RANGE[1]:
            raise ConfigError(
                f"seed must be in [{SEED_RANGE[0]}, {SEED_RANGE[1]}] (what numpy accepts), "
                f"got {self.seed}"
            )
        if not self.specs:
            raise ConfigError("give at least one spec (--spec NAME or --spec FORMULA)")
        for name in ("frames", "eval_episodes", "eval_envs"):
            if int(getattr(self, name)) < 1:
                raise ConfigError(f"{name} must be >= 1, got {getattr(self, name)}")
        for name in ("eval_freq", "checkpoint_freq"):
            if int(getattr(self, name)) < 0:
                raise ConfigError(f"{name} must be >= 0, got {getattr(self, name)}")
        if not 0.0 < self.success_threshold <= 1.0:
            raise ConfigError(f"success_threshold must be in (0, 1], got {self.success_threshold}")
        if isinstance(self.stop_after, bool) or not isinstance(self.stop_after, int):
            raise ConfigError(f"stop_after must be an integer >= 0, got {self.stop_after!r}")
        if self.stop_after < 0 or (self.stop_after and not self.eval_freq):
            raise ConfigError(
                f"stop_after={self.stop_after}: stopping when solved counts periodic "
                "evaluations; give stop_after >= 0 and, for stop_after > 0, eval_freq > 0"
            )
        if self.cost_mode not in COST_MODES:
            raise ConfigError(
                f"cost_mode must be one of {list(COST_MODES)}, got {self.cost_mode!r}"
            )
        Thresholds(**self.thresholds)
        check_tracking(self.tracking)
        BeliefSettings(confidence=self.confidence)  # ConfidenceLevelError outside (0.5, 1)
        object.__setattr__(self, "specs", tuple(_frozen(dict(s)) for s in self.specs))
        if self.reward == "compliance" and self.reward_scale is None:
            object.__setattr__(self, "reward_scale", _scale_from_world(self))
        scheme = self.scheme  # validates reward, reward_scale and shaping
        object.__setattr__(self, "shaping", scheme.shaping)
        names = [spec.name for spec in self.spec_objects()]  # validates every spec
        repeated = sorted({name for name in names if names.count(name) > 1})
        if repeated:
            raise ConfigError(
                f"spec(s) {repeated} given twice: each spec is tracked and reported by its "
                "name; remove the repeat, or give each a name of its own (--spec-set name=...)"
            )

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
        **kwargs: Any,
    ) -> TrainConfig:
        """A config with specs resolved (names or formulas) and hyperparameters loaded.

        A spec given as a mapping may carry ``reward_scale`` (its scale under the
        ``compliance`` scheme) beside the :class:`~noisybolt.bolt.Spec` fields.
        """
        paper = kwargs.get("reward", "compliance") == "paper"
        resolved = []
        for item in expand_specs(specs):
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
            resolved.append(fields)
        params = load_hyperparams(world, algo, overrides, hp_file=hp_file)
        if n_envs is not None:
            params["n_envs"] = int(n_envs)
        chosen = "policy_kwargs.normalize_images" in (overrides or {}) or hp_file is not None
        if is_factory_path(world) and not chosen:
            _keep_small_integer_images(world, dict(kwargs.get("world_kwargs") or {}), params)
        return cls(world=world, specs=tuple(resolved), algo=algo, hyperparams=params, **kwargs)

    @property
    def world_settings(self) -> dict[str, Any]:
        """``world_kwargs`` plus the world settings held among the hyperparameters (the
        Atari convention ``fire_on_reset``): what every world of the run is built with."""
        settings = dict(self.world_kwargs)
        if self.hyperparams.get("fire_on_reset"):
            settings["fire_on_reset"] = True
        return settings

    @property
    def scheme(self) -> RewardScheme:
        """The reward scheme of the run."""
        if self.reward == "paper":
            return RewardScheme("paper", scale=self.reward_scale)
        return RewardScheme(self.reward, scale=self.reward_scale, shaping=self.shaping)

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
        return BeliefSettings(confidence=self.confidence) if self.tracking == "belief" else None

    @property
    def n_envs(self) -> int:
        """Training environments."""
        return int(self.hyperparams.get("n_envs", 1))

    def spec_objects(self) -> list[Spec]:
        """The specs as :class:`~noisybolt.bolt.Spec` (zero rewards when not bolted)."""
        scheme = self.scheme
        specs = []
        for fields in self.specs:
            fields = dict(fields)
            scale = fields.pop("reward_scale", None)
            specs.append(scheme.apply(_parsed_spec(fields), scale=scale))
        if not self.bolted:
            specs = [replace(s, terminal_reward=0.0, low_confidence_cost=0.0) for s in specs]
        return specs

    def to_dict(self) -> dict[str, Any]:
        """JSON-able form (what ``config.json`` holds)."""
        data = _thaw(asdict(self))
        data["specs"] = [_thaw(dict(s)) for s in self.specs]
        data["detector"]["low_confidence"] = list(self.detector.low_confidence)
        return json.loads(json.dumps(data))

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> TrainConfig:
        """Reads :meth:`to_dict`'s output back, strictly.

        Raises:
            ConfigError: an unknown key, or a value of the wrong JSON type; the message
                names the key's path (``detector.samples``).

        Example:
            >>> TrainConfig.from_dict({"specs": ["edge"], "detector": {"samples": "many"}})
            Traceback (most recent call last):
            ...
            noisybolt.errors.ConfigError: config key detector.samples must be an integer, got 'many'
        """
        if not isinstance(data, Mapping):
            raise ConfigError(f"a training config is a mapping, got {type(data).__name__}")
        data = {**LEGACY_DEFAULTS, **data}
        _check_keys(data, _FIELD_TYPES, "")
        detector_data = data.pop("detector", {})
        if not isinstance(detector_data, Mapping):
            raise ConfigError(f"config key detector must be a mapping, got {detector_data!r}")
        _check_keys(detector_data, _DETECTOR_TYPES, "detector.")
        detector = DetectorConfig(**detector_data)
        data["specs"] = tuple(data.get("specs", ()))
        return cls(detector=detector, **data)


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


#: The largest value an image observation may show in random play and still be read as
#: small integers (MiniGrid's symbolic grid: object, colour and state indices, <= 10),
#: not as pixels.
SMALL_INTEGER_IMAGE_MAX = 31


def _keep_small_integer_images(
    world: str, world_kwargs: dict[str, Any], params: dict[str, Any]
) -> None:
    """Turns SB3's division of image observations by 255 off for a user's world whose
    uint8 "images" are small integers (seen in seeded random play), and says so.

    SB3 takes any uint8 ``[H, W, C]`` Box for pixels; MiniGrid's symbolic grid divided by
    255 reaches the network as values under 0.04, and PPO then barely learns (the
    MiniGrid example reached goal and compliance 100 % at 40k frames with the integers
    kept).
    """
    probe: Any = make_world(world, num_envs=2, seed=0, **world_kwargs)
    space = probe.single_observation_space
    if not (
        isinstance(space, gym.spaces.Box) and space.dtype == np.uint8 and len(space.shape) == 3
    ):
        probe.close()
        return
    obs, _ = probe.reset(seed=0)
    probe.action_space.seed(0)
    top = int(np.max(obs))
    for _ in range(64):
        obs, *_ = probe.step(probe.action_space.sample())
        top = max(top, int(np.max(obs)))
    probe.close()
    if top > SMALL_INTEGER_IMAGE_MAX:
        return
    params.setdefault("policy_kwargs", {})["normalize_images"] = False
    warnings.warn(
        f"the {world!r} world's image observations are small integers (at most {top} in "
        "random play, like MiniGrid's symbolic grid), not pixels: they reach the network "
        "as they are (policy_kwargs.normalize_images=false; pass --hp "
        "policy_kwargs.normalize_images=true to divide them by 255 after all)",
        SmallIntegerImagesWarning,
        stacklevel=3,
    )


#: Random-play steps (8 envs together) behind a world's estimated return bounds.
ESTIMATE_STEPS = 4096


def _scale_from_world(config: TrainConfig) -> float:
    """The ``compliance`` scale from the world's declared return bounds, or, for a world
    that declares none, from bounds estimated by seeded random play (with a warning)."""
    probe: Any = make_world(config.world, num_envs=1, seed=0, **config.world_settings)
    bounds = world_return_bounds(probe)
    probe.close()
    if bounds is None:
        # A user's env rarely knows its bounds; refusing to train would send every new
        # user to a flag. Random play's returns are an estimate, said so, not a bound.
        world: Any = make_world(config.world, num_envs=8, seed=0, **config.world_settings)
        estimate = estimate_return_bounds(world, steps=ESTIMATE_STEPS, seed=0)
        world.close()
        bounds = estimate.bounds
        warnings.warn(
            f"the {config.world!r} world declares no bounds on its episodes' returns; the "
            f"compliance scale {compliance_scale(bounds):g} rests on bounds "
            f"{estimate.describe()}. A trained agent may return more than random play: "
            "declare the bounds (FluentLabels(..., return_bounds=(least, most))) or pass "
            "--reward-scale S (S above the widest gap between two episodes' returns)",
            EstimatedBoundsWarning,
            stacklevel=2,
        )
    return compliance_scale(bounds)


#: JSON types of each config field (what ``config.json`` may hold there); None allowed
#: where the field's default is None.
_FIELD_TYPES: dict[str, tuple[type, ...]] = {
    "world": (str,),
    "world_kwargs": (dict,),
    "specs": (list, tuple),
    "algo": (str,),
    "hyperparams": (dict,),
    "detector": (dict,),
    "frames": (int,),
    "seed": (int,),
    "eval_freq": (int,),
    "eval_episodes": (int,),
    "eval_envs": (int,),
    "eval_deterministic": (bool,),
    "success_threshold": (int, float),
    "checkpoint_freq": (int,),
    "thresholds": (dict,),
    "cost_mode": (str,),
    "tracking": (str,),
    "confidence": (int, float),
    "reward": (str,),
    "reward_scale": (int, float, type(None)),
    "shaping": (bool,),
    "bolted": (bool,),
    "keep_best": (bool,),
    "progress_bar": (bool,),
}
_DETECTOR_TYPES: dict[str, tuple[type, ...]] = {
    "kind": (str,),
    "path": (str, type(None)),
    "low_confidence": (list, tuple),
    "samples": (int,),
    "epochs": (int,),
    "seed": (int,),
}
_TYPE_NAMES = {
    str: "a string",
    dict: "a mapping",
    list: "a list",
    int: "an integer",
    float: "a number",
    bool: "true or false",
}


def _check_keys(data: Mapping[str, Any], types: Mapping[str, tuple[type, ...]], path: str) -> None:
    """Refuses unknown keys and values of the wrong JSON type, naming the key's path.

    Fields that a newer config adds and this table lacks are checked by their own
    constructor only (the table types what ``config.json`` holds today).
    """
    unknown = sorted(
        set(data) - set(types) - set(TrainConfig.__dataclass_fields__ if not path else ())
    )
    if unknown:
        known = sorted(set(types) | (set(TrainConfig.__dataclass_fields__) if not path else set()))
        raise ConfigError(f"unknown config key(s) {[path + k for k in unknown]}; known: {known}")
    for key, value in data.items():
        allowed = types.get(key)
        if allowed is None:
            continue
        wrong = not isinstance(value, allowed) or (isinstance(value, bool) and bool not in allowed)
        if wrong:
            wanted = " or ".join(_TYPE_NAMES.get(t, "null") for t in allowed if t is not tuple)
            raise ConfigError(f"config key {path}{key} must be {wanted}, got {value!r}")
