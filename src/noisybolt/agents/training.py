"""Training a bolted agent with Stable-Baselines3: config, run directory, checkpoints, resume.

A run directory holds::

    config.json            the resolved :class:`TrainConfig` (defaults included)
    command.txt            the exact command
    metrics.json           one record per evaluation (returns, compliance, success, frames)
    checkpoints/latest.json  points to the newest complete checkpoint folder
    checkpoints/step_N/    model.zip (+ vecnormalize.pkl, replay_buffer.pkl)
    best/step_N/           with ``keep_best``: the model of the best periodic evaluation
    model.zip              the final model (+ vecnormalize.pkl): the last one, or with
                           ``keep_best`` the best one
    tensorboard/           TensorBoard logs
    summary.json           the final evaluation and the first frame count of compliance

Every file is written atomically, and a checkpoint counts only once ``latest.json`` names
it, which happens after all its files are complete: a run killed at any moment loses at
most the work since its last checkpoint. ``resume=True`` continues from there, after
checking the saved config equals the new one (except the frame budget).
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
from collections.abc import Callable, Mapping, Sequence
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
import torch
from stable_baselines3.common.base_class import BaseAlgorithm
from stable_baselines3.common.callbacks import BaseCallback, CallbackList
from stable_baselines3.common.vec_env import VecEnv, VecMonitor, VecNormalize

from noisybolt.agents.evaluation import EvalResult, evaluate_bolted_policy
from noisybolt.agents.extractor import BoltFeaturesExtractor, check_cnn
from noisybolt.agents.hyperparams import META_KEYS, algorithm_class, load_hyperparams
from noisybolt.agents.specs import expand_specs, resolve_spec
from noisybolt.bolt import COST_MODES, RewardScheme, Spec, Thresholds, compliance_scale
from noisybolt.envs import DEFAULT_WORLD, SB3VecEnv, check_world, make_world
from noisybolt.envs.bounds import world_return_bounds
from noisybolt.envs.registry import is_factory_path, world_fingerprint
from noisybolt.errors import (
    ConfigError,
    UnknownFluentError,
    UnknownNameError,
    UnsatisfiableSpecError,
)
from noisybolt.io import atomic_open, atomic_write_json
from noisybolt.logic import compile_ltlf, is_satisfiable, is_valid
from noisybolt.perception.protocols import FluentDetector
from noisybolt.rundir import RunDirectory
from noisybolt.wrappers import BoltVecEnv, ClipGameReward, LifeLossTerminal

__all__ = [
    "DETECTORS",
    "BoltSetup",
    "DetectorConfig",
    "EntropySchedule",
    "TrainConfig",
    "TrainResult",
    "build_bolted_env",
    "make_detector",
    "prepare_bolt",
    "train",
]

DETECTORS: tuple[str, ...] = ("classifier", "oracle", "synthetic")
#: Settings that may change when a run is resumed.
RESUMABLE_KEYS: tuple[str, ...] = ("frames", "progress_bar")
#: What a config saved before a setting existed meant by it (read on resume).
LEGACY_DEFAULTS: dict[str, Any] = {"reward": "paper", "reward_scale": None, "shaping": False}
BEST_DIR = "best"


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
        checkpoint_freq: frames between checkpoints (0: none).
        thresholds: ``{"truth": 0.5, "high": 0.9}`` of eq. 1.
        cost_mode: ``"count"`` or ``"proportional"``.
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
    checkpoint_freq: int = 20_000
    thresholds: dict[str, float] = field(default_factory=lambda: {"truth": 0.5, "high": 0.9})
    cost_mode: str = "count"
    reward: str = "compliance"
    reward_scale: float | None = None
    shaping: bool = True
    bolted: bool = True
    keep_best: bool = False
    progress_bar: bool = True

    def __post_init__(self) -> None:
        check_world(self.world)  # a registered name or an importable factory path
        algorithm_class(self.algo)
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
        if self.cost_mode not in COST_MODES:
            raise ConfigError(
                f"cost_mode must be one of {list(COST_MODES)}, got {self.cost_mode!r}"
            )
        Thresholds(**self.thresholds)
        object.__setattr__(self, "specs", tuple(dict(s) for s in self.specs))
        if self.reward == "compliance" and self.reward_scale is None:
            object.__setattr__(self, "reward_scale", _scale_from_world(self))
        scheme = self.scheme  # validates reward, reward_scale and shaping
        object.__setattr__(self, "shaping", scheme.shaping)
        self.spec_objects()  # validates every spec under the scheme

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
            fields = asdict(resolve_spec(item))
            if scale is not None:
                fields["reward_scale"] = scale
            resolved.append(fields)
        params = load_hyperparams(world, algo, overrides, hp_file=hp_file)
        if n_envs is not None:
            params["n_envs"] = int(n_envs)
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
            specs.append(scheme.apply(resolve_spec(fields), scale=scale))
        if not self.bolted:
            specs = [replace(s, terminal_reward=0.0, low_confidence_cost=0.0) for s in specs]
        return specs

    def to_dict(self) -> dict[str, Any]:
        """JSON-able form (what ``config.json`` holds)."""
        data = asdict(self)
        data["specs"] = [dict(s) for s in self.specs]
        data["detector"]["low_confidence"] = list(self.detector.low_confidence)
        return json.loads(json.dumps(data))

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> TrainConfig:
        """Reads :meth:`to_dict`'s output back; unknown keys are an error."""
        data = {**LEGACY_DEFAULTS, **data}
        known = set(cls.__dataclass_fields__)
        unknown = sorted(set(data) - known)
        if unknown:
            raise ConfigError(f"unknown training config key(s) {unknown}; known: {sorted(known)}")
        detector = DetectorConfig(**data.pop("detector", {}))
        data["specs"] = tuple(data.get("specs", ()))
        return cls(detector=detector, **data)


