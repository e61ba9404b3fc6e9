"""The sections of a run's config: world, bolt, detector, algorithm, evaluation.

Each is a frozen, keyword-only dataclass that validates itself at construction (values,
ranges, names), naming the setting by its path in ``config.json``. They compose
:class:`~noisybolt.runs.config.TrainConfig`, which checks what spans sections.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from dataclasses import asdict, dataclass, field
from typing import Any

from stable_baselines3.common.off_policy_algorithm import OffPolicyAlgorithm

from noisybolt.agents.hyperparams import (
    SPLIT,
    WORLD_KEYS,
    algorithm_class,
    check_hyperparameter_values,
    known_hyperparameters,
)
from noisybolt.bolt import (
    COST_MODES,
    BeliefSettings,
    BoltSettings,
    CostLimit,
    RewardScheme,
    Thresholds,
)
from noisybolt.bolt.belief import check_tracking
from noisybolt.bolt.constraint import OPTIONAL_KEYS
from noisybolt.bolt.settings import PAPER
from noisybolt.envs import DEFAULT_WORLD, check_world
from noisybolt.errors import ConfigError, UnknownNameError
from noisybolt.runs.schema import freeze
from noisybolt.wrappers import DETECTOR_NAMES

__all__ = [
    "DETECTORS",
    "AlgorithmConfig",
    "BoltConfig",
    "DetectorConfig",
    "EvaluationConfig",
    "WorldConfig",
    "check_count",
    "check_device",
    "check_given_settings",
    "check_precision",
    "is_detector_factory",
]

#: The detectors a run builds by name (the wrappers' list: one list).
DETECTORS: tuple[str, ...] = DETECTOR_NAMES


def is_detector_factory(kind: object) -> bool:
    """Whether a detector kind is a user's factory path ``package.module:function``
    (see :func:`noisybolt.runs.detectors.make_detector`).

    Example:
        >>> is_detector_factory("mydetectors:noisy"), is_detector_factory("oracle")
        (True, False)
        >>> is_detector_factory("mydetectors:"), is_detector_factory(":noisy")
        (False, False)
    """
    if not isinstance(kind, str):
        return False
    module, sep, function = kind.partition(":")
    return bool(sep and function.isidentifier() and module) and all(
        part.isidentifier() for part in module.split(".")
    )


def check_device(device: object) -> None:
    """Refuses an ``algorithm.device`` that is not ``cpu``, ``cuda`` or ``cuda:N``
    (whether the machine has it is checked where the model is built:
    :func:`noisybolt.runs.models.torch_device`)."""
    if not isinstance(device, str) or not re.fullmatch(r"cpu|cuda(:[0-9]+)?", device):
        raise ConfigError(
            f"algorithm.device must be cpu, cuda or cuda:N (a GPU's index), got {device!r}"
        )


#: The number formats the agent's features extractor may compute in
#: (``algorithm.precision``).
PRECISIONS = ("float32", "bfloat16")


def check_precision(precision: object) -> None:
    """Refuses an ``algorithm.precision`` that is not one of :data:`PRECISIONS` (whether
    the machine computes it natively is checked where the model is built:
    :func:`noisybolt.runs.models.compute_dtype`)."""
    if precision not in PRECISIONS:
        raise ConfigError(
            f"algorithm.precision must be one of {list(PRECISIONS)}, got {precision!r}"
        )


def check_count(path: str, value: Any, low: int) -> None:
    """Refuses ``value`` unless it is an integer >= ``low``, naming the setting's path."""
    if isinstance(value, bool) or not isinstance(value, int) or value < low:
        raise ConfigError(f"{path} must be an integer >= {low}, got {value!r}")


