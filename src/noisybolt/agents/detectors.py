"""The bolt's fluent detector for a run: built from its :class:`DetectorConfig`, with the
on-the-fly classifier cached per world, camera and training recipe.
"""

from __future__ import annotations

import hashlib
import json
import os
from collections.abc import Callable, Mapping, Sequence
from dataclasses import asdict
from pathlib import Path
from typing import Any

from noisybolt.agents.config import DetectorConfig
from noisybolt.envs import make_world
from noisybolt.envs.registry import is_factory_path, world_fingerprint
from noisybolt.errors import ConfigError
from noisybolt.perception.protocols import FluentDetector

__all__ = ["classifier_architecture", "default_classifier_path", "make_detector"]


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
    if config.path is not None and not path.is_file():
        raise ConfigError(
            f"the classifier file {path} does not exist; give the path of one saved by "
            "`noisybolt classifiers train` (or omit --classifier to use the cached one)"
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