def _scale_from_world(config: TrainConfig) -> float:
    """The ``compliance`` scale from the world's declared return bounds."""
    bounds = world_return_bounds(
        make_world(config.world, num_envs=1, seed=0, **config.world_settings)
    )
    if bounds is None:
        raise ConfigError(
            f"the {config.world!r} world declares no bounds on its episodes' returns, from "
            "which the compliance reward scheme sets what complying is worth: pass "
            "--reward-scale S (S above the widest gap between two episodes' returns), or "
            "--reward paper"
        )
    return compliance_scale(bounds)


@dataclass(frozen=True)
class TrainResult:
    """What a finished run reports.

    Attributes:
        run_dir: the run directory.
        frames: environment steps trained (all environments together).
        final: the final evaluation.
        frames_to_comply: N_frames, the frames after which an evaluation first had at
            least ``success_threshold`` of its episodes reach the goal while complying
            with every spec (None if it never did).
        history: every evaluation's record.
    """

    run_dir: Path
    frames: int
    final: EvalResult
    frames_to_comply: int | None
    history: tuple[dict[str, Any], ...]


# ---------------------------------------------------------------------- detectors
def _cache_root() -> Path:
    root = os.environ.get("NOISYBOLT_CACHE_DIR")
    return Path(root) if root else Path.home() / ".cache" / "noisybolt"


def classifier_architecture(camera: Any) -> Any:
    """The classifier trained on the fly for a camera.

    A camera drawn in tiles (the gridworld's) gets a tile-reading first layer
    (``ClassifierConfig.patch``): a quarter of the default trunk's multiply-adds, which
    is most of the bolt's cost per training frame; other cameras get the default trunk.
    """
    from noisybolt.perception.classifier import ClassifierConfig

    tile = camera.extra.get("tile_size") if isinstance(camera.extra, Mapping) else None
    if isinstance(tile, int) and tile > 1:
        return ClassifierConfig(channels=(32, 32), patch=tile)
    return ClassifierConfig()


def default_classifier_path(
    world: str,
    config: DetectorConfig,
    camera: Any,
    architecture: Any,
    *,
    fingerprint: str | None = None,
) -> Path:
    """Where the on-the-fly classifier for this world, camera and recipe is cached.

    ``fingerprint`` (:func:`noisybolt.envs.registry.world_fingerprint`, taken for a
    factory-path world) keys it by what the fluents mean too: a user's world whose fluent
    definition changed under the same name gets a new classifier, not the old one.
    """
    from noisybolt.perception.compat import camera_spec_to_dict

    fields = {
        "world": world,
        "camera": camera_spec_to_dict(camera),
        "architecture": asdict(architecture),
        "samples": config.samples,
        "epochs": config.epochs,
        "seed": config.seed,
    }
    if fingerprint is not None:
        fields["fluents"] = fingerprint
    digest = hashlib.sha256(json.dumps(fields, sort_keys=True).encode()).hexdigest()[:16]
    label = world.replace(":", ".")
    return _cache_root() / "classifiers" / f"{label}-{digest}.safetensors"