@dataclass(frozen=True, kw_only=True)
class WorldConfig:
    """The world the agent acts in (``world`` in ``config.json``).

    Attributes:
        name: a registered world (``gridworld``, ``breakout``, ...) or a factory path
            ``package.module:factory`` returning a labelled env
            (:mod:`noisybolt.envs.registry`).
        kwargs: passed to :func:`noisybolt.envs.make_world` (e.g. ``noise``, ``obs_mode``).
        train_kwargs: more world settings for the learner's games only, over ``kwargs``
            (e.g. Breakout's ``left_head_start``, a start-state curriculum): evaluation,
            the classifier's images, random play for the bolt's set-up and the compliance
            scale all use ``kwargs`` alone, so what a run reports is measured on the world
            as given.
        n_envs: training environments (the world's hyperparameter file gives it).
        fire_on_reset: Atari: the world serves the ball after every reset and lost life.
        clip_reward: Atari: the learner sees the game's score clipped to its sign, below
            the bolt (training only).
        life_loss_terminal: Atari: a lost life ends the learner's episode, above the bolt
            (training only).
        workers: 0 (default): the world runs in the training process; N >= 1: its games
            run in N worker processes (:class:`~noisybolt.envs.worker_world.WorkerWorld`,
            for worlds that split into shards, such as Breakout), the same games as in
            process, while the training process runs the bolt and the agent.
        overlap: False (default): the learner steps every game at once. True (PPO, A2C;
            ``workers`` >= 2): the training games are split into two groups, each with
            its own bolt and its world in half the workers, and the rollouts are collected
            overlapped (:mod:`noisybolt.agents.pipeline`): one group's world steps in its
            workers while the learner runs the policy, the classifier and the bolt of the
            other. The same games; the sampled actions are drawn per group.
    """

    name: str = DEFAULT_WORLD
    kwargs: dict[str, Any] = field(default_factory=dict)
    train_kwargs: dict[str, Any] = field(default_factory=dict)
    n_envs: int = 1
    fire_on_reset: bool = False
    clip_reward: bool = False
    life_loss_terminal: bool = False
    workers: int = 0
    overlap: bool = False

    def __post_init__(self) -> None:
        check_world(self.name)  # a registered name or an importable factory path
        object.__setattr__(self, "kwargs", freeze(dict(self.kwargs)))
        object.__setattr__(self, "train_kwargs", freeze(dict(self.train_kwargs)))
        check_count("world.n_envs", self.n_envs, 1)
        check_count("world.workers", self.workers, 0)
        if not isinstance(self.overlap, bool):
            raise ConfigError(f"world.overlap must be true or false, got {self.overlap!r}")
        if self.overlap and self.workers < 2:
            raise ConfigError(
                "world.overlap steps one group of games in worker processes while the "
                f"learner works on the other: it needs world.workers >= 2, got {self.workers}"
            )


