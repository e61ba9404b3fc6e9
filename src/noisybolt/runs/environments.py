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

import warnings
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, replace
from typing import Any, Literal, overload

import numpy as np
from stable_baselines3.common.vec_env import VecEnv, VecMonitor, VecNormalize

from noisybolt.runs.config import TrainConfig
from noisybolt.runs.detectors import make_detector
from noisybolt.agents.hyperparams import SPLIT
from noisybolt.agents.pipeline import GroupedVecEnv, group_bounds
from noisybolt.runs.world_checks import check_specs_against_world, check_world_spaces
from noisybolt.bolt import BeliefSettings, Thresholds
from noisybolt.bolt.belief import frames_to_believe
from noisybolt.envs import SB3VecEnv, make_world
from noisybolt.envs.worker_world import WorkerWorld
from noisybolt.errors import BriefFluentWarning, ConfigError, UnseenFluentWarning
from noisybolt.perception.classifier import ClassifierDetector
from noisybolt.perception.protocols import (
    BOLT_IMAGE_KEY,
    FINAL_INFO_KEY,
    TRUE_FLUENTS_KEY,
    FluentDetector,
)
from noisybolt.wrappers import BoltVecEnv, ClipGameReward, LifeLossTerminal, SplitRewardNormalize

__all__ = [
    "BoltSetup",
    "build_bolted_env",
    "make_env",
    "make_run_world",
    "prepare_bolt",
    "true_runs",
    "warn_of_brief_runs",
    "warn_of_unseen_fluents",
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
        n_envs: environments (default: ``config.n_envs`` for training, else
            ``config.eval_envs``).
        seed: seeds the worlds (default: the run's seed; evaluation ``+ 10,000``).
        dfas: the specs' DFAs, if compiled already (:class:`BoltSetup`).
        letters: see :class:`BoltSetup`.
        belief: belief tracking's settings with the base rates estimated from play
            (:class:`BoltSetup`); None: ``config.belief_settings``.

    Raises:
        ConfigError: ``life_loss_terminal`` for a world without lives.
    """
    if n_envs is None:
        n_envs = config.n_envs if training else config.eval_envs
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
    if config.hyperparams.get("normalize_reward"):
        # Transpose images *below* the normaliser: SB3 would put its VecTransposeImage on
        # top, and off-policy replay buffers, which store VecNormalize's original (here:
        # untransposed) observations, then get the wrong shape (DQN crashed).
        env = _transposed(env)
        gamma = config.hyperparams.get("gamma", 0.99)
        if config.hyperparams["normalize_reward"] == SPLIT:
            # An unbolted run's bolt pays nothing: there is nothing to mix, and its world
            # rewards are normalised as the control of any weight's run (weight 1).
            weight = config.hyperparams.get("bolt_weight")
            if weight is None or not config.bolted:
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
                f"life_loss_terminal: the {config.world!r} world has no lives (it needs a "
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
    return BoltVecEnv(
        venv,
        config.spec_objects(),
        detector,
        world=world,
        dfas=dfas,
        thresholds=Thresholds(**config.thresholds),
        cost_mode=config.cost_mode,  # type: ignore[arg-type]
        tracking=config.tracking,  # type: ignore[arg-type]
        belief=belief if belief is not None else config.belief_settings,
        progress_gamma=config.progress_gamma,
        shaping=config.shaping,
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
        return make_world(config.world, num_envs=n_envs, seed=seed, **place, **settings)
    classifier = detector if isinstance(detector, ClassifierDetector) else None
    return WorkerWorld(
        config.world,
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
    probe: Any = make_world(config.world, num_envs=1, seed=seed, **config.world_kwargs)
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
        world=config.world,
        world_kwargs=config.world_kwargs,
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
        letters = _random_play_letters(config)
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


#: Random play that the base-rate estimate reads: envs x steps frames.
BASE_RATE_PLAY = (16, 128)


def belief_from_play(
    config: TrainConfig,
    detector: FluentDetector,
    *,
    n_envs: int = BASE_RATE_PLAY[0],
    steps: int = BASE_RATE_PLAY[1],
    monotone: Sequence[str] = (),
    spec_fluents: Sequence[str] = (),
) -> BeliefSettings:
    """``config.belief_settings`` with base rates estimated from seeded random play, and
    the fluents the world declares ``monotone`` (its ``monotone_fluents``: true once, true
    for the rest of the episode, as Breakout's bricks gone).

    The detector's probabilities on ``n_envs * steps`` frames of the bolt's camera in
    random play (seeded by the run's seed: training and evaluation estimate the same) go
    through the EM of Saerens et al. (:func:`~noisybolt.perception.base_rates.
    belief_settings_from_play`): no ground truth is read unless the detector itself reads
    it (the oracle and the synthetic detector). A trained classifier's probabilities carry
    the label frequencies of its training images (:attr:`ClassifierDetector.
    training_prior`); the other detectors' are taken as balanced (0.5).

    Random play is not the trained agent's play: a fluent random play rarely shows (a
    far corner) gets a small rate, floored at ``min_base_rate`` (0.01) so that the bolt
    still believes a trained agent that shows it clearly.

    Warns (:class:`~noisybolt.errors.BriefFluentWarning`) where one of ``spec_fluents`` is
    true in random play for fewer frames in a row than the resulting settings need to
    believe it even from a perfect detector (:func:`~noisybolt.bolt.belief.
    frames_to_believe`): a check of the world against the model, reading the world's
    labels as the classifier checks do; the estimate itself reads none.
    """
    from noisybolt.perception.base_rates import belief_settings_from_play

    settings = config.belief_settings
    assert settings is not None, "belief_from_play is for belief tracking"
    frames = []
    # Per env, its frames in time order (each ended episode's last view included) and
    # whether each is an episode's last.
    sequences: list[list[np.ndarray]] = [[] for _ in range(n_envs)]
    last: list[list[bool]] = [[] for _ in range(n_envs)]
    for info, ended in _random_play_infos(config, seed=config.seed + 1, n_envs=n_envs, steps=steps):
        rows, views = _final_views(info, ended, (BOLT_IMAGE_KEY, TRUE_FLUENTS_KEY))
        viewed = set(rows.tolist())
        if views:  # the states the ended episodes reached
            final_images, final_truth = views[BOLT_IMAGE_KEY], views[TRUE_FLUENTS_KEY]
            seen = final_truth if detector.needs_truth else None
            frames.append(detector.predict(final_images, truth=seen))
            for row, row_truth in zip(rows, final_truth, strict=True):
                sequences[row].append(row_truth)
                last[row].append(True)
        truth = np.asarray(info[TRUE_FLUENTS_KEY], dtype=bool)
        seen_truth = truth if detector.needs_truth else None
        frames.append(detector.predict(np.asarray(info[BOLT_IMAGE_KEY]), truth=seen_truth))
        for row in range(n_envs):
            if ended[row] and row not in viewed:  # no last view given: it ended here
                last[row][-1] = True
            sequences[row].append(truth[row])
            last[row].append(False)
    # A trained classifier's label frequencies; a user's detector may state its own.
    prior = getattr(detector, "training_prior", None)
    estimated = belief_settings_from_play(
        [np.concatenate(frames)],
        training_prior=0.5 if prior is None else prior,
        confidence=settings.confidence,
        min_dwell=settings.min_dwell,
        monotone=tuple(settings.monotone) or tuple(monotone),
    )
    fluents = tuple(detector.fluent_names)
    for fluent in spec_fluents:
        column = fluents.index(fluent)
        lengths, at_end = [], []
        for sequence, ends in zip(sequences, last, strict=True):
            run_lengths, run_ends = true_runs(
                np.array([t[column] for t in sequence], dtype=bool), np.array(ends, dtype=bool)
            )
            lengths += run_lengths.tolist()
            at_end += run_ends.tolist()
        warn_of_brief_runs(
            estimated, fluents, fluent, np.array(lengths, dtype=np.int64), np.array(at_end)
        )
    return estimated


def _final_views(
    info: dict[str, Any], ended: np.ndarray, keys: tuple[str, ...]
) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """The rows that ended whose last views ``info["final_info"]`` gives under every one
    of ``keys``, and those views (true fluents as bool); no rows and ``{}`` where no
    episode ended or the world gives none (the step's own view is then its last)."""
    final = info.get(FINAL_INFO_KEY)
    if not ended.any() or not isinstance(final, dict) or any(k not in final for k in keys):
        return np.zeros(0, dtype=np.intp), {}
    rows = ended.copy()
    for key in keys:
        mask = final.get(f"_{key}")
        if mask is not None:
            rows &= np.asarray(mask, dtype=bool)
    index = np.flatnonzero(rows)
    if index.size == 0:
        return index, {}
    views = {key: np.asarray(final[key])[index] for key in keys}
    if TRUE_FLUENTS_KEY in views:
        views[TRUE_FLUENTS_KEY] = views[TRUE_FLUENTS_KEY].astype(bool)
    return index, views


def true_runs(truth: np.ndarray, last: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """The runs of True in one env's frames ``truth`` (bool ``[frames]``, in time order;
    ``last`` marks each episode's last frame, after which the next episode starts).

    A run is counted when it is whole within the frames: it begins at an episode's first
    frame or after a False one, and ends before a False frame or at an episode's end (a
    run still going when the frames stop is not counted).

    Returns:
        ``(lengths, at_end)``: int64 ``[n_runs]`` lengths, and bool ``[n_runs]`` whether
        each run lasted to its episode's last frame.

    Example:
        >>> true_runs(np.array([1, 0, 1, 1, 0, 1, 1], dtype=bool),
        ...           np.array([0, 0, 0, 1, 0, 0, 0], dtype=bool))
        (array([1, 2]), array([False,  True]))
    """
    truth = np.asarray(truth, dtype=bool)
    last = np.zeros(len(truth), dtype=bool) if last is None else np.asarray(last, dtype=bool)
    lengths: list[int] = []
    at_end: list[bool] = []
    run = 0
    for t, on in enumerate(truth):
        if on:
            run += 1
            if last[t]:
                lengths.append(run)
                at_end.append(True)
                run = 0
        else:
            if run:
                lengths.append(run)
                at_end.append(False)
            run = 0
    return np.array(lengths, dtype=np.int64), np.array(at_end, dtype=bool)


def warn_of_brief_runs(
    settings: BeliefSettings,
    fluents: Sequence[str],
    fluent: str,
    runs: np.ndarray,
    at_end: np.ndarray | None = None,
) -> None:
    """Warns (:class:`BriefFluentWarning`) if some of ``runs`` (lengths of ``fluent``'s
    true runs in play; ``at_end``: whether each lasted to its episode's end, where no
    later frame can refute it) are shorter than belief tracking under ``settings`` needs."""
    if len(runs) == 0:
        return
    at_end = np.zeros(len(runs), dtype=bool) if at_end is None else np.asarray(at_end, bool)
    needed, single = frames_to_believe(settings, fluents, fluent)
    needed_at_end, _ = frames_to_believe(settings, fluents, fluent, after=0)

    def short(need: int | None, where: np.ndarray) -> np.ndarray:
        return where & (runs < need) if need is not None else where

    brief_mask = short(needed, ~at_end) | short(needed_at_end, at_end)
    brief = runs[brief_mask]
    if len(brief) == 0:
        return
    if needed is None:
        need = f"does not believe {fluent} within 8 frames in a row"
    else:
        need = f"believes {fluent} only after {needed} frames of it in a row"
    ending = int((brief_mask & at_end).sum())
    ends = f", {ending} of them as the episode ended" if ending else ""
    shortest = int(brief.min())
    fix_with_one, _ = frames_to_believe(replace(settings, min_dwell=1), fluents, fluent)
    if settings.min_dwell > 1 and fix_with_one is not None and fix_with_one <= shortest:
        advice = (
            "with --min-dwell 1 (BeliefSettings(min_dwell=1)) a perfect detector's "
            f"{fix_with_one} frame(s) would be, a noisy detector's may still not be; "
            "threshold tracking (--tracking threshold) believes a single frame"
        )
    else:
        advice = (
            "threshold tracking (--tracking threshold) credits them; belief tracking "
            "needs the world to show it longer"
        )
    warnings.warn(
        BriefFluentWarning(
            f"belief tracking: in random play, {fluent} was true for fewer frames in a row "
            f"than the bolt needs in {len(brief)} of its {len(runs)} visits (the shortest "
            f"{shortest}{ends}); under these settings (base rate "
            f"{_rate_of(settings, fluents, fluent)}, min_dwell {settings.min_dwell}, "
            f"confidence {settings.confidence:g}) the bolt {need}, even from a perfect "
            f"detector (one frame: P = {single:g}), so a spec met only on such a visit is "
            f"never credited; {advice}"
        ),
        stacklevel=2,
    )


def _rate_of(settings: BeliefSettings, fluents: Sequence[str], fluent: str) -> str:
    return f"{settings.resolve(fluents).rates[list(fluents).index(fluent)]:.3f}"


#: Random play that the letters a world shows are read from: envs x steps frames.
RANDOM_PLAY = (16, 128)


def warn_of_unseen_fluents(
    letters: np.ndarray,
    fluents: Sequence[str],
    spec_fluents: Sequence[str],
    *,
    play: tuple[int, int],
) -> None:
    """Warns (:class:`~noisybolt.errors.UnseenFluentWarning`) of each fluent of
    ``spec_fluents`` that is true in none, or in all, of ``letters`` (bool ``[n,
    n_fluents]``, the assignments random play showed: ``play`` = (games, steps each), so
    only the first steps of a long episode): a fluent function that never holds (a typo,
    a state never reached) leaves a spec the bolt can never credit, which training would
    only show as 0 % compliance; one that holds only late in an episode is reported too,
    and the message says how far the play went.

    Example:
        >>> import warnings
        >>> seen = np.array([[True, False], [True, False]])
        >>> with warnings.catch_warnings(record=True) as caught:
        ...     warnings.simplefilter("always")
        ...     warn_of_unseen_fluents(seen, ["a", "won"], ["won"], play=(16, 128))
        >>> print(caught[0].message)  # doctest: +ELLIPSIS
        the specs' fluent won was never true in 16 games of random play, in the first 128 ...
    """
    games, steps = play
    never: dict[str, list[str]] = {"true": [], "false": []}
    for fluent in spec_fluents:
        column = letters[:, list(fluents).index(fluent)]
        if column.all() == column.any():
            never["false" if column.any() else "true"].append(fluent)
    for value, names in never.items():
        if not names:
            continue
        other = "false" if value == "true" else "true"
        warnings.warn(
            UnseenFluentWarning(
                f"the specs' fluent{'s' if len(names) > 1 else ''} {', '.join(names)} "
                f"{'were' if len(names) > 1 else 'was'} never {value} in {games} games of "
                f"random play, in the first {steps} steps of each ({games * steps:,} "
                f"steps): a spec that needs {'them' if len(names) > 1 else 'it'} {value} "
                f"is met only if a trained agent makes it so (or only later in an episode), "
                f"and can never be if a fluent's function is always {other} (check it in "
                "the world's definition)"
            ),
            stacklevel=2,
        )


def _random_play_letters(
    config: TrainConfig, *, n_envs: int = RANDOM_PLAY[0], steps: int = RANDOM_PLAY[1]
) -> np.ndarray:
    """The distinct true-fluent assignments a world shows in ``n_envs * steps`` random
    steps (seeded by the run's seed, so training and evaluation see the same), the states
    ended episodes reached included (a goal true only as its episode ends)."""
    seen = []
    for info, ended in _random_play_infos(config, seed=config.seed, n_envs=n_envs, steps=steps):
        seen.append(np.asarray(info[TRUE_FLUENTS_KEY], dtype=bool))
        _, views = _final_views(info, ended, (TRUE_FLUENTS_KEY,))
        if views:
            seen.append(views[TRUE_FLUENTS_KEY])
    return np.unique(np.concatenate(seen), axis=0)


def _random_play_infos(
    config: TrainConfig, *, seed: int, n_envs: int, steps: int
) -> Iterator[tuple[dict[str, Any], np.ndarray]]:
    """The batched ``info`` of the world's reset and of ``steps`` seeded random steps,
    each with the rows whose episodes the step ended (bool ``[n_envs]``), each to be read
    before the next is asked for (a deferred camera value is valid only until the world
    moves on); the world is closed afterwards."""
    world: Any = make_world(config.world, num_envs=n_envs, seed=seed, **config.world_settings)
    try:
        yield world.reset(seed=seed)[1], np.zeros(n_envs, dtype=bool)
        world.action_space.seed(seed)
        for _ in range(steps):
            _, _, terminated, truncated, info = world.step(world.action_space.sample())
            yield info, np.logical_or(np.asarray(terminated), np.asarray(truncated))
    finally:
        world.close()


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