def make_detector(
    config: DetectorConfig,
    *,
    world: str,
    world_kwargs: Mapping[str, Any],
    fluent_names: Sequence[str],
    camera_spec: Any,
    progress: bool = True,
    log: Callable[[str], None] = print,
    retrain: bool = False,
) -> FluentDetector:
    """Builds the detector; a classifier is loaded (checked against the world) or trained.

    ``retrain`` trains the cached on-the-fly classifier again even if one is cached.

    Raises:
        ConfigError: ``retrain`` with a classifier file given (``config.path``).
    """
    from noisybolt.perception.classifier import load_classifier
    from noisybolt.perception.detectors import BetaNoise, OracleDetector, SyntheticDetector

    if config.kind == "oracle":
        return OracleDetector(fluent_names)
    if config.kind == "synthetic":
        return SyntheticDetector(
            fluent_names,
            seed=config.seed,
            fluents={name: BetaNoise.low_confidence() for name in config.low_confidence},
        )
    architecture = classifier_architecture(camera_spec)
    path = (
        Path(config.path)
        if config.path
        else default_classifier_path(
            world,
            config,
            camera_spec,
            architecture,
            fingerprint=world_fingerprint(world, dict(world_kwargs))
            if is_factory_path(world)
            else None,
        )
    )
    if retrain and config.path is not None:
        raise ConfigError(
            "retraining applies to the cached classifier; a classifier file is used as given"
        )
    if config.path is None and (retrain or not path.exists()):
        why = "retraining it" if retrain else "no cached classifier for this camera"
        log(f"{why}: training one ({path})")
        _train_classifier_on_the_fly(
            path,
            config,
            architecture,
            world=world,
            world_kwargs=world_kwargs,
            progress=progress,
            log=log,
        )
    return load_classifier(path, fluent_names=fluent_names, camera_spec=camera_spec)


def _train_classifier_on_the_fly(
    path: Path,
    config: DetectorConfig,
    architecture: Any,
    *,
    world: str,
    world_kwargs: Mapping[str, Any],
    progress: bool,
    log: Callable[[str], None],
) -> None:
    from noisybolt.perception.dataset import collect_samples
    from noisybolt.perception.training import TrainingConfig, train_classifier

    collector = make_world(world, num_envs=16, seed=config.seed, **world_kwargs)
    dataset = collect_samples(
        collector, num_samples=config.samples, seed=config.seed, progress=progress
    )
    result = train_classifier(
        dataset,
        config=architecture,
        training=TrainingConfig(epochs=config.epochs, seed=config.seed),
        progress=progress,
    )
    result.detector.save(path)
    log(
        f"classifier trained in {result.seconds:.0f} s on {config.samples} bolt images; "
        f"validation report:\n{result.report.format_table()}"
    )


# ---------------------------------------------------------------------- environments
def build_bolted_env(
    config: TrainConfig,
    detector: FluentDetector,
    *,
    n_envs: int,
    seed: int,
    dfas: Sequence[Any] | None = None,
    training: bool = False,
    letters: np.ndarray | None = None,
) -> BoltVecEnv:
    """The world as an SB3 ``VecEnv``, monitored, with the bolt on top.

    The Atari conventions among the hyperparameters: ``fire_on_reset`` is part of the
    world (training and evaluation alike); ``clip_reward`` (the game's score clipped to
    its sign, below the bolt) only when ``training``; ``life_loss_terminal`` is added
    above the bolt by :func:`train` (see :mod:`noisybolt.wrappers.atari`).
    ``letters``: the world's true fluents seen in random play (:class:`BoltSetup`), for
    the compliance scheme's progress terms.
    """
    world = make_world(config.world, num_envs=n_envs, seed=seed, **config.world_settings)
    venv: VecEnv = VecMonitor(SB3VecEnv(world))  # type: ignore[arg-type]
    if training and config.hyperparams.get("clip_reward"):
        venv = ClipGameReward(venv)
    return BoltVecEnv(
        venv,
        config.spec_objects(),
        detector,
        world=world,
        dfas=dfas,
        thresholds=Thresholds(**config.thresholds),
        cost_mode=config.cost_mode,  # type: ignore[arg-type]
        progress_gamma=config.progress_gamma,
        shaping=config.shaping,
        world_letters=letters,
    )