@dataclass(frozen=True, kw_only=True)
class BoltConfig:
    """The restraining bolt: its specs and how it pays (``bolt`` in ``config.json``).

    Attributes:
        specs: the specs as dicts of :class:`~noisybolt.bolt.Spec` fields, plus an
            optional ``reward_scale`` (this spec's scale under the ``compliance`` scheme).
        reward: the reward scheme (:mod:`noisybolt.bolt.schemes`): ``"compliance"``
            (default: compliance first, then the world's return) or ``"paper"`` (each
            spec's own terminal reward every accepting step: what ``reproduce`` uses).
        reward_scale: ``compliance`` only: what a spec's acceptance is worth. None
            computes it from the world's declared return bounds
            (:func:`~noisybolt.bolt.compliance_scale`); the config holds the value used.
        shaping: ``compliance`` only: potential-based progress shaping over each DFA
            (:mod:`noisybolt.bolt.shaping`).
        pay_on_change: ``compliance`` only: pay each spec's acceptance as its DFA comes to
            accept and take it back if it stops, rather than at the episode's end (and
            nothing for an acceptance the first observation already gives); without
            paying a discounting learner for ending accepted episodes sooner
            (:mod:`noisybolt.bolt.schemes`).
        tracking: ``"threshold"`` (Algorithm 1, the default, what ``reproduce`` uses) or
            ``"belief"`` (a distribution over each spec's DFA states,
            :mod:`noisybolt.bolt.belief`; the agent sees the beliefs).
        confidence: ``belief`` only: the probability of the paid-for condition at which a
            spec counts as accepting and is paid, in (0.5, 1).
        min_dwell: ``belief`` only: the fewest steps a fluent, once true, is believed to
            stay true (:class:`~noisybolt.bolt.BeliefSettings`): 2 rides out one-frame
            glitches of the detector but never credits a condition met in one step; 1
            credits it.
        thresholds: ``{"truth": 0.5, "high": 0.9}`` of eq. 1.
        cost_mode: ``"count"`` or ``"proportional"``.
        constraint: ``constrained`` only: the cost budget and how the Lagrange multiplier
            learns (:class:`~noisybolt.bolt.CostLimit`: ``cost_limit``, the specs an
            episode may leave unsatisfied on average; ``lr``, ``kp``, ``kd``,
            ``initial``); under ``constrained`` the config holds every value used, under
            the other schemes it is empty.
        bolted: False trains the same agent without a bolt (for comparison): specs are
            still tracked for compliance metrics, with zero rewards.
    """

    specs: tuple[dict[str, Any], ...] = ()
    reward: str = "compliance"
    reward_scale: float | None = None
    shaping: bool = True
    pay_on_change: bool = True
    tracking: str = "threshold"
    confidence: float = 0.9
    min_dwell: int = 2
    thresholds: dict[str, float] = field(default_factory=lambda: {"truth": 0.5, "high": 0.9})
    cost_mode: str = "count"
    constraint: dict[str, float] = field(default_factory=dict)
    bolted: bool = True

    def __post_init__(self) -> None:
        object.__setattr__(self, "specs", tuple(freeze(dict(s)) for s in self.specs))
        object.__setattr__(self, "thresholds", freeze(dict(self.thresholds)))
        unknown = sorted(set(self.thresholds) - {"truth", "high"})
        if unknown:
            raise ConfigError(
                f"unknown config key(s) bolt.thresholds.{unknown}; known: truth, high"
            )
        Thresholds(**self.thresholds)
        if self.cost_mode not in COST_MODES:
            raise ConfigError(
                f"bolt.cost_mode must be one of {list(COST_MODES)}, got {self.cost_mode!r}"
            )
        if self.reward == "constrained":
            # Every setting of the budget, the defaults filled in: what the run used (a
            # saved run keeps its values if the defaults change).
            limit = CostLimit.from_mapping(self.constraint)
            values = asdict(limit)
            for key in OPTIONAL_KEYS:
                if values[key] is None:
                    # Not given: resolve() chooses it for a fresh run (with the scale); a
                    # run saved before the setting existed has none, and prices linearly,
                    # learns from the first rollout and anneals over ANNEAL, as it did.
                    # A 0 given is kept.
                    del values[key]
            object.__setattr__(self, "constraint", freeze(values))
        elif self.constraint:
            raise ConfigError(
                f"bolt.constraint (a cost budget: {sorted(self.constraint)}) is set but the "
                f"reward scheme is {self.reward!r}: a budget needs --reward constrained; or "
                "leave it out"
            )
        check_tracking(self.tracking)
        # ConfidenceLevelError outside (0.5, 1); ConfigError for a min_dwell below 1
        BeliefSettings(confidence=self.confidence, min_dwell=self.min_dwell)

    @property
    def cost_limit(self) -> CostLimit:
        """The ``constrained`` scheme's budget and gains (the defaults under the others)."""
        return CostLimit.from_mapping(self.constraint)

    @property
    def settings(self) -> BoltSettings:
        """The bolt's settings (:class:`~noisybolt.bolt.BoltSettings`): what every layer
        that builds this run's bolt is handed, whole.

        The specs it pays are :meth:`~noisybolt.runs.config.TrainConfig.spec_objects`
        (each already paid as the scheme says, at its own ``reward_scale`` where it has
        one, which :attr:`~noisybolt.bolt.BoltSettings.spec_scales` repeats); unbolted
        (``bolted`` False), those pay nothing and the scheme is ``paper``: no progress
        terms. Under belief tracking, the belief settings are ``confidence`` and
        ``min_dwell`` (a run replaces them with base rates estimated from play).

        Raises:
            ConfigError: the scheme's scale is not resolved yet
                (:func:`~noisybolt.runs.resolve` gives it).

        Example:
            >>> bolt = BoltConfig(specs=({"formula": "F(a)", "reward_scale": 7.0},),
            ...                   reward_scale=40.0, cost_mode="proportional")
            >>> settings = bolt.settings
            >>> settings.scheme.scale, settings.spec_scales, settings.cost_mode
            (40.0, (7.0,), 'proportional')
        """
        if self.reward != "paper" and self.reward_scale is None:
            raise ConfigError(
                f"the {self.reward} scheme's scale (bolt.reward_scale) is not resolved yet: "
                "noisybolt.runs.resolve(config) computes it from the world (train() and every "
                "door that starts a run call it), or give one"
            )
        scheme = PAPER
        scales: tuple[float | None, ...] = ()
        if self.bolted:
            scheme = self.scheme
            if scheme.name != "paper":
                scales = tuple(spec.get("reward_scale") for spec in self.specs)
        return BoltSettings(
            thresholds=Thresholds(**self.thresholds),
            cost_mode=self.cost_mode,  # type: ignore[arg-type]  # checked at construction
            scheme=scheme,
            spec_scales=scales,
            tracking=self.tracking,  # type: ignore[arg-type]  # checked at construction
            belief=(
                BeliefSettings(confidence=self.confidence, min_dwell=self.min_dwell)
                if self.tracking == "belief"
                else None
            ),
        )

    @property
    def scheme(self) -> RewardScheme:
        """The reward scheme (validates ``reward``, ``reward_scale`` and ``shaping``)."""
        if self.reward == "paper":
            return RewardScheme("paper", scale=self.reward_scale)
        return RewardScheme(
            self.reward,
            scale=self.reward_scale,
            shaping=self.shaping,
            pay_on_change=self.pay_on_change,
        )


