"""The environments of a run: one :func:`make_env` owns the whole wrapper stack.

Bottom to top::

    world (natively vectorised)  ->  SB3VecEnv  ->  VecMonitor
      -> ClipGameReward      (training, ``clip_reward``: the game's score, below the bolt)
      -> BoltVecEnv          (the restraining bolt: DFAs, detector, rewards)
      -> LifeLossTerminal    (training, ``life_loss_terminal``: above the bolt, which must
                              see whole games)
      -> VecTransposeImage   (training, ``normalize_reward``: below the normaliser, see
                              :func:`_transposed`)
      -> VecNormalize        (training, ``normalize_reward``: rewards only; with
                              ``split``, :class:`~noisybolt.wrappers.SplitRewardNormalize`:
                              the world's and the bolt's rewards apart)

Training, evaluation (periodic and ``noisybolt evaluate``) and case 4 build their envs
here, so the stack is written once. With ``world.workers`` the world at the bottom runs its
games in worker processes (:func:`make_run_world`); everything above it stays here. With
``world.overlap`` the training games are two groups, each this stack up to
``LifeLossTerminal`` (and ``VecTransposeImage``) over its share of the games and workers,
side by side in a :class:`~noisybolt.agents.pipeline.GroupedVecEnv`, whose rollouts the
learner collects overlapped (:mod:`noisybolt.agents.pipeline`); a normaliser sits on top
of the groups.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from typing import Any, Literal, overload

import numpy as np
from stable_baselines3.common.vec_env import VecEnv, VecMonitor, VecNormalize

from noisybolt.agents.hyperparams import SPLIT
from noisybolt.agents.pipeline import GroupedVecEnv, group_bounds
from noisybolt.bolt import BeliefSettings
from noisybolt.envs import SB3VecEnv, make_world
from noisybolt.envs.worker_world import WorkerWorld
from noisybolt.errors import ConfigError
from noisybolt.perception.classifier import ClassifierDetector
from noisybolt.perception.protocols import (
    FluentDetector,
)
from noisybolt.runs.config import TrainConfig
from noisybolt.runs.detectors import make_detector
from noisybolt.runs.play import (
    RANDOM_PLAY,
    belief_from_play,
    random_play_letters,
    warn_of_unseen_fluents,
)
from noisybolt.runs.world_checks import check_specs_against_world, check_world_spaces
from noisybolt.wrappers import BoltVecEnv, ClipGameReward, LifeLossTerminal, SplitRewardNormalize

__all__ = [
    "BoltSetup",
    "build_bolted_env",
    "make_env",
    "make_run_world",
    "prepare_bolt",
]

#: Evaluation worlds are seeded apart from the training ones.
EVAL_SEED_OFFSET = 10_000


@overload
def make_env(
    config: TrainConfig,
    detector: FluentDetector,
    *,
    training: Literal[False],
    n_envs: int | None = None,
    seed: int | None = None,
    dfas: Sequence[Any] | None = None,
    letters: np.ndarray | None = None,
    belief: BeliefSettings | None = None,
) -> BoltVecEnv: ...


@overload
def make_env(
    config: TrainConfig,
    detector: FluentDetector,
    *,
    training: bool,
    n_envs: int | None = None,
    seed: int | None = None,
    dfas: Sequence[Any] | None = None,
    letters: np.ndarray | None = None,
    belief: BeliefSettings | None = None,
) -> VecEnv: ...


def make_env(
    config: TrainConfig,
    detector: FluentDetector,
    *,
    training: bool,
    n_envs: int | None = None,
    seed: int | None = None,
    dfas: Sequence[Any] | None = None,
    letters: np.ndarray | None = None,
    belief: BeliefSettings | None = None,
) -> VecEnv:
    """The run's environments with every wrapper, in the order the module docstring draws.

    Args:
        config: the run.
        detector: the bolt's fluent detector.
        training: the learner's envs (the Atari conventions and the reward normaliser on
            top) or evaluation envs (the bolted world alone).
        n_envs: environments (default: ``config.world_config.n_envs`` for training, else
            ``config.evaluation.envs``).
        seed: seeds the worlds (default: the run's seed; evaluation ``+ 10,000``).
        dfas: the specs' DFAs, if compiled already (:class:`BoltSetup`).
        letters: see :class:`BoltSetup`.
        belief: belief tracking's settings with the base rates estimated from play
            (:class:`BoltSetup`); None: ``config.belief_settings``.

    Raises:
        ConfigError: ``life_loss_terminal`` for a world without lives.
    """
    if n_envs is None:
        n_envs = config.world_config.n_envs if training else config.evaluation.envs
    if seed is None:
        seed = config.seed + (0 if training else EVAL_SEED_OFFSET)
    settings: dict[str, Any] = {
        "seed": seed,
        "dfas": dfas,
        "training": training,
        "letters": letters,
        "belief": belief,
    }
    if not training:
        return build_bolted_env(config, detector, n_envs=n_envs, **settings)
    env: VecEnv
    if config.world_config.overlap:
        env = _overlapped_groups(config, detector, n_envs=n_envs, **settings)
    else:
        bolted = build_bolted_env(config, detector, n_envs=n_envs, **settings)
        env = _learner_wrappers(config, bolted)
    if config.algorithm.hyperparams.get("normalize_reward"):
        # Transpose images *below* the normaliser: SB3 would put its VecTransposeImage on
        # top, and off-policy replay buffers, which store VecNormalize's original (here:
        # untransposed) observations, then get the wrong shape (DQN crashed).
        env = _transposed(env)
        gamma = config.algorithm.hyperparams.get("gamma", 0.99)
        if config.algorithm.hyperparams["normalize_reward"] == SPLIT:
            # An unbolted run's bolt pays nothing: there is nothing to mix, and its world
            # rewards are normalised as the control of any weight's run (weight 1).
            weight = config.algorithm.hyperparams.get("bolt_weight")
            if weight is None or not config.bolt.bolted:
                weight = 1.0
            env = SplitRewardNormalize(env, gamma=gamma, bolt_weight=weight)
        else:
            env = VecNormalize(env, norm_obs=False, norm_reward=True, gamma=gamma)
    return env


def _overlapped_groups(
    config: TrainConfig, detector: FluentDetector, *, n_envs: int, **settings: Any
) -> GroupedVecEnv:
    """``world.overlap``: the training games as two groups, each its own bolted stack over
    its share of the world's games (``shard``) and of its workers.

    A reward normaliser goes on top of the groups, as on top of the world in process
    (:func:`make_env`; the collector hands it the groups' joined steps).

    Raises:
        ConfigError: fewer than 2 games.
    """
    if n_envs < 2:
        raise ConfigError(f"world.overlap splits the games into two groups: n_envs is {n_envs}")
    workers = config.world_config.workers
    groups: list[VecEnv] = []
    try:
        for (first, count), (_, group_workers) in zip(
            group_bounds(n_envs, 2), group_bounds(workers, 2), strict=True
        ):
            bolted = build_bolted_env(
                config,
                detector,
                n_envs=count,
                shard=(first, n_envs),
                workers=min(group_workers, count),
                **settings,
            )
            groups.append(_transposed(_learner_wrappers(config, bolted)))
    except BaseException:
        for group in groups:
            group.close()
        raise
    return GroupedVecEnv(groups)


def _learner_wrappers(config: TrainConfig, bolted: BoltVecEnv) -> VecEnv:
    """The training wrappers above the bolt: ``life_loss_terminal``."""
    env: VecEnv = bolted
    if config.world_config.life_loss_terminal:
        lives = getattr(bolted.world, "lives", None)
        if not callable(lives):
            raise ConfigError(
                f"life_loss_terminal: the {config.world_config.name!r} world has no lives (it "
                "needs a "
                "lives() method); remove the hyperparameter"
            )
        env = LifeLossTerminal(env, lives)
    return env


def build_bolted_env(
    config: TrainConfig,
    detector: FluentDetector,
    *,
    n_envs: int,
    seed: int,
    dfas: Sequence[Any] | None = None,
    training: bool = False,
    letters: np.ndarray | None = None,
    belief: BeliefSettings | None = None,
    shard: tuple[int, int] | None = None,
    workers: int | None = None,
) -> BoltVecEnv:
    """The world as an SB3 ``VecEnv``, monitored, with the bolt on top.

    The Atari conventions of the ``world`` section: ``fire_on_reset`` is part of the
    world (training and evaluation alike); ``clip_reward`` (the game's score clipped to
    its sign, below the bolt) only when ``training``; ``life_loss_terminal`` is added
    above the bolt by :func:`train` (see :mod:`noisybolt.wrappers.atari`).
    ``letters``: the world's true fluents seen in random play (:class:`BoltSetup`), for
    the compliance scheme's progress terms. ``world.workers``, ``shard``, ``workers``: see
    :func:`make_run_world`.
    """
    world = make_run_world(
        config,
        n_envs=n_envs,
        seed=seed,
        shard=shard,
        workers=workers,
        detector=detector,
        images=not training,  # a learner's bolt reads the probabilities only
        training=training,
    )
    venv: VecEnv = VecMonitor(SB3VecEnv(world))
    if training and config.world_config.clip_reward:
        venv = ClipGameReward(venv)
    settings = config.bolt.settings
    if belief is not None:
        settings = replace(settings, belief=belief)
    return BoltVecEnv(
        venv,
        config.spec_objects(),
        detector,
        world=world,
        dfas=dfas,
        settings=settings,
        world_letters=letters,
        # The learner reads none of the per-step records; evaluation's envs keep them.
        info_records=not training,
        # What a replay of the bolt's transitions reads (algorithm.counterfactual).
        transition_records=training and config.algorithm.counterfactual,
    )


def make_run_world(
    config: TrainConfig,
    *,
    n_envs: int,
    seed: int,
    shard: tuple[int, int] | None = None,
    workers: int | None = None,
    detector: FluentDetector | None = None,
    images: bool = True,
    training: bool = False,
) -> Any:
    """The run's vectorised world: in this process, or with ``world.workers`` N >= 1 its
    games split over N worker processes (at most one per game; a
    :class:`~noisybolt.envs.worker_world.WorkerWorld`, which plays the same games as the
    world in process). A classifier ``detector`` then runs in the workers too, beside the
    camera (the bolt reads its probabilities from ``info``); any other stays with the bolt.

    ``shard=(first, total)``: these ``n_envs`` games are games ``first`` .. of the world
    of ``total`` games with this seed (a group of ``world.overlap``), in ``workers``
    processes (default: ``world.workers``). ``images=False``: where a classifier runs in
    the workers, the camera's images stay there (only its probabilities come back; no
    one here may read ``info["bolt_image"]``). ``training``: the learner's games, built
    with ``world.train_kwargs`` over ``world.kwargs``.

    Raises:
        ConfigError: a world that cannot be split into worker processes (its factory
            takes no ``shard``), or a bad world setting.
    """
    if workers is None:
        workers = config.world_config.workers
    settings = config.learner_world_settings if training else config.world_settings
    if not workers:
        place: dict[str, Any] = {} if shard is None else {"shard": shard}
        return make_world(config.world_config.name, num_envs=n_envs, seed=seed, **place, **settings)
    classifier = detector if isinstance(detector, ClassifierDetector) else None
    return WorkerWorld(
        config.world_config.name,
        num_envs=n_envs,
        workers=min(workers, n_envs),
        seed=seed,
        shard=shard,
        detector=classifier,
        images=images or classifier is None,
        **settings,
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
        belief: under belief tracking, the run's settings with each fluent's base rate
            in play estimated from the detector's outputs on seeded random play, without
            ground truth (:func:`belief_from_play`); None under threshold tracking.
    """

    fluents: tuple[str, ...]
    dfas: list[Any]
    detector: FluentDetector
    letters: np.ndarray | None = None
    belief: BeliefSettings | None = None


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
        UnseenFluentError: a classifier's images never show a fluent the specs use true
            (or never false).
    """
    probe: Any = make_world(
        config.world_config.name, num_envs=1, seed=seed, **config.world_config.kwargs
    )
    fluents, camera_spec = tuple(probe.fluent_names), probe.camera_spec
    monotone = tuple(getattr(probe, "monotone_fluents", ()))
    try:  # before a classifier is trained for a run that cannot start
        check_world_spaces(config, probe)
    finally:
        probe.close()
    dfas = check_specs_against_world(config, fluents, log=log)
    spec_fluents = tuple(f for f in fluents if any(f in d.relevant_fluents for d in dfas))
    detector = make_detector(
        config.detector,
        world=config.world_config.name,
        world_kwargs=config.world_config.kwargs,
        fluent_names=fluents,
        camera_spec=camera_spec,
        progress=progress,
        log=log,
        retrain=retrain_classifier,
        # what the specs depend on: a classifier that never saw one of these is refused
        spec_fluents=spec_fluents,
    )
    letters = None
    if config.progress_gamma is not None:
        letters = random_play_letters(config)
    if letters is not None and not isinstance(detector, ClassifierDetector):
        # What the compliance scheme's random play showed (a classifier's images are
        # checked by make_detector); the paper scheme plays none, and is not checked here.
        warn_of_unseen_fluents(letters, fluents, spec_fluents, play=RANDOM_PLAY)
    belief = None
    if config.belief_settings is not None:
        if isinstance(detector, ClassifierDetector) and detector.training_prior is None:
            log(
                "belief tracking: this classifier file does not record the label "
                "frequencies it was trained on; its prior is taken as 0.5 (train it again "
                "with --retrain-classifier to record them)"
            )
        belief = belief_from_play(
            config,
            detector,
            monotone=monotone,
            spec_fluents=spec_fluents,
        )
        rates = np.broadcast_to(np.asarray(belief.base_rates, dtype=float), (len(fluents),))
        log(
            "belief tracking: base rates in play, estimated from the detector on random "
            "play (no ground truth): "
            + ", ".join(f"{f} {r:.3f}" for f, r in zip(fluents, rates, strict=True))
            + (
                f"; monotone (true once, true to the episode's end): {', '.join(belief.monotone)}"
                if belief.monotone
                else ""
            )
        )
    return BoltSetup(fluents=fluents, dfas=dfas, detector=detector, letters=letters, belief=belief)


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