@dataclass(frozen=True)
class BoltSetup:
    """What a bolted run needs besides the environments: checked specs and the detector.

    Attributes:
        fluents: the world's fluent vocabulary.
        dfas: every spec's DFA over it.
        detector: the fluent detector, checked against the world's fluents and camera.
        letters: bool ``[n, n_fluents]``, the distinct true-fluent assignments seen in
            random play (None under the paper scheme): progress shaping counts distances
            to acceptance over the letters the world produces.
    """

    fluents: tuple[str, ...]
    dfas: list[Any]
    detector: FluentDetector
    letters: np.ndarray | None = None


def prepare_bolt(
    config: TrainConfig,
    *,
    seed: int,
    progress: bool = False,
    log: Callable[[str], None] = print,
    retrain_classifier: bool = False,
) -> BoltSetup:
    """Compiles the specs over the world's fluents and builds the detector
    (``retrain_classifier``: see :func:`make_detector`'s ``retrain``).

    Raises:
        UnknownFluentError: a spec names a fluent the world lacks (listing the world's).
        IncompatibleError: the detector's fluents or camera differ from the world's.
    """
    probe = make_world(config.world, num_envs=1, seed=seed, **config.world_kwargs)
    fluents = tuple(probe.fluent_names)
    dfas = _check_specs_against_world(config, fluents, log=log)
    detector = make_detector(
        config.detector,
        world=config.world,
        world_kwargs=config.world_kwargs,
        fluent_names=fluents,
        camera_spec=probe.camera_spec,
        progress=progress,
        log=log,
        retrain=retrain_classifier,
    )
    letters = None
    if config.progress_gamma is not None:
        letters = _random_play_letters(config)
    return BoltSetup(fluents=fluents, dfas=dfas, detector=detector, letters=letters)


def _random_play_letters(config: TrainConfig, *, n_envs: int = 16, steps: int = 128) -> np.ndarray:
    """The distinct true-fluent assignments a world shows in ``n_envs * steps`` random
    steps (seeded by the run's seed, so training and evaluation see the same)."""
    world: Any = make_world(
        config.world, num_envs=n_envs, seed=config.seed, **config.world_settings
    )
    world.reset(seed=config.seed)
    world.action_space.seed(config.seed)
    seen = [np.asarray(world.true_fluents(), dtype=bool)]
    for _ in range(steps):
        world.step(world.action_space.sample())
        seen.append(np.asarray(world.true_fluents(), dtype=bool))
    return np.unique(np.concatenate(seen), axis=0)


def _check_specs_against_world(
    config: TrainConfig, fluent_names: Sequence[str], *, log: Callable[[str], None] = print
) -> list[Any]:
    """Compiles every spec over the world's fluents (errors list the world's fluents).

    Raises:
        UnsatisfiableSpecError: no trace satisfies a spec. A spec that every trace
            satisfies gets a warning through ``log`` (the bolt would ask for nothing).
    """
    dfas = []
    for spec in config.spec_objects():
        try:
            dfas.append(compile_ltlf(spec.formula, fluent_names))
        except UnknownFluentError as error:
            raise UnknownFluentError(
                f"spec {spec.name!r} uses fluent(s) {list(error.unknown)} that the "
                f"{config.world} does not have; this world's fluents are {list(fluent_names)}",
                unknown=error.unknown,
                known=tuple(fluent_names),
            ) from None
        if not is_satisfiable(dfas[-1]):
            raise UnsatisfiableSpecError(
                f"spec {spec.name!r} is unsatisfiable: no trace of the {config.world}'s "
                f"fluents satisfies {spec.formula!r}, so no agent can comply; fix the formula",
                formula=spec.formula,
            )
        if is_valid(dfas[-1]):
            log(
                f"warning: spec {spec.name!r} holds on every trace ({spec.formula!r}): the "
                "bolt asks for nothing"
            )
    return dfas