@dataclass(frozen=True, kw_only=True)
class DetectorConfig:
    """Which fluent detector the bolt uses (``detector`` in ``config.json``).

    Attributes:
        kind: ``"classifier"`` (a trained CNN on the bolt's noisy camera), ``"oracle"``
            (ground truth as 0/1), ``"synthetic"`` (ground truth through seeded Beta
            noise), or a user's detector as a factory path ``"package.module:function"``
            (:func:`noisybolt.runs.detectors.make_detector` says how it is called).
        path: the classifier file; None uses a cached one for this world and camera,
            trained on the fly if missing.
        low_confidence: fluents the synthetic detector sees with low confidence.
        samples: images collected to train a classifier on the fly.
        epochs: epochs to train it.
        seed: seeds the synthetic detector and on-the-fly classifier training.
        restarts: how many on-the-fly classifiers may be trained, each from its own
            seed (the first from ``seed``) and on twice the images of the one before:
            after each, its worst fluent's accuracy on one held-out set of fresh images is
            measured, and training stops once that reaches :data:`~noisybolt.agents.
            detectors.ACCEPT_ACCURACY`; the best is kept. 1: the first alone, as runs saved
            before this setting existed did.
        final_views: an on-the-fly classifier's images include the last state of each
            episode random play ends (:func:`noisybolt.perception.dataset.
            collect_samples`), so that a fluent true only as an episode ends (a goal
            reached) is shown to it; False: only the states after each step, as runs
            saved before this setting existed collected them.
        kwargs: more keywords for a user's detector factory (``--set
            detector.kwargs.NAME=VALUE``), beside ``fluent_names``, ``camera_spec`` and
            ``seed``.
    """

    kind: str = "classifier"
    path: str | None = None
    low_confidence: tuple[str, ...] = ()
    samples: int = 4000
    epochs: int = 30
    seed: int = 0
    restarts: int = 3
    final_views: bool = True
    kwargs: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if self.kind not in DETECTORS and not is_detector_factory(self.kind):
            raise UnknownNameError(
                f"unknown detector {self.kind!r}; known detectors: {list(DETECTORS)}, or "
                "your own as a factory path 'package.module:function' (called with the "
                "world's fluent_names, camera_spec and the detector's seed)",
                name=self.kind,
                known=DETECTORS,
            )
        object.__setattr__(self, "low_confidence", tuple(self.low_confidence))
        object.__setattr__(self, "kwargs", freeze(dict(self.kwargs)))
        if self.kwargs and not is_detector_factory(self.kind):
            raise ConfigError(
                f"detector.kwargs {sorted(self.kwargs)} are passed to a detector factory "
                f"(--detector package.module:function); the {self.kind} detector takes none"
            )
        if self.restarts < 1:
            raise ConfigError(
                f"detector.restarts must be at least 1 (one classifier), got {self.restarts}"
            )
        if not isinstance(self.final_views, bool):
            raise ConfigError(
                f"detector.final_views must be true or false, got {self.final_views!r}"
            )


#: The schedules only some learners have: (key, those learners, what the others lack).
_SCHEDULES_OF: tuple[tuple[str, tuple[str, ...], str], ...] = (
    ("ent_coef_final", ("ppo", "a2c"), "entropy bonus"),
    ("clip_range_final", ("ppo",), "clip range"),
)


