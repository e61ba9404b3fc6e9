"""The bolt's fluent detector for a run: built from its :class:`DetectorConfig`, with the
on-the-fly classifier cached per world, camera and training recipe.

An on-the-fly classifier is checked before a run relies on it: its accuracy on fresh
held-out images, fluent by fluent. Where the worst fluent reads below
:data:`ACCEPT_ACCURACY`, another is trained (``detector.restarts``), from another seed and
on twice the images, and the best is kept. Why: under Breakout's occluding camera, 4,000
images made classifiers that read ``left_gone_row4`` with 0.85-0.90 accuracy on fresh
images in four seeds of five (0.97 in the fifth), and those read a trained agent's frames
where that brick was gone at p >= 0.5 in 10 % and 56 % of them (seeds 0 and 1), so that
belief tracking credited the milestone in 14 % and 86 % of the episodes that took it; on
8,000 images seeds 0 and 1 read every fluent at 0.975 or better, the agent's frames at
93-96 %, and belief tracking credited every milestone taken
(benchmarks/breakout_classifier_seeds.py, results/breakout/README.md).

A classifier is also checked against the fluents the run's specs use
(:func:`check_fluents_shown`): one that learnt from images in which such a fluent is never
true (or never false) could not see it, so the run is refused (``UnseenFluentError``), and
a fluent shown true or false in only a few images is warned of (``RareFluentWarning``).
The counts are saved with the classifier, so a cached one is checked again when another
run's specs use it; a file saved before they were is used unchecked.
"""

from __future__ import annotations

import hashlib
import json
import os
import warnings
from collections.abc import Callable, Collection, Mapping, Sequence
from dataclasses import asdict
from pathlib import Path
from typing import Any

import numpy as np

from noisybolt.envs import make_world
from noisybolt.envs.registry import is_factory_path, world_fingerprint
from noisybolt.errors import (
    ConfigError,
    DetectorFactoryError,
    LargeCameraWarning,
    NoisyboltError,
)
from noisybolt.perception import dataset
from noisybolt.perception.dataset import RARE_FLUENT_IMAGES, LabelCounts
from noisybolt.perception.detectors import TRUTH_DETECTORS, truth_detector
from noisybolt.perception.metrics import build_report
from noisybolt.perception.protocols import FluentDetector
from noisybolt.runs.config import DetectorConfig
from noisybolt.runs.sections import is_detector_factory

__all__ = [
    "ACCEPT_ACCURACY",
    "HELD_OUT_SAMPLES",
    "LARGE_CAMERA_SIDE",
    "RARE_FLUENT_IMAGES",
    "best_of_restarts",
    "check_fluents_shown",
    "classifier_architecture",
    "default_classifier_path",
    "make_detector",
    "restart_seed",
    "user_detector",
    "warn_of_large_camera",
]

#: An on-the-fly classifier whose worst fluent reaches this accuracy on the held-out
#: images is kept without training another (``detector.restarts``). Measured: Breakout
#: classifiers under the occluding camera whose worst fluent read 0.85 and 0.90 on fresh
#: images read a trained agent's frames where that brick was gone in 10 % and 56 % of
#: them, one at 0.97 in 93 %; the gridworld's regionally smudged corner reads about 0.95
#: at best (the camera makes it ambiguous), so a bar at 0.95 would retrain it for
#: nothing half the time.
ACCEPT_ACCURACY = 0.92
#: Fresh images the restarts are compared on (at most ``detector.samples``).
HELD_OUT_SAMPLES = 2000

_IF_RARE = "collect more images (--set detector.samples=N) or use --detector synthetic or oracle"
_WHAT_TO_DO = (
    "Use --detector synthetic or oracle (no classifier), collect more images (--set "
    "detector.samples=N), or use a world that shows the state while images are collected. "
    "Collection keeps the state after each random step and the last state of each episode "
    "random play ends (detector.final_views; a run saved before that setting existed keeps "
    "only the former, so a fluent true only as an episode ends is never collected for it); "
    "a state random play does not reach is never collected, but a vectorised world can "
    "jump to such states for collection (sample_collection_states, "
    "noisybolt.perception.dataset.SupportsCollectionStates), a FluentLabels world cannot"
)


def _cache_root() -> Path:
    root = os.environ.get("NOISYBOLT_CACHE_DIR")
    return Path(root) if root else Path.home() / ".cache" / "noisybolt"