# ---------------------------------------------------------------------- checkpoints
def _save_model_files(model: BaseAlgorithm, env: VecEnv, folder: Path) -> None:
    folder.mkdir(parents=True, exist_ok=True)
    with atomic_open(folder / "model.zip", "wb") as handle:
        model.save(handle)  # type: ignore[arg-type]
    if isinstance(env, VecNormalize):
        with atomic_open(folder / "vecnormalize.pkl", "wb") as handle:
            import pickle

            pickle.dump(env, handle)


def _copy_model_files(source: Path, folder: Path) -> None:
    """Copies a saved model (and its normaliser) into ``folder``, each file atomically."""
    for name in ("model.zip", "vecnormalize.pkl"):
        if (source / name).exists():
            with atomic_open(folder / name, "wb") as handle:
                handle.write((source / name).read_bytes())


def _best_folder(run: RunDirectory, frames: int) -> Path:
    return run.file(BEST_DIR) / f"step_{frames:012d}"


def shaped_return(result: EvalResult) -> float:
    """What the agent is trained to maximise, as measured: env + bolt return (means)."""
    return float(result.env_return_mean + result.bolt_return_mean)


def _save_checkpoint(
    model: BaseAlgorithm, env: VecEnv, run: RunDirectory, state: dict[str, Any]
) -> None:
    """Writes a complete checkpoint folder, then points ``latest.json`` at it."""
    root = run.file("checkpoints")
    folder = root / f"step_{model.num_timesteps:012d}"
    _save_model_files(model, env, folder)
    if hasattr(model, "replay_buffer") and getattr(model, "replay_buffer", None) is not None:
        tmp = folder / "replay_buffer.pkl.tmp"
        model.save_replay_buffer(tmp)  # type: ignore[attr-defined]
        os.replace(tmp, folder / "replay_buffer.pkl")
    atomic_write_json(folder / "state.json", state)
    atomic_write_json(root / "latest.json", {"folder": folder.name, "frames": model.num_timesteps})
    for old in root.glob("step_*"):
        if old.is_dir() and old.name != folder.name:
            shutil.rmtree(old, ignore_errors=True)


def _latest_checkpoint(run: RunDirectory) -> Path | None:
    pointer = run.file("checkpoints") / "latest.json"
    if not pointer.exists():
        return None
    folder = run.file("checkpoints") / json.loads(pointer.read_text())["folder"]
    return folder if (folder / "model.zip").exists() else None


# ---------------------------------------------------------------------- callbacks
class EntropySchedule(BaseCallback):
    """PPO's and A2C's entropy coefficient moved linearly from ``start`` to ``end``.

    SB3 reads ``model.ent_coef`` at every update but offers schedules only for the learning
    rate and PPO's clip range. A high bonus early keeps the policy trying routes that pay a
    little more (A2C settled on ``!F(t)``'s shortcut through the corner at 0.01); a low one
    late lets it act as surely as it has learnt (at 0.05 throughout, sampled ``G(on_edge)``
    episodes stepped off the edge in up to 6 %). The value is set before each rollout from
    the frames done, so a resumed run continues the same schedule.

    Args:
        start: coefficient at frame 0.
        end: coefficient from ``frames`` on.
        frames: frames over which it moves (the run's budget).
    """

    def __init__(self, start: float, end: float, frames: int) -> None:
        super().__init__(verbose=0)
        if start < 0 or end < 0 or frames < 1:
            raise ConfigError(
                f"entropy schedule: coefficients must be >= 0 and frames >= 1, got {start}, "
                f"{end}, {frames}"
            )
        self.start, self.end, self.frames = float(start), float(end), int(frames)

    def value(self, frames_done: int) -> float:
        """The coefficient after ``frames_done`` frames."""
        progress = min(1.0, max(0, frames_done) / self.frames)
        return self.start + (self.end - self.start) * progress

    def _on_rollout_start(self) -> None:
        self.model.ent_coef = self.value(self.model.num_timesteps)  # type: ignore[attr-defined]

    def _on_step(self) -> bool:
        return True