@dataclass(frozen=True, kw_only=True)
class AlgorithmConfig:
    """The learner (``algorithm`` in ``config.json``).

    Attributes:
        name: ``ppo``, ``a2c`` or ``dqn``.
        hyperparams: resolved hyperparameters (:mod:`noisybolt.agents.hyperparams`): the
            SB3 constructor's arguments and noisybolt's own agent settings
            (:data:`~noisybolt.agents.hyperparams.META_KEYS`).
        device: where the agent's network trains: ``cpu`` (default), ``cuda`` or
            ``cuda:N`` (an image agent on a GPU machine). It may change on ``--resume``
            (where the network runs, not what it learns). The bolt's classifier and the
            world stay on the CPU.
        precision: the number format the agent's features extractor (its convolutions,
            or the dense layer over a vector observation) computes in: ``float32``
            (default) or ``bfloat16`` (autocast: weights, optimiser and the policy and
            value heads stay float32; on a CPU with native bfloat16, ~2.6× faster
            convolution training, see ``benchmarks/README.md``). It may change on
            ``--resume``: the same weights, rounded differently.
        init_from: a saved agent whose network this run starts from instead of random
            weights (:mod:`noisybolt.runs.warm_start`): a run directory, a checkpoint
            folder or a ``model.zip`` of the same world, specs and network. Only a new run
            reads it (and keeps a copy, ``init_model.zip``); a resume continues from its
            own checkpoint. None (default): random weights.
        counterfactual: counterfactual experience (off-policy learners: DQN; threshold
            tracking): every transition is also stored replayed from other DFA states,
            with the bolt's reward and next state from each
            (:mod:`noisybolt.agents.counterfactual`). False (default): as gathered.
        counterfactual_samples: the most relabelled copies per transition: every other
            joint DFA state where there are at most this many, else this many drawn at
            random (seeded by the run's seed). Default 16.
    """

    name: str = "ppo"
    hyperparams: dict[str, Any] = field(default_factory=dict)
    device: str = "cpu"
    precision: str = "float32"
    init_from: str | None = None
    counterfactual: bool = False
    counterfactual_samples: int = 16

    def __post_init__(self) -> None:
        algorithm_class(self.name)
        check_device(self.device)
        check_precision(self.precision)
        if self.init_from is not None and (
            not isinstance(self.init_from, str) or not self.init_from.strip()
        ):
            raise ConfigError(
                "algorithm.init_from must be the path of a saved agent (a run directory, a "
                f"checkpoint folder or a model.zip), got {self.init_from!r}"
            )
        object.__setattr__(self, "hyperparams", freeze(dict(self.hyperparams)))
        self._check_counterfactual()
        known = known_hyperparameters(self.name) - WORLD_KEYS
        for key in self.hyperparams:
            if key in WORLD_KEYS:
                raise ConfigError(
                    f"algorithm.hyperparams.{key} is a setting of the world: set world.{key}"
                )
            if key not in known:
                raise ConfigError(
                    f"unknown config key algorithm.hyperparams.{key} for {self.name}; "
                    f"known: {sorted(known)}"
                )
        check_hyperparameter_values(
            self.name, {k: v for k, v in self.hyperparams.items() if k != "policy_kwargs"}
        )
        if (
            self.hyperparams.get("bolt_weight") is not None
            and self.hyperparams.get("normalize_reward") != SPLIT
        ):
            raise ConfigError(
                "bolt_weight weighs the bolt's normalised rewards against the world's, which "
                "only normalize_reward=split keeps apart: add --hp normalize_reward=split, or "
                "drop bolt_weight and change --reward-scale (which weighs them where rewards "
                "are not normalised apart)"
            )
        for key, algos, what in _SCHEDULES_OF:
            if self.hyperparams.get(key) is not None and self.name not in algos:
                raise ConfigError(
                    f"{key}: {self.name.upper()} has no {what} (only "
                    f"{' and '.join(a.upper() for a in algos)}); remove the hyperparameter"
                )

    def _check_counterfactual(self) -> None:
        if not isinstance(self.counterfactual, bool):
            raise ConfigError(
                f"algorithm.counterfactual must be true or false, got {self.counterfactual!r}"
            )
        samples = self.counterfactual_samples
        if isinstance(samples, bool) or not isinstance(samples, int) or samples < 1:
            raise ConfigError(
                f"algorithm.counterfactual_samples must be an integer >= 1, got {samples!r}"
            )
        if not self.counterfactual:
            return
        if not issubclass(algorithm_class(self.name), OffPolicyAlgorithm):
            raise ConfigError(
                f"algorithm.counterfactual replays stored transitions from other DFA states, "
                f"and {self.name.upper()} is on-policy (it stores none): use dqn, or turn "
                "algorithm.counterfactual off"
            )
        if self.hyperparams.get("optimize_memory_usage"):
            raise ConfigError(
                "algorithm.counterfactual stores its copies in a dict replay buffer, which "
                "has no optimize_memory_usage: drop the hyperparameter"
            )