def classifier_architecture(camera: Any) -> Any:
    """The classifier trained on the fly for a camera.

    A camera drawn in tiles (the gridworld's) gets a tile-reading first layer
    (``ClassifierConfig.patch``): a quarter of the default trunk's multiply-adds, which
    is most of the bolt's cost per training frame; other cameras get the default trunk.
    A tiled camera that also declares its grid's side (``extra["cells"]``: MinAtar's
    10x10 board) keeps every cell's features apart up to the head (``pool`` = cells):
    fluents about single cells (one brick of a column) need them. Averaged into 4x4 bins,
    three rows of bricks share two bins, and a classifier of MinAtar Breakout's camera
    took the left column's bottom two bricks gone for the whole column gone in nearly
    every such picture: a bolted agent learnt to be paid for that.
    """
    from noisybolt.perception.classifier import ClassifierConfig

    extra = camera.extra if isinstance(camera.extra, Mapping) else {}
    tile, cells = extra.get("tile_size"), extra.get("cells")
    if isinstance(tile, int) and tile > 1:
        if isinstance(cells, int) and cells > 0:
            return ClassifierConfig(channels=(32, 32), patch=tile, pool=cells)
        return ClassifierConfig(channels=(32, 32), patch=tile)
    return ClassifierConfig()


def default_classifier_path(
    world: str,
    config: DetectorConfig,
    camera: Any,
    architecture: Any,
    *,
    fingerprint: str | None = None,
    world_kwargs: Mapping[str, Any] | None = None,
) -> Path:
    """Where the on-the-fly classifier for this world, camera and recipe is cached.

    ``fingerprint`` (:func:`noisybolt.envs.registry.world_fingerprint`, taken for a
    factory-path world) keys it by what the fluents mean too: a user's world whose fluent
    definition changed under the same name gets a new classifier, not the old one.

    From ``detector.restarts`` on (a config whose ``restarts`` is not 1), the restarts and
    the ``world_kwargs`` the images are collected with key it too: two callers that build
    the collector differently (say, one with FIRE on reset) no longer share a file.
    Classifiers of one restart keep the names they had before. So does
    ``detector.final_views``, only where it is True: a classifier that also saw the ended
    episodes' last states learnt from other images, and the names of classifiers cached
    before it existed (False, by :data:`~noisybolt.runs.config.LEGACY_DEFAULTS`) stay
    as they were.
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
    if config.restarts != 1:  # one classifier keeps the name it had before restarts
        fields["restarts"] = config.restarts
        fields["world_kwargs"] = json.loads(
            json.dumps(dict(world_kwargs or {}), sort_keys=True, default=repr)
        )
    if config.final_views:  # classifiers collected without them keep their names
        fields["final_views"] = True
    digest = hashlib.sha256(json.dumps(fields, sort_keys=True).encode()).hexdigest()[:16]
    label = world.replace(":", ".")
    return _cache_root() / "classifiers" / f"{label}-{digest}.safetensors"


def check_fluents_shown(counts: LabelCounts, spec_fluents: Collection[str], *, source: str) -> None:
    """:func:`noisybolt.perception.dataset.check_fluents_shown`, saying what to do in
    the command line's terms (``--detector``, ``--set detector.samples=N``).

    Example:
        >>> counts = LabelCounts(images=800, positives={"has_key": 401, "at_goal": 0})
        >>> check_fluents_shown(counts, ["has_key"], source="the images")
        >>> check_fluents_shown(counts, ["at_goal"], source="the images")  # doctest: +ELLIPSIS
        Traceback (most recent call last):
        ...
        noisybolt.errors.UnseenFluentError: the images never show 'at_goal' true, and a spec ...
    """
    dataset.check_fluents_shown(
        counts, spec_fluents, source=source, what_to_do=_WHAT_TO_DO, if_rare=_IF_RARE
    )


#: Seconds between two of :func:`epoch_log`'s lines.
EPOCH_LOG_EVERY_S = 30.0


def epoch_log(
    epochs: int, log: Callable[[str], None], *, every_s: float = EPOCH_LOG_EVERY_S
) -> Callable[[Any], None]:
    """An ``on_epoch`` for :func:`~noisybolt.perception.training.train_classifier` that,
    without a progress bar, says how training goes: a line at most every ``every_s``
    seconds of training, and at the last epoch.

    Example:
        >>> from noisybolt.perception.training import EpochStats
        >>> lines = []
        >>> report = epoch_log(30, lines.append)
        >>> for epoch, seconds in ((1, 10.0), (2, 31.0), (3, 40.0), (30, 45.0)):
        ...     report(EpochStats(epoch, 0.1, 0.1, (0.9, 0.97), seconds))
        >>> for line in lines:
        ...     print(line)
        classifier: epoch 2/30, worst fluent 0.900 on validation images, 31 s
        classifier: epoch 30/30, worst fluent 0.900 on validation images, 45 s
    """
    last = [0.0]

    def report(stats: Any) -> None:
        if stats.seconds - last[0] >= every_s or stats.epoch >= epochs:
            last[0] = stats.seconds
            log(
                f"classifier: epoch {stats.epoch}/{epochs}, worst fluent "
                f"{min(stats.validation_accuracy):.3f} on validation images, "
                f"{stats.seconds:.0f} s"
            )

    return report


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
    spec_fluents: Collection[str] = (),
) -> FluentDetector:
    """Builds the detector; a classifier is loaded (checked against the world) or trained.

    ``retrain`` trains the cached on-the-fly classifier again even if one is cached.
    ``spec_fluents``, the fluents the run's specs depend on, are checked in the images a
    classifier learns (or learnt) from (:func:`check_fluents_shown`): a freshly collected
    set is refused before a classifier is trained on it, so nothing is cached; a file whose
    counts were not saved with it (written before they were) is used unchecked.

    Raises:
        ConfigError: ``retrain`` with a classifier file given (``config.path``);
            ``low_confidence`` for a detector other than the synthetic one, or naming a
            fluent the world lacks; ``path`` for a detector other than the classifier.
        UnseenFluentError: a fluent of ``spec_fluents`` the classifier's images never
            show true, or never false.
    """
    from noisybolt.perception.classifier import load_classifier
    from noisybolt.perception.training import recorded_label_counts

    if config.low_confidence and config.kind != "synthetic":
        raise ConfigError(
            f"detector.low_confidence (--low-confidence {' '.join(config.low_confidence)}) "
            f"sets what the synthetic detector sees with low confidence; the {config.kind} "
            "detector would ignore it: use --detector synthetic, or leave it out"
        )
    if config.path and config.kind != "classifier":
        raise ConfigError(
            f"detector.path (--classifier {config.path}) is a classifier file; the "
            f"{config.kind} detector would ignore it: use --detector classifier, or leave "
            "it out"
        )
    unknown = sorted(set(config.low_confidence) - set(fluent_names))
    if unknown:
        raise ConfigError(
            f"detector.low_confidence (--low-confidence) names {unknown}, which the world "
            f"{world!r} does not have; its fluents are {list(fluent_names)}"
        )
    if is_detector_factory(config.kind):
        return user_detector(
            config.kind,
            fluent_names=fluent_names,
            camera_spec=camera_spec,
            seed=config.seed,
            kwargs=config.kwargs,
        )
    if config.kind in TRUTH_DETECTORS:
        return truth_detector(
            config.kind, fluent_names, seed=config.seed, low_confidence=config.low_confidence
        )
    if int(camera_spec.height) * int(camera_spec.width) <= 1:
        raise ConfigError(
            f"the world {world!r} shows the bolt no image (FluentLabels(..., camera=False), "
            "or a 1x1 camera): a classifier has nothing to read; use --detector oracle, "
            "synthetic or your own that reads the truth, or give the world a camera"
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
            fingerprint=world_fingerprint(world, dict(world_kwargs), final_views=config.final_views)
            if is_factory_path(world)
            else None,
            world_kwargs=world_kwargs,
        )
    )
    if retrain and config.path is not None:
        raise ConfigError(
            "retraining applies to the cached classifier; a classifier file is used as given"
        )
    if config.path is not None and not path.is_file():
        raise ConfigError(
            f"the classifier file {path} does not exist; give the path of one saved by "
            "`noisybolt classifiers train` (or omit --classifier to use the cached one)"
        )
    if config.path is None and (retrain or not path.exists()):
        warn_of_large_camera(camera_spec, samples=config.samples, epochs=config.epochs)
        why = "retraining it" if retrain else "no cached classifier for this camera"
        log(f"{why}: training one ({path})")
        _train_classifier_on_the_fly(
            path,
            config,
            architecture,
            world=world,
            world_kwargs=world_kwargs,
            spec_fluents=spec_fluents,
            progress=progress,
            log=log,
        )
    detector = load_classifier(path, fluent_names=fluent_names, camera_spec=camera_spec)
    counts = recorded_label_counts(detector.training, detector.fluent_names)
    if counts is not None:  # None: a file saved before the counts were (used as before)
        which = "classifier file" if config.path is not None else "cached classifier"
        check_fluents_shown(
            counts,
            spec_fluents,
            source=f"the {counts.images:,} images the {which} {path} was trained on",
        )
    return detector


def user_detector(
    path: str,
    *,
    fluent_names: Sequence[str],
    camera_spec: Any,
    seed: int,
    kwargs: Mapping[str, Any] | None = None,
) -> FluentDetector:
    """The detector a user's factory path (``--detector mydetectors:noisy``) makes.

    The function is imported as a world factory is (the current directory searched too)
    and called with those of the keywords ``fluent_names`` (the world's, in its column
    order), ``camera_spec`` (the bolt camera's :class:`~noisybolt.perception.protocols.
    CameraSpec`) and ``seed`` (``detector.seed``, the run's seed unless set) that it names
    (all of them if it takes ``**kwargs``), and with ``kwargs`` (``detector.kwargs``), all
    of which it must take. It returns a
    :class:`~noisybolt.perception.protocols.FluentDetector`: ``fluent_names``,
    ``needs_truth`` (True to be handed the world's true fluents, e.g. a noisy sensor
    simulated from them) and ``predict(images, *, truth=None)`` giving probabilities
    ``[n, n_fluents]``; optionally ``training_prior`` (each fluent's frequency in what it
    was trained on, which belief tracking divides out; 0.5 if absent). Its fluents may be
    in any order and include others: they are matched to the world's by name.

    Raises:
        DetectorFactoryError: the path does not import or name a callable, the call
            fails, or it returns something that is not a detector.
        IncompatibleError: the detector lacks some of the world's fluents.
    """
    import inspect

    from noisybolt.envs.registry import resolve_factory
    from noisybolt.perception.detectors import match_fluents

    factory = resolve_factory(path, what="detector", error=DetectorFactoryError)
    offered = {"fluent_names": tuple(fluent_names), "camera_spec": camera_spec, "seed": seed}
    try:
        parameters = inspect.signature(factory).parameters
    except (TypeError, ValueError):  # a builtin without a signature: offer everything
        parameters = None
    if parameters is not None and not any(
        p.kind is inspect.Parameter.VAR_KEYWORD for p in parameters.values()
    ):
        offered = {key: value for key, value in offered.items() if key in parameters}
        unknown = sorted(set(kwargs or {}) - set(parameters))
        if unknown:
            raise DetectorFactoryError(
                f"detector {path!r} takes no keyword {', '.join(map(repr, unknown))} "
                f"(detector.kwargs); it takes {list(parameters)}",
                path=path,
            )
    clash = sorted(set(kwargs or {}) & {"fluent_names", "camera_spec", "seed"})
    if clash:
        raise DetectorFactoryError(
            f"detector.kwargs {clash} would replace what the run hands the detector; "
            "set detector.seed for the seed, and leave the world's fluents and camera to it",
            path=path,
        )
    offered.update(kwargs or {})
    try:
        detector = factory(**offered)
    except NoisyboltError:
        raise
    except Exception as exc:
        raise DetectorFactoryError(
            f"detector {path!r}: calling it with {sorted(offered) or 'no arguments'} failed "
            f"({type(exc).__name__}: {exc}); it is called with those of fluent_names, "
            "camera_spec and seed that it names, and detector.kwargs (--set "
            "detector.kwargs.NAME=VALUE) for any other argument",
            path=path,
        ) from exc
    if not isinstance(detector, FluentDetector):
        raise DetectorFactoryError(
            f"detector {path!r} returned {type(detector).__name__!r}, not a fluent detector: "
            "it needs fluent_names, needs_truth and predict(images, *, truth=None) "
            "(noisybolt.perception.protocols.FluentDetector)",
            path=path,
        )
    return match_fluents(detector, fluent_names)


def restart_seed(seed: int, restart: int) -> int:
    """The seed of an on-the-fly classifier's ``restart``-th training (0: ``seed`` itself,
    so one restart is the classifier of old; the others far from any run's seed)."""
    if restart == 0:
        return seed
    return int(np.random.SeedSequence([seed, restart]).generate_state(1)[0])


def best_of_restarts(
    train_one: Callable[[int], Any],
    held_out: Callable[[], Any],
    *,
    restarts: int,
    log: Callable[[str], None] = print,
) -> Any:
    """Trains up to ``restarts`` classifiers (``train_one(restart)``) and keeps the one
    whose worst fluent is most accurate on the held-out dataset (``held_out()``, built
    once, when a second classifier is to be compared), stopping early once one reaches
    :data:`ACCEPT_ACCURACY`.
    """
    best, best_worst = None, -1.0
    data = None
    for restart in range(restarts):
        detector = train_one(restart)
        if restarts == 1:
            return detector
        if data is None:
            data = held_out()
        report = build_report(
            detector.predict(data.images), data.labels, fluent_names=detector.fluent_names
        )
        worst = report.min_accuracy
        weakest = min(report.fluents, key=lambda fluent: fluent.accuracy).name
        log(
            f"classifier {restart + 1} of at most {restarts}: held-out accuracy "
            f"{worst:.3f} at worst ({weakest})"
        )
        if worst > best_worst:
            best, best_worst = detector, worst
        if worst >= ACCEPT_ACCURACY:
            break
    return best


#: The most pixels on a side of a camera a classifier is trained on without a warning
#: (the shipped worlds' cameras: 48 and 84).
LARGE_CAMERA_SIDE = 128


def warn_of_large_camera(camera: Any, *, samples: int, epochs: int) -> None:
    """Warns (:class:`~noisybolt.errors.LargeCameraWarning`) before a classifier is
    trained on the fly on a camera larger than :data:`LARGE_CAMERA_SIDE` on a side: a
    user's env's full render (Pendulum's 500x500) costs its convolutions about 35 times
    an 84x84 image's, so training takes hours on a CPU and looks like a hang."""
    height, width = int(camera.height), int(camera.width)
    if max(height, width) <= LARGE_CAMERA_SIDE:
        return
    step = -(-max(height, width) // 84)  # the stride that brings it to about 84 pixels
    warnings.warn(
        LargeCameraWarning(
            f"the bolt's camera gives {height}x{width} images: a classifier trained on "
            f"{samples:,} of them for {epochs} epochs costs about "
            f"{height * width / 84**2:.0f} times what it does on 84x84 ones, hours on a "
            "CPU. Give the world a smaller camera (FluentLabels(..., camera=lambda env: "
            f"env.render()[::{step}, ::{step}])), or use --detector synthetic"
        ),
        stacklevel=3,
    )


def _train_classifier_on_the_fly(
    path: Path,
    config: DetectorConfig,
    architecture: Any,
    *,
    world: str,
    world_kwargs: Mapping[str, Any],
    spec_fluents: Collection[str],
    progress: bool,
    log: Callable[[str], None],
) -> None:
    from noisybolt.perception.dataset import collect_samples
    from noisybolt.perception.training import TrainingConfig, train_classifier

    def images(seed: int, samples: int, *, held_out: bool = False) -> Any:
        collector = make_world(world, num_envs=16, seed=seed, **world_kwargs)
        try:
            data = collect_samples(
                collector,
                num_samples=samples,
                seed=seed,
                final_views=config.final_views,
                progress=progress,
            )
        finally:
            close = getattr(collector, "close", None)
            if callable(close):
                close()
        # Refused before any classifier is trained on them, or cached: warnings wait for
        # the classifier kept (make_detector checks its saved counts).
        purpose = "check" if held_out else "train"
        dataset.refuse_unseen(
            LabelCounts.of(data),
            spec_fluents,
            what_to_do=_WHAT_TO_DO,
            source=f"the {len(data):,} {'held-out ' if held_out else ''}images collected "
            f"from the world's random play (seed {seed}) to {purpose} the bolt's classifier",
        )
        return data

    def train_one(restart: int) -> Any:
        # Each restart from its own seed, on twice the images of the one before: a camera
        # that hides what a fluent shows needs more of them (module docstring).
        seed = restart_seed(config.seed, restart)
        samples = config.samples * 2**restart
        dataset = images(seed, samples)
        result = train_classifier(
            dataset,
            config=architecture,
            training=TrainingConfig(epochs=config.epochs, seed=seed),
            progress=progress,
            on_epoch=None if progress else epoch_log(config.epochs, log),
        )
        log(
            f"classifier trained in {result.seconds:.0f} s on {samples} bolt images "
            f"(seed {seed}); validation report:\n{result.report.format_table()}"
        )
        return result.detector

    def held_out() -> Any:
        # seeded as no restart is, so that no classifier has seen these images
        return images(
            restart_seed(config.seed, config.restarts),
            min(HELD_OUT_SAMPLES, config.samples),
            held_out=True,
        )

    detector = best_of_restarts(train_one, held_out, restarts=config.restarts, log=log)
    detector.save(path)