class _BoltCallback(BaseCallback):
    """Periodic evaluation (compliance from ground truth) and atomic checkpoints."""

    def __init__(
        self,
        *,
        config: TrainConfig,
        run: RunDirectory,
        eval_env: BoltVecEnv,
        spec_names: Sequence[str],
        history: list[dict[str, Any]],
        frames_to_comply: int | None,
        best: dict[str, Any] | None = None,
    ) -> None:
        super().__init__(verbose=0)
        self.config = config
        self.run = run
        self.eval_env = eval_env
        self.spec_names = list(spec_names)
        self.history = history
        self.frames_to_comply = frames_to_comply
        self.best = best
        self._next_eval = self._next_ckpt = 0

    def _init_callback(self) -> None:
        done = self.model.num_timesteps
        self._next_eval = _next_multiple(done, self.config.eval_freq)
        self._next_ckpt = _next_multiple(done, self.config.checkpoint_freq)

    def evaluate(self) -> EvalResult:
        """Evaluates the current policy and records it (metrics.json, TensorBoard)."""
        model = self.model
        deterministic = self.config.eval_deterministic
        frames = int(model.num_timesteps)
        # Sampled evaluation actions draw from torch's and numpy's global generators (DQN's
        # epsilon uses numpy's). Draw them from generators of their own, seeded by the
        # frame count, so that how often a run is evaluated does not change its training.
        numpy_state = np.random.get_state()  # noqa: NPY002 (SB3 uses the legacy global)
        with torch.random.fork_rng(devices=[]):
            torch.manual_seed(self.config.seed * 1_000_003 + frames)
            np.random.seed((self.config.seed * 1_000_003 + frames) % 2**32)  # noqa: NPY002
            try:
                result = evaluate_bolted_policy(
                    lambda obs: model.predict(obs, deterministic=deterministic)[0],
                    self.eval_env,
                    n_episodes=self.config.eval_episodes,
                    spec_names=self.spec_names,
                )
            finally:
                np.random.set_state(numpy_state)  # noqa: NPY002
        if self.frames_to_comply is None and result.success_rate >= self.config.success_threshold:
            self.frames_to_comply = frames
        record = {"frames": frames, **result.to_dict()}
        self.history.append(record)
        self.run.write_metrics(self.history)
        if self.config.keep_best:
            score = shaped_return(result)
            # Ties go to the later (longer trained) model.
            if self.best is None or score >= self.best["shaped_return"]:
                env = model.get_env()
                assert env is not None
                _save_model_files(model, env, _best_folder(self.run, frames))
                self.best = {"frames": frames, "shaped_return": score}
        for key in ("env_return_mean", "length_mean", "goal_rate", "success_rate"):
            model.logger.record(f"eval/{key}", getattr(result, key))
        for name, rate in result.compliance.items():
            model.logger.record(f"eval/compliance/{name}", rate)
        return result

    def checkpoint(self) -> None:
        """Saves a complete checkpoint."""
        env = self.model.get_env()
        assert env is not None
        state = {
            "frames_to_comply": self.frames_to_comply,
            "history": self.history,
            "best": self.best,
        }
        _save_checkpoint(self.model, env, self.run, state)
        # Only now that the newest checkpoint names this best model may the older ones
        # go: a run killed earlier resumes from a checkpoint naming one of them.
        if self.best is not None:
            keep = _best_folder(self.run, self.best["frames"])
            for folder in self.run.file(BEST_DIR).glob("step_*"):
                if folder != keep:
                    shutil.rmtree(folder, ignore_errors=True)

    def _on_step(self) -> bool:
        frames = self.model.num_timesteps
        if self.config.eval_freq and frames >= self._next_eval:
            self.evaluate()
            self._next_eval = _next_multiple(frames, self.config.eval_freq)
        if self.config.checkpoint_freq and frames >= self._next_ckpt:
            self.checkpoint()
            self._next_ckpt = _next_multiple(frames, self.config.checkpoint_freq)
        return True


def _transposed(env: VecEnv) -> VecEnv:
    """``env`` with channel-last image entries moved channel-first, as SB3 would do."""
    from stable_baselines3.common.preprocessing import (
        is_image_space,
        is_image_space_channels_first,
    )
    from stable_baselines3.common.vec_env import VecTransposeImage

    spaces = getattr(env.observation_space, "spaces", {"": env.observation_space})
    if any(
        is_image_space(space) and not is_image_space_channels_first(space)
        for space in spaces.values()
    ):
        return VecTransposeImage(env)
    return env