@dataclass(frozen=True, kw_only=True)
class EvaluationConfig:
    """How the run is evaluated while it trains (``evaluation`` in ``config.json``).

    Attributes:
        freq: frames between evaluations (0: only at the end).
        episodes: episodes per evaluation.
        envs: environments used to evaluate.
        deterministic: evaluate the greedy policy; by default PPO's and A2C's actions are
            sampled, as the paper's code base (rl-starter-files) evaluates: a half-trained
            greedy policy on a grid often loops (turning on the spot) where its sampled
            one does not. DQN's default is greedy (:meth:`TrainConfig.build`): sampling
            its policy means SB3's epsilon-exploration.
        success_threshold: the share of evaluation episodes that must reach the goal and
            comply with every spec for the run to count as compliant (N_frames).
        stop_after: stop when solved: end training once this many periodic evaluations
            in a row reach ``success_threshold``
            (:class:`~noisybolt.runs.stopping.StopWhenSolved`); 0 trains the whole
            ``frames`` budget.
        keep_best: the run's final model is the one of the periodic evaluation with the
            highest mean *shaped* return (environment + bolt rewards, as the bolt sees
            them through its detector, at the compliance scale under ``constrained``), not
            the last one, as RL Zoo keeps ``best_model.zip``. Ground truth never chooses:
            compliance is measured on the kept model afterwards. On by default: a policy
            that complied and reached the goal can collapse later in training (a detour
            spec on the gridworld complied at 30k frames and looped at 60k), and the
            model a user gets is the one to deploy. False (``--last-model``) keeps the
            last.
    """

    freq: int = 10_000
    episodes: int = 20
    envs: int = 4
    deterministic: bool = False
    success_threshold: float = 0.95
    stop_after: int = 0
    keep_best: bool = True

    def __post_init__(self) -> None:
        check_count("evaluation.freq", self.freq, 0)
        check_count("evaluation.episodes", self.episodes, 1)
        check_count("evaluation.envs", self.envs, 1)
        if not 0.0 < self.success_threshold <= 1.0:
            raise ConfigError(
                f"evaluation.success_threshold must be in (0, 1], got {self.success_threshold}"
            )
        if isinstance(self.stop_after, bool) or not isinstance(self.stop_after, int):
            raise ConfigError(
                f"evaluation.stop_after must be an integer >= 0, got {self.stop_after!r}"
            )
        if self.stop_after < 0 or (self.stop_after and not self.freq):
            raise ConfigError(
                f"evaluation.stop_after={self.stop_after}: stopping when solved counts "
                "periodic evaluations; give stop_after >= 0 and, for stop_after > 0, "
                "eval_freq > 0 (evaluation.freq)"
            )


def check_given_settings(bolt: BoltConfig, given: Mapping[str, Any]) -> None:
    """Refuses a setting that was given (``given``: ``{schema path: value}``, as
    :meth:`~noisybolt.runs.config.TrainConfig.build` and ``resumed`` take them) where a
    run with the ``bolt`` section would ignore it: a rule on what a user asked for, not on
    the values (a saved config holds every setting, its defaults too).

    Raises:
        ConfigError: ``bolt.confidence`` or ``bolt.min_dwell`` without belief tracking,
            ``bolt.shaping`` under the paper scheme; naming the path and its flag.

    Example:
        >>> check_given_settings(BoltConfig(specs=({"formula": "F(a)"},)), {"bolt.confidence": 0.8})
        Traceback (most recent call last):
        ...
        noisybolt.errors.ConfigError: bolt.confidence 0.8 (--confidence) sets how belief \
tracking reads the detector; with threshold tracking it would be ignored: set bolt.tracking \
belief (--tracking belief), or leave it out
    """
    for path, flag in (("bolt.confidence", "--confidence"), ("bolt.min_dwell", "--min-dwell")):
        if path in given and bolt.tracking != "belief":
            raise ConfigError(
                f"{path} {given[path]} ({flag}) sets how belief tracking reads the detector; "
                f"with {bolt.tracking} tracking it would be ignored: set bolt.tracking "
                "belief (--tracking belief), or leave it out"
            )
    if "bolt.shaping" in given and bolt.reward == "paper":
        raise ConfigError(
            "bolt.shaping (--no-shaping) turns off the compliance scheme's progress shaping; "
            "the paper scheme has none, so it would be ignored: set bolt.reward compliance "
            "(--reward compliance), or leave it out"
        )