def _next_multiple(value: int, step: int) -> int:
    return (value // step + 1) * step if step else 0


# ---------------------------------------------------------------------- training
def _make_model(config: TrainConfig, env: VecEnv, run: RunDirectory) -> BaseAlgorithm:
    params = {k: v for k, v in config.hyperparams.items() if k not in META_KEYS}
    policy_kwargs = dict(params.pop("policy_kwargs", {}) or {})
    extractor_kwargs = dict(policy_kwargs.pop("features_extractor_kwargs", {}) or {})
    if config.hyperparams.get("image_features") is not None:
        extractor_kwargs["image_features"] = int(config.hyperparams["image_features"])
    if config.hyperparams.get("cnn") is not None:
        extractor_kwargs["cnn"] = str(config.hyperparams["cnn"])
    policy_kwargs["features_extractor_class"] = BoltFeaturesExtractor
    policy_kwargs["features_extractor_kwargs"] = extractor_kwargs
    cls = algorithm_class(config.algo)
    return cls(
        "MultiInputPolicy",
        env,
        policy_kwargs=policy_kwargs,
        seed=config.seed,
        verbose=0,
        device="cpu",
        tensorboard_log=str(run.file("tensorboard")),
        **params,
    )


def train(
    config: TrainConfig,
    run_dir: str | os.PathLike[str],
    *,
    resume: bool = False,
    argv: Sequence[str] | None = None,
    log: Callable[[str], None] = print,
    retrain_classifier: bool = False,
) -> TrainResult:
    """Trains (or resumes) a bolted agent; see the module docstring for the run directory.

    Raises:
        ConfigError: ``resume`` on a directory whose config differs (the message names the
            differing keys), or a fresh run into a directory that already holds one.
        UnknownFluentError: a spec names a fluent the world does not have.
        IncompatibleError: the detector's fluents or camera differ from the world's.
    """
    torch.set_num_threads(1)
    run = RunDirectory(run_dir)
    if resume and retrain_classifier:
        raise ConfigError(
            "--retrain-classifier with --resume would change the bolt's eyes halfway through "
            "a run; retrain for a new run"
        )
    if resume:
        run.check_same_config(config.to_dict(), ignore=RESUMABLE_KEYS, defaults=LEGACY_DEFAULTS)
    elif run.exists():
        raise ConfigError(
            f"{run.path} already holds a run; pass --resume to continue it or choose another "
            "directory"
        )

    if config.hyperparams.get("ent_coef_final") is not None and config.algo not in ("ppo", "a2c"):
        raise ConfigError(
            f"ent_coef_final: {config.algo.upper()} has no entropy bonus (only PPO and A2C); "
            "remove the hyperparameter"
        )
    if config.hyperparams.get("cnn") is not None:
        check_cnn(config.hyperparams["cnn"])  # before anything is written
    if config.hyperparams.get("life_loss_terminal"):
        probe = make_world(config.world, num_envs=1, seed=0, **config.world_settings)
        if not callable(getattr(probe, "lives", None)):
            raise ConfigError(
                f"life_loss_terminal: the {config.world!r} world has no lives (it needs a "
                "lives() method); remove the hyperparameter"
            )
    setup = prepare_bolt(
        config,
        seed=config.seed,
        progress=config.progress_bar,
        log=log,
        retrain_classifier=retrain_classifier,
    )
    dfas, detector = setup.dfas, setup.detector
    run.path.mkdir(parents=True, exist_ok=True)
    run.write_config(config.to_dict())
    run.write_command(argv)

    bolted = build_bolted_env(
        config,
        detector,
        n_envs=config.n_envs,
        seed=config.seed,
        dfas=dfas,
        training=True,
        letters=setup.letters,
    )
    env: VecEnv = bolted
    if config.hyperparams.get("life_loss_terminal"):
        env = LifeLossTerminal(env, bolted.world.lives)  # type: ignore[attr-defined]
    if config.hyperparams.get("normalize_reward"):
        # Transpose images *below* the normaliser: SB3 would put its VecTransposeImage on
        # top, and off-policy replay buffers, which store VecNormalize's original (here:
        # untransposed) observations, then get the wrong shape (DQN crashed).
        env = _transposed(env)
        env = VecNormalize(
            env, norm_obs=False, norm_reward=True, gamma=config.hyperparams.get("gamma", 0.99)
        )
    eval_env = build_bolted_env(
        config,
        detector,
        n_envs=config.eval_envs,
        seed=config.seed + 10_000,
        dfas=dfas,
        letters=setup.letters,
    )

    history: list[dict[str, Any]] = []
    frames_to_comply: int | None = None
    best: dict[str, Any] | None = None
    checkpoint = _latest_checkpoint(run) if resume else None
    if checkpoint is not None:
        if isinstance(env, VecNormalize) and (checkpoint / "vecnormalize.pkl").exists():
            env = VecNormalize.load(str(checkpoint / "vecnormalize.pkl"), env.venv)
        model = algorithm_class(config.algo).load(checkpoint / "model.zip", env=env, device="cpu")
        if (checkpoint / "replay_buffer.pkl").exists():
            model.load_replay_buffer(checkpoint / "replay_buffer.pkl")  # type: ignore[attr-defined]
        state = json.loads((checkpoint / "state.json").read_text())
        history = list(state.get("history", []))
        frames_to_comply = state.get("frames_to_comply")
        best = state.get("best")
        log(f"resuming {run.path} from {model.num_timesteps} frames")
    else:
        model = _make_model(config, env, run)

    spec_names = [s.name for s in config.spec_objects()]
    callback = _BoltCallback(
        config=config,
        run=run,
        eval_env=eval_env,
        spec_names=spec_names,
        history=history,
        frames_to_comply=frames_to_comply,
        best=best,
    )
    callbacks: list[BaseCallback] = [callback]
    if config.hyperparams.get("ent_coef_final") is not None:
        callbacks.append(
            EntropySchedule(
                float(config.hyperparams.get("ent_coef", 0.0)),
                float(config.hyperparams["ent_coef_final"]),
                config.frames,
            )
        )
    remaining = config.frames - model.num_timesteps
    if remaining > 0:
        try:
            model.learn(
                total_timesteps=remaining,
                callback=CallbackList(callbacks),
                reset_num_timesteps=checkpoint is None,
                progress_bar=config.progress_bar,
                tb_log_name="run",
            )
        except KeyboardInterrupt:
            # Ctrl-C (or the CLI's SIGTERM): keep every frame trained so far, not only
            # those up to the last periodic checkpoint. Mid-rollout is fine: the model,
            # normaliser and replay buffer are consistent between steps, and a resume
            # starts a fresh rollout, as it does from any checkpoint.
            callback.init_callback(model)  # in case learn() had not got that far
            callback.checkpoint()
            log(
                f"interrupted at {model.num_timesteps:,} frames: checkpoint saved; continue "
                f"with --resume --out {run.path}"
            )
            raise
    callback.init_callback(model)
    final = (
        callback.evaluate() if not history or history[-1]["frames"] != model.num_timesteps else None
    )
    if final is None:
        final = _result_from_record(history[-1], spec_names)
    callback.checkpoint()
    kept: dict[str, Any] = {"frames": int(model.num_timesteps), "chosen_by": "last"}
    if config.keep_best and callback.best is not None:
        best_frames = callback.best["frames"]
        record = next(r for r in reversed(history) if r["frames"] == best_frames)
        final = _result_from_record(record, spec_names)
        kept = {"frames": best_frames, "chosen_by": "best shaped return", **callback.best}
        _copy_model_files(_best_folder(run, best_frames), run.path)
    else:
        _save_model_files(model, env, run.path)
    summary = {
        "frames": int(model.num_timesteps),
        "frames_to_comply": callback.frames_to_comply,
        "kept_model": kept,
        "final": final.to_dict(),
    }
    atomic_write_json(run.file("summary.json"), summary)
    return TrainResult(
        run_dir=run.path,
        frames=int(model.num_timesteps),
        final=final,
        frames_to_comply=callback.frames_to_comply,
        history=tuple(history),
    )


def _result_from_record(record: Mapping[str, Any], spec_names: Sequence[str]) -> EvalResult:
    fields = {k: v for k, v in record.items() if k in EvalResult.__dataclass_fields__}
    return EvalResult(**fields)
